"""The culling tests of the reference: orientation, frustum, distance (section 5.3),
level of detail, and occlusion against a depth pyramid. Twins of ``shaders/cull.wgsl``
and the depth-pyramid shaders (see :mod:`grasswidget.core.reference`)."""

from __future__ import annotations

import math

import numpy as np

from ..enums import BladeShape, GravityMode
from ...errors import GrassValueError
from .physics import width_direction
from .vectors import dot, safe_normalize

__all__ = [
    "LOD_SEGMENTS",
    "CULLED_SEGMENTS",
    "LOD_MIN_PIXELS",
    "orientation_cull",
    "clip_outside",
    "frustum_cull",
    "distance_cull",
    "projected_pixels",
    "lod_class",
    "CULL_REASONS",
    "cull_reason",
    "cull",
    "occlusion_bounds",
    "hzb_level",
    "hzb_layout",
    "build_hzb",
    "hzb_max",
    "occlusion_cull",
    "curve_pieces",
    "OCCLUSION_PIECES",
    "HZB_SPAN_TEXELS",
    "OCCLUSION_RADIUS_PER_WIDTH",
    "HZB_ROW_ALIGN",
    "HZB_MAX_LEVELS",
]


# --------------------------------------------------------------------------- culling

#: Segments along a blade for each level-of-detail class (class 0 = nearest).
#: Splitting a quadratic Bezier into k chords misses the curve by at most
#: |v0 - 2 v1 + v2| / (8 k^2); a blade bent by half its height (|v0 - 2 v1 + v2|
#: ~ h / 2) that covers H pixels is then off by H / (16 k^2) pixels: about 0.5 px
#: for a full-screen blade (480 px) with 8 segments, 0.75 px at the class limits
#: below. (15, 8, 4, 2) was indistinguishable and drew twice the triangles, which
#: costs a CPU rasterizer (lavapipe) about 20 % of a frame in the cis565 view.
LOD_SEGMENTS = (8, 4, 2, 1)
#: Segments of the culled blades drawn with ``color_by = "cull"`` (context, not detail).
CULLED_SEGMENTS = LOD_SEGMENTS[1]
#: A blade goes to class k when its projected height in pixels is >= LOD_MIN_PIXELS[k].
LOD_MIN_PIXELS = (192.0, 64.0, 20.0, 0.0)


def orientation_cull(v0, t1, cam_pos, threshold=0.9):
    """True where a blade is seen edge-on: |dot(normalize(v0 - cam), t1)| > threshold."""
    dir_c = safe_normalize(np.asarray(v0, np.float64) - np.asarray(cam_pos, np.float64))
    return np.abs(dot(dir_c, t1)) > threshold


def _clip(points, view_proj):
    p = np.concatenate([points, np.ones(points.shape[:-1] + (1,))], axis=-1)
    return p @ np.asarray(view_proj, np.float64).T


def clip_outside(clip, tol):
    """True where a clip-space point (x, y, z, w) is outside the view: not
    (|x|, |y| <= w + tol and 0 <= z <= w)."""
    clip = np.asarray(clip, np.float64)
    x, y, z, w = clip[..., 0], clip[..., 1], clip[..., 2], clip[..., 3]
    lim = w + tol
    inside = (np.abs(x) <= lim) & (np.abs(y) <= lim) & (z >= 0) & (z <= w)
    return ~inside


def frustum_cull(v0, v1, v2, view_proj, tol=0.5):
    """True where v0, the curve midpoint m = v0/4 + v1/2 + v2/4 and v2 are all
    outside the view: a clip-space point is inside when |x|, |y| <= w + tol and
    0 <= z <= w (WebGPU depth range). ``view_proj`` maps world to clip (4x4)."""
    m = 0.25 * v0 + 0.5 * v1 + 0.25 * v2
    return clip_outside(_clip(v0, view_proj), tol) & clip_outside(_clip(m, view_proj), tol) & clip_outside(_clip(v2, view_proj), tol)


def distance_cull(v0, up, cam_pos, ids, buckets=100, d_max=100.0):
    """Bucketed thinning with ground distance (author's scheme)::

        d_proj = |v0 - c - up dot(v0 - c, up)|
        cull if id mod n >= ceil(n * max(1 - d_proj / d_max, 0))
    """
    d = np.asarray(v0, np.float64) - np.asarray(cam_pos, np.float64)
    d_proj = np.linalg.norm(d - up * dot(d, up)[..., None], axis=-1)
    keep = np.ceil(buckets * np.maximum(1.0 - d_proj / d_max, 0.0))
    return (np.asarray(ids) % buckets) >= keep


