"""The meadow to the horizon in real renders (lavapipe here): from the preset's camera, a low
camera just above the grass (through a 12-degree lens, so that the band is more than 3 rows)
and a high one looking far, the band of the picture between the
near grass and the horizon's haze is grass-coloured (no khaki ground) and shows no ring where
the last blades give way to the far ground; the drawn blade count is bounded by the field's,
whatever the view.

How the band is found: each row's centre ray meets the ground at a distance d (m, from the
camera geometry); the band is the rows with 0.35 R <= d <= 1.2 R (R, where the last level of the
blades that follow the camera fades out, ``HorizonLayout.drawn_reach``: about 180 m; 1.2 R is short
of 240 m, where the ground fades into the horizon, 0.6 of the 400 m far plane). Every camera is
checked where the preset puts it and again after it moved 50 m (the blades follow it). "Grass-coloured": a pixel's hue (HSV, degrees) is over 68 (khaki, the bare
ground's #787a4e, is 62; the meadow's blades and far ground 75..100) and green is its
largest channel. "No ring" (measured with the fog off, which could only hide one): the mean colour (RGB, 0..255) of the rows with d in
[0.8 R, R) and of those in (R, 1.2 R] differ by at most RING_TOLERANCE, and no two
neighbouring rows' means differ by more than STEP_TOLERANCE; the same scene with the far
ground's grass colour held back to R (khaki, the bare ground of before, under every level of
blades, the far grass from R on: a ground whose edge is where the last blades end) must fail both, so the check can fail.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.core.orbit_limits import OrbitLimits, clamp_orbit
from conftest import assert_same_picture, save_test_picture

W, H = 320, 180
N_BLADES = 1 << 16
#: Largest difference (0..255, any channel) between the mean colours just inside and just outside the reach.
RING_TOLERANCE = 10.0
#: Largest difference (0..255, any channel) between neighbouring rows' mean colours in the band.
STEP_TOLERANCE = 12.0
KHAKI_HUE_MAX = 68.0


@pytest.fixture(scope="module")
def horizon_scene():
    """The meadow preset (a field to the horizon) at W x H, 30 steps in; released after the module."""
    s = gw.GrassScene.preset("meadow", blades=N_BLADES, size=(W, H))
    s.step(30)
    yield s
    s.release()


def _cameras(scene):
    limits = OrbitLimits.for_scene(scene, "grass")
    r0 = scene.field.blades.horizon.near_radius
    home_p = np.array(scene.camera.local.position, np.float64)  # a copy: look() moves the camera later
    home_t = home_p + 30.0 * (-np.asarray(scene.camera.world.matrix, np.float64)[:3, 2])
    low = (np.array([0.0, limits.ground_y + limits.clearance + 0.05, 0.6 * r0]), np.array([0.0, 0.6, -r0]))
    el = math.radians(20.0)
    high_t = np.array([0.0, 0.0, -r0])
    high = (high_t + 0.98 * limits.max_distance * np.array([0.0, math.sin(el), math.cos(el)]), high_t)
    fov = scene.vertical_fov()
    # the low camera looks through a long lens (12 degrees): the band it sees is 3 rows at 50 degrees
    cams = {"preset": (home_p, home_t, fov), "low": (*clamp_orbit(*low, limits), 12.0),
            "high": (*clamp_orbit(*high, limits), fov)}
    moved = np.array([30.0, 0.0, -40.0])  # 50 m: the blades follow the camera there
    for name, (p, t, f) in list(cams.items()):
        cams[f"{name}_moved_50m"] = (*clamp_orbit(p + moved, t + moved, limits), f)
    return cams


def _row_distances(scene):
    """Distance (m) from the camera at which each row's centre ray meets the ground (inf: none)."""
    cam = scene.camera
    inv = np.linalg.inv(np.asarray(cam.projection_matrix, np.float64) @ np.asarray(cam.view_matrix, np.float64))
    eye = np.asarray(cam.world.position, np.float64)
    ground_y = scene.sky_ground.material.uniform_buffer.data["ground"][1]
    out = np.full(H, np.inf)
    for row in range(H):
        ndc_y = 1.0 - 2.0 * (row + 0.5) / H
        far = inv @ np.array([0.0, ndc_y, 1.0, 1.0])
        d = far[:3] / far[3] - eye
        if d[1] < -1e-9:
            out[row] = np.linalg.norm(d * (ground_y - eye[1]) / d[1])
    return out


def _hue(img):
    rgb = img.astype(np.float64) / 255.0
    mx, mn = rgb.max(-1), rgb.min(-1)
    c = np.maximum(mx - mn, 1e-9)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    hue = np.where(mx == r, ((g - b) / c) % 6, np.where(mx == g, (b - r) / c + 2, (r - g) / c + 4)) * 60.0
    return hue


def _band_measures(img, dist, reach):
    band = (dist >= 0.35 * reach) & (dist <= 1.2 * reach)
    rows = img[band].astype(np.float64)
    hue = _hue(rows)
    grass = (hue > KHAKI_HUE_MAX) & (rows[..., 1] >= rows[..., 0]) & (rows[..., 1] >= rows[..., 2])
    means = img.astype(np.float64).mean(axis=1)
    inside = means[(dist >= 0.8 * reach) & (dist < reach)]
    outside = means[(dist > reach) & (dist <= 1.2 * reach)]
    # None: the reach falls inside one row (a camera near the ground at this height): the steps cover it
    ring = float(np.abs(inside.mean(0) - outside.mean(0)).max()) if len(inside) and len(outside) else None
    steps = np.abs(np.diff(means[band], axis=0)).max() if band.sum() > 1 else 0.0
    return int(band.sum()), float(grass.mean()), ring, float(steps)


