"""Teaching views, the pure part: colours, the frozen camera's frustum, input checks.

No GPU import. The GPU side lives in :mod:`grasswidget.gpu.frozen_camera` and
:mod:`grasswidget.gpu.inspector`; ``params.color_by`` picks the colouring.

- ``CULL_COLORS``: for ``color_by = "cull"``, the flat colour of a blade culled by
  each test (keys in the order the tests run: orientation, frustum, distance,
  occlusion: hidden behind nearer grass, the ground or anything opaque).
  None of them is green, so they stand out against the kept (natural) grass.
- ``LOD_COLORS``: for ``color_by = "lod"``, one flat colour per level-of-detail
  class, nearest (most segments, ``reference.LOD_SEGMENTS[0]``) first.
"""

from __future__ import annotations

import numbers

import numpy as np

from ..errors import GrassValueError
from .camera_rules import view_proj
from .params import COLOR_BY
from .reference import CULL_REASONS, FORCE_NAMES, LOD_MIN_PIXELS, LOD_SEGMENTS

__all__ = [
    "COLOR_BY",
    "CULL_COLORS",
    "LOD_COLORS",
    "COMPUTE_RASTER_COLOR",
    "FROZEN_FRUSTUM_COLOR",
    "INSPECTOR_COLORS",
    "INSPECTED_BLADE_COLORS",
    "MAX_INSPECTED",
    "INSPECTED_POINT_BYTES",
    "ARROW_ACCEL_PER_HEIGHT",
    "COLLISION_ARROW_SCALE",
    "hex_to_rgb",
    "legend",
    "frustum_corners",
    "frustum_segments",
    "check_inspect_ids",
    "FrozenView",
    "camera_view_proj",
    "frozen_view",
    "inspected_rows",
    "inspector_segment_colors",
    "SEGMENT_VERTICES",
    "pick_blade_on_ray",
]

#: sRGB colour of a blade culled by each test (color_by "cull"): magenta, amber, blue, cyan.
CULL_COLORS = {"orientation": "#e6007e", "frustum": "#ff9900", "distance": "#2f4bff", "occlusion": "#00e5ff"}
#: sRGB colour of each level-of-detail class (color_by "lod"), nearest first:
#: yellow (8 segments), orange (4), red-pink (2), purple (1).
LOD_COLORS = ["#ffe119", "#f58231", "#d6336c", "#7b00b4"]
#: sRGB colour of the blades drawn by the compute rasterizer (color_by "lod";
#: GrassParams.compute_raster): white, "drawn in compute", beside the LOD colours.
COMPUTE_RASTER_COLOR = "#ffffff"
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
#: One colour per inspected blade, by its position in the inspected ids (cycled): the panel's
#: inspector line marks each blade with it and the lab bench's charts draw its series in it.
INSPECTED_BLADE_COLORS = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#17becf", "#e377c2", "#8c564b"]
#: The blade inspector draws at most this many blades.
MAX_INSPECTED = 64
#: Bytes of one inspected blade's control points as both engines read them back: v0, v1, v2,
#: three float32 each (the inspector's ``s_points``).
INSPECTED_POINT_BYTES = 3 * 3 * 4
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
        rows.append(("drawn in compute (thinner than compute_raster_max_px)", COMPUTE_RASTER_COLOR))
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


# ---------------------------------------------------------------------- the frozen culling camera (pure)


class FrozenView:
    """A frozen culling camera as the culling pass sees it (no GPU): ``view_proj``
    (4x4 float64, world to WebGPU clip space, depth 0..1), ``position`` (3,) world
    position (m) and ``viewport_size`` ((w, h) pixels: the aspect it was taken at and
    the pixel scale of the LOD classes). :func:`grasswidget.core.engine_inputs.cull_uniform_values`
    writes it into ``u_cull`` for both engines; :meth:`segments` is its view volume as lines.
    """

    def __init__(self, view_proj, position, viewport_size):
        w, h = viewport_size
        if not (w > 0 and h > 0):
            raise GrassValueError(f"viewport_size must be (width, height) > 0 pixels; got {viewport_size!r}")
        self.view_proj = np.array(view_proj, np.float64).reshape(4, 4)
        self.position = np.array(position, np.float64).reshape(3)
        self.viewport_size = (float(w), float(h))
        #: A renderer's camera of the same view (the kernel engine's pygfx copy), or None.
        self.camera = None

    def segments(self, to_local=None) -> np.ndarray:
        """(24, 3) float32 end points of the 12 frustum edges; in world space, or
        mapped by the 4x4 ``to_local`` (e.g. the inverse of a parent's world matrix)."""
        seg = frustum_segments(self.view_proj).astype(np.float64)
        if to_local is not None:
            p = np.concatenate([seg, np.ones((len(seg), 1))], axis=1) @ np.asarray(to_local, np.float64).T
            seg = p[:, :3] / p[:, 3:4]
        return seg.astype(np.float32)

    def __repr__(self):
        return f"<FrozenView at {tuple(np.round(self.position, 3))}, {self.viewport_size[0]:g}x{self.viewport_size[1]:g} px>"


