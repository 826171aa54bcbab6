"""The blade inspector: its arrows (read back from the buffer it draws) equal the
NumPy reference's forces, every frame, without calling inspect again."""

import math

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.core import reference as ref
from grasswidget.gpu.inspector import SEGMENT_VERTICES
from grasswidget.core.teaching import ARROW_ACCEL_PER_HEIGHT, COLLISION_ARROW_SCALE, INSPECTOR_COLORS, hex_to_rgb


# Fixtures blades and scene (conftest).
BLADES = dict(count=1200, size=8.0, seed=9, height=(1.3, 2.5), width=(0.1, 0.14))
SCENE = dict(size=(320, 240))


@pytest.fixture
def fresh_scene(scene):
    """The module's scene at rest in a wave wind, nothing inspected afterwards."""
    scene.field.reset()
    scene.colliders.clear()
    p = scene.params
    p.wind_strength, p.wind_field = 5.0, "wave"
    yield scene
    scene.inspect([])
    scene.colliders.clear()
    p.wind_strength = 5.0
    scene.reset_camera()


def _time(scene):
    p = scene.params
    t = scene.field.step_count * p.dt
    period = ref.wind_period(p)
    return math.fmod(t, period) if period else t


def _arrows(scene):
    """Forces (n, 4, 3) from the drawn arrows: (end - start) * ARROW_ACCEL_PER_HEIGHT / h,
    the collision push (end - start) / COLLISION_ARROW_SCALE; NaN arrows (not drawn)
    read as zero. Also the control points (n, 3, 3)."""
    ids = scene.inspected
    seg = scene.field.inspector.read_segments().reshape(-1, SEGMENT_VERTICES, 3)[: len(ids)]
    h = scene.field.blades.height[list(ids)].astype(np.float64)
    forces = np.zeros((len(ids), len(ref.FORCE_NAMES), 3))
    for j in range(len(ref.FORCE_NAMES)):
        start, end = seg[:, 4 + 6 * j], seg[:, 5 + 6 * j]
        vec = np.nan_to_num((end - start).astype(np.float64), nan=0.0)
        if ref.FORCE_NAMES[j] == "collision":
            forces[:, j] = vec / COLLISION_ARROW_SCALE
        else:
            forces[:, j] = vec * (ARROW_ACCEL_PER_HEIGHT / h)[:, None]
    points = np.stack([seg[:, 0], seg[:, 1], seg[:, 3]], axis=1)
    return forces, points, seg


def _check(scene, ids, colliders=None, rtol=2e-3, atol=2e-3, atol_push=2e-5):
    state = scene.field.read_state()
    expected = ref.blade_forces(state, scene.params, _time(scene), colliders=colliders)
    forces, points, seg = _arrows(scene)
    for j, name in enumerate(ref.FORCE_NAMES):
        want = expected[name][list(ids)]
        scale = np.linalg.norm(want, axis=1, keepdims=True) * rtol + (atol_push if name == "collision" else atol)
        assert np.all(np.abs(forces[:, j] - want) <= scale), (name, forces[:, j], want)
    for k, key in enumerate(("v0", "v1", "v2")):
        assert np.allclose(points[:, k], state[key][list(ids)], atol=1e-6)
    return forces, expected


def test_arrows_equal_the_reference_forces_in_wind(fresh_scene):
    scene = fresh_scene
    scene.params.wind_strength = 25.0
    scene.step(50)
    ids = [3, 100, 777, 1199]
    scene.inspect(ids)
    scene.render()
    forces, expected = _check(scene, ids)
    assert np.all(np.linalg.norm(forces[:, 2], axis=1) > 0.5)  # wind arrows are drawn
    assert np.all(forces[:, 3] == 0)  # no sphere: no collision arrow
    # numbers for the panel come from the same GPU buffers
    rows = scene.read_inspected()
    assert [r["id"] for r in rows] == ids
    assert np.allclose([r["wind"] for r in rows], expected["wind"][ids], atol=1e-3)
    # the next frames follow the GPU state without a new inspect(): step, render, compare
    scene.step(7)
    scene.render()
    _check(scene, ids)
    # a parameter changed while paused shows at the next render (calm air: no wind arrow)
    scene.params.wind_strength = 0.0
    scene.render()
    forces, _ = _check(scene, ids)
    assert np.all(forces[:, 2] == 0)


