"""Camera-following levels of a field to the horizon (``core/horizon.py``): which level a blade is
in, where the wrap moves it, and its weight (the NumPy twins of ``blade_math.wgsl``'s
``level_index``, ``wrap_shift`` and ``level_weight``, and of ``shaders/levels.wgsl``'s
``follow_camera`` step and ``blade_weight``).

The level table is the dict :meth:`grasswidget.core.horizon.HorizonLayout.table` gives
(``level_bands``, ``level_periods``, ``level_ends``, ``n_levels``), the one both engines write
into ``u_cull``. Metres, in the field's own space; the wrap and the weights work on (x, z): the
weights on the horizontal distance from the camera to the root.
"""

from __future__ import annotations

import numpy as np

__all__ = ["level_index", "wrap_shift", "level_weight", "follow_camera", "blade_weights"]


def level_index(i, ends_lo, ends_hi, n_levels):
    """Level of blade id ``i``: how many of the level ends (the first id after each level;
    ``ends_lo`` levels 0..3, ``ends_hi`` 4..7, unused ones 2^32 - 1) are <= i, at most
    ``n_levels - 1`` (n_levels 0 counts as 1)."""
    i = np.asarray(i, np.uint64)[..., None]
    ends = np.concatenate([np.asarray(ends_lo, np.uint64), np.asarray(ends_hi, np.uint64)], axis=-1)
    k = np.sum(i >= ends, axis=-1).astype(np.int64)
    return np.minimum(k, np.maximum(np.asarray(n_levels, np.int64), 1) - 1).astype(np.uint32)


def wrap_shift(p, cam, period):
    """The (x, z) shift that moves a root at ``p`` (x, z) to its copy nearest the camera at ``cam``
    (x, z) on a plane repeated every ``period`` metres: ``period * round((cam - p) / period)``
    (float32, rounding half to even, as WGSL's ``round``)."""
    p, cam = np.asarray(p, np.float32), np.asarray(cam, np.float32)
    period = np.asarray(period, np.float32)[..., None] if np.ndim(period) else np.float32(period)
    return (period * np.round((cam - p) / period)).astype(np.float32)


def _smoothstep(a, b, x):
    t = np.clip((np.asarray(x, np.float64) - a) / (np.asarray(b, np.float64) - a), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def level_weight(d, bands):
    """Weight (0..1) of a blade of a level at distance ``d`` (m) from the camera, its
    level's ``bands`` = (in_start, in_end, out_start, out_end): ``smoothstep(in_start, in_end, d)
    (1 - smoothstep(out_start, out_end, d))``."""
    b = np.asarray(bands, np.float64)
    return _smoothstep(b[..., 0], b[..., 1], d) * (1.0 - _smoothstep(b[..., 2], b[..., 3], d))


def _levels(n, table):
    ends = np.asarray(table["level_ends"], np.uint64).reshape(2, 4)
    return level_index(np.arange(n), ends[0], ends[1], int(table["n_levels"])).astype(np.int64)


def follow_camera(v0, v1, v2, cam, table):
    """The blades after the culling pass's wrap (``shaders/levels.wgsl`` ``follow_camera``):
    each blade moved to the copy of its root nearest the camera ``cam`` (x, y, z; m, the
    culling camera in the field's space) on its level's tile; v1 and v2 move with v0 (the bend is
    kept). Returns new (v0, v1, v2) float32 arrays (N, 3)."""
    v0 = np.array(v0, np.float32)
    v1, v2 = np.array(v1, np.float32), np.array(v2, np.float32)
    k = _levels(len(v0), table)
    period = np.asarray(table["level_periods"], np.float32).reshape(-1)[k]
    cam = np.asarray(cam, np.float32).reshape(3)
    shift = wrap_shift(v0[:, [0, 2]], cam[[0, 2]][None, :], period)
    for v in (v0, v1, v2):
        v[:, 0] += shift[:, 0]
        v[:, 2] += shift[:, 1]
    return v0, v1, v2


def blade_weights(v0, cam, table):
    """Each blade's weight (``shaders/levels.wgsl`` ``blade_weight``): :func:`level_weight` of its
    level's bands at the horizontal distance from the camera ``cam`` (x, y, z; m) to its root."""
    v0 = np.asarray(v0, np.float64)
    k = _levels(len(v0), table)
    cam = np.asarray(cam, np.float64).reshape(3)
    d = np.hypot(v0[:, 0] - cam[0], v0[:, 2] - cam[2])
    return level_weight(d, np.asarray(table["level_bands"], np.float64)[k])
