"""A field to the horizon (Blades.on_plane(..., reach=R), core/horizon.py): levels of wrapped tiles
that follow the camera. Where the blades go, how wide they are, their weights, the wrap's NumPy twin,
the near count against the square field of before, and what the orbit, the presets and the culling
make of it (pure, no GPU)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.core import engine_inputs
from grasswidget.core import reference as ref
from grasswidget.core.camera_presets import camera_preset, field_box
from grasswidget.core.horizon import BAND_OUTER, MAX_LEVELS, MAX_WIDEN, NEAR_RADIUS, HorizonLayout
from grasswidget.core.orbit_limits import OrbitLimits, clamp_orbit
from grasswidget.core.presets import meadow_side, preset_field

N = 1 << 17
SIZE, REACH = 20.0, 160.0
WIDTH = (0.02, 0.04)


@pytest.fixture(scope="module")
def levels_field():
    return gw.Blades.on_plane(N, size=SIZE, reach=REACH, seed=5, width=WIDTH, height=(0.5, 1.0))


def _rest(blades):
    """v1 and v2 of the rest pose: straight up, one height above the root."""
    tip = (blades.v0 + blades.up * blades.height[:, None]).astype(np.float32)
    return tip, tip.copy()


def _levels(blades):
    return np.repeat(np.arange(blades.horizon.n_levels), blades.horizon.counts)


def test_the_count_is_the_users_and_each_level_fills_its_tile(levels_field):
    h = levels_field.horizon
    assert len(levels_field) == N == sum(h.counts) and h == HorizonLayout((0.0, 0.0), SIZE / 2, REACH, N)
    assert 2 <= h.n_levels <= MAX_LEVELS and h.ends[-1] == N
    assert all(p1 == pytest.approx(2 * p0) for p0, p1 in zip(h.periods, h.periods[1:]))
    k = _levels(levels_field)
    for lvl, p in enumerate(h.periods):
        x, z = levels_field.v0[k == lvl, 0], levels_field.v0[k == lvl, 2]
        assert np.all(np.abs(x) <= p / 2 + 1e-3) and np.all(np.abs(z) <= p / 2 + 1e-3)
        # stratified over its tile: each of 4 x 4 cells holds its share to 10 %
        cells = np.histogram2d(x, z, bins=4, range=[[-p / 2, p / 2]] * 2)[0]
        assert cells.min() > 0.9 * cells.mean() and cells.max() < 1.1 * cells.mean(), (lvl, cells)
    assert np.all(levels_field.v0[:, 1] == 0) and np.all(levels_field.up[:, 1] == 1)
    again = gw.Blades.on_plane(N, size=SIZE, reach=REACH, seed=5, width=WIDTH, height=(0.5, 1.0))
    assert np.array_equal(again.v0, levels_field.v0) and np.array_equal(again.width, levels_field.width)
    assert len(gw.Blades.on_plane(N, size=SIZE, reach=4 * REACH, seed=5)) == N


@pytest.mark.parametrize("count", [1 << 18, 1 << 20, 1 << 22, 1 << 24])
def test_far_levels_are_never_denser_than_their_fall_allows(count):
    """Level 0 has the square field's density (capped at NEAR_SHARE_MAX of the blades); a far level
    k that is not the last is at most FAR_DENSITY_FALL^-k times as dense as level 0, the rest going
    farther out (a large count fills the middle distance no denser than the far look needs); every
    level has blades and the count is the user's. Layouts only (no blades made)."""
    from grasswidget.core.horizon import FAR_DENSITY_FALL, NEAR_SHARE_MAX
    from grasswidget.core.presets import meadow_side

    side = meadow_side(count)
    h = HorizonLayout((0.0, 0.0), side / 2, 200.0, count)
    rho = h.densities()
    assert sum(h.counts) == count and min(h.counts) >= 1 and h.n_levels >= 2
    square = count / side ** 2
    assert rho[0] == pytest.approx(min(square, NEAR_SHARE_MAX * count / h.periods[0] ** 2), rel=1e-3)
    for k in range(1, h.n_levels - 1):
        assert rho[k] <= rho[0] * FAR_DENSITY_FALL ** -k * (1 + 1e-6), (k, rho)
    assert all(a >= b for a, b in zip(rho, rho[1:])), rho  # thinner and thinner outwards


