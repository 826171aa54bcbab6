"""The meadow's looks in real renders: fog, soil, colour patches, anti-aliased exports.

Each test renders small pictures on the adapter at hand (lavapipe here) and measures
pixels: the fog softens the horizon band and leaves the sky alone; the soil under a
dense field is darker than under a sparse one; blade colours vary in patches that
follow the reference's clump noise; exports are closer to a 4 x 4 supersample than
the live view's plain render.
"""

import numpy as np

import grasswidget as gw
from grasswidget.core import reference as ref
from conftest import assert_same_picture

W, H = 200, 150


def _scene(n=4096, **params):
    return gw.GrassScene(gw.Blades.on_plane(n, seed=5), size=(W, H), params=gw.GrassParams(**params))


def _project(scene, points):
    """Pixel (x, y) of world points (N, 3) in a (W, H) picture of the scene's camera."""
    cam = scene.camera
    m = np.asarray(cam.projection_matrix, np.float64) @ np.asarray(cam.view_matrix, np.float64)
    p = np.c_[np.asarray(points, np.float64), np.ones(len(points))] @ m.T
    ndc = p[:, :2] / p[:, 3:4]
    return np.c_[(ndc[:, 0] + 1) / 2 * W, (1 - ndc[:, 1]) / 2 * H]


def test_fog_softens_the_horizon_and_leaves_the_sky():
    scene = _scene(fog_density=0.0)  # the default view: the field, the ground beyond it, the horizon, the sky
    clear = scene.render_at((W, H), antialias=False)[..., :3].astype(float)
    scene.params.fog_density = 0.05
    foggy = scene.render_at((W, H), antialias=False)[..., :3].astype(float)
    horizon = np.array(scene.sky_ground.material.horizon_color.rgb[:3]) * 255
    # the horizon row: the highest ground, i.e. the first row where the sky stops
    sky_rows = np.flatnonzero((np.abs(clear - horizon).sum(-1) < 80).mean(1) > 0.9)
    top = int(sky_rows.max()) + 1 if sky_rows.size else H // 2
    band = slice(top, min(H, top + 25))
    d_clear = np.abs(clear[band] - horizon).sum(-1).mean()
    d_foggy = np.abs(foggy[band] - horizon).sum(-1).mean()
    assert d_foggy < 0.6 * d_clear, (d_clear, d_foggy)  # far ground and grass fade into the sky's colour
    # softer: smaller jumps from row to row across the band
    jump = lambda img: np.abs(np.diff(img[max(0, top - 5):top + 25].mean(1), axis=0)).sum(-1).max()  # noqa: E731
    assert jump(foggy) < jump(clear)
    assert np.array_equal(clear[: max(1, top - 5)], foggy[: max(1, top - 5)])  # the sky itself has no fog


def test_soil_is_darker_under_dense_grass():
    colours = []
    for n in (100, 20000):
        scene = _scene(n, fog_density=0.0)
        scene.field.visible = False  # the soil the grass stands on, seen without the grass
        img = scene.render_at((W, H), antialias=False)[..., :3].astype(float)
        (cx, cy), = _project(scene, [(0.0, 0.0, 2.0)])  # inside the 10 m field
        (fx, fy), = _project(scene, [(0.0, 0.0, -12.0)])  # beyond it
        colours.append((img[int(cy) - 3:int(cy) + 3, int(cx) - 3:int(cx) + 3].mean((0, 1)),
                        img[int(fy) - 2:int(fy) + 2, int(fx) - 2:int(fx) + 2].mean((0, 1))))
    (sparse_in, sparse_out), (dense_in, dense_out) = colours
    assert dense_in.sum() < 0.75 * sparse_in.sum(), (sparse_in, dense_in)
    assert np.abs(dense_out - sparse_out).max() <= 2  # the ground beyond the field does not care
    assert sparse_in[0] > sparse_in[2] and dense_in[0] > dense_in[2]  # brown soil (red over blue)
    assert dense_in.sum() < dense_out.sum()  # darker under the grass than beyond


def test_blade_colours_vary_in_patches_that_follow_the_clump_noise():
    blocks = np.linspace(-4.0, 4.0, 9)
    means = {}
    for variation in (0.0, 1.0):
        scene = _scene(40000, color_variation=variation, dryness=0.0, translucency=0.0, fog_density=0.0,
                       patch_size=2.0, wind_strength=0.0)
        scene.look(position=(0.0, 14.0, 0.5), target=(0.0, 0.0, 0.0), fov_deg=45)  # from above
        img = scene.render_at((W, H), antialias=False)[..., :3].astype(float)
        xs, zs = np.meshgrid(blocks, blocks)
        pts = np.c_[xs.ravel(), np.full(xs.size, 0.5), zs.ravel()]
        px = _project(scene, pts)
        inside = (px[:, 0] > 4) & (px[:, 0] < W - 4) & (px[:, 1] > 4) & (px[:, 1] < H - 4)
        lum = np.array([img[int(y) - 3:int(y) + 3, int(x) - 3:int(x) + 3].mean() for x, y in px[inside]])
        means[variation] = (lum, pts[inside])
    flat, (lum, pts) = means[0.0][0], means[1.0]
    assert len(lum) >= 40
    assert lum.std() > 1.5 * flat.std(), (lum.std(), flat.std())  # colour varies over the field
    clump = ref.clump_noise(pts[:, 0], pts[:, 2], 2.0)[:, 0]
    r = np.corrcoef(lum, clump)[0, 1]
    assert r > 0.5, r  # ... in patches: brighter where the clump noise is higher


def test_exports_are_anti_aliased(tmp_path):
    import imageio.v3 as iio

    scene = _scene(8192)
    scene.step(60)
    w, h = 160, 90
    ref4 = scene.render_at((4 * w, 4 * h), antialias=False)[..., :3].astype(float)
    ref4 = ref4.reshape(h, 4, w, 4, 3).mean(axis=(1, 3))
    plain = scene.render_at((w, h), antialias=False)[..., :3].astype(float)
    export = scene.render_at((w, h))[..., :3].astype(float)
    d_plain, d_export = np.abs(plain - ref4).mean(), np.abs(export - ref4).mean()
    assert d_export < 0.65 * d_plain, (d_plain, d_export)
    assert d_export < 4.0
    path = scene.save_png(tmp_path / "aa.png", size=(w, h))
    assert_same_picture(iio.imread(path), export.astype(np.uint8), "save_png against the export")  # save_png is the export
