"""The collider grid (pure NumPy): every sphere in reach of a root is in the root's cell list,
in ascending order; the grid fits its fixed buffers; set_array bulk colliders."""

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.core import reference as ref
from grasswidget.core.collider_grid import (GRID_HEADER_WORDS, GRID_WORDS, MAX_GRID_CELLS, MAX_GRID_ENTRIES,
                                            build_collider_grid, collider_cell_range, root_bounds)
from grasswidget.core.colliders import MAX_COLLIDERS, ColliderList, collider_array
from grasswidget.errors import GrassError


def _roots(rng, n, size):
    v0 = np.zeros((n, 3))
    v0[:, [0, 2]] = rng.uniform(-size / 2, size / 2, (n, 2))
    return v0


def _crowd(rng, k, size, r=(0.2, 1.0)):
    """Balls over and beyond the field: some overlap, some straddle cells, one big, some far out."""
    radius = rng.uniform(*r, k)
    c = np.column_stack([rng.uniform(-0.7 * size, 0.7 * size, k), rng.uniform(-1, 2, k),
                         rng.uniform(-0.7 * size, 0.7 * size, k)])
    c[1::7] = c[0::7][: len(c[1::7])] + 0.3  # overlapping pairs
    c[-1] = (5 * size, 0.5, -3 * size)  # far outside
    radius[0] = size / 3  # bigger than a cell
    return np.column_stack([c, radius])


def _check_superset(grid, spheres, v0, h):
    """Every sphere in reach of each root is listed in its cell, and the lists are ascending."""
    cells = grid.cell_of(v0)
    in_reach = ref.sphere_in_reach(v0[:, None, :], h[:, None], spheres[None, :, :])  # (N, K)
    start = grid.cell_start.astype(np.int64) - grid.table_end
    listed = np.zeros_like(in_reach)
    for c in np.unique(cells):
        items = grid.items[start[c]: start[c] + grid.cell_count[c]]
        assert np.all(np.diff(items.astype(np.int64)) > 0), "a cell's list is not ascending"
        listed[np.ix_(cells == c, items.astype(np.int64))] = True
    missing = in_reach & ~listed
    assert not missing.any(), f"{missing.sum()} (root, sphere) pairs in reach but not listed"
    return in_reach, listed


@pytest.mark.parametrize("seed,k", [(1, 3), (2, 40), (3, 300), (4, 1024)])
def test_every_sphere_in_reach_is_in_the_roots_cell(seed, k):
    rng = np.random.default_rng(seed)
    size = 30.0
    v0 = _roots(rng, 20000, size)
    h = rng.uniform(0.5, 1.5, len(v0))
    spheres = _crowd(rng, k, size).astype(np.float32).astype(np.float64)
    grid = build_collider_grid(spheres, root_bounds(v0), h.max())
    # roots outside the bounds (the border cells reach to infinity), and on cell edges
    edges = np.column_stack([grid.origin[0] + grid.cell_size * rng.integers(0, grid.nx + 1, 500), np.zeros(500),
                             rng.uniform(-size, size, 500)])
    outside = _roots(rng, 500, 3 * size)
    roots = np.concatenate([v0, edges, outside])
    heights = np.concatenate([h, rng.uniform(0.5, h.max(), 1000)])
    in_reach, listed = _check_superset(grid, spheres, roots, heights)
    assert in_reach.any()
    assert grid.nx * grid.nz <= MAX_GRID_CELLS and len(grid.items) <= MAX_GRID_ENTRIES
    assert len(grid.words()) <= GRID_WORDS
    if k >= 40:  # the grid prunes: a blade's list is much shorter than all the spheres
        assert grid.nx * grid.nz > 16
        assert grid.cell_count[grid.cell_of(v0)].mean() < 0.2 * k


def test_words_layout_and_cell_range_twin():
    rng = np.random.default_rng(5)
    v0 = _roots(rng, 3000, 20.0)
    spheres = _crowd(rng, 60, 20.0)
    grid = build_collider_grid(spheres, root_bounds(v0), 1.0)
    w = grid.words()
    assert w.dtype == np.uint32
    assert (w[0], w[1], w[2], w[3]) == (grid.nx, grid.nz, 60, len(grid.items))
    assert w[4:8].view(np.float32).tolist() == [grid.origin[0], grid.origin[1], grid.inv_cell_size, grid.cell_size]
    start, count = collider_cell_range(v0, w)
    for k in rng.choice(len(v0), 50, replace=False):
        listed = w[int(start[k]): int(start[k]) + int(count[k])]
        assert np.array_equal(listed, grid.candidates(v0[k]))
    assert start.min() >= GRID_HEADER_WORDS + 2 * grid.nx * grid.nz
    # deterministic
    assert np.array_equal(w, build_collider_grid(spheres, root_bounds(v0), 1.0).words())