def test_widths_keep_the_covered_share_from_level_to_level(levels_field):
    """Each level's blades are its factor times their near width; density x width x 2^k (the covered
    share at a grazing view, the distance doubling per level) is level 0's wherever the factor is not
    capped at MAX_WIDEN, and below it where it is."""
    h = levels_field.horizon
    k = _levels(levels_field)
    factors = h.width_factors()
    rho = h.densities()
    for lvl in range(h.n_levels):
        w = levels_field.width[k == lvl] / factors[lvl]
        assert w.min() >= WIDTH[0] * 0.999 and w.max() <= WIDTH[1] * 1.001
        share = rho[lvl] * factors[lvl] * 2 ** lvl
        if factors[lvl] < MAX_WIDEN:
            assert share == pytest.approx(rho[0], rel=1e-9) or factors[lvl] == 1.0
        else:
            assert share <= rho[0] * (1 + 1e-9)
        # measured density in the level's own tile against its count
        p = h.periods[lvl]
        assert np.count_nonzero(k == lvl) / (p * p) == pytest.approx(rho[lvl])


def test_weights_partition_the_distance_and_end_inside_each_tile(levels_field):
    """The level weights sum to 1 from the camera out to the last level's fade, each reaches 0 strictly
    inside its tile's inscribed circle (a blade moves only at weight 0), and they depend on the
    horizontal distance from the camera to the root only (the reference's per-blade weight agrees
    with the layout's, the camera's height changes nothing)."""
    h = levels_field.horizon
    d = np.linspace(0.0, h.drawn_reach() * 1.2, 4001)
    w = h.weights(d)
    inside = d <= h.bands[-1][2]
    assert np.allclose(w.sum(axis=0)[inside], 1.0)
    assert np.all(w[:, d >= h.drawn_reach()] == 0)
    for (a, b, c, e), p in zip(h.bands, h.periods):
        assert e == pytest.approx(BAND_OUTER * p / 2) and e < p / 2
        assert a < b <= c < e
    # no step anywhere: the steepest change is the smoothstep's (1.5 over its band) across the narrowest band
    narrowest = min(min(b - a for a, b, _c, _e in h.bands[1:]), min(e - c for _a, _b, c, e in h.bands))
    assert np.abs(np.diff(w, axis=1)).max() <= 1.5 * (d[1] - d[0]) / narrowest * 1.01
    cam = np.array([3.0, 2.0, -7.0])
    table = h.table()
    v0, _, _ = ref.follow_camera(levels_field.v0, *_rest(levels_field), cam, table)
    got = ref.blade_weights(v0, cam, table)
    dist = np.hypot(v0[:, 0] - cam[0], v0[:, 2] - cam[2])  # horizontally, from the camera to the root
    want = h.weights(dist)[_levels(levels_field), np.arange(N)]
    assert np.allclose(got, want)
    assert np.array_equal(ref.blade_weights(v0, cam + [0.0, 25.0, 0.0], table), got)