def projected_pixels(v0, v2, height, view_proj, viewport_height):
    """Projected blade height in pixels: h * P11 * viewport_height / (2 w), with w the
    clip w of the curve's middle (v0 + v2) / 2 and P11 the vertical focal factor of
    ``view_proj`` (the length of its second row's xyz part)."""
    vp = np.asarray(view_proj, np.float64)
    mid = 0.5 * (np.asarray(v0, np.float64) + np.asarray(v2, np.float64))
    w = np.maximum(_clip(mid, vp)[..., 3], 1e-6)
    focal = np.linalg.norm(vp[1, :3])
    return np.asarray(height, np.float64) * focal * viewport_height * 0.5 / w


def lod_class(v0, v2, height, view_proj, viewport_height):
    """Level-of-detail class per blade from its projected height in pixels.

    pixels = h * P11 * viewport_height / (2 w), with w the clip w of the curve's
    middle (v0 + v2) / 2 and P11 the vertical focal factor of ``view_proj``
    (the length of its second row's xyz part). Class k is the first with
    pixels >= LOD_MIN_PIXELS[k].
    """
    pixels = projected_pixels(v0, v2, height, view_proj, viewport_height)
    cls = np.full(len(pixels), len(LOD_MIN_PIXELS) - 1)
    for k in reversed(range(len(LOD_MIN_PIXELS))):
        cls = np.where(pixels >= LOD_MIN_PIXELS[k], k, cls)
    return cls


#: What :func:`cull_reason` returns, by index: 0 kept, then the culling tests in
#: the order they are applied (the first one that culls a blade is its reason).
CULL_REASONS = ("kept", "orientation", "frustum", "distance", "occlusion")


def cull_reason(state, params, view_proj, cam_pos, ids=None):
    """Why each blade is culled: an int array (N,) indexing :data:`CULL_REASONS`.

    0 means the blade survives every enabled test; otherwise the value names the
    first enabled test that culls it, in the order orientation (1), frustum (2),
    distance (3). A blade culled by frustum and distance is a frustum blade.
    Occlusion (4) needs a depth buffer: see :func:`occlusion_cull`, applied to the
    blades this function keeps.
    ``view_proj`` (4x4, world to clip) and ``cam_pos`` describe the culling camera;
    ``ids`` (default 0..N-1) feed the distance buckets.
    """
    v0, v1, v2, up = (np.asarray(state[k], np.float64) for k in ("v0", "v1", "v2", "up"))
    n = len(v0)
    ids = np.arange(n) if ids is None else ids
    reason = np.zeros(n, np.int32)
    tests = []
    if params.cull_orientation:
        t1 = width_direction(up, state["orientation"])
        tests.append((1, lambda: orientation_cull(v0, t1, cam_pos, params.cull_orientation_threshold)))
    if params.cull_frustum:
        tests.append((2, lambda: frustum_cull(v0, v1, v2, view_proj, params.cull_frustum_tolerance)))
    if params.cull_distance:
        tests.append((3, lambda: distance_cull(v0, up, cam_pos, ids, params.cull_buckets, params.cull_distance_max)))
    for code, test in tests:
        reason = np.where((reason == 0) & test(), code, reason)
    return reason


def cull(state, params, view_proj, cam_pos, ids=None):
    """Which blades survive all enabled culling tests (bool (N,), True = drawn)."""
    return cull_reason(state, params, view_proj, cam_pos, ids) == 0



# --------------------------------------------------------------------------- occlusion culling

#: A ribbon point lies within this many blade widths of the curve (blade_render.wgsl:
#: c -+ width * t1, and the "fold" shape adds width / 2 along the normal: sqrt(1.25) < 1.5).
OCCLUSION_RADIUS_PER_WIDTH = 1.5
#: The occlusion test splits the curve into this many pieces (t in [k/P, (k+1)/P]), each
#: boxed by its own control points: a bent blade's one box would cover much empty screen.
OCCLUSION_PIECES = 4
#: The occlusion test reads the pyramid at the finest level where a piece's screen rect is at most
#: this many texels long each way (so it touches at most HZB_SPAN_TEXELS + 1 texels each way: at most
#: (HZB_SPAN_TEXELS + 1)^2 reads a piece). At 1 (a 2 x 2 read) the texels of a tall near piece reach
#: far past it, over the gaps where far grass shows, and hide almost nothing: in the cis565 view at
#: 2^16 blades 3,352 were drawn for 132 that show; at 4, 987 (docs/benchmarks-method.md, "A tighter
#: occlusion test").
HZB_SPAN_TEXELS = 4
#: Rows of the pyramid's level 0 start every HZB_ROW_ALIGN texels (a depth texture is
#: copied into a buffer in rows of a multiple of 256 bytes = 64 float32).
HZB_ROW_ALIGN = 64
#: Levels of the depth pyramid the level table (``s_hzb_levels``) holds: views up to
#: 2^15 pixels wide and high (both engines).
HZB_MAX_LEVELS = 16


