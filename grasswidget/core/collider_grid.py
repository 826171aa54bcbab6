"""The collider grid: which sphere colliders each blade has to test (pure NumPy).

A field with hundreds of balls must not make every blade loop over all of them.
:func:`build_collider_grid` bins the spheres into square cells over the xz bounds
of the blade roots: a cell lists, in ascending sphere order, every sphere that can
come within reach (:data:`~grasswidget.core.reference.COLLIDER_REACH` blade heights,
:func:`~grasswidget.core.reference.sphere_in_reach`) of a root in that cell. A blade
looks up its root's cell (:func:`~grasswidget.core.reference.grid_cell`, the twin of
the WGSL ``grid_cell``) and tests only that cell's list
(``collide_spheres`` of ``shaders/collisions.wgsl``). Since the list holds every
sphere in reach and the spheres out of reach are skipped anyway, the result equals
the reference's loop over all spheres (:func:`grasswidget.core.reference.collide_spheres`).

The border cells reach to infinity (indices are clamped), so a root outside the
bounds, or a sphere far outside the field, is still handled exactly; a sphere far
away only lengthens the border cells' lists.

Both engines upload the same two arrays, built once whenever the colliders change:

* the spheres, (K, 4) float32 (cx, cy, cz, radius) -> ``s_colliders: array<vec4<f32>>``;
* the grid words (u32) -> ``s_collider_grid: array<u32>``, laid out as

  ======================  ==============================================================
  word 0, 1               nx, nz: cells along x and z
  word 2, 3               spheres K, list entries E
  word 4, 5, 6, 7         f32 bits of origin x, origin z (m), 1 / cell size (1/m), cell size (m)
  8 + 2 c, 9 + 2 c        cell c (= cz * nx + cx): word index of its first list entry, entries
  8 + 2 nx nz ...         the lists: sphere indices (u32), cell after cell
  ======================  ==============================================================

The cell size follows the spheres (about the median reach radius, R + reach),
so a blade typically tests the few spheres around it; the grid stays within
:data:`MAX_GRID_CELLS` cells and :data:`MAX_GRID_ENTRIES` list entries (it is made
coarser until it fits; one cell holding every sphere always fits), so the GPU
buffers have a fixed size.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import GrassValueError
from .colliders import MAX_COLLIDERS, check_sphere_array
from .reference import COLLIDER_REACH, grid_cell

__all__ = ["ColliderGrid", "build_collider_grid", "root_bounds", "MAX_GRID_CELLS", "MAX_GRID_ENTRIES",
           "GRID_HEADER_WORDS", "GRID_WORDS", "ONE_CELL_MAX", "collider_cell_range"]

#: Most cells of a collider grid (64 x 64).
MAX_GRID_CELLS = 4096
#: Most entries of the cell lists together (a sphere counts once per cell it is listed in).
MAX_GRID_ENTRIES = 65536
#: u32 words before the cell table (see the module docstring).
GRID_HEADER_WORDS = 8
#: Up to this many spheres the grid is one cell listing them all: for a handful a grid buys
#: nothing, and the arrays then have one size and do not depend on where the spheres are
#: (:meth:`ColliderGrid.words` and :meth:`ColliderGrid.sphere_data` are padded to it), so the
#: live page (:mod:`grasswidget.browser.page`) can move its ball by patching the spheres alone.
ONE_CELL_MAX = 4
#: Words of the GPU buffer of a grid: header, the largest cell table and list.
GRID_WORDS = GRID_HEADER_WORDS + 2 * MAX_GRID_CELLS + MAX_GRID_ENTRIES

assert MAX_GRID_ENTRIES >= MAX_COLLIDERS  # a 1 x 1 grid always fits


@dataclass(frozen=True)
class ColliderGrid:
    """A built grid (see the module docstring); make one with :func:`build_collider_grid`.

    Attributes: ``spheres`` (K, 4) float32, ``nx``, ``nz`` (cells along x, z), ``origin``
    (x, z) float32 (m), ``cell_size`` and ``inv_cell_size`` float32 (m, 1/m), ``cell_start``
    (nx nz,) word index of each cell's list in :meth:`words`, ``cell_count`` (nx nz,),
    ``items`` (E,) uint32 sphere indices, cell after cell, ascending within a cell.
    """

    spheres: np.ndarray
    nx: int
    nz: int
    origin: np.ndarray
    cell_size: np.float32
    inv_cell_size: np.float32
    cell_start: np.ndarray
    cell_count: np.ndarray
    items: np.ndarray

    @property
    def n_cells(self) -> int:
        return self.nx * self.nz

    def words(self) -> np.ndarray:
        """The grid as the u32 words of ``s_collider_grid`` (layout in the module docstring)."""
        floats = np.array([self.origin[0], self.origin[1], self.inv_cell_size, self.cell_size], np.float32)
        header = np.concatenate([np.array([self.nx, self.nz, len(self.spheres), len(self.items)], np.uint32),
                                 floats.view(np.uint32)])
        table = np.stack([self.cell_start, self.cell_count], axis=1).astype(np.uint32).reshape(-1)
        pad = np.zeros(max(0, ONE_CELL_MAX - len(self.items)), np.uint32)  # never read: one size for a few spheres
        return np.concatenate([header, table, self.items.astype(np.uint32), pad])

    def sphere_data(self) -> np.ndarray:
        """The spheres as float32 (max(K, ONE_CELL_MAX), 4) rows for ``s_colliders`` (zero rows past K)."""
        out = np.zeros((max(len(self.spheres), ONE_CELL_MAX), 4), np.float32)
        out[: len(self.spheres)] = self.spheres
        return out

    def cell_of(self, p) -> np.ndarray:
        """Cell index of the points p (N, 3) (their x, z), as the GPU computes it."""
        return grid_cell(p, self.origin, self.inv_cell_size, self.nx, self.nz)

    def candidates(self, p) -> np.ndarray:
        """Sphere indices listed in the cell of the one point p (3,), ascending."""
        c = int(self.cell_of(np.asarray(p, np.float64)[None])[0])
        start = int(self.cell_start[c]) - self.table_end
        return self.items[start: start + int(self.cell_count[c])]

    @property
    def table_end(self) -> int:
        """Word index of the first list entry (after the header and the cell table)."""
        return GRID_HEADER_WORDS + 2 * self.n_cells


def collider_cell_range(v0, words):
    """(start, count) of the list each root v0 (N, 3) looks at: the twin of
    ``collider_cell_range(v0)`` of ``shaders/collisions.wgsl``, reading the grid ``words``
    (:meth:`ColliderGrid.words`). Returns two (N,) uint32 arrays."""
    w = np.asarray(words, np.uint32)
    nx, nz = int(w[0]), int(w[1])
    origin = w[4:6].view(np.float32)
    inv = w[6:7].view(np.float32)[0]
    cell = grid_cell(v0, origin, inv, nx, nz).astype(np.int64)
    return w[GRID_HEADER_WORDS + 2 * cell], w[GRID_HEADER_WORDS + 2 * cell + 1]


def root_bounds(v0) -> tuple:
    """(x_min, z_min, x_max, z_max) of the roots v0 (N, 3), metres: the extent a grid covers."""
    v0 = np.asarray(v0, np.float64).reshape(-1, 3)
    if len(v0) == 0:
        return (0.0, 0.0, 0.0, 0.0)
    lo, hi = v0.min(axis=0), v0.max(axis=0)
    return (float(lo[0]), float(lo[2]), float(hi[0]), float(hi[2]))


def _check_bounds(bounds, max_height):
    try:
        b = np.asarray(bounds, np.float64).reshape(4)
    except (TypeError, ValueError):
        raise GrassValueError(f"bounds must be (x_min, z_min, x_max, z_max) in metres; got {bounds!r}") from None
    if not np.isfinite(b).all() or b[2] < b[0] or b[3] < b[1]:
        raise GrassValueError(f"bounds must be finite (x_min, z_min, x_max, z_max) with min <= max; got {b.tolist()}")
    h = float(max_height)
    if not (np.isfinite(h) and h >= 0):
        raise GrassValueError(f"max_height must be a finite number >= 0 (metres); got {max_height!r}")
    return b, h


def _ranges(lo, hi, origin, cell, n):
    """Clamped cell index ranges [i0, i1] covering [lo, hi] along one axis."""
    i0 = np.clip(np.floor((lo - origin) / cell), 0, n - 1).astype(np.int64)
    i1 = np.clip(np.floor((hi - origin) / cell), 0, n - 1).astype(np.int64)
    return i0, i1


def build_collider_grid(spheres, bounds, max_height, max_cells=MAX_GRID_CELLS,
                        max_entries=MAX_GRID_ENTRIES, one_cell_max=ONE_CELL_MAX) -> ColliderGrid:
    """Bin ``spheres`` ((K, 4) rows (cx, cy, cz, R), metres; K up to MAX_COLLIDERS) into a
    grid over ``bounds`` ((x_min, z_min, x_max, z_max) of the blade roots, :func:`root_bounds`)
    for blades at most ``max_height`` m tall.

    A sphere is listed in every cell whose xz square (the border cells reaching to
    infinity) comes within R + COLLIDER_REACH * max_height (plus a float32 margin) of its
    centre's xz, so every sphere in reach of a root is in the root's cell. Cells are square,
    about the median of R + reach wide (a blade then tests the spheres within about
    1.5 (R + reach) of its cell: few, where a coarser grid lists more), at least (bounds area / max_cells)^0.5, and at
    most max_cells; while the lists exceed ``max_entries`` the cells double in size. Up to
    ``one_cell_max`` spheres (default :data:`ONE_CELL_MAX`) the grid is one cell over the bounds.
    Deterministic: the same inputs give the same words.
    """
    s64 = check_sphere_array(spheres, "spheres")
    s32 = s64.astype(np.float32)
    s = s32.astype(np.float64)  # bin what the GPU sees
    b, h = _check_bounds(bounds, max_height)
    reach = COLLIDER_REACH * h
    width, depth = b[2] - b[0], b[3] - b[1]
    scale = max(1.0, float(np.abs(b).max()), width, depth)
    if len(s) <= one_cell_max:
        cell = max(width, depth, 1e-3)
    else:
        cell = max(float(np.median(s[:, 3] + reach)), np.sqrt(width * depth / max_cells), 1e-3 * scale)
    while True:
        nx = max(1, int(np.ceil(width / cell)))
        nz = max(1, int(np.ceil(depth / cell)))
        if len(s) <= one_cell_max:
            nx = nz = 1
        if nx * nz > max_cells:
            cell *= 1.25
            continue
        # margin: a root within float32 rounding of a cell edge may look up the neighbour
        extent = s[:, 3] + reach + 1e-3 * cell + 1e-5 * scale
        ix0, ix1 = _ranges(s[:, 0] - extent, s[:, 0] + extent, b[0], cell, nx)
        iz0, iz1 = _ranges(s[:, 2] - extent, s[:, 2] + extent, b[1], cell, nz)
        per_sphere = (ix1 - ix0 + 1) * (iz1 - iz0 + 1)
        if int(per_sphere.sum()) <= max_entries or nx * nz == 1:
            break
        cell *= 2.0
    # every (sphere, cell) pair, sphere-major; a stable sort by cell keeps the spheres ascending
    k = np.repeat(np.arange(len(s)), per_sphere)
    local = np.arange(len(k)) - np.repeat(np.cumsum(per_sphere) - per_sphere, per_sphere)
    span_x = (ix1 - ix0 + 1)[k]
    cx = ix0[k] + local % span_x
    cz = iz0[k] + local // span_x
    # drop the cells of a sphere's bounding square that its reach disc misses (the corners)
    gx = np.clip(s[k, 0], b[0] + cx * cell, b[0] + (cx + 1) * cell)
    gz = np.clip(s[k, 2], b[1] + cz * cell, b[1] + (cz + 1) * cell)
    gx = np.where((cx == 0) & (s[k, 0] < b[0]), s[k, 0], gx)  # the border cells reach to infinity
    gx = np.where((cx == nx - 1) & (s[k, 0] > b[0] + nx * cell), s[k, 0], gx)
    gz = np.where((cz == 0) & (s[k, 2] < b[1]), s[k, 2], gz)
    gz = np.where((cz == nz - 1) & (s[k, 2] > b[1] + nz * cell), s[k, 2], gz)
    keep = (gx - s[k, 0]) ** 2 + (gz - s[k, 2]) ** 2 <= extent[k] ** 2
    k, cx, cz = k[keep], cx[keep], cz[keep]
    cells = cz * nx + cx
    order = np.argsort(cells, kind="stable")
    items = k[order].astype(np.uint32)
    counts = np.bincount(cells, minlength=nx * nz).astype(np.uint32)
    table_end = GRID_HEADER_WORDS + 2 * nx * nz
    starts = (table_end + np.cumsum(counts) - counts).astype(np.uint32)
    return ColliderGrid(
        spheres=s32, nx=nx, nz=nz, origin=np.array([b[0], b[1]], np.float32),
        cell_size=np.float32(cell), inv_cell_size=np.float32(1.0 / np.float32(cell)),
        cell_start=starts, cell_count=counts, items=items,
    )
