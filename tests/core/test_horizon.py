"""A field to the horizon (Blades.on_plane(..., reach=R), core/horizon.py): where its blades go,
how wide they are, and what the orbit, the presets and the culling make of it (pure, no GPU)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.core import engine_inputs
from grasswidget.core.camera_presets import camera_preset, field_box
from grasswidget.core.presets import preset_field
from grasswidget.core.horizon import HorizonLayout, concentric_disc
from grasswidget.core.orbit_limits import OrbitLimits

N = 1 << 17
SIZE, REACH = 20.0, 160.0  # near disc radius 10 m, 16 x farther: four doublings of the distance
WIDTH = (0.02, 0.04)


@pytest.fixture(scope="module")
def disc_blades():
    return gw.Blades.on_plane(N, size=SIZE, reach=REACH, seed=5, width=WIDTH, height=(0.5, 1.0))


def _radius(blades):
    return np.hypot(blades.v0[:, 0].astype(np.float64), blades.v0[:, 2].astype(np.float64))


def test_the_count_is_the_users_and_every_blade_lies_on_the_disc(disc_blades):
    r = _radius(disc_blades)
    assert len(disc_blades) == N and disc_blades.horizon == HorizonLayout((0.0, 0.0), SIZE / 2, REACH)
    assert r.max() <= REACH * (1 + 1e-6) and r.max() > 0.99 * REACH
    assert np.all(disc_blades.v0[:, 1] == 0) and np.all(disc_blades.up[:, 1] == 1)
    # the same arguments, the same field; another reach, the same count
    again = gw.Blades.on_plane(N, size=SIZE, reach=REACH, seed=5, width=WIDTH, height=(0.5, 1.0))
    assert np.array_equal(again.v0, disc_blades.v0) and np.array_equal(again.width, disc_blades.width)
    assert len(gw.Blades.on_plane(N, size=SIZE, reach=4 * REACH, seed=5)) == N


def test_density_per_band_halves_as_the_analytic_expectation(disc_blades):
    """Blades per distance band (each twice as far out as the last, beyond the near disc) against
    the integral of rho0 r0 / r: within 3 standard deviations of a Poisson count (the placement is
    stratified, so it is much closer), and the mean density halves from band to band."""
    r = _radius(disc_blades)
    layout = disc_blades.horizon
    r0 = layout.near_radius
    edges = [0.0, r0, 2 * r0, 4 * r0, 8 * r0, 16 * r0]
    densities = []
    for a, b in zip(edges[:-1], edges[1:]):
        got = int(np.count_nonzero((r >= a) & (r < b)))
        want = layout.expected_count(a, b, N)
        assert abs(got - want) <= 3 * math.sqrt(want) + 1, (a, b, got, want)
        densities.append(got / (math.pi * (b * b - a * a)))
    # band k (k >= 1) spans [2^(k-1), 2^k] r0: its mean density is rho0 * 2 / (3 * 2^(k-1))
    rho0 = layout.near_density(N)
    assert densities[0] == pytest.approx(rho0, rel=0.02)
    for k in range(1, len(densities)):
        assert densities[k] == pytest.approx(rho0 * 2.0 / (3.0 * 2 ** (k - 1)), rel=0.02), k
        if k > 1:
            assert densities[k] / densities[k - 1] == pytest.approx(0.5, rel=0.03)
    # continuous at the near disc's edge: just inside and just outside alike
    inside = np.count_nonzero((r > 0.9 * r0) & (r < r0)) / (math.pi * (r0 ** 2 - (0.9 * r0) ** 2))
    outside = np.count_nonzero((r > r0) & (r < 1.1 * r0)) / (math.pi * ((1.1 * r0) ** 2 - r0 ** 2))
    assert outside == pytest.approx(inside, rel=0.06)


def test_width_doubles_per_band_and_the_covered_area_per_band_is_constant(disc_blades):
    """Each blade's width is its near width times max(1, r / r0); the leaf area per square metre
    of ground (sum of width x height over the band's area) is the same in every band, to 3 %."""
    r = _radius(disc_blades)
    r0 = disc_blades.horizon.near_radius
    near = r < r0
    assert disc_blades.width[near].min() >= WIDTH[0] * 0.999 and disc_blades.width[near].max() <= WIDTH[1] * 1.001
    unscaled = disc_blades.width / np.maximum(1.0, r / r0)
    assert unscaled.min() >= WIDTH[0] * 0.999 and unscaled.max() <= WIDTH[1] * 1.001
    edges = [0.0, r0, 2 * r0, 4 * r0, 8 * r0, 16 * r0]
    cover, widths = [], []
    for a, b in zip(edges[:-1], edges[1:]):
        band = (r >= a) & (r < b)
        cover.append(float(np.sum(disc_blades.width[band] * disc_blades.height[band])) / (math.pi * (b * b - a * a)))
        widths.append(float(np.mean(disc_blades.width[band])))
    assert max(cover) / min(cover) < 1.03, cover
    for k in range(2, len(widths)):
        assert widths[k] / widths[k - 1] == pytest.approx(2.0, rel=0.03), widths


def test_the_near_disc_is_stratified():
    """No bald patch: every 1 m^2 cell of the near disc holds blades, about its share."""
    b = gw.Blades.on_plane(1 << 15, size=20.0, reach=60.0, seed=1)
    r0 = b.horizon.near_radius
    x, z = b.v0[:, 0], b.v0[:, 2]
    rho0 = b.horizon.near_density(len(b))
    full = [(i, j) for i in range(-10, 10) for j in range(-10, 10) if math.hypot(abs(i + 0.5) + 0.5,
                                                                                 abs(j + 0.5) + 0.5) < r0]
    assert len(full) > 200
    counts = np.array([np.count_nonzero((x >= i) & (x < i + 1) & (z >= j) & (z < j + 1)) for i, j in full])
    assert counts.min() > 0.6 * rho0 and counts.max() < 1.4 * rho0, (counts.min(), counts.max(), rho0)
    u, v = np.meshgrid(np.linspace(0, 1, 101), np.linspace(0, 1, 101))
    dx, dz = concentric_disc(u, v)
    assert np.hypot(dx, dz).max() <= 1 + 1e-12


def test_bad_reach_is_refused_naming_the_range():
    for bad in (5.0, 7.5, -1.0, float("nan"), float("inf"), "far", True):
        with pytest.raises(gw.GrassValueError, match="reach"):
            gw.Blades.on_plane(64, size=15.0, reach=bad)
    with pytest.raises(gw.GrassValueError, match="near_radius"):
        HorizonLayout((0.0, 0.0), 0.0, 10.0)


def test_distance_culling_is_off_for_a_field_that_thins_itself(disc_blades):
    p = gw.GrassParams()
    assert p.cull_distance
    assert engine_inputs.cull_uniform_values(p, N)["cull_distance"] == 1
    assert engine_inputs.cull_uniform_values(p, N, thinned=True)["cull_distance"] == 0


def test_orbit_keeps_the_camera_near_the_middle(disc_blades):
    """Whatever the drag, the camera stays within half the reach of the centre (the edge of the
    blades is at least half the reach away), over the near disc's target box."""
    limits = OrbitLimits.for_field(disc_blades.v0, disc_blades.up, disc_blades.height, 400.0,
                                   horizon=disc_blades.horizon)
    r0 = disc_blades.horizon.near_radius
    assert limits.hi[0] == pytest.approx(r0 + 0.2 * r0) and limits.lo[1] == pytest.approx(-1.2 * r0)
    rng = np.random.default_rng(0)
    from grasswidget.core.orbit_limits import clamp_orbit
    for _ in range(300):
        p, t = clamp_orbit(rng.normal(0, 300, 3), rng.normal(0, 100, 3), limits)
        assert math.hypot(p[0], p[2]) <= disc_blades.horizon.max_camera_offset() + 1e-6
    # the ground blend is done before the nearest the edge can be
    start, end = disc_blades.horizon.ground_blend()
    assert 0 < start < end <= REACH - disc_blades.horizon.max_camera_offset()


@pytest.mark.parametrize("count", [1 << 14, 1 << 20])  # 2^20: the preset's default, a near disc of 32 m
def test_meadow_preset_reaches_the_horizon_and_its_cameras_are_allowed(count):
    blades, size, view = preset_field("meadow", count)
    flat, _, flat_view = preset_field("meadow", count, horizon=False)
    assert len(blades) == len(flat) == count and flat.horizon is None
    assert blades.horizon.reach == 0.5 * view["far"]
    assert view["position"] == flat_view["position"]
    # the same view: the target moved along the ray onto the near disc (the orbit's pivot stays over it)
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


def test_far_ground_values_follow_the_looks(disc_blades):
    v = engine_inputs.sky_ground_values(disc_blades, 400.0, gw.GrassParams())
    assert v["horizon"] == (0.0, 0.0, REACH, 1.0)
    assert 0.2 < min(v["far_grass"][:3]) <= max(v["far_grass"][:3]) < 1.5
    drier = engine_inputs.sky_ground_values(disc_blades, 400.0, gw.GrassParams(dryness=0.8, patch_size=7.0))
    assert drier["dryness"] == 0.8 and drier["far_blend"][2] == 7.0
    square = engine_inputs.sky_ground_values(gw.Blades.on_plane(256), 100.0)
    assert square["horizon"][3] == 0.0
    # the far ground is green (grass), not khaki, in the twin
    from grasswidget.core import reference as ref
    rgb = ref.ground_albedo(150.0, 0.0, 150.0, np.array(v["soil_color"][:3]), np.array(v["beyond_color"][:3]),
                            np.array(v["field"][:2]), np.array(v["field"][2:]), v["field_edge"], v["cover"],
                            v["horizon"], v["far_blend"], np.array(v["far_grass"]),
                            np.array(v["grass_root"][:3]), np.array(v["grass_tip"][:3]), v["color_variation"],
                            v["dryness"])
    assert rgb[1] > rgb[0] + 0.05 and rgb[1] > rgb[2] + 0.05
