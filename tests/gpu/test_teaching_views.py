"""Teaching views on the GPU: frozen culling camera, colour by cull test / LOD
class, checked against the NumPy reference in real renders."""

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.core import reference as ref
from grasswidget.core import teaching
from conftest import assert_same_picture, grass_mask

SIZE = (400, 300)


# Fixtures blades and scene (conftest): 1500 tall blades on 15 x 15 m (quad ribbons:
# full width at their middle).
BLADES = dict(count=1500, size=15.0, seed=7, height=(1.3, 2.5), width=(0.1, 0.14))
# Occlusion off: these tests compare with reference.cull_reason (three tests); test_occlusion.py covers it.
SCENE = dict(size=SIZE, params=dict(blade_shape="quad", cull_distance_max=25.0, cull_buckets=10, cull_occlusion=False))


@pytest.fixture(autouse=True)
def exact_colours(scene):
    """These tests read the flat teaching colours pixel by pixel: no post-process
    anti-aliasing (pygfx's default on a GPU), which blends the edges of thin blades."""
    before = scene.renderer.ppaa
    scene.renderer.ppaa = "none"
    yield
    scene.renderer.ppaa = before


@pytest.fixture
def frozen(scene):
    """The scene's field culling against a camera at (0, 1, 10) looking at (4, 1, 0)."""
    scene.field.reset()
    scene.camera.local.position = (0, 1, 10)
    scene.camera.look_at((4, 1, 0))
    scene.field.freeze_culling(scene.camera, scene.size)
    yield scene.field.frozen_camera
    scene.field.unfreeze_culling()
    scene.params.color_by = "natural"
    scene.reset_camera()


def _view(scene, position, target=(0, 0, 0)):
    scene.camera.local.position = position
    scene.camera.look_at(target)


def _pixels_of(scene, points):
    """Pixel (column, row) of world points in the scene's last render, and which are inside."""
    cam = scene.camera
    vp = np.asarray(cam.projection_matrix, np.float64) @ np.asarray(cam.world.inverse_matrix, np.float64)
    c = np.c_[points, np.ones(len(points))] @ vp.T
    ndc = c[:, :2] / c[:, 3:]
    w, h = scene.size
    col = np.floor((ndc[:, 0] + 1) / 2 * w).astype(int)
    row = np.floor((1 - ndc[:, 1]) / 2 * h).astype(int)
    inside = (col >= 0) & (col < w) & (row >= 0) & (row < h) & (c[:, 3] > 0)
    return col.clip(0, w - 1), row.clip(0, h - 1), inside


def _colour_index(rgb, palette):
    """Index + 1 of the palette colour each pixel shows exactly (+-3), 0 for none."""
    out = np.zeros(len(rgb), int)
    for k, color in enumerate(palette):
        out[np.abs(rgb.astype(int) - teaching.hex_to_rgb(color)).max(axis=1) <= 3] = k + 1
    return out


def _confusion(expected, seen, n):
    """Row e: the share of blades of class e whose pixel shows class s."""
    conf = np.zeros((n, n))
    for e in range(n):
        sel = expected == e
        if sel.any():
            conf[e] = np.bincount(seen[sel], minlength=n)[:n] / sel.sum()
    return conf


def _blade_middles(state):
    return 0.25 * state["v0"] + 0.5 * state["v1"] + 0.25 * state["v2"]


def test_frozen_culling_keeps_the_same_blades_whatever_the_camera(scene, frozen):
    p = scene.params
    state = scene.field.read_state()
    expected = ref.cull(state, p, frozen.view_proj, frozen.position)
    assert 100 < expected.sum() < len(expected) - 100  # the frozen view culls some, keeps some
    kept = []
    for pos in [(0, 30, 0.01), (20, 5, -20), (-3, 2, 12), (0, 1, 10)]:
        _view(scene, pos)
        scene.render()
        kept.append(scene.field.read_visible())
        assert scene.visible_count() == len(kept[-1])
    for ids in kept[1:]:
        assert np.array_equal(ids, kept[0])
    drawn = np.zeros(len(expected), bool)
    drawn[kept[0]] = True
    assert (drawn != expected).sum() <= 2  # float32 vs float64 at a threshold
    assert scene.field.culling_frozen and scene.field.frustum_lines is not None

    scene.field.unfreeze_culling()
    assert not scene.field.culling_frozen and scene.field.frustum_lines is None
    counts = []
    for pos in [(0, 30, 0.01), (20, 5, -20)]:
        _view(scene, pos)
        scene.render()
        counts.append(scene.visible_count())
    assert counts[0] != counts[1] and len(kept[0]) not in counts