def occlusion_bounds(v0, v1, v2, radius, view_proj, viewport_size):
    """Screen bounds of a blade for the occlusion test: ``(rect, depth)``.

    The blade lies in the box around its control points v0, v1, v2 (the curve stays
    in their triangle) grown by ``radius`` (metres); its 8 corners are projected by
    ``view_proj`` (world to clip). ``rect`` (x0, y0, x1, y1) is their extent in
    pixels of a ``viewport_size`` (width, height) view, clamped to [0, width] x
    [0, height], y down (row 0 at the top); ``depth`` the nearest corner's depth
    (0 near .. 1 far). A box that reaches behind the near plane gets the whole view
    and depth 0 (it cannot be hidden). Per blade: arrays of shape (N, 3) / (N,) /
    (4, 4) / (2,) give (N, 4) and (N,).
    """
    v0, v1, v2 = (np.asarray(x, np.float64) for x in (v0, v1, v2))
    r = np.asarray(radius, np.float64)[..., None]
    lo = np.minimum(np.minimum(v0, v1), v2) - r
    hi = np.maximum(np.maximum(v0, v1), v2) + r
    corners = np.stack([np.stack([(hi if k & 1 else lo)[..., 0], (hi if k & 2 else lo)[..., 1],
                                  (hi if k & 4 else lo)[..., 2]], axis=-1) for k in range(8)], axis=-2)
    clip = _clip(corners, view_proj)  # (..., 8, 4)
    w = clip[..., 3]
    behind = np.any((w <= 1e-6) | (clip[..., 2] < 0.0), axis=-1)
    safe_w = np.where(w <= 1e-6, 1.0, w)
    ndc = clip[..., :3] / safe_w[..., None]
    size = np.asarray(viewport_size, np.float64)
    width, height = size[..., 0:1], size[..., 1:2]
    x0 = np.clip((ndc[..., 0].min(axis=-1, keepdims=True) * 0.5 + 0.5) * width, 0.0, width)
    x1 = np.clip((ndc[..., 0].max(axis=-1, keepdims=True) * 0.5 + 0.5) * width, 0.0, width)
    y0 = np.clip((0.5 - 0.5 * ndc[..., 1].max(axis=-1, keepdims=True)) * height, 0.0, height)
    y1 = np.clip((0.5 - 0.5 * ndc[..., 1].min(axis=-1, keepdims=True)) * height, 0.0, height)
    rect = np.concatenate([x0, y0, x1, y1], axis=-1)
    depth = np.maximum(ndc[..., 2].min(axis=-1), 0.0)
    full = np.concatenate([np.zeros_like(width), np.zeros_like(height), width, height], axis=-1)
    rect = np.where(behind[..., None], np.broadcast_to(full, rect.shape), rect)
    depth = np.where(behind, 0.0, depth)
    return rect, depth


def hzb_level(rect):
    """The pyramid level at which a pixel rect (x0, y0, x1, y1) spans at most
    HZB_SPAN_TEXELS + 1 texels each way: the smallest L with
    HZB_SPAN_TEXELS * 2^L >= ceil(max(x1 - x0, y1 - y0)) (0 for a rect of at most
    HZB_SPAN_TEXELS pixels). Level L's texel (x, y) holds the farthest depth of the pixels
    [x 2^L, (x + 1) 2^L) x [y 2^L, (y + 1) 2^L)."""
    rect = np.asarray(rect, np.float64)
    span = np.ceil(np.maximum(rect[..., 2] - rect[..., 0], rect[..., 3] - rect[..., 1]))
    span = np.maximum(span, 1.0).astype(np.int64)
    level = np.zeros(span.shape, np.int64)
    while np.any(HZB_SPAN_TEXELS * (1 << level) < span):
        level = np.where(HZB_SPAN_TEXELS * (1 << level) < span, level + 1, level)
    return level.astype(np.uint32)


