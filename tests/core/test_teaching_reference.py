"""The pure side of the teaching views: why blades are culled, the forces the
inspector draws, the frozen frustum's geometry, colours and input checks."""

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.core import reference as ref
from grasswidget.core import teaching


def _look_at(eye, target, fov_deg=45.0, aspect=4 / 3, near=0.1, far=100.0):
    """An independent world-to-clip matrix (WebGPU depth 0..1), right-handed, y up."""
    eye, target = np.asarray(eye, float), np.asarray(target, float)
    f = target - eye
    f /= np.linalg.norm(f)
    r = np.cross(f, (0, 1, 0))
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    view = np.eye(4)
    view[0, :3], view[1, :3], view[2, :3] = r, u, -f
    view[:3, 3] = -view[:3, :3] @ eye
    t = 1 / np.tan(np.radians(fov_deg) / 2)
    proj = np.zeros((4, 4))
    proj[0, 0], proj[1, 1] = t / aspect, t
    proj[2, 2], proj[2, 3] = far / (near - far), near * far / (near - far)
    proj[3, 2] = -1
    return proj @ view


@pytest.fixture(scope="module")
def field_state():
    b = gw.Blades.on_plane(4000, 15.0, seed=4)
    st = ref.simulate(b.rest_state(), gw.GrassParams(wind_strength=25), 30)
    return st


@pytest.mark.parametrize("eye", [(0, 1, 10), (12, 6, -3), (0, 30, 0.01), (-3, 2, 25)])
def test_cull_reason_is_the_first_test_that_culls(field_state, eye):
    p = gw.GrassParams(cull_distance_max=20.0, cull_buckets=10)
    vp = _look_at(eye, (0, 0, 0))
    reason = ref.cull_reason(field_state, p, vp, eye)
    v0, v1, v2, up = (field_state[k] for k in ("v0", "v1", "v2", "up"))
    o = ref.orientation_cull(v0, ref.width_direction(up, field_state["orientation"]), eye)
    f = ref.frustum_cull(v0, v1, v2, vp)
    d = ref.distance_cull(v0, up, eye, np.arange(len(v0)), 10, 20.0)
    expected = np.select([o, f, d], [1, 2, 3], 0)
    assert np.array_equal(reason, expected)
    assert np.array_equal(ref.cull(field_state, p, vp, eye), ~(o | f | d))
    assert ref.CULL_REASONS[0] == "kept" and list(ref.CULL_REASONS[1:]) == list(gw.CULL_COLORS)


def test_cull_reason_skips_disabled_tests(field_state):
    eye = (12, 6, -3)
    vp = _look_at(eye, (0, 0, 0))
    p = gw.GrassParams(cull_distance_max=20.0, cull_buckets=10, cull_orientation=False)
    reason = ref.cull_reason(field_state, p, vp, eye)
    assert 1 not in reason and {2, 3} <= set(np.unique(reason))
    p.cull_frustum = p.cull_distance = False
    assert not ref.cull_reason(field_state, p, vp, eye).any()


def test_forces_are_what_the_step_integrates(field_state):
    """gravity + recovery + wind is the explicit acceleration of the semi-implicit update."""
    p = gw.GrassParams(wind_strength=25)
    t = 0.37
    F = ref.blade_forces(field_state, p, t)
    assert list(F) == list(ref.FORCE_NAMES)
    v0, v2, up, h = (np.asarray(field_state[k], float) for k in ("v0", "v2", "up", "height"))
    s = field_state["stiffness"] * p.stiffness_scale
    iv2 = v0 + up * h[:, None]
    accel = F["gravity"] + F["wind"]
    stepped = ref.integrate_tip(v2, iv2, s, accel, p.dt)
    total = F["gravity"] + F["recovery"] + F["wind"]
    assert np.allclose(stepped - v2, p.dt * total / (1 + s * p.dt)[:, None], atol=1e-12)
    # gravity: straight down 9.8 plus a quarter of that along the front direction
    assert np.allclose(F["gravity"][:, 1], -9.8)
    assert np.allclose(np.linalg.norm(F["gravity"][:, [0, 2]], axis=1), 0.25 * 9.8)
    assert np.abs(F["wind"]).max() > 1 and np.abs(F["recovery"]).max() > 1
    assert not F["collision"].any()
    # calm air: no wind force at all
    calm = ref.blade_forces(field_state, gw.GrassParams(wind_strength=0), t)
    assert not calm["wind"].any()


