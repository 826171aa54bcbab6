"""The sky and ground pass (shaders/sky_ground.wgsl, gpu/sky_ground.py) on the GPU: the ground beyond every
field is the far grass of its NumPy twin (reference.ground_albedo), pixel by pixel; the kernel's two draws
(the sky's piece and the ground's piece of the screen) give the one full-screen pass's picture from any
camera; the template switches follow the values."""

from __future__ import annotations

import math

import numpy as np
import pylinalg as la
import pytest

import grasswidget as gw
from grasswidget.core import engine_inputs, reference as ref
from grasswidget.gpu.scene import GrassScene, make_renderer
from rendercanvas.offscreen import RenderCanvas
from grasswidget.gpu.sky_ground import SkyGround
from conftest import save_test_picture

SIZE = (96, 64)


@pytest.fixture(scope="module")
def course():
    """The course's square field (cis565's look), small: soil under it, far grass beyond. Compared
    with the twins as drawn, whatever the adapter: without the sunlight's shadows (on by default on a
    GPU adapter: they darken the soil, which ``ground_albedo`` alone leaves out) and without the
    post-process anti-aliasing (a GPU adapter's live view has it: it blends the pixels along the edges
    the split test compares)."""
    scene = GrassScene.preset("cis565", blades=512, size=SIZE)
    scene.params.shadows = False
    scene.renderer.ppaa = "none"
    yield scene
    scene.release()


def _rays(scene):
    """Per pixel centre (h, w): the view ray's near point and direction (world space), NumPy."""
    cam = scene.camera
    inv = np.linalg.inv(np.asarray(cam.projection_matrix, np.float64) @ np.asarray(cam.view_matrix, np.float64))
    w, h = SIZE
    X, Y = np.meshgrid((np.arange(w) + 0.5) / w * 2 - 1, 1 - (np.arange(h) + 0.5) / h * 2)

    def unproject(z):
        p = np.stack([X, Y, np.full_like(X, z), np.ones_like(X)], -1) @ inv.T
        return p[..., :3] / p[..., 3:]

    near = unproject(0.0)
    return near, unproject(1.0) - near


def _expected_ground(scene, values):
    """The ground's sRGB colour (0..255) per pixel from the twins (ground_albedo, fog, the far plane's
    fade), NaN where the ray does not meet the ground square before the far plane."""
    near, d = _rays(scene)
    g = values["ground"]
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (g[1] - near[..., 1]) / d[..., 1]
    hit = near + s[..., None] * d
    on = (s > 0) & (s <= 1) & (np.abs(hit[..., 0] - g[0]) <= g[3]) & (np.abs(hit[..., 2] - g[2]) <= g[3])
    cam = np.asarray(scene.camera.world.position, np.float64)
    dist = np.linalg.norm(hit - cam, axis=-1)
    view = np.asarray(scene.camera.view_matrix, np.float64)
    depth = -(np.concatenate([hit, np.ones_like(s)[..., None]], -1) @ view.T)[..., 2]
    v = {k: np.asarray(values[k], np.float64) for k in values if k != "shadow_balls"}
    albedo = ref.ground_albedo(hit[..., 0], hit[..., 2], dist, v["soil_color"][:3], v["beyond_color"][:3],
                               v["field"][:2], v["field"][2:], values["field_edge"], values["cover"],
                               values["horizon"], values["far_blend"], v["far_grass"], v["grass_root"][:3],
                               v["grass_tip"][:3], values["color_variation"], values["dryness"])
    t = np.clip((depth / values["far_distance"] - 0.6) / 0.4, 0, 1)
    fade = np.maximum(t * t * (3 - 2 * t), ref.fog_amount(dist, values["fog_density"]))[..., None]
    rgb = 255 * (albedo + (v["horizon_color"][:3] - albedo) * fade)
    rgb[~on] = np.nan
    return rgb


