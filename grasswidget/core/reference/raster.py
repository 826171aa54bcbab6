"""The compute rasterizer of thin blades in the reference: spans, coverage, payload
and the walk along a blade. Twins of the compute-raster shaders
(see :mod:`grasswidget.core.reference`)."""

from __future__ import annotations

import math

import numpy as np

from ..enums import BladeShape, GravityMode
from ...errors import GrassValueError
from .looks import blade_shape_t, hash01
from .vectors import U32_MASK

__all__ = [
    "clip_to_pixel",
    "raster_step",
    "raster_section",
    "raster_cover",
    "raster_payload",
    "raster_walk",
    "raster_blades",
    "RASTER_MAX_SAMPLES",
    "RASTER_MAX_ACROSS",
    "RASTER_EMPTY",
]


# --------------------------------------------------------------------------- compute rasterization

#: Most samples the compute walk takes along one blade (raster_step: at least 1 / this).
RASTER_MAX_SAMPLES = 256.0
#: Most pixels the walk writes across one cross-section (a blade sent to the compute
#: rasterizer is under GrassParams.compute_raster_max_px wide; this bounds a blade seen
#: at a grazing angle).
RASTER_MAX_ACROSS = 16
#: The depth word of a pixel no compute-rasterized blade covers (raster.wgsl).
RASTER_EMPTY = 0xFFFFFFFF


def clip_to_pixel(clip, viewport_size):
    """Clip-space points (..., 4) to (x, y, depth): pixels, x right and y down from the
    view's top-left corner, depth 0 near .. 1 far (blade_math.wgsl ``clip_to_pixel``)."""
    clip = np.asarray(clip, np.float64)
    size = np.asarray(viewport_size, np.float64)
    ndc = clip[..., :3] / clip[..., 3:4]
    return np.stack([(ndc[..., 0] * 0.5 + 0.5) * size[..., 0], (0.5 - 0.5 * ndc[..., 1]) * size[..., 1],
                     ndc[..., 2]], axis=-1)


def raster_step(s0, s1, s2, v):
    """The compute walk's step in v at v: 0.9 / (the curve's screen speed there,
    ``|2 (1 - v) (s1 - s0) + 2 v (s2 - s1)|`` pixels per unit v), clamped to
    [1 / RASTER_MAX_SAMPLES, 1]: samples about 0.9 pixels apart along the curve."""
    s0, s1, s2 = (np.asarray(x, np.float64) for x in (s0, s1, s2))
    v = np.asarray(v, np.float64)[..., None]
    speed = np.linalg.norm(2.0 * (1.0 - v) * (s1 - s0) + 2.0 * v * (s2 - s1), axis=-1)
    return np.clip(0.9 / np.maximum(speed, 1e-6), 1.0 / RASTER_MAX_SAMPLES, 1.0)


def _raster_step_scalar(d1x, d1y, d2x, d2y, v):
    """raster_step for one v, given s1 - s0 = (d1x, d1y) and s2 - s1 = (d2x, d2y) (float64):
    the same operations in the same order (NumPy's norm over the last axis of a 2-vector is
    sqrt(x * x + y * y); its clip is min(max(., low), high), NaN passing through), so the
    same float64 result."""
    a, b = 2.0 * (1.0 - v), 2.0 * v
    gx, gy = a * d1x + b * d2x, a * d1y + b * d2y
    speed = math.sqrt(gx * gx + gy * gy)
    step = 0.9 / (speed if speed >= 1e-6 or speed != speed else 1e-6)
    if step != step:
        return step
    return min(max(step, 1.0 / RASTER_MAX_SAMPLES), 1.0)


def raster_section(c0, c1, c2, across_px, v, shape, tau, viewport_size):
    """The ribbon's cross-section at v on screen: its two ends (x, y, depth), each (..., 3)
    (blade_math.wgsl ``raster_section``).

    ``c0, c1, c2`` are the control points in clip space; ``across_px`` is the blade's
    half-width vector in clip space (``view_proj @ (width * t1, 0)``, x and y) times
    (0.5 width, -0.5 height) of the view. The ends are the projected curve point c(v) plus
    (2 t - 1) across_px / c(v).w for t = blade_shape_t(0, v) and blade_shape_t(1, v), both
    at c(v)'s depth.
    """
    c0, c1, c2 = (np.asarray(x, np.float64) for x in (c0, c1, c2))
    across_px = np.asarray(across_px, np.float64)
    v = np.asarray(v, np.float64)[..., None]
    a = c0 + v * (c1 - c0)
    b = c1 + v * (c2 - c1)
    c = a + v * (b - a)
    centre = clip_to_pixel(c, viewport_size)
    half = across_px / c[..., 3:4]
    vs = v[..., 0]
    if np.ndim(shape) == 0 and np.ndim(tau) == 0:  # one shape (a blade's walk): all v at once
        t_left = blade_shape_t(0.0, vs, int(shape), float(tau)) + 0.0 * vs
        t_right = blade_shape_t(1.0, vs, int(shape), float(tau)) + 0.0 * vs
    else:
        shape = np.broadcast_to(np.asarray(shape), vs.shape)
        tau = np.broadcast_to(np.asarray(tau, np.float64), vs.shape)
        t_left = np.array([blade_shape_t(0.0, vv, int(s), t) for vv, s, t in zip(vs.ravel(), shape.ravel(), tau.ravel())])
        t_right = np.array([blade_shape_t(1.0, vv, int(s), t) for vv, s, t in zip(vs.ravel(), shape.ravel(), tau.ravel())])
    t_left, t_right = np.reshape(t_left, vs.shape)[..., None], np.reshape(t_right, vs.shape)[..., None]
    zero = np.zeros_like(half[..., :1])
    return (centre + np.concatenate([(2.0 * t_left - 1.0) * half, zero], axis=-1),
            centre + np.concatenate([(2.0 * t_right - 1.0) * half, zero], axis=-1))


