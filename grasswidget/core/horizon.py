"""Grass to the horizon: levels of tiles that follow the camera (pure NumPy).

A field made with ``Blades.on_plane(count, size, reach=R)`` is a *clipmap of wrapped
tiles*: its ``count`` blades are split into K levels (k = 0 .. K-1). Level k is a square
tile of side ``P_k = P0 2^k`` metres repeated over the whole plane (a torus); its blades
are laid out in one period as ``on_plane`` lays out a square (jittered cells, patches of
4 x 4 cells in Z order, random order within a patch). Each frame the culling pass moves
every blade to the copy of its root nearest the camera (``x += P_k round((cam_x - x) /
P_k)``, the same for z; ``reference.follow_camera``), so every level is always centred on
the camera, wherever it goes.

Each level draws only in a band of horizontal distance from the camera to the blade's root (so that
the 10 m around the camera hold level 0's density from any height, the "top" camera included: a
dense disc under it, fading into the thinner levels), through a weight
(``reference.level_weight``) that scales the blade's drawn width and culls it at 0:

- level k fades out (smoothstep) from ``a_k = FADE_START b_k`` to ``b_k = BAND_OUTER P_k / 2``,
  strictly inside the tile's inscribed circle (the distance to the root is at least the horizontal
  one), so a blade is moved by the wrap only where its weight is 0 (nothing visible jumps);
- level k >= 1 fades in over level k-1's fade-out band, with the same smoothstep, so the
  weights of the levels sum to 1 out to ``b_{K-1}`` (no band edge shows as a line);
- level 0 is full from the camera out to ``a_0``.

The weights depend on the camera's position only: turning the camera changes nothing.

Counts (``split``): level 0 keeps the square field's density ``N / size^2`` (about 1000 per
m^2 for the meadow) over a tile just large enough that its weight is above one half out to
:data:`NEAR_RADIUS` (10 m) from the camera, with at most :data:`NEAR_SHARE_MAX` of the blades
(a small count: the density falls below the square field's, but the 10 m disc holds as many
blades as the square field had there from its home camera). The rest go to the far levels,
shared evenly, but no level k denser than :data:`FAR_DENSITY_FALL` ^ -k times level 0 (what a
level cannot take moves on to the next; the last takes what is left): a large count fills the
middle distance only as densely as the far look needs and puts the rest farther out, where the
blades are a few pixels each (on an H200 at 2^24, 1920 x 1080: 134 pipelined frames/s, where
level 0 grown to half the blades drew 114). There are as many levels as make ``b_{K-1}`` the
nearest to ``R`` (at most :data:`MAX_LEVELS`).

Widths: seen at a grazing angle from d metres away, the share of a pixel covered by blades
goes as density x width x d. A level k blade is drawn at about 2^k times level 0's
distance, so the covered share stays the same from level to level when
``rho_k w_k 2^k = rho_0 w_0``: each level k blade is ``(rho_0 / rho_k) / 2^k`` times wider
(:meth:`HorizonLayout.width_factors`; 2^k when the density falls 4 times per level), at most
:data:`MAX_WIDEN` times (beyond that the far ground's grass colour, not wider blades, covers
the soil; a blade as wide as it is tall no longer looks like grass).

Over level 0's fade-out band the ground turns from soil to the grass's colour seen from afar
(``shaders/sky_ground.wgsl`` ``ground_albedo``, :meth:`HorizonLayout.ground_blend`), so the
thinner far levels stand on grass-coloured ground (no line of soil where level 0 ends: their
blades give the texture and the silhouettes, the ground the colour), and past ``b_{K-1}`` the
ground alone draws the far field. The orbit
may take the camera anywhere within ``R`` of the centre (:meth:`HorizonLayout.max_camera_offset`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import GrassValueError

__all__ = ["HorizonLayout", "MAX_LEVELS", "NEAR_RADIUS", "BAND_OUTER", "FADE_START", "MAX_WIDEN",
           "NEAR_SHARE_MAX", "FAR_DENSITY_FALL", "concentric_disc"]

#: Most levels a field to the horizon has (the uniform table of both engines holds this many).
MAX_LEVELS = 8
#: Radius (m) around the camera that level 0 covers with weight above one half.
NEAR_RADIUS = 10.0
#: A level's weight reaches 0 at this share of its tile's half side (< 1: inside the inscribed circle).
BAND_OUTER = 0.95
#: A level starts fading out at this share of the distance where its weight reaches 0 (> 0.5, so that
#: level k's full band, from b_{k-1} = b_k / 2 to a_k, is not empty).
FADE_START = 0.8
#: Most a blade is widened (times its near width).
MAX_WIDEN = 4.0
#: Most share of the blades in level 0 (a small count: its density falls below the square's).
NEAR_SHARE_MAX = 0.85
#: A far level k is at most ``FAR_DENSITY_FALL ** -k`` times as dense as level 0 (per doubling
#: of the tile, half the density: the 1/r fall-off of Outerra's bands).
FAR_DENSITY_FALL = 2.0


def _smoothstep(a, b, x):
    t = np.clip((np.asarray(x, np.float64) - a) / (b - a), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


@dataclass(frozen=True)
class HorizonLayout:
    """How a field to the horizon is laid out and drawn (metres).

    Attributes:
        center: (x, z) of the field's centre (the tiles' origin, and what the orbit keeps
            the camera near).
        near_radius: half the side of the near square (``on_plane``'s ``size`` / 2, > 0): the
            square field of the same count has density ``count / (2 near_radius)^2``; the
            camera presets frame that square.
        reach: R (m, > near_radius): the levels reach about this far from the camera, and the
            camera may go this far from the centre.
        count: the blades N (>= 1).

    Derived (read-only): ``counts`` (blades per level), ``periods`` (P_k, m), ``ends`` (the
    first id after each level), ``bands`` ((fade-in start, fade-in end, fade-out start,
    fade-out end) per level, m from the camera).
    """

    center: tuple
    near_radius: float
    reach: float
    count: int = 1
    counts: tuple = field(init=False, compare=False, repr=False)
    periods: tuple = field(init=False, compare=False, repr=False)

    def __post_init__(self):
        r0, reach = float(self.near_radius), float(self.reach)
        if not (np.isfinite(r0) and r0 > 0):
            raise GrassValueError(f"near_radius must be a finite number > 0 (metres); got {self.near_radius!r}")
        if not (np.isfinite(reach) and reach > r0):
            raise GrassValueError(f"reach must be a finite number > size / 2 = {r0:g} metres (the near square's "
                                  f"half side); got {self.reach!r}")
        if isinstance(self.count, bool) or not isinstance(self.count, (int, np.integer)) or self.count < 1:
            raise GrassValueError(f"count must be an integer >= 1; got {self.count!r}")
        counts, p0 = self._split(int(self.count), r0, reach)
        object.__setattr__(self, "counts", counts)
        object.__setattr__(self, "periods", tuple(p0 * 2.0 ** k for k in range(len(counts))))

    @staticmethod
    def _split(n, r0, reach):
        """(blades per level, P0): see the module's docstring."""
        rho_sq = n / (2.0 * r0) ** 2
        mid = 0.5 * (1.0 + FADE_START) * BAND_OUTER  # weight 1/2 at mid * P / 2 (smoothstep's middle)
        p0 = 2.0 * NEAR_RADIUS / mid
        b0 = 0.5 * BAND_OUTER * p0
        levels = 1 + max(0, int(round(math.log2(reach / b0)))) if reach > b0 else 1
        levels = min(levels, MAX_LEVELS, n)
        if levels == 1:
            return (n,), p0
        n0 = int(min(rho_sq * p0 * p0, NEAR_SHARE_MAX * n))
        n0 = min(max(n0, 1), n - (levels - 1))
        counts, rest = [n0], n - n0
        for k in range(1, levels):
            left = levels - k  # far levels still to fill, this one included
            if left == 1:
                counts.append(rest)
                break
            share = max(1, min(rest // left, int(n0 * (4.0 / FAR_DENSITY_FALL) ** k)))
            counts.append(share)
            rest -= share
        return tuple(counts), p0

    # ------------------------------------------------------------------ the levels

    @property
    def n_levels(self) -> int:
        """K, the number of levels (1 .. MAX_LEVELS)."""
        return len(self.counts)

    @property
    def ends(self) -> tuple:
        """The first blade id after each level (ids run level by level, level 0 first)."""
        return tuple(int(x) for x in np.cumsum(self.counts))

    @property
    def bands(self) -> tuple:
        """Per level ``(in_start, in_end, out_start, out_end)``: metres from the camera over which
        its weight rises from 0 to 1 (level 0: always 1, given as -2, -1) and falls back to 0."""
        out = []
        for k, p in enumerate(self.periods):
            b = 0.5 * BAND_OUTER * p
            rise = (-2.0, -1.0) if k == 0 else out[-1][2:]
            out.append((*rise, FADE_START * b, b))
        return tuple(out)

    def densities(self) -> tuple:
        """Blades per square metre of each level (its count over its tile's area)."""
        return tuple(n / (p * p) for n, p in zip(self.counts, self.periods))

    def width_factors(self) -> tuple:
        """How much wider than its near width each level's blades are: ``min((rho_0 / rho_k) / 2^k,
        MAX_WIDEN)``, at least 1 (see the module's docstring)."""
        rho = self.densities()
        return tuple(float(min(max(rho[0] / r / 2.0 ** k, 1.0), MAX_WIDEN)) for k, r in enumerate(rho))

    def near_density(self, count=None) -> float:
        """Blades per square metre near the camera (level 0's). ``count``: ignored unless given,
        then it must be the layout's (kept for callers of before)."""
        if count is not None and int(count) != int(self.count):
            raise GrassValueError(f"count must be the layout's {self.count}; got {count!r}")
        return self.densities()[0]

    def weights(self, d):
        """(K, ...) weights of every level at distances ``d`` (m) from the camera to the roots
        (``reference.level_weight`` of each level's bands); they sum to 1 out to ``drawn_reach``."""
        d = np.asarray(d, np.float64)
        return np.stack([_smoothstep(a, b, d) * (1.0 - _smoothstep(c, e, d)) for a, b, c, e in self.bands])

    def drawn_reach(self) -> float:
        """Where the last level's weight reaches 0 (m from the camera): no blade is drawn beyond."""
        return self.bands[-1][3]

    def expected_drawn(self, radius: float, threshold: float = 0.5) -> float:
        """Expected number of blades within ``radius`` m (horizontally) of the camera whose weight is
        above ``threshold`` (0..1), wherever the camera is and at any height: per level its density
        times the area of the part of the disc where its weight is above ``threshold`` (the weights
        are monotonic in each band of horizontal distance, so that part is a ring)."""
        thr = float(threshold)
        total = 0.0
        for rho, (a, b, c, e) in zip(self.densities(), self.bands):
            inner = 0.0 if a < 0 else _inverse_smoothstep(a, b, thr)
            outer = _inverse_smoothstep(c, e, 1.0 - thr)
            lo, hi = min(inner, radius), min(outer, radius)
            total += rho * math.pi * max(hi * hi - lo * lo, 0.0)
        return total

    def table(self) -> dict:
        """The level table both engines write once into ``u_cull`` (``uniform_layouts.CULL_LAYOUT``):
        ``level_bands`` (MAX_LEVELS x 4, m), ``level_periods`` (2 x 4: P_k at [k // 4][k % 4], m),
        ``level_ends`` (2 x 4 u32, unused levels 2^32 - 1) and ``n_levels``."""
        bands = np.zeros((MAX_LEVELS, 4))
        bands[:self.n_levels] = self.bands
        periods = np.zeros(2 * 4)
        periods[:self.n_levels] = self.periods
        ends = np.full(2 * 4, 0xFFFFFFFF, np.uint64)
        ends[:self.n_levels] = self.ends
        return {"level_bands": bands, "level_periods": periods.reshape(2, 4), "level_ends": ends.reshape(2, 4),
                "n_levels": self.n_levels}

    # ------------------------------------------------------------------ placement

    def place(self, rng, count: int, square_points):
        """Roots (x, z) (float64 arrays) and width factors of ``count`` (the layout's) blades.

        ``square_points(rng, n)`` gives ``n`` jittered-stratified points (x, z) in [0, 1)^2 in
        the order the blades' ids take (patches in Z order); each level gets its own, scaled to
        its tile centred on the field's centre. Level 0 comes first in id order."""
        if int(count) != int(self.count):
            raise GrassValueError(f"count must be the layout's {self.count}; got {count!r}")
        cx, cz = (float(self.center[0]), float(self.center[1]))
        xs, zs, ws = [], [], []
        for n, p, f in zip(self.counts, self.periods, self.width_factors()):
            u, v = square_points(rng, n)
            xs.append(cx + (u - 0.5) * p)
            zs.append(cz + (v - 0.5) * p)
            ws.append(np.full(n, f))
        return np.concatenate(xs), np.concatenate(zs), np.concatenate(ws)

    # ------------------------------------------------------------------ cameras

    def max_camera_offset(self) -> float:
        """How far (m, horizontally) from the centre an orbiting camera may go: the reach (the
        levels follow the camera, so the grass around it is the same anywhere)."""
        return float(self.reach)

    def ground_blend(self) -> tuple:
        """``(start, end)`` metres from the camera over which the soil seen between the blades
        gives way to the grass's colour seen from afar: level 0's fade-out band, so that the
        thinner far levels stand on grass-coloured ground (their blades add the texture and the
        silhouettes, the ground the colour) and the last one fades into it."""
        a, b = self.bands[0][2:]
        return (float(a), float(b))


def _inverse_smoothstep(a, b, y):
    """The x in [a, b] where smoothstep(a, b, x) = y (0 <= y <= 1)."""
    y = min(max(float(y), 0.0), 1.0)
    t = 0.5 - math.sin(math.asin(1.0 - 2.0 * y) / 3.0)  # the root in [0, 1] of 3 t^2 - 2 t^3 = y
    return a + t * (b - a)


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