def test_the_wrap_twin_moves_each_blade_to_its_copy_nearest_the_camera(levels_field):
    """follow_camera: roots move by whole periods of their level to within half a period of the camera
    (x and z), v1 and v2 move with v0 (the bend is kept), and a second call moves nothing."""
    h = levels_field.horizon
    rng = np.random.default_rng(3)
    v1, v2 = _rest(levels_field)
    v1 = v1 + rng.normal(0, 0.1, v1.shape).astype(np.float32)
    v2 = v2 + rng.normal(0, 0.3, v2.shape).astype(np.float32)
    cam = np.array([37.0, 3.0, -121.5])
    table = h.table()
    v0n, v1n, v2n = ref.follow_camera(levels_field.v0, v1, v2, cam, table)
    period = np.asarray(h.periods)[_levels(levels_field)]
    shift = (v0n - levels_field.v0)[:, [0, 2]]
    assert np.allclose(shift / period[:, None], np.round(shift / period[:, None]), atol=1e-4)
    assert np.all(np.abs(v0n[:, [0, 2]] - cam[[0, 2]]) <= period[:, None] / 2 + 1e-3)
    assert np.allclose(v1n - v0n, v1 - levels_field.v0, atol=1e-4) and np.allclose(v2n - v0n, v2 - levels_field.v0, atol=1e-4)
    assert np.count_nonzero(np.any(shift != 0, axis=1)) > N // 2
    again = ref.follow_camera(v0n, v1n, v2n, cam, table)
    assert all(np.array_equal(a, b) for a, b in zip(again, (v0n, v1n, v2n)))
    assert np.array_equal(ref.level_index(np.array([0, h.ends[0] - 1, h.ends[0], N - 1]), *table["level_ends"],
                                          table["n_levels"]), [0, 0, 1, h.n_levels - 1])


def test_a_moving_camera_moves_only_blades_of_weight_zero():
    """Nothing visible jumps: along a camera path of 50 m in 0.5 m steps (as frames would), every blade
    the wrap moves has weight 0 just before and just after the move."""
    levels_field = gw.Blades.on_plane(1 << 15, size=SIZE, reach=REACH, seed=2)
    table = levels_field.horizon.table()
    v0, (v1, v2) = levels_field.v0, _rest(levels_field)
    moved_any = 0
    for t in np.arange(0.0, 50.0, 0.5):
        cam = np.array([0.6 * t, 3.0, -0.8 * t])
        n0, n1, n2 = ref.follow_camera(v0, v1, v2, cam, table)
        moved = np.any(n0 != v0, axis=1)
        moved_any += int(moved.sum())
        if moved.any():
            assert ref.blade_weights(v0, cam, table)[moved].max() == 0.0
            assert ref.blade_weights(n0, cam, table)[moved].max() == 0.0
        v0, v1, v2 = n0, n1, n2
    assert moved_any > 300


def _square_near_count(count):
    """Blades of the square meadow of before (horizon=False) within 10 m (horizontally) of its home camera."""
    flat, _size, view = preset_field("meadow", count, horizon=False)
    p = np.asarray(view["position"], np.float64)
    d = np.hypot(flat.v0[:, 0] - p[0], flat.v0[:, 2] - p[2])
    return int(np.count_nonzero(d < 10.0)), len(flat) / meadow_side(count) ** 2


@pytest.mark.parametrize("count", [1 << 18, 1 << 20])
def test_near_the_camera_at_least_the_square_fields_count_wherever_it_goes(count):
    """The meadow at 2^18 and 2^20: from cameras anywhere within the reach (3 m up, as the home
    camera, and one 20 m up, as the "top" camera: the weights go by the horizontal distance), the blades drawn (weight > 0.5) within 10 m (horizontally) are at least as many as the
    square field had within 10 m of its home camera;
    at 2^20 the density near the camera is at least the square field's (about 1000 per m^2); at 2^18
    (the count cannot fill a 10 m disc at that density) level 0 spreads its share over the 10 m disc."""
    blades, _size, view = preset_field("meadow", count)
    h = blades.horizon
    table = h.table()
    square, rho_square = _square_near_count(count)
    rng = np.random.default_rng(count)
    cams = [np.asarray(view["position"], np.float64)]
    for height in (3.0, 3.0, 3.0, 20.0):
        r, a = h.max_camera_offset() * math.sqrt(rng.uniform()), rng.uniform(0, 2 * math.pi)
        cams.append(np.array([r * math.cos(a), height, r * math.sin(a)]))
    v0, (v1, v2) = blades.v0, _rest(blades)
    for cam in cams:
        v0, v1, v2 = ref.follow_camera(v0, v1, v2, cam, table)
        d = np.hypot(v0[:, 0] - cam[0], v0[:, 2] - cam[2])
        drawn = ref.blade_weights(v0, cam, table) > 0.5
        near = int(np.count_nonzero(drawn & (d < 10.0)))
        assert near >= square, (cam, near, square)
        assert near == pytest.approx(h.expected_drawn(10.0), rel=0.03)
        density = np.count_nonzero(d < 5.0) / (math.pi * 25.0)
        if count >= 1 << 20:
            assert density >= 0.97 * rho_square, (cam, density)
        else:
            assert density == pytest.approx(h.near_density(), rel=0.05)
    assert square > 100_000  # the square field's 10 m (it is about 1000 per m^2)


