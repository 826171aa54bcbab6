"""The kernel frame's host work (issue 28 item 3): what a frame asks of pygfx and wgpu,
and that the cuts keep the pictures and the physics.

- occlusion culling's second-phase draws go in the second phase's submission: a frame is
  one ``renderer.render()`` call (plus one for the late collider balls), and a mesh the
  user adds to the scene is drawn with the grass, in front of and behind it;
- the blade draws are replayed from a render bundle, recorded again only after a change;
- (the scene's sun re-aimed only when it moved: tests/test_compat.py);
- the simulation's uniforms are worked out again only when the params, the field's
  transform or the number of colliders changed.
"""

import numpy as np
import pygfx as gfx
import pytest

import grasswidget as gw
from grasswidget import compat
from grasswidget.core.engine_inputs import sim_uniform_values
from grasswidget.gpu.frame import render_frame
from conftest import grass_mask

SIZE = (160, 120)


def _counting(renderer):
    calls = []
    original = renderer.render

    def counted(*args, **kwargs):
        calls.append(args[0])
        return original(*args, **kwargs)

    renderer.render = counted
    return calls


def _red_mask(img):
    rgb = img[..., :3].astype(int)
    return (rgb[..., 0] > 150) & (rgb[..., 1] < 80) & (rgb[..., 2] < 80)


@pytest.fixture(scope="module")
def occluded_scene():
    scene = gw.GrassScene.preset("cis565", blades=6000, size=SIZE, seed=3)
    scene.params.cull_occlusion = True
    scene.params.compute_raster = False
    scene.step(5)
    yield scene
    scene.release()


def test_an_occlusion_frame_is_one_render_call_and_the_unculled_picture(occluded_scene):
    scene = occluded_scene
    target = gfx.Texture(dim=2, size=(*SIZE, 1), format="rgba8unorm")
    renderer = gfx.WgpuRenderer(target, pixel_ratio=1, ppaa="none", enable_events=False)
    calls = _counting(renderer)
    for _ in range(3):  # the seen flags settle; every frame is one render call
        calls.clear()
        scene.draw_into(renderer)
        assert calls == [scene.scene]
    drawn = scene.field.read_draw_args()[:, 1].sum()
    occluded = scene.field.read_occluded_count()
    assert occluded > 0 and drawn > 0  # both phases ran: some blades hidden, the rest drawn
    # The picture is the one without occlusion culling (the second phase's draws landed).
    on = scene.render()
    scene.params.cull_occlusion = False
    off = scene.render()
    scene.params.cull_occlusion = True
    differ = (np.abs(on[..., :3].astype(int) - off[..., :3].astype(int)).max(axis=2) > 24).mean()
    assert differ < 0.002, differ
    assert grass_mask(on).mean() > 0.2


def test_second_phase_draws_something_when_the_camera_moves(occluded_scene):
    """A camera turn shows blades not seen last frame: only the second phase draws them."""
    scene = occluded_scene
    scene.render()
    position = np.array(scene.camera.local.position)
    scene.look(position=position + np.array([4.0, 0.0, 0.0]), target=(4.0, 1.0, 0.0))
    try:
        on = scene.render()
        args = scene.field.read_draw_args()[:, 1].sum()
        scene.params.cull_occlusion = False
        off = scene.render()
        scene.params.cull_occlusion = True
        differ = (np.abs(on[..., :3].astype(int) - off[..., :3].astype(int)).max(axis=2) > 24).mean()
        assert args > 0 and differ < 0.002, differ
    finally:
        scene.reset_camera()


def test_a_users_mesh_is_drawn_with_the_grass_under_occlusion_culling(occluded_scene):
    """A mesh added to the scene is drawn in the frame with the grass (a blade in front of
    it cuts its corner), pixel for pixel as without occlusion culling."""
    scene = occluded_scene
    box = gfx.Mesh(gfx.box_geometry(0.3, 0.3, 0.3), gfx.MeshBasicMaterial(color="#ff0000"))
    box.local.position = (-0.4, 0.8, 8.5)  # between the camera (z = 10) and the field (|z| <= 7.5)
    scene.scene.add(box)
    try:
        img = scene.render()
        scene.params.cull_occlusion = False
        off = scene.render()
        scene.params.cull_occlusion = True
    finally:
        scene.scene.remove(box)
    red = _red_mask(img)
    assert 0.02 < red.mean() < 0.2  # the box is drawn
    assert (red ^ _red_mask(off)).mean() < 0.001
    assert grass_mask(img).mean() > 0.3  # and the grass around it


