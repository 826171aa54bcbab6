"""Sunlight (GrassParams.shadows) in pixels of real renders (kernel engine, lavapipe on a CPU machine).

* A ball's shadow: the ground where the ball hides the sun is darker than the ground on the
  ball's other side, and the dark spot moves to the other side when the sun goes round.
* The grass' shadow: the ground just beyond the field's edge opposite the sun darkens with
  shadows on (more than the ground beyond the sunny edge, which only follows the sun's height).
* Darkened roots follow density: with shadows on, a denser field of the same blades darkens
  more than a sparse one.
* Shadows off is the picture without them (switching them on and off leaves nothing behind).
"""

from __future__ import annotations

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.core.engine_inputs import sunlight_values

SIZE = (160, 120)


def _luminance(img):
    rgb = np.asarray(img, np.float64)[..., :3]
    return rgb @ np.array([0.2126, 0.7152, 0.0722])


def _pixel(scene, point):
    """(column, row) of world ``point`` in the scene's picture."""
    m = np.asarray(scene.camera.camera_matrix, np.float64)  # pygfx: projection @ view
    clip = m @ np.array([*point, 1.0])
    ndc = clip[:3] / clip[3]
    w, h = scene.size
    return int(round((ndc[0] * 0.5 + 0.5) * w - 0.5)), int(round((0.5 - 0.5 * ndc[1]) * h - 0.5))


def _patch(lum, xy, r=3):
    x, y = xy
    return float(lum[y - r: y + r + 1, x - r: x + r + 1].mean())


@pytest.fixture(scope="module")
def ball_scene():
    # A small field at the origin; the ball on the bare ground 8 m away, seen from straight above.
    scene = gw.GrassScene(gw.Blades.on_plane(256, size=4.0, seed=1), size=SIZE,
                          params=gw.GrassParams(shadows=True, fog_density=0.0))
    scene.show_colliders = False  # the ball's own (translucent) drawing would cover its shadow
    scene.colliders = [gw.SphereCollider(center=(8.0, 0.5, 0.0), radius=0.5)]
    scene.look(position=(8.0, 6.0, 0.01), target=(8.0, 0.0, 0.0), fov_deg=40.0)
    yield scene
    scene.release()


@pytest.mark.parametrize("azimuth", [0.0, 180.0])
def test_a_balls_shadow_lies_opposite_the_sun(ball_scene, azimuth):
    """Sun 45 degrees high: the ball (r 0.5 m, resting on the ground) hides the sun from the
    ground around 0.5 m from its foot away from the sun; the same distance towards the sun is lit.
    Turning the sun round (azimuth 0 -> 180) moves the dark spot to the other side."""
    scene = ball_scene
    scene.params.sun_elevation = 45.0
    scene.params.sun_azimuth = azimuth
    lum = _luminance(scene.render())
    towards = np.array([np.cos(np.radians(azimuth)), 0.0, np.sin(np.radians(azimuth))])
    foot = np.array([8.0, 0.0, 0.0])
    shadow = _patch(lum, _pixel(scene, foot - 0.55 * towards))
    sunny = _patch(lum, _pixel(scene, foot + 0.55 * towards))
    print(f"\n[ball shadow] sun azimuth {azimuth:g}: ground in the shadow {shadow:.1f}, "
          f"on the sunny side {sunny:.1f} (luminance 0..255)")
    assert shadow < 0.75 * sunny
    # the shadow is the sun's only: the sky still lights it (not black)
    assert shadow > 0.2 * sunny


def test_shadows_off_is_the_picture_without_them(ball_scene):
    scene = ball_scene
    scene.params.shadows = False
    before = scene.render()
    scene.params.shadows = True
    with_shadows = scene.render()
    scene.params.shadows = False
    after = scene.render()
    scene.params.shadows = True
    assert np.abs(with_shadows.astype(int) - before.astype(int)).max() > 30  # the switch does something
    assert np.array_equal(before, after)


def _field_scene(blades, **params):
    scene = gw.GrassScene(blades, size=SIZE, params=gw.GrassParams(fog_density=0.0, **params))
    return scene