def test_frustum_lines_are_drawn_where_the_frozen_view_is(scene, frozen):
    _view(scene, (0, 30, 0.01))
    img = scene.render()
    white = np.all(img[..., :3] >= 250, axis=-1)
    seg = frozen.segments()
    # the frozen camera's position (the frustum's apex) is drawn white
    col, row, inside = _pixels_of(scene, frozen.position[None])
    assert inside[0] and white[row[0] - 2 : row[0] + 3, col[0] - 2 : col[0] + 3].any()
    # points along a side edge of the frustum, inside the picture, are white
    t = np.linspace(0.02, 0.2, 12)[:, None]
    edge = seg[20] + t * (seg[21] - seg[20])  # corner 2 (near, top left) to corner 6 (far): above the ground
    col, row, inside = _pixels_of(scene, edge)
    hits = [white[max(r - 1, 0) : r + 2, max(c - 1, 0) : c + 2].any() for c, r in zip(col[inside], row[inside])]
    assert len(hits) >= 4 and np.mean(hits) > 0.8
    scene.field.unfreeze_culling()
    assert np.all(scene.render()[..., :3] >= 250, axis=-1).sum() < white.sum() / 4


def test_cull_colours_are_where_the_reference_culls(scene, frozen, tmp_path):
    """Bird's-eye render of the frozen view's culling: every blade's middle shows the
    colour of the first test that culled it (reference.cull_reason), or grass."""
    p = scene.params
    p.color_by = "cull"
    _view(scene, (0, 30, 0.01))
    img = scene.render()
    import imageio.v3 as iio

    iio.imwrite(tmp_path / "cull_birdseye.png", img)
    state = scene.field.read_state()
    reason = ref.cull_reason(state, p, frozen.view_proj, frozen.position)
    assert np.all(np.bincount(reason, minlength=4) > 100)  # every test culls here
    assert scene.visible_count() == (reason == 0).sum()  # culled blades are drawn, not counted
    assert scene.field.read_draw_args()[:, 1].sum() == (reason == 0).sum()
    col, row, inside = _pixels_of(scene, _blade_middles(state))
    seen = _colour_index(img[row, col, :3], list(gw.CULL_COLORS.values()))
    conf = _confusion(reason[inside], seen[inside], 4)
    assert np.all(np.diag(conf) > 0.7), np.round(conf, 3)
    assert np.all(conf.argmax(axis=1) == np.arange(4)), np.round(conf, 3)
    assert conf[0, 1:].sum() < 0.05  # kept blades are not painted in cull colours
    assert grass_mask(img[row[inside & (reason == 0)], col[inside & (reason == 0)]][None]).mean() > 0.6
    # with color_by "natural", none of the cull colours shows
    p.color_by = "natural"
    img = scene.render()
    assert (_colour_index(img.reshape(-1, 4)[:, :3], list(gw.CULL_COLORS.values())) > 0).mean() < 0.002


def test_lod_colours_match_the_reference_classes(scene, frozen, tmp_path):
    p = scene.params
    p.color_by = "lod"
    _view(scene, (0, 30, 0.01))
    img = scene.render()
    import imageio.v3 as iio

    iio.imwrite(tmp_path / "lod_birdseye.png", img)
    state = scene.field.read_state()
    kept = ref.cull(state, p, frozen.view_proj, frozen.position)
    cls = ref.lod_class(state["v0"], state["v2"], state["height"], frozen.view_proj, frozen.viewport_size[1])
    counts = np.bincount(cls[kept], minlength=len(gw.LOD_COLORS))
    assert (counts >= 10).sum() >= 3, counts  # the frozen view spans several classes
    col, row, inside = _pixels_of(scene, _blade_middles(state))
    sel = inside & kept
    seen = _colour_index(img[row[sel], col[sel], :3], gw.LOD_COLORS) - 1  # -1: no LOD colour
    seen_ok = seen >= 0
    agree = (seen == cls[sel])[seen_ok]
    assert seen_ok.mean() > 0.8 and agree.mean() > 0.95, (seen_ok.mean(), agree.mean())
    # culled blades are not drawn in "lod": no LOD colour where only culled blades stand
    culled_only = inside & ~kept
    seen_c = _colour_index(img[row[culled_only], col[culled_only], :3], gw.LOD_COLORS)
    assert (seen_c > 0).mean() < 0.2