def camera_view_proj(position, target, fov_deg, near, far, aspect) -> np.ndarray:
    """World to WebGPU clip space (4x4 float64, row-major) of a camera at ``position``
    looking at ``target`` (metres; world up +y), vertical field of view ``fov_deg``,
    depth 0 at ``near`` and 1 at ``far`` (m), ``aspect`` = width / height.

    :func:`grasswidget.core.camera_rules.view_proj` (the camera's matrices, decided there;
    the browser engine's ``rules.js`` executes them); the frozen culling camera is computed with it.
    """
    return view_proj(position, target, fov_deg, near, far, aspect)


def frozen_view(camera: dict, viewport_size) -> FrozenView:
    """The :class:`FrozenView` of a camera dict (``position``, ``target``, ``fov_deg``,
    ``near``, ``far``, as the browser engine's ``camera`` trait holds it) rendering a view
    of ``viewport_size`` (w, h) physical pixels."""
    w, h = viewport_size
    if not (w > 0 and h > 0):
        raise GrassValueError(f"viewport_size must be (width, height) > 0 pixels; got {viewport_size!r}")
    vp = camera_view_proj(camera["position"], camera["target"], camera["fov_deg"], camera["near"],
                          camera["far"], float(w) / float(h))
    return FrozenView(vp, camera["position"], (w, h))


# ---------------------------------------------------------------------- the blade inspector's data (pure)

#: Line vertices per inspected blade: 2 polygon segments + 3 segments per force arrow, 2 vertices each.
SEGMENT_VERTICES = 2 * (2 + 3 * len(FORCE_NAMES))


def inspector_segment_colors() -> list:
    """The sRGB hex colour of each of the ``SEGMENT_VERTICES`` line vertices of one blade:
    the control polygon (4), then 6 per arrow in ``reference.FORCE_NAMES`` order."""
    out = [INSPECTOR_COLORS["polygon"]] * 4
    for name in FORCE_NAMES:
        out += [INSPECTOR_COLORS[name]] * 6
    return out


def inspected_rows(ids, heights, stiffnesses, stiffness_scale, points, forces) -> list:
    """The inspector's numbers as both engines return them (``read_inspected``): one dict
    per id with ``id``, ``height`` (m), ``stiffness`` (1/s^2, times ``stiffness_scale``),
    ``v0``, ``v1``, ``v2`` (float32 (3,), from ``points`` (n, 3, 3)) and one float32 (3,)
    vector per name of ``reference.FORCE_NAMES`` (from ``forces`` (n, n_forces, 3 or 4));
    with 4 components (inspect.wgsl writes the blade's stored collision factor eta in w)
    also ``collision_strength`` (eta, 0..1).
    ``heights`` and ``stiffnesses`` are the whole field's (indexed by id)."""
    points = np.asarray(points, np.float32)
    raw = np.asarray(forces, np.float32)
    forces = raw[..., :3]
    out = []
    for k, i in enumerate(ids):
        i = int(i)
        row = {"id": i, "height": float(heights[i]), "stiffness": float(stiffnesses[i] * stiffness_scale),
               "v0": points[k, 0].copy(), "v1": points[k, 1].copy(), "v2": points[k, 2].copy()}
        for j, name in enumerate(FORCE_NAMES):
            row[name] = forces[k, j].copy()
        if raw.shape[-1] == 4:
            row["collision_strength"] = float(raw[k, 0, 3])
        out.append(row)
    return out


def pick_blade_on_ray(v0, up, height, width, origin, direction, pixel_angle=0.004):
    """The blade a click along a view ray means, or None: of the blades whose rest pose
    (the segment from ``v0`` along ``up`` for ``height`` m) passes within their ``width``
    plus ``pixel_angle`` radians of the ray (``origin`` + s ``direction``, s >= 0, world
    space), the nearest to the eye. The browser engine's ctrl + click (the kernel engine
    reads the id of the drawn pixel instead); it ignores how the blades bend."""
    v0 = np.asarray(v0, np.float64)
    u = np.asarray(up, np.float64) * np.asarray(height, np.float64)[:, None]
    o = np.asarray(origin, np.float64).reshape(3)
    d = np.asarray(direction, np.float64).reshape(3)
    d = d / max(float(np.linalg.norm(d)), 1e-300)
    w = v0 - o
    # Closest points of the line o + s d and the segments v0 + t u, t in [0, 1].
    uu = np.einsum("ij,ij->i", u, u)
    ud = u @ d
    uw = np.einsum("ij,ij->i", u, w)
    dw = w @ d
    denom = np.maximum(uu - ud * ud, 1e-12)
    t = np.clip((ud * dw - uw) / denom, 0.0, 1.0)
    s = np.maximum(ud * t + dw, 0.0)
    gap = np.linalg.norm(w + u * t[:, None] - s[:, None] * d, axis=1)
    hit = gap <= np.asarray(width, np.float64) + pixel_angle * s
    if not hit.any():
        return None
    ids = np.flatnonzero(hit)
    return int(ids[np.argmin(s[ids])])
