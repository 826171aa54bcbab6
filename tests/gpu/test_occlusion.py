"""Occlusion culling: the GPU against the NumPy reference blade for blade, and the
picture with it against the picture without it (still and moving cameras, wind, a
ball, a view from above, both presets)."""

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.core import reference as ref
from grasswidget.core import teaching
from conftest import grass_mask, save_test_picture, shaded_grass_mask

SCENE = dict(preset="cis565", blades=6000, size=(160, 120), seed=3)


def _view_proj(scene):
    cam = scene.camera
    return np.asarray(cam.projection_matrix, np.float64) @ np.asarray(cam.view_matrix, np.float64)


def _on_off(scene):
    """(picture with occlusion culling, picture without, blades drawn with, without):
    the same state and camera; the off render leaves the seen flags alone."""
    p = scene.params
    p.cull_occlusion = True
    on = scene.render()
    drawn_on = scene.visible_count()
    p.cull_occlusion = False
    off = scene.render()
    drawn_off = scene.visible_count()
    p.cull_occlusion = True
    return on, off, drawn_on, drawn_off


def _differing(a, b, tol=24):
    """Share of pixels whose colour differs by more than ``tol`` (of 255) in any channel."""
    return float((np.abs(a[..., :3].astype(int) - b[..., :3].astype(int)).max(axis=2) > tol).mean())


def test_curve_pieces_cover_the_curve():
    rng = np.random.default_rng(0)
    v0, v1, v2 = rng.normal(size=(3, 5, 3))
    pieces = ref.curve_pieces(v0, v1, v2, 4)
    assert np.allclose(pieces[0][0], v0) and np.allclose(pieces[-1][2], v2)
    for k, (p0, p1, p2) in enumerate(pieces):
        for t in np.linspace(0, 1, 7):  # the piece's own curve is the blade's on its span of t
            u = (k + t) / 4
            blade = (1 - u) ** 2 * v0 + 2 * u * (1 - u) * v1 + u * u * v2
            assert np.allclose((1 - t) ** 2 * p0 + 2 * t * (1 - t) * p1 + t * t * p2, blade)


def test_hzb_layout_and_pyramid_reference():
    layout = ref.hzb_layout(37, 10)
    assert layout[0] == (0, 37, 10, 64)  # level 0: rows every 64 texels (256 bytes)
    assert [lv[1:3] for lv in layout] == [(37, 10), (19, 5), (10, 3), (5, 2), (3, 1), (2, 1), (1, 1)]
    assert layout[1][0] == 640 and all(a[0] + a[1] * a[2] == b[0] for a, b in zip(layout[1:], layout[2:]))
    depth = np.random.default_rng(1).random((10, 37)).astype(np.float32)
    levels = ref.build_hzb(depth)
    assert [lv.shape for lv in levels] == [(h, w) for _, w, h, _ in layout]
    assert levels[1][4, 18] == depth[8:10, 36:38].max() and levels[-1][0, 0] == depth.max()
    # the farthest depth over a rect, read at the finest level where it spans <= HZB_SPAN_TEXELS + 1 texels
    assert ref.HZB_SPAN_TEXELS == 4
    rect = np.array([[3.2, 1.5, 9.9, 6.0]])
    assert ref.hzb_level(rect)[0] == 1  # 6.7 px wide: 4 x 2^1 >= 7 > 4 x 2^0
    assert ref.hzb_level(np.array([[0.0, 0.0, 4.0, 4.0], [0.0, 0.0, 4.0, 33.0], [0.0, 0.0, 0.2, 0.1]])).tolist() == [0, 4, 0]
    assert ref.hzb_max(levels, rect, 1)[0] >= depth[1:7, 3:10].max()
    # read at that level it covers the rect's pixels and at most 5 x 5 texels
    lv = int(ref.hzb_level(rect)[0])
    assert ((9 >> lv) - (3 >> lv) + 1) * ((6 >> lv) - (1 >> lv) + 1) <= (ref.HZB_SPAN_TEXELS + 1) ** 2
    with pytest.raises(ValueError, match="1 x 1"):
        ref.hzb_layout(0, 5)