def raster_cover(blade, sample, span_px):
    """Points the compute walk writes across a cross-section ``span_px`` pixels wide:
    ``floor(span_px + hash01(blade * 2654435761 + sample * 40503))`` (u32 arithmetic),
    clamped to [0, RASTER_MAX_ACROSS]: on average span_px, the same every frame."""
    blade = np.asarray(blade, np.int64).astype(np.uint64)
    sample = np.asarray(sample, np.int64).astype(np.uint64)
    key = (blade * np.uint64(2654435761) + sample * np.uint64(40503)) & U32_MASK
    h = hash01(key).astype(np.float32)
    total = (np.asarray(span_px, np.float32) + h).astype(np.float64)
    return np.clip(np.floor(total), 0, RASTER_MAX_ACROSS).astype(np.int64)


def raster_payload(blade, v):
    """The shading payload of a rasterized pixel: ``blade << 8 | round(v * 255)`` (u32; blade < 2^24)."""
    blade = np.asarray(blade, np.int64)
    q = np.round(np.clip(np.asarray(v, np.float64), 0.0, 1.0) * 255.0).astype(np.int64)
    return ((blade << 8) | q) & 0xFFFFFFFF


def raster_walk(c0, c1, c2, across, blade, shape, tau, viewport_size):
    """The compute rasterizer's walk of one blade (raster.wgsl), in float32 like the GPU.

    The blade is projected once: control points s0, s1, s2 in pixels and the half-width
    vector ``across`` (clip space, ``view_proj @ (width * t1, 0)``) scaled to pixels times w.
    Samples s = 0, 1, ... at v = 0, then v += raster_step(s0, s1, s2, v) (the last sample at
    v = 1, at most RASTER_MAX_SAMPLES + 1 samples); at each, the cross-section
    (raster_section) of length L pixels is covered by m = raster_cover(blade, s, L) points,
    point j at a + (j + 0.5) (b - a) / m. A point writes pixel floor(x, y) when it is inside
    the view and 0 < depth <= 1 (the section's depth). Returns (x, y, depth, v) arrays, one
    entry per written pixel (a pixel may repeat)."""
    f32 = np.float32
    size = np.asarray(viewport_size, f32)
    c0, c1, c2, across = (np.asarray(x, f32) for x in (c0, c1, c2, across))
    across_px = (across[:2] * np.array([0.5 * size[0], -0.5 * size[1]], f32)).astype(f32)
    s0, s1, s2 = clip_to_pixel(np.stack([c0, c1, c2]), size)[:, :2]  # elementwise: as one point at a time
    # The samples' v, one after the other (each step depends on the last v), in float32. The step
    # is raster_step's float64 arithmetic on Python floats, operation for operation (the same
    # IEEE results, without NumPy's per-call cost on a 2-vector).
    (d1x, d1y), (d2x, d2y) = (s1 - s0).tolist(), (s2 - s1).tolist()
    v, vs = f32(0.0), []
    for _ in range(int(RASTER_MAX_SAMPLES) + 1):
        vs.append(v)
        if v >= 1.0:
            break
        v = f32(min(f32(v + f32(_raster_step_scalar(d1x, d1y, d2x, d2y, float(v)))), f32(1.0)))
    vs = np.array(vs, f32)
    # Every sample's cross-section and coverage at once, then each sample's points.
    a, b = raster_section(c0, c1, c2, across_px, vs, shape, tau, size)
    a, b = a.astype(f32), b.astype(f32)
    span_px = np.linalg.norm(b[:, :2] - a[:, :2], axis=1).astype(f32)
    m = raster_cover(blade, np.arange(len(vs)), span_px)
    along = (b[:, :2] - a[:, :2]) / np.maximum(m, 1).astype(f32)[:, None]
    live = (m > 0) & (a[:, 2] > 0.0) & (a[:, 2] <= 1.0)
    sample = np.repeat(np.flatnonzero(live), m[live])
    j = np.arange(len(sample)) - np.repeat(np.cumsum(m[live]) - m[live], m[live])
    p = a[sample, :2] + (j.astype(f32) + f32(0.5))[:, None] * along[sample]
    x, y = np.floor(p[:, 0]).astype(np.int64), np.floor(p[:, 1]).astype(np.int64)
    inside = (x >= 0) & (x < size[0]) & (y >= 0) & (y < size[1])
    keep = sample[inside]
    return x[inside], y[inside], a[keep, 2].astype(np.float64), vs[keep].astype(np.float64)


def raster_blades(blades, viewport_size):
    """Depth and payload images of the compute rasterizer for a few blades: each item
    of ``blades`` is (c0, c1, c2, across, blade id, shape, tau) as for :func:`raster_walk`.
    The nearest depth wins per pixel; among equal depths the largest payload
    (raster.wgsl: atomicMin of the depth's float bits, then atomicMax of the payload).
    Returns (depth (H, W) float64, inf where empty; payload (H, W) uint32, 0 where empty)."""
    w, h = int(viewport_size[0]), int(viewport_size[1])
    depth = np.full((h, w), np.inf)
    payload = np.zeros((h, w), np.uint64)
    for c0, c1, c2, across, blade, shape, tau in blades:
        xs, ys, ds, vs = raster_walk(c0, c1, c2, across, blade, shape, tau, viewport_size)
        for x, y, d, p in zip(xs, ys, ds, raster_payload(blade, vs).tolist()):  # elementwise: one v at a time
            if d < depth[y, x]:
                depth[y, x], payload[y, x] = d, p
            elif d == depth[y, x]:
                payload[y, x] = max(int(payload[y, x]), p)
    return depth, payload.astype(np.uint32)

