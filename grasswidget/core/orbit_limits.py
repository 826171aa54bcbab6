"""Orbit limits, pure: the camera stays above the ground, the field stays in sight.

:class:`OrbitLimits` describes what a meadow view allows; :func:`clamp_orbit`
(NumPy) puts a camera position and orbit target back inside those limits. Both
engines hold their orbit to them: the kernel's
:class:`grasswidget.notebook.orbit.GroundOrbitController`, and the browser's
drag (engine.js ``clampOrbit``, with the limits sent as data by
:func:`grasswidget.core.frame_data.orbit_rules`).

The limits, for a field on a y-up ground plane:

- the camera is at least ``clearance`` above the ground (``ground_y``), and at
  most ``max_elevation_deg`` above the target's horizon (not straight down,
  where the orbit would flip);
- the camera is ``min_distance`` .. ``max_distance`` from the target (zoom);
- the target stays over the field (its x/z bounds, plus ``margin``) and between
  the ground and ``top_y`` (a pan cannot carry the view off the field).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["OrbitLimits", "clamp_orbit"]


@dataclass(frozen=True)
class OrbitLimits:
    """What an orbiting camera may do (metres, degrees; world space).

    Attributes:
        lo, hi: (x, z) corners of the area the target may move in.
        ground_y: height of the ground; None for a field that is not on a plane
            (grass on a sphere): then only the distance and target limits apply.
        top_y: the highest the target may go.
        clearance: least height of the camera above the ground (default 0.3 m).
        min_distance, max_distance: zoom range, camera to target.
        max_elevation_deg: highest angle of the camera above the target's horizon.
    """

    lo: tuple
    hi: tuple
    ground_y: float | None
    top_y: float
    min_distance: float
    max_distance: float
    clearance: float = 0.3
    max_elevation_deg: float = 85.0

    @classmethod
    def for_field(cls, v0, up, height, far=None):
        """Limits for blades with roots ``v0`` (N, 3), normals ``up`` (N, 3) and
        heights (N,), seen by a camera whose far plane is ``far`` (or None).

        Zoom: from the tallest blade's height (at least 0.5 m) out to three times
        the field's extent, but no farther than 70 % of the far plane (so the
        field is never clipped away). A field whose normals do not all point up
        (y > 0.9) gets no ground limit.
        """
        v0 = np.asarray(v0, np.float64)
        lo, hi = v0.min(axis=0), v0.max(axis=0)
        extent = float(max(hi[0] - lo[0], hi[2] - lo[2], 1.0))
        margin = 0.1 * extent
        tallest = float(np.max(height)) if len(height) else 1.0
        flat = bool(np.all(np.asarray(up)[:, 1] > 0.9))
        max_distance = 3.0 * extent
        if far:
            max_distance = min(max_distance, 0.7 * float(far))
        min_distance = max(0.5, tallest)
        return cls(
            lo=(float(lo[0] - margin), float(lo[2] - margin)),
            hi=(float(hi[0] + margin), float(hi[2] + margin)),
            ground_y=float(lo[1]) if flat else None,
            top_y=float(hi[1] + 2.0 * tallest),
            min_distance=min_distance,
            max_distance=max(max_distance, 2.0 * min_distance),
        )

    @classmethod
    def for_scene(cls, scene):
        """Limits for a :class:`~grasswidget.gpu.scene.GrassScene`'s field and camera."""
        blades = scene.field.blades
        far = scene.camera.depth_range[1] if scene.camera.depth_range else None
        return cls.for_field(blades.v0, blades.up, blades.height, far)

    def min_elevation(self, target_y, distance) -> float:
        """Lowest elevation (radians above the target's horizon) that keeps the
        camera ``clearance`` above the ground at this distance."""
        if self.ground_y is None:
            return -math.radians(self.max_elevation_deg)
        s = (self.ground_y + self.clearance - target_y) / max(distance, 1e-9)
        return math.asin(min(max(s, -1.0), 1.0))


def _elevation(offset):
    """Angle (radians) of ``offset`` (camera - target) above the horizontal plane."""
    d = float(np.linalg.norm(offset))
    return math.asin(min(max(offset[1] / max(d, 1e-12), -1.0), 1.0))


def clamp_orbit(position, target, limits: OrbitLimits):
    """``(position, target)`` moved the least way into ``limits``: the target into
    its box (the camera moves with it), the distance into the zoom range, then the
    elevation into its range (keeping the azimuth). Arrays of 3 floats."""
    pos = np.asarray(position, np.float64).copy()
    tgt = np.asarray(target, np.float64).copy()
    # target over the field (the camera follows, as in a pan)
    clamped = tgt.copy()
    clamped[0] = min(max(tgt[0], limits.lo[0]), limits.hi[0])
    clamped[2] = min(max(tgt[2], limits.lo[1]), limits.hi[1])
    floor = limits.ground_y if limits.ground_y is not None else -math.inf
    clamped[1] = min(max(tgt[1], floor), limits.top_y)
    pos += clamped - tgt
    tgt = clamped
    # distance (zoom)
    offset = pos - tgt
    d = float(np.linalg.norm(offset))
    if d < 1e-9:
        offset, d = np.array([0.0, 0.0, 1.0]), 1e-9
    d_new = min(max(d, limits.min_distance), limits.max_distance)
    direction = offset / d
    # elevation (above the ground, not over the top), keeping the azimuth
    el = _elevation(direction)
    lo_el = limits.min_elevation(tgt[1], d_new)
    hi_el = math.radians(limits.max_elevation_deg)
    el_new = min(max(el, lo_el), hi_el)
    if el_new != el:
        horizontal = np.array([direction[0], 0.0, direction[2]])
        h = float(np.linalg.norm(horizontal))
        horizontal = horizontal / h if h > 1e-9 else np.array([0.0, 0.0, 1.0])
        direction = horizontal * math.cos(el_new) + np.array([0.0, math.sin(el_new), 0.0])
    return tgt + direction * d_new, tgt