def test_cull_mode_in_the_rendering_camera_paints_edge_on_and_thinned_blades(scene):
    """Unfrozen: orientation- and distance-culled blades in front of the camera show."""
    p = scene.params
    scene.field.reset()
    scene.reset_camera()
    p.color_by = "cull"
    try:
        img = scene.render()
        seen = _colour_index(img.reshape(-1, 4)[:, :3], list(gw.CULL_COLORS.values()))
        shares = np.bincount(seen, minlength=4) / seen.size
        assert shares[1] > 0.005 and shares[3] > 0.005, shares  # orientation and distance
        assert shares[2] < 0.001  # frustum-culled blades are off screen
    finally:
        p.color_by = "natural"


def test_freeze_bad_viewport(scene):
    with pytest.raises(ValueError, match="viewport_size"):
        scene.field.freeze_culling(scene.camera, (0, 10))
    assert not scene.field.culling_frozen


def test_grass_field_freezes_in_any_pygfx_scene():
    """GrassField.freeze_culling on its own: a plain pygfx scene, two cameras."""
    import pygfx as gfx
    from rendercanvas.offscreen import RenderCanvas

    field = gw.GrassField(gw.Blades.on_plane(2000, 10.0, seed=2), gw.GrassParams(cull_distance_max=20.0))
    scene = gfx.Scene()
    scene.add(field)
    canvas = RenderCanvas(size=(200, 150), pixel_ratio=1)
    renderer = gfx.WgpuRenderer(canvas, pixel_ratio=1, ppaa="none")
    a = gfx.PerspectiveCamera(50, 4 / 3)
    a.local.position = (-4, 1.5, 8)
    a.look_at((2, 0, 0))
    b = gfx.PerspectiveCamera(50, 4 / 3)
    b.local.position = (0, 25, 0.01)
    b.look_at((0, 0, 0))
    field.freeze_culling(a, (200, 150))
    frozen = field.frozen_camera
    assert np.allclose(frozen.position, (-4, 1.5, 8))
    for cam in (b, a):
        canvas.request_draw(lambda cam=cam: renderer.render(scene, cam))
        canvas.draw()
        drawn = np.zeros(field.count, bool)
        drawn[field.read_visible()] = True
        expected = ref.cull(field.read_state(), field.params, frozen.view_proj, frozen.position)
        assert (drawn != expected).sum() <= 2 and 100 < drawn.sum() < field.count - 100
    field.unfreeze_culling()
    canvas.request_draw(lambda: renderer.render(scene, b))
    canvas.draw()
    assert abs(len(field.read_visible()) - drawn.sum()) > 100  # the bird's-eye camera culls otherwise
    canvas.close()
    field.release()


def test_flat_colours_are_compiled_in_only_while_shown(scene):
    """The natural view carries no flat-colour path (it costs GPU draw time): switching
    colour modes after a render rebuilds the ribbons, and back gives the same pixels."""
    scene.field.reset()
    scene.step(2)
    natural = scene.render().copy()
    assert scene.field.flat_colors is False
    scene.params.color_by = "lod"
    assert scene.field.flat_colors is True
    lod = scene.render().copy()
    lod_rgb = {tuple(int(c) for c in teaching.hex_to_rgb(h)) for h in teaching.LOD_COLORS}
    flat = np.array([tuple(p) in lod_rgb for p in lod[..., :3].reshape(-1, 3)])
    assert flat.mean() > 0.05  # blades now show their class colours
    scene.params.color_by = "natural"
    assert scene.field.flat_colors is False
    assert_same_picture(scene.render(), natural, "natural colours again")
