"""A labelled contact sheet: pictures in a row or a grid, with a title, column labels,
row labels and a note under each picture (Pillow, its default font). Used by the
sweeps (:mod:`grasswidget.tools.sweep`) and a comparison's Save PNG
(:mod:`grasswidget.notebook.compare`)."""

from __future__ import annotations

import numpy as np

__all__ = ["labelled_sheet"]

_BACKGROUND = (255, 255, 255, 255)
_INK = (20, 20, 20, 255)
_FAINT = (90, 90, 90, 255)
#: Text sizes (pixels) of the labels and of the notes under the pictures.
LABEL_PX, NOTE_PX = 13, 11


def labelled_sheet(cells, title="", col_labels=(), row_labels=(), notes=None) -> np.ndarray:
    """Lay out ``cells`` ((rows, cols, h, w, 4) uint8 RGBA) on a white sheet and return it
    as (H, W, 4) uint8 RGBA: ``title`` on top, ``col_labels`` (one per column) over the
    pictures, ``row_labels`` (one per row, or none) left of them, and ``notes``
    ((rows, cols) strings, or None) under each picture."""
    from PIL import Image, ImageDraw, ImageFont

    cells = np.asarray(cells, np.uint8)
    rows, cols, h, w, _ = cells.shape
    font = ImageFont.load_default(size=LABEL_PX)
    small = ImageFont.load_default(size=NOTE_PX)
    probe = ImageDraw.Draw(Image.new("RGBA", (1, 1)))

    def text_w(t, f):
        box = probe.textbbox((0, 0), t, font=f)
        return box[2] - box[0]

    pad = 8
    title_h = 22 if title else 4
    head_h = 20 if any(col_labels) else 0
    foot_h = 18 if notes is not None else 0
    left = (max(text_w(t, font) for t in row_labels) + 2 * pad) if any(row_labels) else pad
    width = max(left + cols * (w + pad), (text_w(title, font) + 2 * pad) if title else 0)
    height = title_h + head_h + rows * (h + foot_h + pad) + pad
    sheet = Image.new("RGBA", (width, height), _BACKGROUND)
    draw = ImageDraw.Draw(sheet)
    if title:
        draw.text((pad, 4), title, fill=_INK, font=font)
    for c, label in enumerate(col_labels):
        x = left + c * (w + pad)
        draw.text((x + max(0, (w - text_w(label, font)) // 2), title_h + 2), label, fill=_INK, font=font)
    for r in range(rows):
        y = title_h + head_h + r * (h + foot_h + pad)
        if any(row_labels):
            draw.text((pad, y + h // 2 - LABEL_PX // 2), row_labels[r], fill=_INK, font=font)
        for c in range(cols):
            x = left + c * (w + pad)
            sheet.paste(Image.fromarray(cells[r, c], "RGBA"), (x, y))
            if notes is not None:
                draw.text((x + 2, y + h + 2), notes[r][c], fill=_FAINT, font=small)
    return np.asarray(sheet.convert("RGBA"), np.uint8).copy()