def _picture(scene):
    """A frame of the scene's view (W x H) without post-process anti-aliasing, as lavapipe's live frame is.
    On a GPU the live view runs pygfx's DDAA, which blends the bright horizon line into the row below it:
    from the preset's camera that row is the only one past the reach (d in (R, 1.2 R]), and an H200 drew
    it (74, 92, 58) against lavapipe's (53, 74, 27), a "ring" of 34.75 that is the horizon's anti-aliasing,
    not the far ground (2026-11-28; measured without it, the H200 passes every camera's checks)."""
    before = scene.renderer.ppaa
    scene.renderer.ppaa = "none"
    try:
        return scene.render()[..., :3]
    finally:
        scene.renderer.ppaa = before


@pytest.mark.slow
def test_the_horizon_band_is_grass_without_a_ring_from_three_cameras(horizon_scene):
    reach = horizon_scene.field.blades.horizon.drawn_reach()
    drawn = []
    for name, (position, target, fov) in _cameras(horizon_scene).items():
        horizon_scene.look(position=position, target=target, fov_deg=fov)
        img = _picture(horizon_scene)
        dist = _row_distances(horizon_scene)
        rows, grass, _ring, _steps = _band_measures(img, dist, reach)
        # the ring and the steps without the fog (which would hide them: it only blends towards one colour)
        horizon_scene.params.fog_density = 0.0
        try:
            clear = _picture(horizon_scene)
        finally:
            horizon_scene.params.fog_density = gw.GrassParams().fog_density
        _rows, clear_grass, ring, steps = _band_measures(clear, dist, reach)
        save_test_picture(f"horizon_{name}", np.concatenate([img, clear], axis=0))  # fog on, off
        drawn.append(horizon_scene.visible_count())
        print(f"[horizon] {name}: {rows} band rows, {grass:.1%} grass-coloured, ring {ring}/255, "
              f"largest row step {steps:.1f}/255, {drawn[-1]} blades drawn")
        assert rows >= 2, name
        assert grass > 0.98 and clear_grass > 0.98, (name, grass, clear_grass)
        assert ring is None or ring <= RING_TOLERANCE, (name, ring)
        assert steps <= STEP_TOLERANCE, (name, steps)
        # the control: the far ground off (khaki beyond the reach, the look of before) fails the checks
        values = horizon_scene.sky_ground.material.uniform_buffer.data
        horizon_scene.params.fog_density = 0.0  # (rewrites the sky/ground's values: first)
        saved, saved_soil = values["far_blend"].copy(), values["soil_color"].copy()
        # khaki (the bare ground of before) under every level of blades, the far grass only from R on:
        # the edge where the last blades end
        horizon_scene.sky_ground.material.set_values({"far_blend": (reach - 0.1, reach, *map(float, saved[2:])),
                                                      "soil_color": tuple(float(x) for x in values["beyond_color"])})
        try:
            bare = _picture(horizon_scene)
        finally:
            horizon_scene.params.fog_density = gw.GrassParams().fog_density
            horizon_scene.sky_ground.material.set_values({"far_blend": tuple(float(x) for x in saved),
                                                          "soil_color": tuple(float(x) for x in saved_soil)})
        _rows, bare_grass, bare_ring, bare_steps = _band_measures(bare, dist, reach)
        print(f"[horizon] {name}, the control (khaki under the blades, far grass from R): {bare_grass:.1%} "
              f"grass-coloured, ring {bare_ring}/255, largest row step {bare_steps:.1f}/255")
        if name != "low":  # just over the grass, the tips short of the reach hide the ground past it (93 % grass)
            assert bare_grass < grass - 0.03, (name, bare_grass)
            # (ring None: R falls within one row from this camera; the row steps hold the edge then)
            assert bare_ring is None or bare_ring > RING_TOLERANCE, (name, bare_ring)
            assert bare_steps > STEP_TOLERANCE, (name, bare_steps)
    # memory and work bounded by the field, not by the view
    assert horizon_scene.field.count == N_BLADES and max(drawn) <= N_BLADES


def test_far_grass_is_compiled_in_only_while_the_ground_shows_it(horizon_scene):
    """The ground's far grass (sky_ground.wgsl, template switch ``far_grass``) is in the kernel's
    shader while the ground shows it: beyond every preset's field (``far_grass.w``, the course's
    square field too) and over a field to the horizon (``horizon.w``); with both 0 (the bare plain
    of before) it is left out (lavapipe pays its noise on every ground pixel). Switched off and on
    again through the values both engines get, the pipeline follows (the far ground goes, then
    comes back pixel for pixel)."""
    material = horizon_scene.sky_ground.material
    assert material.far_grass
    course = gw.GrassScene.preset("cis565", blades=64, size=(32, 24))
    assert course.sky_ground.material.far_grass
    course.release()
    with_far_grass = horizon_scene.render().copy()
    saved = tuple(float(x) for x in material.uniform_buffer.data["horizon"])
    saved_far = tuple(float(x) for x in material.uniform_buffer.data["far_grass"])
    material.set_values({"horizon": (0.0, 0.0, 0.0, 0.0)})
    assert material.far_grass  # still beyond the field
    material.set_values({"far_grass": (*saved_far[:3], 0.0)})
    assert not material.far_grass
    without = horizon_scene.render().copy()
    assert np.abs(without.astype(int) - with_far_grass).max() > 20  # the bare ground where the far grass was
    material.set_values({"horizon": saved, "far_grass": saved_far})
    assert material.far_grass
    assert_same_picture(horizon_scene.render(), with_far_grass, "far grass compiled in again")