@pytest.mark.parametrize("dryness", [0.0, 0.4])
def test_the_ground_beyond_the_field_is_the_far_grass_of_the_twin(course, dryness):
    """Looking down past the course's field: soil under it, beyond it the grass seen from afar in the
    blades' patches, every ground pixel within 3/255 of reference.ground_albedo (dryness 0 and 0.4:
    the patches' dryness, their second noise, counts)."""
    scene = course
    scene.params.dryness = dryness
    try:
        material = scene.sky_ground.material
        assert material.far_grass
        scene.look(position=(0.0, 9.0, 14.0), target=(0.0, 0.0, 2.0), fov_deg=60)
        img = scene.render()[..., :3].astype(np.float64)
        values = engine_inputs.sky_ground_values(scene.field.blades, scene.camera.depth_range[1], scene.params)
        want = _expected_ground(scene, values)
        blades = np.abs(img - np.nan_to_num(want)).max(-1) > 40  # a blade (or its edge) in front of the ground
        ground = ~np.isnan(want[..., 0]) & ~blades
        x, z = _hits_xz(scene, values)
        inside = ref.field_inside(x, z, np.array(values["field"][:2]), np.array(values["field"][2:]),
                                  values["field_edge"])
        f = values["field"]
        outside = np.maximum(np.abs(x - f[0]) - f[2], np.abs(z - f[1]) - f[3])  # metres past the field's edge
        beyond = ground & (outside > 3.0)  # past the tallest blade's reach (2.5 m): no blade in front
        assert beyond.mean() > 0.3 and (ground & (inside == 1)).any()
        err = np.abs(img - want).max(-1)
        save_test_picture(f"sky_ground_course_dryness{dryness}", np.concatenate([img, np.nan_to_num(want)], 1))
        print(f"[sky/ground] dryness {dryness}: beyond the field {beyond.mean():.0%} of the picture, |GPU - twin| "
              f"mean {err[beyond].mean():.2f}/255, max {err[beyond].max():.2f}; under it (soil, blades' edges "
              f"not told apart) median {np.median(err[ground & (inside == 1)]):.2f}")
        assert err[beyond].max() <= 3.0 and err[beyond].mean() < 1.0
        assert np.median(err[ground & (inside == 1)]) <= 3.0
        # the far grass is patchy (the blades' patches), not one flat colour; green without dryness,
        # partly straw with it
        far = img[beyond]
        green = (far[:, 1] > far[:, 0] + 10).mean()
        assert far[:, 1].std() > 2.0
        assert green > 0.95 if dryness == 0 else 0.1 < green < 0.9, green
    finally:
        scene.params.dryness = gw.GrassParams().dryness


def _hits_xz(scene, values):
    near, d = _rays(scene)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (values["ground"][1] - near[..., 1]) / d[..., 1]
    return near[..., 0] + s * d[..., 0], near[..., 2] + s * d[..., 2]


def _cameras():
    """(position, target, roll degrees): down at the ground, across to the horizon, up at the sky, rolled."""
    return [((0.0, 9.0, 14.0), (0.0, 0.0, 2.0), 0.0), ((0.0, 1.5, 12.0), (0.0, 1.2, 0.0), 0.0),
            ((2.0, 1.0, 8.0), (0.0, 6.0, 0.0), 0.0), ((4.0, 2.0, 10.0), (0.0, 1.0, -10.0), 30.0),
            ((-6.0, 3.0, 9.0), (10.0, 2.0, -40.0), -70.0), ((0.0, 30.0, 0.5), (0.0, 0.0, 0.0), 15.0)]


