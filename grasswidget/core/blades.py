"""Blade generation (pure NumPy, no GPU import).

A blade is packed, as in Jahrmann & Wimmer (2017), into 4 x vec4 (64 bytes):

=====  ================================  =====================
vec4   xyz                               w
=====  ================================  =====================
0      v0: root on the surface (fixed)   orientation theta (rad)
1      v1: Bezier guide above v0         height h (m)
2      v2: tip guide, simulated          width w (m)
3      up: surface normal at v0          stiffness s (1/s^2)
=====  ================================  =====================
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import GrassTypeError, GrassValueError
from .horizon import HorizonLayout
from .limits import MAX_BLADE_HEIGHT, MAX_BLADE_STIFFNESS, MAX_BLADE_WIDTH, MAX_COORDINATE
from .memory import BladeCountError, check_blade_count

__all__ = ["Blades", "BladeCountError"]


#: The largest value of each per-blade number (grasswidget.core.limits), with its unit.
_BLADE_MAX = {"height": (MAX_BLADE_HEIGHT, "m"), "width": (MAX_BLADE_WIDTH, "m"),
              "stiffness": (MAX_BLADE_STIFFNESS, "1/s^2")}


#: Orientations (rad) beyond this are brought into [-pi, pi] (the same angle) when Blades are made.
_ORIENTATION_REDUCE = 1e4


def _check_range(name, value, lo_min=0.0):
    hi_max, unit = _BLADE_MAX[name]
    try:
        lo, hi = (float(value[0]), float(value[1]))
    except (TypeError, IndexError, ValueError):
        raise GrassValueError(f"{name} must be a (min, max) pair of numbers; got {value!r}") from None
    if not (np.isfinite(lo) and np.isfinite(hi)) or lo <= lo_min or hi < lo or hi > hi_max:
        raise GrassValueError(
            f"{name} must be a (min, max) pair with {lo_min:g} < min <= max <= {hi_max:g} {unit}, finite; got {value!r}"
        )
    return lo, hi


def _check_size(size):
    """The side of a square field (metres) in (0, 2 MAX_COORDINATE], as a float."""
    if isinstance(size, bool) or not isinstance(size, (int, float, np.number)) or not np.isfinite(size) \
            or not 0 < size <= 2 * MAX_COORDINATE:
        raise GrassValueError(f"size must be a finite number in (0, {2 * MAX_COORDINATE:g}] (metres); got {size!r}")
    return float(size)


@dataclass
class Blades:
    """A set of N grass blades in their rest pose.

    Attributes (all float32):
        v0: (N, 3) roots, metres, every coordinate in [-1e7, 1e7] (``limits.MAX_COORDINATE``).
        up: (N, 3) unit surface normals at the roots (any finite non-zero vectors, normalised).
        orientation: (N,) angle theta (radians) of the width direction in the tangent plane
            (any finite angle; beyond 1e4 rad brought into [-pi, pi], the same angle).
        height: (N,) blade heights h, metres, in (0, 1e3] (``limits.MAX_BLADE_HEIGHT``).
        width: (N,) blade widths w, metres, in (0, 1e2] (``limits.MAX_BLADE_WIDTH``).
        stiffness: (N,) stiffness s of the recovery force, 1/s^2, in (0, 1e6] (``limits.MAX_BLADE_STIFFNESS``).

    Values outside these ranges raise a GrassValueError naming the array and the range.
        horizon: a :class:`~grasswidget.core.horizon.HorizonLayout` for a field to the
            horizon (``on_plane(..., reach=R)``), else None.
    """

    v0: np.ndarray
    up: np.ndarray
    orientation: np.ndarray
    height: np.ndarray
    width: np.ndarray
    stiffness: np.ndarray
    horizon: HorizonLayout | None = None

    def __post_init__(self):
        n = len(self.v0)
        v0 = np.asarray(self.v0, np.float64).reshape(n, 3)
        if not np.all(np.isfinite(v0)):
            raise GrassValueError("v0 (roots) must be finite")
        if n and np.abs(v0).max() > MAX_COORDINATE:
            raise GrassValueError(f"v0 (roots) must have every coordinate in [{-MAX_COORDINATE:g}, {MAX_COORDINATE:g}] "
                                  f"metres (MAX_COORDINATE); got {float(np.abs(v0).max()):g}")
        self.v0 = np.ascontiguousarray(v0, np.float32)
        up = np.asarray(self.up, np.float64).reshape(n, 3)
        if n and not np.all(np.isfinite(up)):
            raise GrassValueError("up vectors must be finite and non-zero")
        # Only the direction counts: scale by the largest component first (no overflow or
        # underflow in the length of (1e300, 1, 0) or (1e-300, 0, 0)).
        up = up / np.maximum(np.abs(up).max(axis=1, keepdims=True), 1e-300) if n else up
        norm = np.linalg.norm(up, axis=1, keepdims=True)
        if n and np.any(norm < 1e-12):
            raise GrassValueError("up vectors must be finite and non-zero")
        self.up = (up / np.maximum(norm, 1e-30)).astype(np.float32)
        for name in ("orientation", "height", "width", "stiffness"):
            arr = np.asarray(getattr(self, name), np.float64).reshape(n)
            if not np.all(np.isfinite(arr)):
                raise GrassValueError(f"{name} must be finite")
            if name in _BLADE_MAX and n and not (arr.min() > 0 and arr.max() <= _BLADE_MAX[name][0]):
                hi, unit = _BLADE_MAX[name]
                raise GrassValueError(f"{name} must be in (0, {hi:g}] {unit} for every blade; "
                                      f"got values in [{float(arr.min()):g}, {float(arr.max()):g}]")
            if name == "orientation" and n and np.abs(arr).max() > _ORIENTATION_REDUCE:
                # The same angle, reduced where float32's sin/cos would lose it (|theta| > 1e4 rad).
                # (NumPy's float64 sin/cos reduce exactly; atan2 gives the angle back in [-pi, pi].)
                arr = np.where(np.abs(arr) > _ORIENTATION_REDUCE, np.arctan2(np.sin(arr), np.cos(arr)), arr)
            setattr(self, name, np.ascontiguousarray(arr, np.float32))
        if n and (self.height.min() <= 0 or self.width.min() <= 0 or self.stiffness.min() <= 0):
            raise GrassValueError("height, width and stiffness must be > 0")  # a value that rounds to 0 in float32
        if self.horizon is not None:
            if not isinstance(self.horizon, HorizonLayout):
                raise GrassTypeError(f"horizon must be a HorizonLayout or None, not {type(self.horizon).__name__}")
            if int(self.horizon.count) != n:  # its levels are id ranges of exactly these blades
                raise GrassValueError(f"horizon is a layout of {self.horizon.count} blades; these are {n}")

    def __len__(self):
        return len(self.v0)

    @property
    def count(self) -> int:
        """Number of blades N."""
        return len(self.v0)

    @classmethod
    def on_plane(
        cls,
        count: int,
        size: float = 15.0,
        seed: int = 0,
        height=(1.3, 2.5),
        width=(0.1, 0.14),
        stiffness=(7.0, 13.0),
        reach=None,
    ) -> "Blades":
        """Blades on a ``size`` x ``size`` plane centred at the origin, y up, or, with
        ``reach``, in tiles that follow the camera to the horizon.

        Roots are uniform on the plane (jittered-stratified, so the meadow has no
        bald patches), each blade has a uniform random orientation in [0, 2 pi) and
        height, width and stiffness uniform in the given (min, max) ranges. Ids follow
        the ground in patches of about 16 blades in Z order, in random order within a
        patch (GPU threads that run together share colliders and pixels; distance
        culling thins by id modulo its levels, evenly in every patch). The same arguments give the same blades.

        Args:
            count: number of blades N, >= 1. A count whose making would not fit in the
                available memory raises :class:`~grasswidget.core.memory.BladeCountError`
                (a ValueError) at once, before anything is allocated.
            size: side of the square plane in metres, in (0, 2e7] (default 15, the course scene).
            seed: random seed (int).
            height, width, stiffness: (min, max) ranges; metres, metres, 1/s^2; at most
                1e3 m, 1e2 m and 1e6 1/s^2 (:mod:`grasswidget.core.limits`: the float32
                physics stays finite with every parameter in range).
            reach: None (default: the square field) or R, metres (> size / 2), for a field to
                the horizon that follows the camera: the blades are split into levels of
                square tiles repeated over the plane (level k's tile 2^k times level 0's), each
                blade moved by the culling pass to the copy of its root nearest the camera; level
                0 keeps the density of the square field of ``size`` (``count / size^2``) near the
                camera where the count allows, the far levels are thinner and their blades wider
                (``width`` is level 0's), each drawn in a band of distance from the camera that
                fades into the next, out to about R; the camera may go anywhere within R of the
                centre (:mod:`grasswidget.core.horizon`; ``Blades.horizon`` holds the layout).
                The count stays ``count``: the memory does not grow with the reach.
                Distance culling (``GrassParams.cull_distance``) is not applied to such a
                field, which is thinned with distance already.
        """
        if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 1:
            raise GrassValueError(f"count must be an integer >= 1; got {count!r}")
        count = check_blade_count(count)
        size = _check_size(size)
        h = _check_range("height", height)
        w = _check_range("width", width)
        s = _check_range("stiffness", stiffness)
        horizon = None
        if reach is not None:
            if isinstance(reach, bool) or not isinstance(reach, (int, float, np.number)) or not np.isfinite(reach) \
                    or not 0.5 * size < reach <= MAX_COORDINATE:
                raise GrassValueError(f"reach must be None or a finite number in (size / 2 = {0.5 * size:g}, "
                                      f"{MAX_COORDINATE:g}] metres; got {reach!r}")
            horizon = HorizonLayout(center=(0.0, 0.0), near_radius=0.5 * float(size), reach=float(reach), count=count)
        rng = np.random.default_rng(seed)
        v0 = np.zeros((count, 3), np.float32)
        if horizon is None:
            # Jittered stratified sampling on a k x k grid (k*k >= count): a random subset
            # of the cells, in patches in Z order (see _jittered_unit_square).
            x, z = _jittered_unit_square(rng, count)
            v0[:, 0] = (x - 0.5) * size
            v0[:, 2] = (z - 0.5) * size
        else:
            x, z, widen = horizon.place(rng, count, _jittered_unit_square)
            v0[:, 0], v0[:, 2] = x, z
        up = np.tile(np.float32([0, 1, 0]), (count, 1))
        blades = cls._with_random_traits(rng, v0, up, h, w, s)
        if horizon is not None:
            blades.width = (blades.width * widen).astype(np.float32)
            blades.horizon = horizon
        return blades

    @classmethod
    def on_mesh(
        cls,
        geometry,
        count=None,
        density=None,
        seed: int = 0,
        height=(1.3, 2.5),
        width=(0.1, 0.14),
        stiffness=(7.0, 13.0),
    ) -> "Blades":
        """Blades rooted on the triangles of any mesh (grass on a sphere, a hill, ...).

        Roots are sampled uniformly by area: a triangle is picked with probability
        proportional to its area, then a uniform point in it (barycentric
        ``(1 - sqrt r1, sqrt r1 (1 - r2), sqrt r1 r2)``). Each blade's ``up`` is the
        vertex normal interpolated with those weights, normalised; without vertex
        normals (or where they cancel) the face normal ``normalize(cross(b - a, c - a))``
        (counter-clockwise triangles face outwards, as in pygfx). Orientation, height,
        width and stiffness are random as in :meth:`on_plane`. Ids come in random order.

        Args:
            geometry: a pygfx ``Geometry`` (anything with ``.positions.data``, optional
                ``.indices.data`` and ``.normals.data``), a dict with those keys, or a
                tuple ``(positions, indices[, normals])`` of arrays. positions (V, 3);
                indices (M, 3) or (3M,) vertex ids (None: consecutive vertex triples);
                normals (V, 3). Metres, in the space the field will live in.
            count: number of blades (exactly one of count / density).
            density: blades per square metre of mesh area (count = round(density * area)).
            seed: random seed (int).
            height, width, stiffness: (min, max) ranges as in :meth:`on_plane`.

        Raises ValueError for an empty mesh (no triangle of non-zero area), non-finite
        positions or normals, out-of-range indices, or a bad count/density.

        This module stays pure: pygfx is never imported here.
        """
        positions, tris, normals = _mesh_arrays(geometry)
        a, b, c = positions[tris[:, 0]], positions[tris[:, 1]], positions[tris[:, 2]]
        face = np.cross(b - a, c - a)
        area2 = np.linalg.norm(face, axis=1)
        total = float(area2.sum()) * 0.5
        if len(tris) == 0 or not np.isfinite(total) or total <= 0.0:
            raise GrassValueError(
                f"geometry is an empty mesh: it has {len(tris)} triangles and total area {total:g} m^2; "
                "blades need at least one triangle of non-zero area"
            )
        count = check_blade_count(_count_from(count, density, total))
        rng = np.random.default_rng(seed)
        hr, wr, sr = _check_range("height", height), _check_range("width", width), _check_range("stiffness", stiffness)
        cdf = np.cumsum(area2)
        pick = np.minimum(np.searchsorted(cdf, rng.random(count) * cdf[-1], side="right"), len(tris) - 1)
        # Never pick a zero-area triangle (searchsorted with side="right" skips them).
        r1, r2 = rng.random(count), rng.random(count)
        sq = np.sqrt(r1)
        wa, wb, wc = 1.0 - sq, sq * (1.0 - r2), sq * r2
        ta, tb, tc = tris[pick, 0], tris[pick, 1], tris[pick, 2]
        v0 = wa[:, None] * positions[ta] + wb[:, None] * positions[tb] + wc[:, None] * positions[tc]
        face_n = face[pick] / np.maximum(area2[pick], 1e-300)[:, None]
        up = face_n
        if normals is not None:
            n = wa[:, None] * normals[ta] + wb[:, None] * normals[tb] + wc[:, None] * normals[tc]
            length = np.linalg.norm(n, axis=1)
            ok = length > 1e-6
            up = np.where(ok[:, None], n / np.maximum(length, 1e-300)[:, None], face_n)
        return cls._with_random_traits(rng, v0, up, hr, wr, sr)

    @classmethod
    def on_heightmap(
        cls,
        heights,
        size: float,
        count: int,
        seed: int = 0,
        height=(1.3, 2.5),
        width=(0.1, 0.14),
        stiffness=(7.0, 13.0),
    ) -> "Blades":
        """Blades on a terrain given as a height map over a ``size`` x ``size`` square.

        ``heights[i, j]`` (metres, an (H, W) array, H, W >= 2) is the ground height y at
        ``x = -size/2 + j * size / (W - 1)``, ``z = -size/2 + i * size / (H - 1)``
        (columns along x, rows along z, centred at the origin). Roots are
        jittered-stratified in xz as in :meth:`on_plane`, their y is the bilinear
        interpolation of the map, and ``up`` is the normal of that bilinear surface,
        ``normalize(-dh/dx, 1, -dh/dz)`` with the gradient of the interpolant.

        Raises ValueError for NaN/inf heights, a map smaller than 2 x 2, or a bad
        size/count.
        """
        h = np.asarray(heights, np.float64)
        if h.ndim != 2 or h.shape[0] < 2 or h.shape[1] < 2:
            raise GrassValueError(f"heights must be a 2D (H, W) array with H, W >= 2; got shape {h.shape}")
        if not np.all(np.isfinite(h)):
            bad = int(np.count_nonzero(~np.isfinite(h)))
            raise GrassValueError(f"heights must be finite; {bad} of {h.size} values are NaN or inf")
        if np.abs(h).max() > MAX_COORDINATE:
            raise GrassValueError(f"heights must be in [{-MAX_COORDINATE:g}, {MAX_COORDINATE:g}] metres "
                                  f"(MAX_COORDINATE); got {float(np.abs(h).max()):g}")
        size = _check_size(size)
        if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 1:
            raise GrassValueError(f"count must be an integer >= 1; got {count!r}")
        count, size = check_blade_count(count), float(size)
        hr, wr, sr = _check_range("height", height), _check_range("width", width), _check_range("stiffness", stiffness)
        rng = np.random.default_rng(seed)
        u, v = _jittered_unit_square(rng, count)  # along x and z, 0..1
        rows, cols = h.shape
        gx, gz = u * (cols - 1), v * (rows - 1)
        j = np.minimum(np.floor(gx).astype(np.int64), cols - 2)
        i = np.minimum(np.floor(gz).astype(np.int64), rows - 2)
        fx, fz = gx - j, gz - i
        h00, h01, h10, h11 = h[i, j], h[i, j + 1], h[i + 1, j], h[i + 1, j + 1]
        y = (1 - fz) * ((1 - fx) * h00 + fx * h01) + fz * ((1 - fx) * h10 + fx * h11)
        dx_cell, dz_cell = size / (cols - 1), size / (rows - 1)
        dhdx = ((1 - fz) * (h01 - h00) + fz * (h11 - h10)) / dx_cell
        dhdz = ((1 - fx) * (h10 - h00) + fx * (h11 - h01)) / dz_cell
        v0 = np.stack([(u - 0.5) * size, y, (v - 0.5) * size], axis=1)
        up = np.stack([-dhdx, np.ones(count), -dhdz], axis=1)
        return cls._with_random_traits(rng, v0, up, hr, wr, sr)

    @classmethod
    def _with_random_traits(cls, rng, v0, up, height, width, stiffness):
        """Blades at roots v0 with normals up; orientation uniform in [0, 2 pi),
        height, width and stiffness uniform in their (min, max) ranges."""
        count = len(v0)
        return cls(
            v0=v0,
            up=up,
            orientation=rng.uniform(0.0, 2.0 * np.pi, count),
            height=rng.uniform(*height, count),
            width=rng.uniform(*width, count),
            stiffness=rng.uniform(*stiffness, count),
        )

    def rest_state(self) -> dict:
        """State dict of the rest pose: v1 = v2 = v0 + h * up (the tip guide iv2)."""
        iv2 = self.v0 + self.up * self.height[:, None]
        return dict(
            v0=self.v0.copy(),
            v1=iv2.copy(),
            v2=iv2.copy(),
            up=self.up.copy(),
            height=self.height.copy(),
            width=self.width.copy(),
            orientation=self.orientation.copy(),
            stiffness=self.stiffness.copy(),
        )

    def packed(self) -> np.ndarray:
        """The (N, 4, 4) float32 array of the paper's 4 x vec4 layout, in rest pose."""
        return pack_state(self.rest_state())


def _array_of(x):
    """The ndarray behind x: x itself, or a pygfx Buffer's ``.data``."""
    if x is None or isinstance(x, np.ndarray):
        return x
    data = getattr(x, "data", None)
    if data is not None and not isinstance(data, memoryview):
        return data
    return x


def _mesh_arrays(geometry):
    """(positions (V, 3) float64, triangles (M, 3) int64, normals (V, 3) float64 or None)."""
    if isinstance(geometry, dict):
        pos, idx, nrm = geometry.get("positions"), geometry.get("indices"), geometry.get("normals")
    elif isinstance(geometry, (tuple, list)):
        if not 2 <= len(geometry) <= 3:
            raise GrassValueError("geometry as a tuple must be (positions, indices) or (positions, indices, normals)")
        pos, idx = geometry[0], geometry[1]
        nrm = geometry[2] if len(geometry) == 3 else None
    elif hasattr(geometry, "positions"):
        pos = geometry.positions
        idx = getattr(geometry, "indices", None)
        nrm = getattr(geometry, "normals", None)
    else:
        raise GrassTypeError(
            "geometry must be a pygfx Geometry (with .positions and .indices), a dict or a "
            f"(positions, indices[, normals]) tuple; got {type(geometry).__name__}"
        )
    if pos is None:
        raise GrassValueError("geometry has no positions")
    try:
        pos = np.asarray(_array_of(pos), np.float64)
    except (TypeError, ValueError):
        raise GrassValueError("geometry positions must be a numeric (V, 3) array") from None
    if pos.ndim != 2 or pos.shape[1] != 3:
        raise GrassValueError(f"geometry positions must be a (V, 3) array; got shape {pos.shape}")
    if not np.all(np.isfinite(pos)):
        raise GrassValueError("geometry positions must be finite (found NaN or inf)")
    if pos.size and np.abs(pos).max() > MAX_COORDINATE:
        raise GrassValueError(f"geometry positions must be in [{-MAX_COORDINATE:g}, {MAX_COORDINATE:g}] metres "
                              f"(MAX_COORDINATE); got {float(np.abs(pos).max()):g}")
    if idx is None:
        if len(pos) % 3:
            raise GrassValueError("geometry has no indices and its vertex count is not a multiple of 3")
        tris = np.arange(len(pos), dtype=np.int64).reshape(-1, 3)
    else:
        raw = np.asarray(_array_of(idx))
        if raw.size and not np.issubdtype(raw.dtype, np.integer):
            raise GrassValueError(f"geometry indices must be integers; got dtype {raw.dtype}")
        if raw.size % 3:
            raise GrassValueError(f"geometry indices must form triangles ((M, 3) or 3M values); got {raw.size} values")
        tris = raw.astype(np.int64).reshape(-1, 3)
        if tris.size and (tris.min() < 0 or tris.max() >= len(pos)):
            raise GrassValueError(f"geometry indices must be in [0, {len(pos)}) (the number of positions)")
    if nrm is not None:
        nrm = np.asarray(_array_of(nrm), np.float64)
        if nrm.shape != pos.shape:
            raise GrassValueError(f"geometry normals must have the shape of positions {pos.shape}; got {nrm.shape}")
        if not np.all(np.isfinite(nrm)):
            raise GrassValueError("geometry normals must be finite (found NaN or inf)")
    return pos, tris, nrm


def _count_from(count, density, area):
    if (count is None) == (density is None):
        raise GrassValueError("give exactly one of count (blades) or density (blades per m^2)")
    if count is not None:
        if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 1:
            raise GrassValueError(f"count must be an integer >= 1; got {count!r}")
        return int(count)
    if isinstance(density, bool) or not isinstance(density, (int, float, np.number)) or not np.isfinite(density) or density <= 0:
        raise GrassValueError(f"density must be a finite number > 0 (blades per m^2); got {density!r}")
    n = int(round(float(density) * area))
    if n < 1:
        raise GrassValueError(f"density {density:g} per m^2 on {area:g} m^2 gives no blades; raise density or give count")
    return n


#: Side of the tiles (in jitter cells, about one blade each) whose Z order orders the
#: blades of on_plane and on_heightmap.
TILE = 4


def _jittered_unit_square(rng, count):
    """``count`` points (x, z) in [0, 1)^2, jittered-stratified on a k x k grid
    (k*k >= count, random subset of cells), ordered by tiles of TILE x TILE cells in
    Z order, in random order within a tile: the 32 or 64 GPU threads that run together
    work on one patch of the meadow (they test the same colliders and draw near
    pixels), while ids modulo a small number (distance culling's buckets) still fall
    at random within each patch."""
    k = int(np.ceil(np.sqrt(count)))
    cells = rng.permutation(k * k)[:count]  # a random subset, in random order
    tile = z_order(cells % k // TILE, cells // k // TILE)
    cells = cells[np.argsort(tile, kind="stable")]  # stable: random order within a tile
    x = (cells % k + rng.random(count)) / k
    z = (cells // k + rng.random(count)) / k
    return x, z


def z_order(ix, iz):
    """The Z-order (Morton) key of integer cell coordinates ``ix``, ``iz`` (each
    0 .. 2^16 - 1): their bits interleaved, x in the even bits. Sorting by it keeps
    cells that are near on the ground near in the order."""
    def spread(v):
        v = np.asarray(v, np.uint64) & np.uint64(0xFFFF)
        v = (v | (v << np.uint64(8))) & np.uint64(0x00FF00FF)
        v = (v | (v << np.uint64(4))) & np.uint64(0x0F0F0F0F)
        v = (v | (v << np.uint64(2))) & np.uint64(0x33333333)
        v = (v | (v << np.uint64(1))) & np.uint64(0x55555555)
        return v
    return spread(ix) | (spread(iz) << np.uint64(1))


#: The GPU blade record, row by row: 4 x vec4<f32> = 64 bytes per blade (the paper's
#: layout). Each row is (a vec3 field, a scalar field). The twin of the WGSL ``struct Blade``
#: and its ``load_blade``/``store_blade`` in ``shaders/blade.wgsl`` (a test compares them).
BLADE_LAYOUT = (("v0", "orientation"), ("v1", "height"), ("v2", "width"), ("up", "stiffness"))
#: Bytes per blade record.
BLADE_BYTES = 16 * len(BLADE_LAYOUT)


def pack_state(state: dict) -> np.ndarray:
    """Pack a state dict into the (N, 4, 4) float32 layout of the GPU buffer (BLADE_LAYOUT)."""
    n = len(state["v0"])
    out = np.empty((n, len(BLADE_LAYOUT), 4), np.float32)
    for row, (vec, scalar) in enumerate(BLADE_LAYOUT):
        out[:, row, :3], out[:, row, 3] = state[vec], state[scalar]
    return out


def unpack_state(packed: np.ndarray) -> dict:
    """Inverse of :func:`pack_state`: (N, 4, 4) float32 -> state dict of copies."""
    p = np.asarray(packed, np.float32).reshape(-1, len(BLADE_LAYOUT), 4)
    out = {}
    for row, (vec, scalar) in enumerate(BLADE_LAYOUT):
        out[vec] = p[:, row, :3].copy()
        out[scalar] = p[:, row, 3].copy()
    return out
