"""Grass to the horizon: where a field's blades go and how wide they are (pure NumPy).

A field made with ``Blades.on_plane(count, size, reach=R)`` is a disc of radius
``R`` (the *reach*, metres) around the plane's centre:

- a *near disc* of diameter ``size`` (radius ``r0``) at full density ``rho0``;
- beyond it the density falls as ``rho0 r0 / r`` (half per doubling of the distance
  from the centre, as Outerra's grass halves the count per distance band) and each
  blade's width grows as ``r / r0`` (double per doubling), so the leaf area per square
  metre of ground (count x width x height), hence the ground the grass covers and its
  colour seen from afar, is the same everywhere. The density falls continuously (no
  band edge, so no ring where it steps), and the widening is data of each blade: the
  simulation and the culling see ordinary blades.

With density ``rho0 r0 / r`` a ring of width ``dr`` holds ``2 pi rho0 r0 dr`` blades,
the same for every ``dr`` of radius: the radius of a blade beyond the near disc is
uniform in ``[r0, R]``. The count is fixed by the caller; of ``N`` blades the near disc
holds ``N r0 / (2 R - r0)`` (the density is continuous at ``r0``), and
``rho0 = N / (pi r0 (2 R - r0))``.

Beyond ``R`` the ground is coloured like the grass seen from afar
(``shaders/sky_ground.wgsl`` ``ground_albedo``, values from
:func:`grasswidget.core.engine_inputs.sky_ground_values`); the orbit keeps the camera over
the near disc and close enough to it (:meth:`HorizonLayout.max_camera_offset`) that the
edge at ``R`` is always far away, where the blades are a few pixels and the ground
there already has the grass's colour.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import GrassValueError

__all__ = ["HorizonLayout", "concentric_disc"]


@dataclass(frozen=True)
class HorizonLayout:
    """How a field to the horizon is laid out on its plane (metres).

    Attributes:
        center: (x, z) of the field's centre.
        near_radius: radius r0 of the near disc at full density (> 0).
        reach: radius R of the last blades (> near_radius).
    """

    center: tuple
    near_radius: float
    reach: float

    def __post_init__(self):
        r0, reach = float(self.near_radius), float(self.reach)
        if not (np.isfinite(r0) and r0 > 0):
            raise GrassValueError(f"near_radius must be a finite number > 0 (metres); got {self.near_radius!r}")
        if not (np.isfinite(reach) and reach > r0):
            raise GrassValueError(f"reach must be a finite number > size / 2 = {r0:g} metres (the near disc's "
                                  f"radius); got {self.reach!r}")

    # ------------------------------------------------------------------ counts and densities

    def near_count(self, count: int) -> int:
        """How many of ``count`` blades lie in the near disc: ``round(count r0 / (2 R - r0))``."""
        r0, reach = float(self.near_radius), float(self.reach)
        return int(min(count, round(count * r0 / (2.0 * reach - r0))))

    def near_density(self, count: int) -> float:
        """Blades per square metre in the near disc for ``count`` blades: ``count / (pi r0 (2 R - r0))``."""
        r0, reach = float(self.near_radius), float(self.reach)
        return float(count) / (math.pi * r0 * (2.0 * reach - r0))

    def density(self, r, count: int):
        """Expected blades per square metre at distance ``r`` (m, array) from the centre:
        ``rho0`` inside the near disc, ``rho0 r0 / r`` out to the reach, 0 beyond."""
        r = np.asarray(r, np.float64)
        rho0, r0 = self.near_density(count), float(self.near_radius)
        return np.where(r <= r0, rho0, np.where(r <= self.reach, rho0 * r0 / np.maximum(r, 1e-30), 0.0))

    def expected_count(self, r_in, r_out, count: int) -> float:
        """Expected number of blades with ``r_in <= r < r_out`` (metres from the centre): the
        integral of :meth:`density` over that ring."""
        r0, reach = float(self.near_radius), float(self.reach)
        rho0 = self.near_density(count)
        a, b = max(float(r_in), 0.0), min(float(r_out), reach)
        if b <= a:
            return 0.0
        near = math.pi * rho0 * (min(b, r0) ** 2 - min(a, r0) ** 2)
        far = 2.0 * math.pi * rho0 * r0 * (max(b, r0) - max(a, r0))
        return near + far

    def width_scale(self, r):
        """Factor on a blade's width at distance ``r`` (m) from the centre: ``max(1, r / r0)``."""
        return np.maximum(1.0, np.asarray(r, np.float64) / float(self.near_radius))

    # ------------------------------------------------------------------ placement

    def place(self, rng, count: int, square_points):
        """Roots (x, z) (float64 arrays) and width factors of ``count`` blades.

        ``square_points(rng, n)`` gives ``n`` jittered-stratified points (x, z) in
        [0, 1)^2 in the order the blades' ids take (patches in Z order): the near disc
        gets them through :func:`concentric_disc` (area-preserving, so the disc stays
        stratified), the ring beyond gets them as (radius, angle) with the radius uniform
        in [r0, R] (density ``rho0 r0 / r``). Near blades come first in id order."""
        n_near = self.near_count(count)
        r0, reach = float(self.near_radius), float(self.reach)
        cx, cz = (float(self.center[0]), float(self.center[1]))
        xs, zs = [], []
        if n_near:
            u, v = square_points(rng, n_near)
            dx, dz = concentric_disc(u, v)
            xs.append(cx + r0 * dx)
            zs.append(cz + r0 * dz)
        n_far = count - n_near
        if n_far:
            u, v = square_points(rng, n_far)
            r = r0 + u * (reach - r0)
            angle = 2.0 * math.pi * v
            xs.append(cx + r * np.cos(angle))
            zs.append(cz + r * np.sin(angle))
        x, z = np.concatenate(xs), np.concatenate(zs)
        return x, z, self.width_scale(np.hypot(x - cx, z - cz))

    # ------------------------------------------------------------------ cameras

    def max_camera_offset(self) -> float:
        """How far (m, horizontally) from the centre an orbiting camera may go: half the
        reach, so the field's edge is never nearer than half the reach."""
        return 0.5 * float(self.reach)

    def ground_blend(self) -> tuple:
        """``(start, end)`` metres from the camera over which the soil seen between the
        blades gives way to the grass's colour seen from afar: from the near radius to
        the nearest the edge can be (``R`` - :meth:`max_camera_offset`), at most 4 near radii."""
        r0 = float(self.near_radius)
        end = min(4.0 * r0, float(self.reach) - self.max_camera_offset())
        return (min(r0, 0.5 * end), end)


def concentric_disc(u, v):
    """Shirley and Chiu's concentric map of [0, 1)^2 onto the unit disc: area-preserving
    (uniform points stay uniform) and continuous, so stratified points stay stratified.
    Returns (x, z) arrays."""
    a = 2.0 * np.asarray(u, np.float64) - 1.0
    b = 2.0 * np.asarray(v, np.float64) - 1.0
    first = np.abs(a) > np.abs(b)
    safe_a = np.where(a == 0.0, 1.0, a)
    safe_b = np.where(b == 0.0, 1.0, b)
    r = np.where(first, a, b)
    phi = np.where(first, (math.pi / 4.0) * (b / safe_a), math.pi / 2.0 - (math.pi / 4.0) * (a / safe_b))
    return r * np.cos(phi), r * np.sin(phi)