def test_gpu_occlusion_matches_numpy_blade_for_blade(scene):
    """Still camera, two frames: the GPU's seen flags are reference.cull (the other
    tests) and not reference.occlusion_cull against the depth the GPU tested with;
    the GPU's pyramid is reference.build_hzb of its depth."""
    p = scene.params
    p.cull_occlusion = True
    scene.render()
    scene.render()
    state = scene.field.read_state()
    vp = _view_proj(scene)
    levels = scene.field.occlusion.read_hzb()
    depth = levels[0]
    assert depth.shape == (120, 160) and depth.min() < 0.99 and depth.max() == 1.0  # grass, sky
    for got, want in zip(levels, ref.build_hzb(depth)):
        assert np.array_equal(got, want)
    kept = ref.cull(state, p, vp, np.asarray(scene.camera.world.position, np.float64))
    hidden = ref.occlusion_cull(state, vp, depth)
    seen = scene.field.read_seen()
    # Blades whose nearest depth is within float32 noise of the pyramid's are left out.
    radius = ref.OCCLUSION_RADIUS_PER_WIDTH * state["width"]
    close = np.zeros(len(radius), bool)
    for piece in ref.curve_pieces(state["v0"], state["v1"], state["v2"]):
        rect, near = ref.occlusion_bounds(*piece, radius, vp, (160, 120))
        close |= np.abs(near - ref.hzb_max(levels, rect, ref.hzb_level(rect))) < 1e-5
    expected = kept & ~hidden
    assert kept.sum() > 1500 and (kept & hidden).sum() > 0.3 * kept.sum()  # the near grass hides much
    mismatch = (seen != expected) & ~close
    assert mismatch.sum() == 0, np.flatnonzero(mismatch)[:10]
    assert close.sum() < 0.01 * len(close)
    # the second frame drew exactly the blades seen in the first, and counted the hidden ones
    assert scene.visible_count() == seen.sum()
    assert abs(scene.field.read_occluded_count() - (kept & hidden).sum()) <= close.sum()
    assert np.array_equal(scene.field.read_visible(), np.flatnonzero(seen))


@pytest.mark.parametrize("shadows", [False, True])
def test_still_camera_picture_is_the_unculled_one(scene, shadows):
    """With the sunlight off (a CPU adapter's default) and on (a GPU's): the grass is counted by its
    hue, so that the roots in the grass' own shade count (conftest.shaded_grass_mask)."""
    scene.field.reset()  # the blades at rest, whatever the tests before did (wind bends them over: less hidden)
    scene.reset_camera()
    default = scene.params.shadows
    scene.params.shadows = shadows
    try:
        for _ in range(2):
            on, off, drawn_on, drawn_off = _on_off(scene)
            assert _differing(on, off) <= 0.001
    finally:
        scene.params.shadows = default
    save_test_picture(f"occlusion_still_shadows_{shadows}", np.concatenate([on, off], axis=1))
    assert drawn_on < 0.7 * drawn_off  # ... with far fewer blades drawn
    assert shaded_grass_mask(on).mean() > 0.5


def test_moving_camera_wind_and_ball_keep_the_picture(scene):
    """Each frame the camera moves on (frames apart: what was seen last frame is no
    longer what is seen), the wind blows and a ball rolls through the grass in front
    of the camera; the first phase draws last frame's set, the second finds the rest."""
    scene.reset_camera()
    scene.params.wind_strength = 12.0
    ball = gw.SphereCollider((0.0, 0.6, 6.0), 0.7)
    scene.colliders = [ball]
    try:
        worst = 0.0
        for k in range(6):
            scene.camera.local.position = (1.2 * k - 3.0, 1.0 + 0.3 * k, 10.0 - 0.8 * k)
            scene.camera.look_at((0.5 * k, 0.8, 0.0))
            ball.center = (-1.0 + 0.4 * k, 0.6, 6.0 - 0.5 * k)
            scene.step(4)
            on, off, drawn_on, drawn_off = _on_off(scene)
            worst = max(worst, _differing(on, off))
            assert drawn_on <= drawn_off
        assert worst <= 0.002, worst
    finally:
        scene.colliders = []
        scene.params.wind_strength = gw.GrassParams().wind_strength
        scene.reset_camera()


def test_ball_in_front_of_the_camera_is_drawn_over_the_second_phase(scene):
    """A translucent ball right in front of the camera after a jump of the camera: the
    blades behind it that the second phase adds are blended under the ball, as without
    occlusion culling."""
    scene.reset_camera()
    scene.render()
    scene.camera.local.position = (-4.0, 1.5, 8.0)  # a jump: many blades are new
    scene.camera.look_at((0.0, 0.8, 0.0))
    scene.colliders = [gw.SphereCollider((-3.2, 1.2, 6.8), 0.6)]
    try:
        on, off, _, _ = _on_off(scene)
        assert _differing(on, off) <= 0.002
        scene.show_colliders = False
        no_ball = scene.render()
        scene.show_colliders = True
        assert _differing(on, no_ball) > 0.05  # the ball covers a good part of the view
    finally:
        scene.colliders = []
        scene.reset_camera()


def test_view_from_above_hides_little(scene):
    scene.camera.local.position = (0.0, 30.0, 0.01)
    scene.camera.look_at((0.0, 0.0, 0.0))
    try:
        scene.render()
        on, off, drawn_on, drawn_off = _on_off(scene)
        assert _differing(on, off) <= 0.001
        assert drawn_on > 0.9 * drawn_off  # little to hide from above
    finally:
        scene.reset_camera()


