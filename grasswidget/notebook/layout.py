"""Where a GrassWidget puts its view and its panel: the default and the lecture layout.

Both layouts are one flex box that wraps (``.grasswidget``): the view first, then
the panel as a column (:data:`PANEL_WIDTH` px wide at most, or the view's width when
that is narrower). Where the notebook is wide enough the column stands *beside* the
view, otherwise it wraps *under* it, so the widget fits a 1080p screen without
scrolling between picture and controls (a 640 x 480 view and its panel side by side
are about 600 px tall in JupyterLab at 1920 x 1080; under the view they were about
1050 px).

The column starts with the camera bar (:class:`~grasswidget.notebook.camera_bar.CameraBar`:
presets, the floor, "more"), then the panel's rows. Folded (``panel_folded``), only the
bar shows, one line with Play/Pause added.

- ``"default"``: a 640 x 480 view (or the ``size`` given), the panel unfolded.
- ``"lecture"``: a large view (1280 x 720 unless ``size`` is given, for a projector
  or a 1080p screen) with the panel folded to its one line; "more" unfolds it.

:data:`LAYOUTS` lists them; ``GrassWidget(layout=...)`` checks the name.
"""

from __future__ import annotations

import ipywidgets as ipw

from ..errors import GrassValueError

__all__ = ["LAYOUTS", "LAYOUT_VIEW_SIZES", "PANEL_WIDTH", "WidgetLayout", "check_layout", "close_widgets"]

#: The layouts a GrassWidget offers.
LAYOUTS = ("default", "lecture")
#: The view size (CSS px) of each layout when ``size`` is not given.
LAYOUT_VIEW_SIZES = {"default": (640, 480), "lecture": (1280, 720)}
#: Widest the panel column gets, CSS px (two columns of controls).
PANEL_WIDTH = 640
#: Space between the view and the panel column beside it, CSS px.
GAP = 8


def check_layout(layout) -> str:
    """``layout`` if it is one of :data:`LAYOUTS` (GrassValueError naming them otherwise)."""
    if not isinstance(layout, str) or layout not in LAYOUTS:
        raise GrassValueError(f"layout must be one of {', '.join(map(repr, LAYOUTS))}; got {layout!r}")
    return layout


def view_size(layout: str, size) -> tuple:
    """The view's (width, height) in CSS pixels: ``size`` ((w, h) or "WxH"), or the layout's
    default (:data:`LAYOUT_VIEW_SIZES`) when None."""
    from ..core.presets import parse_size

    return parse_size(LAYOUT_VIEW_SIZES[layout] if size is None else size)


def make_stage(view, *below) -> ipw.VBox:
    """The stage: ``view``'s widget with ``below`` (the lab bench's chart, the adapter probe) right under it."""
    return ipw.VBox([view.widget, *below], layout=ipw.Layout(max_width="100%"))


def show_view(stage, view) -> None:
    """Put ``view``'s widget first on ``stage`` in place of the one before (an engine switch)."""
    stage.children = [view.widget, *stage.children[1:]]


def close_widgets(*widgets) -> None:
    """Close each ipywidget in ``widgets`` and the ``layout`` and ``style`` it holds.

    An ipywidget makes a ``Layout`` (and most a ``Style``) of its own, each a widget
    with its comm, registered in ipywidgets' registry until closed; ``Widget.close()``
    closes only the widget itself, so every control of a closed GrassWidget left
    about 130 of them behind (0.36 MiB a widget created and closed). Children are
    not closed (their owners close them). None entries are skipped; closing twice is
    harmless.
    """
    for widget in widgets:
        if widget is None:
            continue
        parts = [getattr(widget, name, None) for name in ("layout", "style")]
        widget.close()
        for part in parts:
            if isinstance(part, ipw.Widget):
                part.close()


class WidgetLayout:
    """The panel column of a GrassWidget and how it folds.

    Args:
        bar: the camera bar's row (always shown, first).
        rows: the panel's rows (shown while unfolded).
        view_width: the view's width, CSS px (the column is as wide, up to PANEL_WIDTH).

    Attributes: ``column`` (the VBox beside or under the view), ``more`` (the VBox of
    the panel's rows, hidden while folded), ``root_layout`` (the ``ipw.Layout`` for the
    widget's own box).
    """

    def __init__(self, bar, rows, view_width):
        width = min(int(view_width), PANEL_WIDTH)
        self.more = ipw.VBox(list(rows), layout=ipw.Layout(width="100%"))
        self.column = ipw.VBox([bar, self.more],
                               layout=ipw.Layout(width=f"{width}px", max_width="100%", margin=f"0 0 0 {GAP}px"))
        self.column.add_class("grasswidget-panel")
        self.root_layout = ipw.Layout(display="flex", flex_flow="row wrap", align_items="flex-start",
                                      max_width="100%")

    def set_rows(self, rows):
        """Replace the panel's rows (e.g. after a view change)."""
        self.more.children = list(rows)

    def fold(self, folded: bool):
        """Show only the bar (True) or the whole panel (False)."""
        self.more.layout.display = "none" if folded else ""

    def close(self):
        """Close the column's own boxes (the rows and the bar are closed by their owners)."""
        close_widgets(self.more, self.column)