def test_the_split_draws_give_the_one_pass_picture_from_any_camera(course):
    """The kernel's sky/ground is two draws (the sky's piece of the screen and the ground's, split where
    the view ray turns towards the ground); the browser engine draws one full-screen pass ("all"). From
    six cameras (the split line level, tilted by a roll, off screen above or below) both give the same
    picture: no gap, no overlap, no pixel of one part's colour in the other's piece."""
    scene = course
    split = scene.sky_ground
    assert split.part == "sky" and split.ground_part is not None and split.ground_part.part == "ground"
    whole = SkyGround(split.material, split=False)
    assert whole.part == "all"
    scene.scene.add(whole)
    try:
        for position, target, roll in _cameras():
            scene.look(position=position, target=target, fov_deg=50)
            if roll:
                q = la.quat_from_axis_angle((0.0, 0.0, 1.0), math.radians(roll))
                scene.camera.local.rotation = la.quat_mul(scene.camera.local.rotation, q)
            whole.visible, split.visible = False, True
            two = scene.render().copy()
            whole.visible, split.visible = True, False
            one = scene.render().copy()
            # the same to the rounding of the interpolated rays (other triangles): at most 2/255 anywhere (a
            # gap or an overlap would leave the clear colour or another part's colour: far more)
            diff = np.abs(two[..., :3].astype(int) - one[..., :3]).max()
            assert diff <= 2, (position, roll, diff)
            r, g, b = (one[..., k].astype(int) for k in range(3))
            sky = ((b > r + 10) & (b >= g)).mean()
            print(f"[sky/ground] camera {position} roll {roll}: sky {sky:.0%} of the picture")
    finally:
        split.visible = True
        scene.scene.remove(whole)


def _default_scene():
    scene = GrassScene(1024, size=SIZE)
    scene.renderer.ppaa = "none"
    return scene


def test_a_still_views_sky_and_ground_are_copied_and_the_picture_is_the_same():
    """render_frame shades the sky and ground while what they show changes and copies them once a
    frame finds them as the last one left them (SkyGroundCache): the copied frames are the shaded
    ones, pixel for pixel, while the grass moves under them; a camera that moves, another size or a
    changed sky/ground value shades them again, and the copy comes back once they are still."""
    a, b = _default_scene(), _default_scene()
    try:
        cache = a.sky_ground.cache
        first = a.render()
        assert not a.sky_ground.material.copied and cache.builds == 0  # the first frame: shaded
        # (its render settles the camera's aspect: the second frame may still be a change)
        frames = [a.render() for _ in range(2)]
        assert a.sky_ground.material.copied and cache.builds == 1  # still: shaded once more into the copy
        second = frames[-1]
        assert np.array_equal(first, second)
        a.step(8)
        b.step(8)
        moved = a.render()  # the grass moved, the sky did not: copied, not built again
        assert a.sky_ground.material.copied and cache.builds == 1
        shaded = b.render()  # the same state, its first frame: shaded
        assert not b.sky_ground.material.copied
        assert not np.array_equal(moved, second)  # the grass did move
        assert np.array_equal(moved, shaded)
        save_test_picture("sky_ground_copied", moved)
        # the camera turns: shaded again; still again: a new copy
        a.camera.local.position = a.camera.local.position + np.array([0.3, 0.0, 0.0])
        b.camera.local.position = b.camera.local.position + np.array([0.3, 0.0, 0.0])
        turned = a.render()
        assert not a.sky_ground.material.copied and cache.builds == 1
        assert np.array_equal(turned, b.render())
        still = a.render()
        assert a.sky_ground.material.copied and cache.builds == 2 and np.array_equal(still, turned)
        # a sky/ground value: shaded again, then copied in its new colours
        a.params.fog_density = b.params.fog_density = 0.05
        fogged = a.render()
        assert not a.sky_ground.material.copied
        assert np.array_equal(fogged, b.render()) and not np.array_equal(fogged, still)
        again = a.render()
        assert a.sky_ground.material.copied and cache.builds == 3 and np.array_equal(again, fogged)
        # another size (another renderer): a new texture, the same pictures
        pictures = []
        for scene in (a, b):
            canvas = RenderCanvas(size=(80, 48), pixel_ratio=1)
            renderer = make_renderer(canvas)
            canvas.request_draw(lambda scene=scene, renderer=renderer: scene.draw_into(renderer))
            frames = [np.asarray(canvas.draw()) for _ in range(3 if scene is a else 1)]
            pictures.append(frames[-1])
            canvas.close()
        assert cache.builds == 4 and pictures[0].shape[:2] == (48, 80)
        assert np.array_equal(pictures[0], pictures[1])
        # an export (supersampled, pixel ratio 2) shades its sky and ground, however still
        exports = [a.render_at(), a.render_at()]
        assert not a.sky_ground.material.copied and cache.builds == 4
        assert np.array_equal(exports[0], exports[1])
    finally:
        a.release()
        b.release()