def test_grids_fit_their_buffers_for_any_crowd():
    rng = np.random.default_rng(6)
    bounds = (-50.0, -50.0, 50.0, 50.0)
    # 1024 balls each larger than the field: one cell listing every ball (each one is in reach)
    huge = np.column_stack([rng.uniform(-50, 50, (MAX_COLLIDERS, 3)), np.full(MAX_COLLIDERS, 200.0)])
    grid = build_collider_grid(huge, bounds, 1.0)
    assert grid.nx * grid.nz == 1 and np.array_equal(grid.items, np.arange(MAX_COLLIDERS))
    # lists longer than the buffer's room: the cells grow until they fit, and stay exact
    medium = np.column_stack([rng.uniform(-50, 50, (MAX_COLLIDERS, 3)), np.full(MAX_COLLIDERS, 6.0)])
    fine = build_collider_grid(medium, bounds, 1.0)
    coarse = build_collider_grid(medium, bounds, 1.0, max_entries=len(fine.items) // 3)
    assert len(coarse.items) <= len(fine.items) // 3 and coarse.cell_size > fine.cell_size
    v0 = _roots(rng, 5000, 100.0)
    _check_superset(coarse, medium.astype(np.float32).astype(np.float64), v0, np.full(len(v0), 1.0))
    # 1024 tiny balls: many small cells, bounded
    tiny = np.column_stack([rng.uniform(-50, 50, (MAX_COLLIDERS, 3)), np.full(MAX_COLLIDERS, 0.01)])
    grid = build_collider_grid(tiny, bounds, 0.05)
    assert grid.nx * grid.nz <= MAX_GRID_CELLS and grid.nx * grid.nz > 1000
    # no spheres: one empty cell per lookup
    empty = build_collider_grid(np.zeros((0, 4)), bounds, 1.0)
    assert len(empty.items) == 0 and empty.cell_count.sum() == 0
    # a field of one point
    assert build_collider_grid(huge[:3], (1.0, 2.0, 1.0, 2.0), 1.0).candidates((1.0, 0.0, 2.0)).tolist() == [0, 1, 2]


@pytest.mark.parametrize("bad,match", [
    (np.zeros((3, 3)), "shape"), ([[0, 0, 0, -1.0]], "radius"), ([[0, np.nan, 0, 1.0]], "finite"),
    ("balls", "array"), (np.ones((MAX_COLLIDERS + 1, 4)), f"at most {MAX_COLLIDERS}"),
])
def test_set_array_refuses_bad_input_and_keeps_the_old(bad, match):
    colliders = ColliderList([gw.SphereCollider(center=(0, 1, 0), radius=1)])
    good = np.array([[1.0, 0.5, 2.0, 0.5], [3.0, 0.5, 4.0, 0.7]])
    colliders.set_array(good)
    with pytest.raises(ValueError, match=match) as info:
        colliders.set_array(bad)
    assert isinstance(info.value, GrassError)
    assert np.array_equal(colliders.bulk, good) and colliders.count == 3


def test_set_array_beside_the_list_items():
    ball = gw.SphereCollider(center=(0, 1, 0), radius=1)
    colliders = ColliderList([ball])
    rows = np.random.default_rng(1).uniform(0.1, 1, (MAX_COLLIDERS - 1, 4))
    colliders.set_array(rows)
    assert len(colliders) == 1 and colliders.count == MAX_COLLIDERS
    a = collider_array(colliders)
    assert a.shape == (MAX_COLLIDERS, 4) and np.array_equal(a[0], [0, 1, 0, 1]) and np.array_equal(a[1:], rows)
    with pytest.raises(ValueError, match="colliders"):  # the items and rows together are limited
        colliders.append(gw.SphereCollider())
    # a per-ball trait change shows in the array (the cache follows the ball)
    ball.center = (2.0, 3.0, 4.0)
    assert np.array_equal(collider_array(colliders)[0], [2, 3, 4, 1])
    rows[0] = 9.0  # set_array copied: later edits of the caller's array do not leak in
    assert collider_array(colliders)[1, 0] != 9.0
    colliders.set_array([])
    assert colliders.count == 1
    colliders.set_array(rows[:5])
    colliders.clear()
    assert colliders.count == 0 and collider_array(colliders).shape == (0, 4)