def test_the_grass_shades_the_ground_beyond_its_edge_opposite_the_sun():
    """A low sun (20 degrees) towards +x: beyond the field's -x edge the blades' shadow falls on the
    ground (a band about the grass height / tan 20 deg = 2.7 x the height wide); beyond the +x edge
    the ground is lit (shadows on changes it only by the sun's height, as everywhere)."""
    blades = gw.Blades.on_plane(2048, size=6.0, seed=2, height=(0.5, 0.8), width=(0.02, 0.03))
    scene = _field_scene(blades, sun_elevation=20.0, sun_azimuth=0.0)
    scene.look(position=(0.0, 14.0, 0.01), target=(0.0, 0.0, 0.0), fov_deg=50.0)
    ratios = {}
    try:
        pictures = {}
        for on in (False, True):
            scene.params.shadows = on
            pictures[on] = _luminance(scene.render())
        for side, x in (("shadow side", -3.0 - 0.45), ("sun side", 3.0 + 0.45)):
            xy = _pixel(scene, (x, 0.0, 0.0))
            ratios[side] = _patch(pictures[True], xy, 2) / _patch(pictures[False], xy, 2)
    finally:
        scene.release()
    print(f"\n[grass shadow] ground beyond the edge, shadows on / off: {ratios}")
    assert ratios["shadow side"] < 0.8 * ratios["sun side"]


def test_darkened_roots_follow_the_density():
    """The same 1024 blades on a 3 m and on a 6 m square (4x the density on the first), seen from
    the side at the same distance: shadows on / off darkens the grass of the dense field more."""
    ratios = {}
    for side in (3.0, 6.0):
        blades = gw.Blades.on_plane(1024, size=side, seed=3, height=(0.6, 0.9), width=(0.02, 0.03))
        scene = _field_scene(blades)
        scene.look(position=(0.0, 1.2, side / 2 + 2.5), target=(0.0, 0.3, 0.0), fov_deg=40.0)
        try:
            pictures = {}
            for on in (False, True):
                scene.params.shadows = on
                pictures[on] = np.asarray(scene.render(), np.float64)[..., :3]
        finally:
            scene.release()
        r, g, b = (pictures[False][..., k] for k in range(3))
        grass = (g > r + 8) & (g > b + 8)
        assert grass.mean() > 0.2
        ratios[side] = float(_luminance(pictures[True])[grass].mean() / _luminance(pictures[False])[grass].mean())
    print(f"\n[root darkening] grass luminance shadows on / off: dense {ratios[3.0]:.3f}, sparse {ratios[6.0]:.3f}")
    assert ratios[3.0] < ratios[6.0] - 0.03
    assert ratios[6.0] < 1.0


def test_the_first_balls_cast_shadows_into_both_materials():
    """The values both engines write: the first four colliders, the others none; the params' sun."""
    params = gw.GrassParams(shadows=True, sun_elevation=30.0, sun_azimuth=90.0)
    balls = [gw.SphereCollider(center=(k, 1.0, 0.0), radius=0.5) for k in range(6)]
    values = sunlight_values(params, gw.Blades.on_plane(64, size=2.0), balls)
    assert values["shadows"] == 1.0
    np.testing.assert_allclose(values["shadow_balls"][:, 0], [0, 1, 2, 3])
    np.testing.assert_allclose(values["light_direction"][:3], [0.0, 0.5, np.sqrt(3) / 2], atol=1e-12)


def test_compute_rasterized_blades_get_the_same_sunlight():
    """Blades drawn by the compute rasterizer (its resolve shades them) are lit as the ribbons are:
    with nearly every blade in compute (max 16 px), the shadows change the picture as much as they
    change the all-hardware one, and the two rasterizers stay as close with shadows as without."""
    blades = gw.Blades.on_plane(2048, size=6.0, seed=4, height=(0.5, 0.8), width=(0.02, 0.03))
    scene = _field_scene(blades, sun_elevation=30.0, compute_raster_max_px=16.0)
    scene.look(position=(0.0, 5.0, 9.0), target=(0.0, 0.0, 0.0), fov_deg=40.0)
    pictures, rastered = {}, 0
    try:
        for raster in (False, True):
            scene.params.compute_raster = raster
            for on in (False, True):
                scene.params.shadows = on
                pictures[raster, on] = scene.render()[..., :3].astype(int)
                if raster:
                    rastered = scene.field.read_raster_count()
    finally:
        scene.release()
    assert rastered > 1000

    def mean_diff(a, b):
        return float(np.abs(pictures[a] - pictures[b]).mean())

    apart_off, apart_on = mean_diff((True, False), (False, False)), mean_diff((True, True), (False, True))
    effect_hw, effect_cr = mean_diff((False, True), (False, False)), mean_diff((True, True), (True, False))
    print(f"\n[compute raster] {rastered} blades in compute: |compute - hardware| {apart_off:.2f}/255 without "
          f"shadows, {apart_on:.2f}/255 with; shadows change the hardware picture by {effect_hw:.2f}/255, "
          f"the compute one by {effect_cr:.2f}/255")
    assert effect_hw > 10.0
    assert abs(effect_cr - effect_hw) < 0.15 * effect_hw
    assert apart_on < apart_off + 1.0