def test_collision_is_the_push_of_the_step():
    """"collision" is exactly how much the spheres move the tip in simulate_step."""
    b = gw.Blades.on_plane(3000, 6.0, seed=2)
    p = gw.GrassParams(wind_strength=0)
    ball = np.array([[0.5, 1.0, 0.0, 1.1]])
    st = ref.simulate(b.rest_state(), p, 40, colliders=ball)
    t = 40 * p.dt
    F = ref.blade_forces(st, p, t, colliders=ball)
    with_ball = ref.simulate_step(st, p, t, ball)["v2"]
    without = ref.simulate_step(st, p, t, None)["v2"]
    assert np.allclose(F["collision"], with_ball - without, atol=1e-12)
    touched = np.linalg.norm(F["collision"], axis=1) > 1e-6
    assert 20 < touched.sum() < len(st["v0"]) / 2
    # pushes point away from the ball's centre
    away = st["v2"][touched] - ball[0, :3]
    assert (np.sum(away * F["collision"][touched], axis=1) > 0).mean() > 0.95
    far = np.linalg.norm(st["v0"][:, [0, 2]] - ball[0, [0, 2]], axis=1) > 3.5
    assert not F["collision"][far].any()


def test_frustum_corners_invert_the_projection():
    vp = _look_at((3, 4, 9), (0, 0.5, 0), fov_deg=50, near=0.5, far=40)
    corners = teaching.frustum_corners(vp)
    clip = np.concatenate([corners, np.ones((8, 1))], 1) @ vp.T
    ndc = clip[:, :3] / clip[:, 3:]
    assert np.allclose(ndc[:, :2], [[x, y] for z in (0, 1) for y in (-1, 1) for x in (-1, 1)])
    assert np.allclose(ndc[:, 2], [0] * 4 + [1] * 4)
    eye = np.array([3, 4, 9.0])
    dist = np.linalg.norm(corners - eye, axis=1)
    assert np.all(dist[:4] < 1.0) and np.all(dist[4:] > 40)  # near and far planes
    seg = teaching.frustum_segments(vp)
    assert seg.shape == (24, 3) and seg.dtype == np.float32
    # each corner is the end of exactly 3 edges
    _, counts = np.unique(np.round(seg, 3), axis=0, return_counts=True)
    assert sorted(counts) == [3] * 8


def test_colours():
    all_colors = list(gw.CULL_COLORS.values())
    assert list(gw.CULL_COLORS) == ["orientation", "frustum", "distance", "occlusion"]
    assert len(set(all_colors)) == 4
    for c in all_colors:
        r, g, b = teaching.hex_to_rgb(c)
        assert not (g > r + 8 and g > b + 8), f"{c} looks green"  # the conftest grass test
    assert len(gw.LOD_COLORS) == len(ref.LOD_SEGMENTS) == len(set(gw.LOD_COLORS))
    rows = teaching.legend("lod")
    assert [c for _, c in rows] == gw.LOD_COLORS + [teaching.COMPUTE_RASTER_COLOR] and "8 segments" in rows[0][0]
    assert "compute" in rows[-1][0]  # the compute rasterizer's blades (GrassParams.compute_raster)
    assert [c for _, c in teaching.legend("cull")][1:] == all_colors
    assert teaching.legend("natural") == []


def test_color_by_param():
    p = gw.GrassParams()
    assert p.color_by == "natural"
    p.color_by = "cull"
    for bad in ("LOD", "", 3, None):
        with pytest.raises(ValueError, match="color_by must be one of 'natural', 'lod', 'cull'"):
            p.color_by = bad
    assert p.color_by == "cull"
    with pytest.raises(ValueError, match="color_by"):
        teaching.legend("depth")


@pytest.mark.parametrize(
    "ids, match",
    [
        (list(range(65)), "at most 64"),
        ([0, 100], r"in \[0, 99\]"),
        ([-1], r"in \[0, 99\]"),
        ([1.0], "must be integers"),
        ([True], "must be integers"),
        (["3"], "must be integers"),
        (7, "list of blade ids"),
    ],
)
def test_inspect_ids_are_checked(ids, match):
    with pytest.raises(ValueError, match=match):
        teaching.check_inspect_ids(ids, 100)


def test_inspect_ids_accepts_numpy_and_removes_repeats():
    ids = teaching.check_inspect_ids(np.array([5, 2, 5], np.uint32), 100)
    assert list(ids) == [5, 2]
    assert list(teaching.check_inspect_ids(range(64), 100)) == list(range(64))
    assert len(teaching.check_inspect_ids([], 100)) == 0