def test_arrows_equal_the_reference_forces_against_a_ball(fresh_scene):
    scene = fresh_scene
    p = scene.params
    p.wind_strength = 0.0
    ball = gw.SphereCollider(center=(0.0, 1.2, 0.0), radius=1.1)
    scene.colliders.append(ball)
    scene.step(40)
    v0 = scene.field.blades.v0
    # the 64 blades nearest 1.15 m from the ball's axis (just inside its 1.1 m rim at the
    # blades' mid height) lean on it
    near = np.argsort(np.abs(np.linalg.norm(v0[:, [0, 2]], axis=1) - 1.15))[:64]
    scene.inspect(near)
    scene.render()
    spheres = np.array([[*ball.center, ball.radius]])
    forces, expected = _check(scene, near, colliders=spheres)
    pushed = np.linalg.norm(forces[:, 3], axis=1) > 1e-3  # pushed by more than a millimetre
    assert pushed.sum() >= 5, np.linalg.norm(expected["collision"][near], axis=1)
    # a blade pushed by the ball: the push points away from the ball's centre
    tips = scene.field.read_state()["v2"][near][pushed]
    assert np.all(np.sum((tips - spheres[0, :3]) * forces[pushed, 3], axis=1) > 0)
    # the ball moved between steps (no step yet): the arrows follow at the next render
    ball.center = (4.0, 1.2, 4.0)
    scene.render()
    forces, _ = _check(scene, near, colliders=np.array([[4.0, 1.2, 4.0, 1.1]]))
    assert not np.any(forces[:, 3])


def test_arrows_equal_the_reference_forces_in_a_crowd(fresh_scene):
    """30 balls (set_array) resting on the grass: the inspector reads the same collider grid as the
    simulation, and its collision arrows equal the reference's (every ball)."""
    scene = fresh_scene
    scene.params.wind_strength = 0.0
    rng = np.random.default_rng(3)
    r = rng.uniform(0.6, 1.1, 30)
    balls = np.column_stack([rng.uniform(-4, 4, 30), r + 0.1, rng.uniform(-4, 4, 30), r])
    balls = balls.astype(np.float32).astype(np.float64)
    scene.colliders.set_array(balls)
    scene.step(30)
    v0 = scene.field.blades.v0
    dist = np.linalg.norm(v0[:, None, [0, 2]] - balls[None, :, [0, 2]], axis=2) - balls[:, 3]
    near = np.argsort(np.abs(dist - 0.3).min(axis=1))[:64]  # blades just outside some ball's rim
    scene.inspect(near)
    scene.render()
    forces, expected = _check(scene, near, colliders=balls)
    assert (np.linalg.norm(forces[:, 3], axis=1) > 1e-3).sum() >= 5, np.linalg.norm(forces[:, 3], axis=1)


def test_inspector_is_drawn_and_cleared(fresh_scene, tmp_path):
    scene = fresh_scene
    scene.params.wind_strength = 25.0
    scene.step(30)
    v0 = scene.field.blades.v0
    i = int(np.argmin(np.linalg.norm(v0 - [0, 0, 0], axis=1)))
    scene.camera.local.position = (3, 2.5, 5)
    scene.camera.look_at(v0[i] + [0, 1, 0])
    before = scene.render()
    scene.inspect([i])
    img = scene.render()
    import imageio.v3 as iio

    iio.imwrite(tmp_path / "inspector.png", img)

    def share(im, name):
        return np.all(np.abs(im[..., :3].astype(int) - hex_to_rgb(INSPECTOR_COLORS[name])) <= 6, axis=-1).sum()

    for name in ("gravity", "recovery", "wind", "points"):
        assert share(img, name) > 10 and share(img, name) > 5 * share(before, name), name
    scene.inspect([])
    assert scene.inspected == ()
    after = scene.render()
    assert np.abs(after.astype(int) - before.astype(int)).max() <= 1


@pytest.mark.parametrize(
    "ids, match",
    [
        (list(range(65)), "at most 64"),
        ([0, 1200], r"in \[0, 1199\]"),
        ([-3], r"in \[0, 1199\]"),
        ([2.0], "must be integers"),
        ([np.float32(2)], "must be integers"),
        ([None], "must be integers"),
        ("12", "list of blade ids"),
    ],
)
def test_bad_ids_raise_and_change_nothing(fresh_scene, ids, match):
    scene = fresh_scene
    scene.inspect([4, 5])
    with pytest.raises(ValueError, match=match):
        scene.inspect(ids)
    assert scene.inspected == (4, 5)


def test_inspect_up_to_64_and_numpy_ids(fresh_scene):
    scene = fresh_scene
    ids = np.arange(64, dtype=np.int64) * 17
    scene.inspect(ids)
    scene.render()
    assert scene.inspected == tuple(int(i) for i in ids)
    _check(scene, list(ids))


def test_inspect_a_new_field_before_any_step():
    sc = gw.GrassScene(gw.Blades.on_plane(300, 4.0, seed=1), size=(96, 72))
    sc.inspect([0, 299])
    sc.render()
    _check(sc, [0, 299])
    rows = sc.read_inspected()
    assert np.allclose(rows[0]["gravity"][1], -9.8) and not rows[0]["recovery"].any()  # at rest
    sc.release()