def test_the_split_follows_the_count():
    """Level 0 covers the near radius at weight > 0.5 whatever the count; at 2^24 the near density stays
    the square field's (1000 per m^2: the far levels are the cheap part) and the levels still reach
    about R."""
    for count in (1 << 12, 1 << 16, 1 << 18, 1 << 20, 1 << 24):
        side = meadow_side(count)
        h = HorizonLayout((0.0, 0.0), side / 2, 200.0, count)
        a, b = h.bands[0][2:]
        assert 0.5 * (a + b) >= NEAR_RADIUS * (1 - 1e-9)
        # within 10 m only level 0 is drawn at more than half its width, all of it
        assert h.expected_drawn(10.0) == pytest.approx(h.densities()[0] * math.pi * NEAR_RADIUS ** 2, rel=1e-9)
        assert sum(h.counts) == count and min(h.counts) >= 1
        assert h.near_density() <= count / side ** 2 * (1 + 1e-9)
        if count >= 1 << 20:
            assert h.near_density() >= 0.99 * count / side ** 2
        assert 200.0 / math.sqrt(2) <= h.drawn_reach() <= 200.0 * math.sqrt(2) or h.n_levels == 1
    assert HorizonLayout((0.0, 0.0), 7.5, 8.0, 100).n_levels == 1


def test_bad_input_is_refused_naming_the_range():
    for bad in (5.0, 7.5, -1.0, float("nan"), float("inf"), "far", True):
        with pytest.raises(gw.GrassValueError, match="reach"):
            gw.Blades.on_plane(64, size=15.0, reach=bad)
    with pytest.raises(gw.GrassValueError, match="near_radius"):
        HorizonLayout((0.0, 0.0), 0.0, 10.0, 10)
    with pytest.raises(gw.GrassValueError, match="count"):
        HorizonLayout((0.0, 0.0), 5.0, 10.0, 0)
    b = gw.Blades.on_plane(64, size=15.0, reach=40.0)
    with pytest.raises(gw.GrassValueError, match="horizon"):  # a layout of other blades: its levels would not fit
        gw.Blades(b.v0[:32], b.up[:32], b.orientation[:32], b.height[:32], b.width[:32], b.stiffness[:32], b.horizon)
    with pytest.raises(gw.GrassTypeError, match="horizon"):
        gw.Blades(b.v0, b.up, b.orientation, b.height, b.width, b.stiffness, "far")


def test_distance_culling_is_off_and_the_table_is_written_for_a_field_to_the_horizon(levels_field):
    p = gw.GrassParams()
    assert p.cull_distance
    assert engine_inputs.cull_uniform_values(p, N)["cull_distance"] == 1
    assert engine_inputs.cull_uniform_values(p, N, thinned=True)["cull_distance"] == 0
    values = engine_inputs.cull_uniform_values(p, N, horizon=levels_field.horizon)
    assert values["cull_distance"] == 0 and values["n_levels"] == levels_field.horizon.n_levels
    assert engine_inputs.cull_uniform_values(p, N)["n_levels"] == 0


def test_orbit_keeps_the_camera_within_the_reach(levels_field):
    """Whatever the drag, the camera stays within the reach of the centre (the grass follows it there)."""
    limits = OrbitLimits.for_field(levels_field.v0, levels_field.up, levels_field.height, 400.0, horizon=levels_field.horizon)
    half = max(levels_field.horizon.near_radius, REACH / 4)
    assert limits.hi[0] == pytest.approx(1.2 * half) and limits.lo[1] == pytest.approx(-1.2 * half)
    rng = np.random.default_rng(0)
    far = 0.0
    for _ in range(300):
        p, t = clamp_orbit(rng.normal(0, 300, 3), rng.normal(0, 100, 3), limits)
        far = max(far, math.hypot(p[0], p[2]))
        assert math.hypot(p[0], p[2]) <= levels_field.horizon.max_camera_offset() + 1e-6
    assert far > 0.5 * REACH  # it does go far out
    start, end = levels_field.horizon.ground_blend()
    assert 0 < start < end < levels_field.horizon.drawn_reach()