def hzb_layout(width, height):
    """Where each pyramid level lives in one float32 buffer: a list of
    ``(offset, width, height, pitch)`` in texels, level 0 first. Level 0 is the
    depth buffer (width x height, rows every HZB_ROW_ALIGN-aligned pitch); level
    k + 1 halves level k rounding up, down to 1 x 1, rows packed."""
    width, height = int(width), int(height)
    if width < 1 or height < 1:
        raise GrassValueError(f"hzb_layout needs a viewport of at least 1 x 1 pixels; got {width} x {height}")
    pitch = -(-width // HZB_ROW_ALIGN) * HZB_ROW_ALIGN
    levels = [(0, width, height, pitch)]
    offset = pitch * height
    while width > 1 or height > 1:
        width, height = -(-width // 2), -(-height // 2)
        levels.append((offset, width, height, width))
        offset += width * height
    return levels


def build_hzb(depth):
    """The max-depth pyramid of a depth image (height, width): a list of arrays,
    level 0 = ``depth``; each texel of level k + 1 the farthest of its (up to) 2 x 2
    texels of level k (the layout of :func:`hzb_layout`)."""
    levels = [np.asarray(depth, np.float32)]
    while levels[-1].shape != (1, 1):
        d = levels[-1]
        h, w = d.shape
        padded = np.full((h + h % 2, w + w % 2), -np.inf, np.float32)
        padded[:h, :w] = d
        levels.append(padded.reshape(padded.shape[0] // 2, 2, padded.shape[1] // 2, 2).max(axis=(1, 3)))
    return levels


def hzb_max(levels, rect, level):
    """Farthest depth of the pyramid ``levels`` (:func:`build_hzb`) over the pixel
    rect (x0, y0, x1, y1) at ``level`` (the texels holding pixels floor(x0)..floor(x1),
    floor(y0)..floor(y1), clamped to the view); one rect per row."""
    rect = np.atleast_2d(np.asarray(rect, np.float64))
    level = np.broadcast_to(np.asarray(level, np.int64), rect.shape[:1])
    h0, w0 = levels[0].shape
    out = np.empty(len(rect), np.float32)
    for k, (r, lv) in enumerate(zip(rect, level)):
        lv = min(int(lv), len(levels) - 1)
        px0 = min(int(np.floor(r[0])), w0 - 1)
        px1 = min(int(np.floor(r[2])), w0 - 1)
        py0 = min(int(np.floor(r[1])), h0 - 1)
        py1 = min(int(np.floor(r[3])), h0 - 1)
        out[k] = levels[lv][py0 >> lv: (py1 >> lv) + 1, px0 >> lv: (px1 >> lv) + 1].max()
    return out


def occlusion_cull(state, view_proj, depth, world_scale=1.0):
    """True where a blade is hidden: for each piece of its curve (:func:`curve_pieces`),
    the piece's nearest depth (:func:`occlusion_bounds`, radius
    OCCLUSION_RADIUS_PER_WIDTH x width x ``world_scale``) is farther than the farthest
    depth of ``depth`` (an (H, W) float32 depth buffer of the same camera, 0 near ..
    1 far) over the piece's screen rect, read at :func:`hzb_level` of the rect from
    the pyramid :func:`build_hzb`. Conservative: every pixel the blade could cover
    already holds something nearer.
    """
    depth = np.asarray(depth, np.float32)
    h, w = depth.shape
    levels = build_hzb(depth)
    radius = OCCLUSION_RADIUS_PER_WIDTH * np.asarray(state["width"], np.float64) * world_scale
    hidden = np.ones(len(radius), bool)
    for p0, p1, p2 in curve_pieces(state["v0"], state["v1"], state["v2"]):
        rect, near = occlusion_bounds(p0, p1, p2, radius, view_proj, (w, h))
        hidden &= near.astype(np.float32) > hzb_max(levels, rect, hzb_level(rect))
    return hidden


def curve_pieces(v0, v1, v2, pieces=None):
    """The control points (p0, p1, p2) of the quadratic Bezier v0, v1, v2 on each of
    ``pieces`` (default OCCLUSION_PIECES) equal spans of t: on [a, b], p0 = B(a),
    p2 = B(b), p1 = (1-a)(1-b) v0 + (a(1-b) + b(1-a)) v1 + a b v2."""
    v0, v1, v2 = (np.asarray(x, np.float64) for x in (v0, v1, v2))
    n = OCCLUSION_PIECES if pieces is None else int(pieces)

    def point(t):
        return (1 - t) ** 2 * v0 + 2 * t * (1 - t) * v1 + t * t * v2

    out = []
    for k in range(n):
        a, b = k / n, (k + 1) / n
        out.append((point(a), (1 - a) * (1 - b) * v0 + (a * (1 - b) + b * (1 - a)) * v1 + a * b * v2, point(b)))
    return out


