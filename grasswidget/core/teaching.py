"""Teaching views, the pure part: colours, the frozen camera's frustum, input checks.

No GPU import. The GPU side lives in :mod:`grasswidget.gpu.frozen_camera` and
:mod:`grasswidget.gpu.inspector`; ``params.color_by`` picks the colouring.

- ``CULL_COLORS``: for ``color_by = "cull"``, the flat colour of a blade culled by
  each test (keys in the order the tests run: orientation, frustum, distance).
  None of them is green, so they stand out against the kept (natural) grass.
- ``LOD_COLORS``: for ``color_by = "lod"``, one flat colour per level-of-detail
  class, nearest (most segments, ``reference.LOD_SEGMENTS[0]``) first.
"""

from __future__ import annotations

import numbers

import numpy as np

from ..errors import GrassValueError
from .params import COLOR_BY
from .reference import CULL_REASONS, LOD_MIN_PIXELS, LOD_SEGMENTS

__all__ = [
    "COLOR_BY",
    "CULL_COLORS",
    "LOD_COLORS",
    "FROZEN_FRUSTUM_COLOR",
    "INSPECTOR_COLORS",
    "MAX_INSPECTED",
    "ARROW_ACCEL_PER_HEIGHT",
    "COLLISION_ARROW_SCALE",
    "hex_to_rgb",
    "legend",
    "frustum_corners",
    "frustum_segments",
    "check_inspect_ids",
]

#: sRGB colour of a blade culled by each test (color_by "cull"): magenta, amber, blue.
CULL_COLORS = {"orientation": "#e6007e", "frustum": "#ff9900", "distance": "#2f4bff"}
#: sRGB colour of each level-of-detail class (color_by "lod"), nearest first:
#: yellow (8 segments), orange (4), red-pink (2), purple (1).
LOD_COLORS = ["#ffe119", "#f58231", "#d6336c", "#7b00b4"]
#: Colour of the frozen camera's frustum lines.
FROZEN_FRUSTUM_COLOR = "#ffffff"
#: Colours of the inspector: control points and polygon, then one arrow per force
#: (the keys of reference.FORCE_NAMES).
INSPECTOR_COLORS = {
    "points": "#ffffff",
    "polygon": "#202020",
    "gravity": "#7a3cff",
    "recovery": "#00c8c8",
    "wind": "#ff3030",
    "collision": "#ffb000",
}
#: The blade inspector draws at most this many blades.
MAX_INSPECTED = 64
#: Inspector arrows: an acceleration of this many m/s^2 is drawn as long as the
#: blade is high (so default gravity, 9.8 m/s^2 plus front gravity, is about half a blade).
ARROW_ACCEL_PER_HEIGHT = 20.0
#: The collision arrow is the push of one step (metres; a few millimetres to
#: centimetres) drawn this many times longer.
COLLISION_ARROW_SCALE = 10.0

assert len(LOD_COLORS) == len(LOD_SEGMENTS)
assert tuple(CULL_COLORS) == CULL_REASONS[1:]


def hex_to_rgb(color: str) -> tuple:
    """(r, g, b) in 0..255 of an sRGB hex colour "#rrggbb"."""
    c = color.lstrip("#")
    return tuple(int(c[k : k + 2], 16) for k in (0, 2, 4))


def legend(color_by: str) -> list:
    """(label, sRGB hex or None) rows explaining a colouring; None = natural grass colours."""
    if color_by not in COLOR_BY:
        raise GrassValueError(f"color_by must be one of {', '.join(map(repr, COLOR_BY))}; got {color_by!r}")
    if color_by == "lod":
        rows = []
        for k, (segments, pixels) in enumerate(zip(LOD_SEGMENTS, LOD_MIN_PIXELS)):
            what = f">= {pixels:g} px tall" if pixels > 0 else "smaller"
            rows.append((f"LOD {k}: {segments} segment{'s' if segments > 1 else ''} ({what})", LOD_COLORS[k]))
        return rows
    if color_by == "cull":
        return [("kept (drawn as usual)", None)] + [
            (f"culled by {name}", color) for name, color in CULL_COLORS.items()
        ]
    return []


_NDC_CORNERS = np.array(
    [[x, y, z] for z in (0.0, 1.0) for y in (-1.0, 1.0) for x in (-1.0, 1.0)], np.float64
)
# Edges between the 8 corners above (index bits: x, y, z): near rectangle, far rectangle, sides.
_EDGES = [(0, 1), (1, 3), (3, 2), (2, 0), (4, 5), (5, 7), (7, 6), (6, 4), (0, 4), (1, 5), (2, 6), (3, 7)]


def frustum_corners(view_proj) -> np.ndarray:
    """The 8 world-space corners (8, 3) of the view volume of a world-to-clip matrix.

    WebGPU clip space: x, y in [-1, 1], depth z in [0, 1] (near plane at 0).
    Corner k has x = +1 if bit 0 of k, y = +1 if bit 1, the far plane if bit 2.
    """
    inv = np.linalg.inv(np.asarray(view_proj, np.float64))
    p = np.concatenate([_NDC_CORNERS, np.ones((8, 1))], axis=1) @ inv.T
    return p[:, :3] / p[:, 3:4]


def frustum_segments(view_proj) -> np.ndarray:
    """(24, 3) float32 world positions: the 12 edges of the frustum as point pairs
    (for a pygfx Line with ``LineSegmentMaterial``)."""
    corners = frustum_corners(view_proj)
    return np.array([corners[k] for edge in _EDGES for k in edge], np.float32)


def check_inspect_ids(ids, count: int) -> np.ndarray:
    """Validate blade ids for the inspector; returns them as a unique int array, in order.

    Raises ValueError naming the limit for more than MAX_INSPECTED (64) ids, for an
    id outside [0, count - 1], or for anything that is not an integer (bools and
    floats such as 1.0 are refused).
    """
    if isinstance(ids, (str, bytes)) or not np.iterable(ids):
        raise GrassValueError(f"inspect takes a list of blade ids (integers in [0, {count - 1}]); got {ids!r}")
    items = list(np.asarray(ids, dtype=object).reshape(-1)) if isinstance(ids, np.ndarray) else list(ids)
    for x in items:
        if isinstance(x, (bool, np.bool_)) or not isinstance(x, numbers.Integral):
            raise GrassValueError(f"inspect: blade ids must be integers in [0, {count - 1}]; got {x!r}")
    out = list(dict.fromkeys(int(x) for x in items))
    if len(out) > MAX_INSPECTED:
        raise GrassValueError(f"inspect takes at most {MAX_INSPECTED} blade ids; got {len(out)}")
    bad = [x for x in out if not 0 <= x < count]
    if bad:
        raise GrassValueError(f"inspect: blade ids must be in [0, {count - 1}] ({count} blades); got {bad[0]}")
    return np.array(out, np.int64)