@pytest.mark.parametrize("count", [1 << 14, 1 << 20])
def test_meadow_preset_reaches_the_horizon_and_its_cameras_are_allowed(count):
    blades, size, view = preset_field("meadow", count)
    flat, _, flat_view = preset_field("meadow", count, horizon=False)
    assert len(blades) == len(flat) == count and flat.horizon is None
    assert blades.horizon.reach == 0.5 * view["far"]
    assert view["position"] == flat_view["position"]
    ray = np.subtract(view["target"], view["position"])
    flat_ray = np.subtract(flat_view["target"], flat_view["position"])
    assert np.allclose(ray / np.linalg.norm(ray), flat_ray / np.linalg.norm(flat_ray))
    limits = OrbitLimits.for_field(blades.v0, blades.up, blades.height, view["far"], horizon=blades.horizon)
    assert limits.allows(view["position"], view["target"], tol=1e-4)
    home = {"position": view["position"], "target": view["target"], "fov_deg": view["fov_deg"]}
    for name in ("top", "low"):
        cam = camera_preset(name, blades.v0, blades.height, home=home, aspect=16 / 9, limits=limits,
                            horizon=blades.horizon)
        assert limits.allows(cam["position"], cam["target"], tol=1e-4), name
    box = field_box(blades.v0, blades.height, blades.horizon)
    assert box["hi"][0] == pytest.approx(blades.horizon.near_radius)


def test_far_ground_values_follow_the_looks(levels_field):
    v = engine_inputs.sky_ground_values(levels_field, 400.0, gw.GrassParams())
    assert v["horizon"] == (0.0, 0.0, REACH, 1.0)
    assert v["far_blend"][:2] == pytest.approx(levels_field.horizon.ground_blend())
    assert 0.2 < min(v["far_grass"][:3]) <= max(v["far_grass"][:3]) < 1.5
    drier = engine_inputs.sky_ground_values(levels_field, 400.0, gw.GrassParams(dryness=0.8, patch_size=7.0))
    assert drier["dryness"] == 0.8 and drier["far_blend"][2] == 7.0
    square = engine_inputs.sky_ground_values(gw.Blades.on_plane(256), 100.0)
    assert square["horizon"][3] == 0.0
    rgb = ref.ground_albedo(150.0, 0.0, 150.0, np.array(v["soil_color"][:3]), np.array(v["beyond_color"][:3]),
                            np.array(v["field"][:2]), np.array(v["field"][2:]), v["field_edge"], v["cover"],
                            v["horizon"], v["far_blend"], np.array(v["far_grass"]),
                            np.array(v["grass_root"][:3]), np.array(v["grass_tip"][:3]), v["color_variation"],
                            v["dryness"])
    assert rgb[1] > rgb[0] + 0.05 and rgb[1] > rgb[2] + 0.05


def test_the_soil_lies_under_the_blades_wherever_the_camera_goes(levels_field):
    """The ground's field rectangle (soil, the grass layer's shadow) holds every root the wrap can put
    around a camera anywhere within the reach."""
    (cx, cz), (hx, hz) = engine_inputs.field_rectangle(levels_field)
    table = levels_field.horizon.table()
    for angle in np.linspace(0.0, 2 * math.pi, 8, endpoint=False):
        cam = np.array([REACH * math.cos(angle), 2.0, REACH * math.sin(angle)])
        v0, _, _ = ref.follow_camera(levels_field.v0, *_rest(levels_field), cam, table)
        assert np.all(np.abs(v0[:, 0] - cx) <= hx) and np.all(np.abs(v0[:, 2] - cz) <= hz)