def test_late_balls_still_draw_after_the_second_phase(occluded_scene):
    scene = occluded_scene
    target = gfx.Texture(dim=2, size=(*SIZE, 1), format="rgba8unorm")
    renderer = gfx.WgpuRenderer(target, pixel_ratio=1, ppaa="none", enable_events=False)
    calls = _counting(renderer)
    scene.colliders.append(gw.SphereCollider((0.0, 1.0, 5.0), 1.0))
    try:
        scene.draw_into(renderer)
        assert calls == [scene.scene, scene.scene]  # the frame, then the translucent balls
        calls.clear()
        render_frame(renderer, scene.scene, scene.camera)  # no late objects: one call
        assert calls == [scene.scene]
    finally:
        scene.colliders.clear()
        scene.collider_balls.sync()


def test_blade_draws_are_recorded_once_and_replayed(occluded_scene):
    scene = occluded_scene
    field = scene.field
    bundles = (field.blade_draw_bundle, field.occlusion.draws.blade_draw_bundle)
    scene.render()
    before = [(b.records, b.replays) for b in bundles]
    for _ in range(3):
        scene.render()
    after = [(b.records, b.replays) for b in bundles]
    assert [a[0] for a in after] == [b[0] for b in before]  # nothing recorded again
    assert [a[1] - b[1] for a, b in zip(after, before)] == [3, 3]  # both phases replayed every frame
    natural = scene.render()
    scene.params.color_by = "lod"  # the ribbon pipelines are rebuilt: recorded again, drawn flat
    try:
        lod = scene.render()
        assert all(b.records > r for b, (r, _) in zip(bundles, after))
        changed = (np.abs(lod[..., :3].astype(int) - natural[..., :3].astype(int)).max(axis=2) > 40).mean()
        assert changed > 0.3, changed  # the new bundles draw with the new pipelines
    finally:
        scene.params.color_by = "natural"
    again = scene.render()
    assert (np.abs(again[..., :3].astype(int) - natural[..., :3].astype(int)).max(axis=2) > 24).mean() < 0.002


def test_simulation_uniforms_follow_params_transform_and_colliders():
    field = gw.GrassField(gw.Blades.on_plane(256, seed=1))
    try:
        sim = field.simulation

        def expected(steps, time0):
            return sim_uniform_values(field.params, field.count, field.colliders, world_matrix=field.world.matrix,
                                      steps=steps, time0=time0)

        def same(a, b):
            return a.keys() == b.keys() and all(np.allclose(a[k], b[k]) for k in a)

        assert same(sim.uniform_values(2, 0.5), expected(2, 0.5))
        field.params.gravity = 3.0
        field.params.wind_direction = 40.0
        assert same(sim.uniform_values(1, 1.5), expected(1, 1.5))
        field.local.rotation = (0.0, 0.0, 0.38268343, 0.92387953)  # 45 degrees about z: gravity in local space
        assert same(sim.uniform_values(1, 0.0), expected(1, 0.0))
        field.colliders.append(gw.SphereCollider((0.0, 0.0, 0.0), 0.5))
        assert sim.uniform_values(1, 0.0)["n_colliders"] == 1 and same(sim.uniform_values(1, 0.0), expected(1, 0.0))
        field.colliders.set_array(np.array([[1.0, 0.0, 1.0, 0.3], [2.0, 0.0, 2.0, 0.3]]))
        assert sim.uniform_values(1, 0.0)["n_colliders"] == 3
        field.step(2)  # the physics runs with them (no error, state finite)
        assert np.isfinite(field.read_state()["v2"]).all()
    finally:
        field.release()