def test_meadow_preset_picture_is_the_unculled_one():
    sc = gw.GrassScene.preset("meadow", blades=1 << 14, size=(192, 108), seed=2,
                              horizon=False)  # the dense square meadow (not the sparser field to the horizon)
    try:
        sc.params.cull_occlusion = True  # forced (not "auto"): the frame before _on_off's culls too
        sc.render()
        on, off, drawn_on, drawn_off = _on_off(sc)
        assert _differing(on, off) <= 0.001
        assert drawn_on < drawn_off
        sc.camera.local.position = np.asarray(sc.camera.local.position) + (1.0, 0.5, -1.0)
        sc.step(3)
        on, off, _, _ = _on_off(sc)
        assert _differing(on, off) <= 0.002
    finally:
        sc.release()


def test_plain_render_draws_without_occlusion(scene):
    """A pygfx renderer.render() of the scene never arms the first phase: every blade
    the other tests keep is drawn (occlusion culling needs render_frame)."""
    scene.reset_camera()
    scene.params.cull_occlusion = True
    scene.render()
    state = scene.field.read_state()
    kept = ref.cull(state, scene.params, _view_proj(scene), np.asarray(scene.camera.world.position, np.float64))
    scene.canvas.request_draw(lambda: scene.renderer.render(scene.scene, scene.camera))
    try:
        scene.canvas.draw()
        assert abs(scene.visible_count() - kept.sum()) <= 3
    finally:
        scene.canvas.request_draw(scene.draw_frame)


def test_frozen_culling_freezes_occlusion_and_colours_it(scene, tmp_path):
    """Freeze at the course view, fly above: the blades the frozen view hides are
    culled (cyan with color_by "cull"), the same ones whatever the camera."""
    import imageio.v3 as iio

    p = scene.params
    occlusion = p.cull_occlusion
    p.cull_occlusion = True  # the preset's "auto" may decide it off at this size: this test is about it on
    scene.field.reset()  # blades at rest (earlier tests' wind bends them over: less to hide)
    scene.reset_camera()
    scene.freeze_culling()
    try:
        p.color_by = "cull"
        scene.camera.local.position = (0.0, 22.0, 9.0)
        scene.camera.look_at((0.0, 0.0, 0.0))
        img = scene.render()
        iio.imwrite(tmp_path / "occlusion_birdseye.png", img)
        seen = scene.field.read_seen()
        frozen = scene.field.frozen_camera
        state = scene.field.read_state()
        kept = ref.cull(state, p, frozen.view_proj, frozen.position)
        occluded = kept & ~seen
        assert occluded.sum() > 0.3 * kept.sum()  # the near grass hides much of the far grass
        assert scene.field.read_occluded_count() == occluded.sum()
        assert scene.visible_count() == (kept & seen).sum()
        # the occluded blades show cyan, seen from above
        cyan = np.array(teaching.hex_to_rgb(gw.CULL_COLORS["occlusion"]))
        mid = 0.25 * state["v0"] + 0.5 * state["v1"] + 0.25 * state["v2"]
        clip = np.concatenate([mid, np.ones((len(mid), 1))], 1) @ _view_proj(scene).T
        ndc = clip[:, :2] / clip[:, 3:4]
        col = np.clip(((ndc[:, 0] + 1) / 2 * 160).astype(int), 0, 159)
        row = np.clip(((1 - ndc[:, 1]) / 2 * 120).astype(int), 0, 119)
        is_cyan = np.abs(img[row, col, :3].astype(int) - cyan).max(axis=1) <= 3
        assert is_cyan[occluded].mean() > 0.5 and is_cyan[kept & seen].mean() < 0.1
        # another camera: the same blades
        scene.camera.local.position = (8.0, 6.0, 8.0)
        scene.camera.look_at((0.0, 0.0, 0.0))
        scene.render()
        assert np.array_equal(scene.field.read_seen(), seen)
    finally:
        scene.unfreeze_culling()
        p.color_by = "natural"
        p.cull_occlusion = occlusion
        scene.reset_camera()


def test_stats_count_the_occluded_blades(scene):
    from grasswidget.notebook.panel import format_details
    from grasswidget.notebook.switch_choice import SWITCH_CHOICES

    scene.params.cull_occlusion = True  # forced on (the default "auto" may decide either way)
    scene.field.reset()
    scene.reset_camera()
    for _ in range(4):
        scene.render()
    stats = scene.stats
    for _ in range(50):  # the non-blocking stats land a frame or two later
        stats.poll()
        if stats.occluded == scene.field.read_occluded_count():
            break
        scene.render()
    assert stats.occluded == scene.field.read_occluded_count() > 500
    assert stats.visible == scene.visible_count()
    line = format_details(dict(visible=stats.visible, blades=6000, occluded=stats.occluded))
    assert f"{stats.occluded:,} occluded" in line
    assert ("occlusion culling", "cull_occlusion") in SWITCH_CHOICES  # the panel's auto / on / off choice
