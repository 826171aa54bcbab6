"""A field to the horizon follows the camera on the GPU (lavapipe here): the culling pass's wrap against
its NumPy twin (reference.follow_camera), state kept through a wrap, nothing moved without a frame, a
ball far from the field's middle still bending the blades, and the picture the same whatever path the
camera took to where it is (the wrap is a function of the camera's position alone)."""

from __future__ import annotations

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.core import reference as ref
from conftest import assert_same_picture, save_test_picture

W, H = 96, 54
N_BLADES = 1 << 14


def _scene():
    s = gw.GrassScene.preset("meadow", blades=N_BLADES, size=(W, H))
    s.params.wind_strength = 6.0
    return s


def _move(scene, dx, dz):
    p = np.array(scene.camera.local.position, np.float64)
    forward = -np.asarray(scene.camera.world.matrix, np.float64)[:3, 2]
    p = p + np.array([dx, 0.0, dz])
    scene.look(position=p, target=p + 30.0 * forward)
    return p


def test_the_cull_pass_wraps_as_the_twin_and_keeps_each_blades_state():
    from grasswidget.gpu.wgsl_templates import follows_camera

    s = _scene()
    try:
        assert follows_camera(s.field) and not follows_camera(object())  # the level code: such a field only
        table = s.field.blades.horizon.table()
        s.step(20)  # bent by the wind
        s.render()
        before = s.field.read_state()
        cam = _move(s, 29.0, -23.0)  # 37 m away
        s.step(3)  # simulation alone: nothing moves without a frame
        stepped = s.field.read_state()
        assert np.array_equal(stepped["v0"], before["v0"])
        s.render()
        after = s.field.read_state()
        v0, v1, v2 = ref.follow_camera(stepped["v0"], stepped["v1"], stepped["v2"], cam, table)
        moved = np.any(v0 != stepped["v0"], axis=1)
        assert moved.sum() > N_BLADES // 4
        assert np.array_equal(after["v0"], v0)  # the same float32 arithmetic
        # the bend and the motion moved with the root (the sim ran no step since: the guides are the twin's)
        assert np.allclose(after["v1"], v1, atol=1e-5) and np.allclose(after["v2"], v2, atol=1e-5)
        assert np.allclose(after["v2"] - after["v0"], stepped["v2"] - stepped["v0"], atol=1e-4)
        bent = np.linalg.norm((stepped["v2"] - stepped["v0"])[:, [0, 2]], axis=1)
        assert np.median(bent[moved]) > 0.01  # the moved blades were bent: their state came along
        # a second frame from the same camera moves nothing
        s.render()
        assert np.array_equal(s.field.read_state()["v0"], after["v0"])
        # every blade of a level is within half its period of the camera (x and z)
        k = np.repeat(np.arange(len(table["level_ends"].ravel()))[:s.field.blades.horizon.n_levels],
                      s.field.blades.horizon.counts)
        period = np.asarray(s.field.blades.horizon.periods)[k]
        assert np.all(np.abs(after["v0"][:, [0, 2]] - cam[[0, 2]]) <= period[:, None] / 2 + 1e-3)
    finally:
        s.release()


def test_a_ball_far_from_the_middle_still_bends_the_blades_near_the_camera():
    """After the camera moved 100 m, the blades around it are simulated with the full model: a ball
    there pushes them (the collider grid's border cells reach to infinity), against the same field
    stepped the same without it."""
    s, control = _scene(), _scene()
    try:
        for scene in (s, control):
            cam = _move(scene, 60.0, -80.0)
            scene.render()  # the blades come to the camera
        state = s.field.read_state()
        ahead = cam + np.array([0.0, -cam[1], -4.0])
        d = np.hypot(state["v0"][:, 0] - ahead[0], state["v0"][:, 2] - ahead[2])
        near = d < 0.5
        assert near.sum() > 8 and np.hypot(ahead[0], ahead[2]) > 95.0
        s.field.colliders.append(gw.SphereCollider(center=(ahead[0], 0.5, ahead[2]), radius=0.6))
        s.step(10)
        control.step(10)
        moved = np.linalg.norm(s.field.read_state()["v2"] - control.field.read_state()["v2"], axis=1)
        far = d > 3.0
        assert np.median(moved[near]) > 0.2 and moved[far].max() < 1e-5, (np.median(moved[near]), moved[far].max())
    finally:
        s.release()
        control.release()


def test_the_picture_depends_on_where_the_camera_is_not_on_its_path():
    """50 m in 100 frames (0.5 m each, as a walk would) or in one jump: the same picture, pixel for
    pixel (no simulation step between: the state is the rest pose's), so no wrap left a blade where the
    twin would not put it, and none jumped where it was drawn."""
    walked, jumped = _scene(), _scene()
    try:
        for s in (walked, jumped):
            s.params.wind_strength = 0.0
        for _ in range(100):
            _move(walked, 0.3, -0.4)
            walked.render()
        _move(jumped, 30.0, -40.0)
        a, b = walked.render().copy(), jumped.render().copy()
        save_test_picture("follow_camera_walked_50m", a[..., :3])
        assert_same_picture(a, b, "walked 50 m against jumped 50 m")
        # the same roots (a walked root took several shifts of one period: float32 sums, to a millimetre)
        assert np.allclose(walked.field.read_state()["v0"], jumped.field.read_state()["v0"], atol=1e-3)
        assert a[..., :3].std() > 10  # a picture of grass, not a blank
    finally:
        walked.release()
        jumped.release()
