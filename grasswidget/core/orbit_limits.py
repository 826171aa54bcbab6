"""Orbit limits, pure: the camera stays above the grass (or the ground), the field stays in sight.

:class:`OrbitLimits` describes what a meadow view allows; :func:`clamp_orbit`
(NumPy) puts a camera position and orbit target back inside those limits. Both
engines hold their orbit to them: the kernel's
:class:`grasswidget.views.orbit.GroundOrbitController`, and the browser's
drag (``browser/js/rules.js`` ``clampOrbit``, with the limits sent as data by
:func:`grasswidget.core.engine_inputs.orbit_rules`).

The limits, for a field on a y-up ground plane:

- the camera is at least ``clearance`` above the ground (``ground_y``), and at
  most ``max_elevation_deg`` above the target's horizon (88.5: the "top" camera
  preset looks straight down within 1.5 degrees; pygfx's orbit stops at 89 and
  the browser's drag at 88.8, short of the pole where the orbit would flip);
- the *floor* (:data:`FLOORS`) decides that clearance: ``"grass"`` (the default)
  puts it :data:`GRASS_CLEARANCE` above the top of the tallest blade, so no
  drag, pan or wheel flick takes the camera into the grass or below the blades it
  looks at; ``"ground"`` puts it :data:`GROUND_CLEARANCE` above the ground (down
  among the blades, asked for explicitly). Under ``"grass"`` the least zoom
  distance is raised so that the camera can always be that high above a target
  on the ground (``clearance / sin(max_elevation)``);
- the camera is ``min_distance`` .. ``max_distance`` from the target (zoom);
- the target stays over the field (its x/z bounds, plus ``margin``) and between
  the ground and ``top_y`` (a pan cannot carry the view off the field).

A field to the horizon (``Blades.on_plane(..., reach=R)``, a
:class:`~grasswidget.core.horizon.HorizonLayout`) follows the camera (its levels of tiles
are moved around it every frame), so the camera may go anywhere within
:meth:`HorizonLayout.max_camera_offset` (R) of its centre: the target pans over a square of
half side R / 4 around the centre (or the near square, if larger), and the zoom stops where
a camera over that square's farthest corner would be farther than R from the centre.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import GrassValueError

__all__ = ["OrbitLimits", "clamp_orbit", "FLOORS", "GRASS_CLEARANCE", "GROUND_CLEARANCE", "check_floor",
           "grass_top"]

#: What the camera stays above: "grass" (the tallest blade's tip) or "ground" (the ground plane).
FLOORS = ("grass", "ground")
#: Least height of the camera above the tallest blade's tip under the "grass" floor, metres.
GRASS_CLEARANCE = 0.3
#: Least height of the camera above the ground under the "ground" floor, metres.
GROUND_CLEARANCE = 0.3
#: Highest elevation of the camera above the target's horizon, degrees (default of OrbitLimits).
MAX_ELEVATION_DEG = 88.5


def check_floor(floor, name="camera_floor") -> str:
    """``floor`` if it is one of :data:`FLOORS`, else GrassValueError naming ``name`` and the choices."""
    if not isinstance(floor, str) or floor not in FLOORS:
        raise GrassValueError(f"{name} must be one of {', '.join(map(repr, FLOORS))}; got {floor!r}")
    return floor


def grass_top(v0, height) -> float:
    """Height (y, metres) of the highest blade tip of a field at rest: max of root y + blade height."""
    v0 = np.asarray(v0, np.float64)
    if not len(v0):
        return 0.0
    return float(np.max(v0[:, 1] + np.asarray(height, np.float64)))


@dataclass(frozen=True)
class OrbitLimits:
    """What an orbiting camera may do (metres, degrees; world space).

    Attributes:
        lo, hi: (x, z) corners of the area the target may move in.
        ground_y: height of the ground; None for a field that is not on a plane
            (grass on a sphere): then only the distance and target limits apply.
        top_y: the highest the target may go.
        clearance: least height of the camera above the ground (default 0.3 m;
            :meth:`for_field` with the "grass" floor: up to the tallest blade's tip
            plus :data:`GRASS_CLEARANCE`).
        min_distance, max_distance: zoom range, camera to target.
        max_elevation_deg: highest angle of the camera above the target's horizon
            (default 88.5).
    """

    lo: tuple
    hi: tuple
    ground_y: float | None
    top_y: float
    min_distance: float
    max_distance: float
    clearance: float = GROUND_CLEARANCE
    max_elevation_deg: float = MAX_ELEVATION_DEG

    @classmethod
    def for_field(cls, v0, up, height, far=None, floor="grass", horizon=None):
        """Limits for blades with roots ``v0`` (N, 3), normals ``up`` (N, 3) and
        heights (N,), seen by a camera whose far plane is ``far`` (or None).

        Zoom: from the tallest blade's height (at least 0.5 m) out to three times
        the field's extent, but no farther than 70 % of the far plane (so the
        field is never clipped away). A field whose normals do not all point up
        (y > 0.9) gets no ground limit (and no floor).

        ``floor`` (:data:`FLOORS`): "grass" (default) keeps the camera
        :data:`GRASS_CLEARANCE` above the tallest blade's tip (so above every blade
        it looks at, and never inside the field) and raises the least zoom distance
        to ``clearance / sin(max_elevation)``, so a wheel flick towards a target on
        the ground stops above the grass; "ground" keeps it :data:`GROUND_CLEARANCE`
        above the ground.

        ``horizon``: the :class:`~grasswidget.core.horizon.HorizonLayout` of a field to the
        horizon (``Blades.horizon``), else None. Its target box is the square of half side
        ``max(near_radius, reach / 4)`` around its centre (plus the margin), and the zoom stops
        where a camera could be farther than ``horizon.max_camera_offset()`` from the centre.
        """
        check_floor(floor, "floor")
        v0 = np.asarray(v0, np.float64)
        lo, hi = v0.min(axis=0), v0.max(axis=0)
        if horizon is not None:  # the blades follow the camera: pan over a square a quarter of the reach wide
            r0, (cx, cz) = max(float(horizon.near_radius), 0.25 * float(horizon.reach)), horizon.center
            lo = np.array([cx - r0, lo[1], cz - r0])
            hi = np.array([cx + r0, hi[1], cz + r0])
        extent = float(max(hi[0] - lo[0], hi[2] - lo[2], 1.0))
        margin = 0.1 * extent
        tallest = float(np.max(height)) if len(height) else 1.0
        flat = bool(np.all(np.asarray(up)[:, 1] > 0.9))
        max_distance = 3.0 * extent
        if far:
            max_distance = min(max_distance, 0.7 * float(far))
        if horizon is not None:  # the farthest target corner plus the zoom stays within the offset
            max_distance = min(max_distance, horizon.max_camera_offset() - math.sqrt(2.0) * (0.5 * extent + margin))
        min_distance = max(0.5, tallest)
        ground_y = float(lo[1]) if flat else None
        clearance = GROUND_CLEARANCE
        if floor == "grass" and ground_y is not None:
            clearance = grass_top(v0, height) - ground_y + GRASS_CLEARANCE
            # reachable from a target on the ground at the highest elevation, with 1 % to spare
            min_distance = max(min_distance, 1.01 * clearance / math.sin(math.radians(MAX_ELEVATION_DEG)))
        return cls(
            lo=(float(lo[0] - margin), float(lo[2] - margin)),
            hi=(float(hi[0] + margin), float(hi[2] + margin)),
            ground_y=ground_y,
            top_y=float(hi[1] + 2.0 * tallest),
            min_distance=min_distance,
            max_distance=max(max_distance, 2.0 * min_distance),
            clearance=clearance,
        )

    @classmethod
    def for_scene(cls, scene, floor="grass"):
        """Limits for a :class:`~grasswidget.gpu.scene.GrassScene`'s field and camera."""
        blades = scene.field.blades
        far = scene.camera.depth_range[1] if scene.camera.depth_range else None
        return cls.for_field(blades.v0, blades.up, blades.height, far, floor=floor, horizon=blades.horizon)

    def allows(self, position, target, tol=1e-6) -> bool:
        """Whether ``(position, target)`` is inside these limits (:func:`clamp_orbit` leaves it)."""
        p, t = clamp_orbit(position, target, self)
        return bool(np.allclose(p, position, atol=tol) and np.allclose(t, target, atol=tol))

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
