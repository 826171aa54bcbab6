"""Real renders: non-blank, grass-coloured, wind visible, deterministic, PNG export."""

import numpy as np
import pytest

import grasswidget as gw

from conftest import grass_mask, hue_degrees, save_test_picture, shaded_grass_mask, sky_mask


# Fixtures blades and scene (conftest).
BLADES = dict(count=4096, seed=11)
SCENE = dict(size=(200, 150))


@pytest.mark.parametrize("shadows", [False, True])
def test_render_shape_and_grass(scene, shadows):
    """With the sunlight off (a CPU adapter's default) and on (a GPU's): the grass is counted by its
    hue, so that the roots in the grass' own shade count (conftest.shaded_grass_mask)."""
    scene.field.reset()
    default = scene.params.shadows
    scene.params.shadows = shadows
    try:
        img = scene.render()
    finally:
        scene.params.shadows = default
    assert img.shape == (150, 200, 4) and img.dtype == np.uint8
    save_test_picture(f"renders_default_view_shadows_{shadows}", img)
    grass = shaded_grass_mask(img)
    # the field fills the lower part of the default view; the sky the top
    assert grass[90:].mean() > 0.6
    assert sky_mask(img)[:10].mean() > 0.9
    assert grass[:10].mean() < 0.05


def test_render_does_not_advance_time(scene):
    scene.field.reset()
    scene.step(30)
    before = scene.field.read_state()
    a = scene.render()
    b = scene.render()
    after = scene.field.read_state()
    assert np.array_equal(a, b)
    assert np.array_equal(before["v2"], after["v2"])
    assert scene.field.step_count == 30


def test_wind_changes_the_picture(scene):
    p = scene.params
    scene.field.reset()
    p.wind_strength = 0
    scene.step(120)
    calm = scene.render()
    scene.field.reset()
    p.wind_strength = 80
    try:
        scene.step(120)
        windy = scene.render()
    finally:
        p.wind_strength = 5
    changed = np.any(calm[..., :3] != windy[..., :3], axis=-1).mean()
    assert changed > 0.2


def test_save_png_any_size(scene, tmp_path):
    import imageio.v3 as iio

    for size in [None, (320, 200), "123x77"]:
        path = scene.save_png(tmp_path / "shot.png", size=size)
        with open(path, "rb") as f:
            assert f.read(8) == b"\x89PNG\r\n\x1a\n"
        img = iio.imread(path)
        w, h = (200, 150) if size is None else ((320, 200) if size == (320, 200) else (123, 77))
        assert img.shape[:2] == (h, w)
        assert grass_mask(img).mean() > 0.2
    with pytest.raises(ValueError, match="size"):
        scene.save_png(tmp_path / "bad.png", size=(0, 10))


@pytest.mark.parametrize("shadows", [False, True])
def test_sky_and_ground_in_one_pass(shadows):
    """The backdrop: the sky paler at the horizon and bluer above it; below it the ground:
    brown soil under the field (the cis565 camera looks at it from 1 m up), the far grass past its
    edge, sky
    everywhere when the ground is switched off; the grass covers it. With the sunlight off (a CPU
    adapter's default) and on (a GPU's, where the grass' shade darkens the soil and the roots to
    20-30 levels: brown and grass are told by their hue, not by a lead of 8 levels)."""
    s = gw.GrassScene.preset("cis565", blades=2048)
    s.params.shadows = shadows
    s.field.visible = False
    img = s.render()[..., :3].astype(int)
    ground = img[400:450].reshape(-1, 3)
    hue = hue_degrees(img[400:450].astype(np.uint8)).reshape(-1)
    # soil: brown (red leads, blue last; hue 15..60 degrees: lit soil (48, 40, 27) is 36, shaded (28, 24, 17) 40;
    # grass is over 68)
    assert np.all(ground[:, 0] >= ground[:, 1]) and np.all(ground[:, 1] > ground[:, 2]) and np.all((hue > 15) & (hue < 60))
    assert ground.mean(0).max() < 90  # dark under 2048 blades
    # the bottom rows see the ground just past the field's edge (the camera stands 2.5 m outside it): the grass
    # seen from afar, green (hue over 60; the khaki plain of before was 56)
    beyond = hue_degrees(img[472:].astype(np.uint8))
    assert np.all(beyond > 60) and np.all(img[472:, :, 1] > img[472:, :, 2] + 15)
    top, mid = img[0].mean(0), img[200].mean(0)
    assert sky_mask(img[:150]).mean() > 0.99 and top[0] < mid[0]  # bluer towards the zenith, paler at the horizon
    s.ground.visible = False
    img2 = s.render()[..., :3]
    assert sky_mask(img2[400:]).mean() > 0.99
    s.ground.visible = True
    s.field.visible = True
    img3 = s.render()
    save_test_picture(f"renders_cis565_backdrop_shadows_{shadows}", np.concatenate([img.astype(np.uint8), img3[..., :3]], axis=1))
    assert shaded_grass_mask(img3[250:460]).mean() > 0.5  # drawn after the grass, only where nothing is
