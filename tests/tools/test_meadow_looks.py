"""benchmarks/meadow_looks.py's rules on a tiny view: the soil share (two renders, the soil keyed) against an
independent count of the pixels whose view ray meets the field's bare rectangle, and the near density against
a count of the roots made on the CPU."""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

import grasswidget as gw

BENCH = Path(__file__).resolve().parents[2] / "benchmarks"
SIZE = (64, 48)
HALF = 4.0  # the field's half side (m)


def _load():
    spec = importlib.util.spec_from_file_location("bench_meadow_looks", BENCH / "meadow_looks.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def looks():
    return _load()


@pytest.fixture(scope="module")
def bare_scene():
    """A field of 2,048 blades a few mm tall and thin (they cover no pixel): its whole rectangle is bare soil."""
    from grasswidget.gpu.scene import GrassScene

    blades = gw.Blades.on_plane(2048, 2 * HALF, seed=3, height=(0.004, 0.006), width=(0.001, 0.002))
    scene = GrassScene(blades, size=SIZE)
    yield scene
    scene.release()


def _rays_on_rectangle(scene, half):
    """Share of the pixel centres whose view ray meets the ground plane inside |x|, |z| <= half (NumPy)."""
    cam = scene.camera
    inv = np.linalg.inv(np.asarray(cam.projection_matrix, np.float64) @ np.asarray(cam.view_matrix, np.float64))
    w, h = SIZE
    x = (np.arange(w) + 0.5) / w * 2 - 1
    y = 1 - (np.arange(h) + 0.5) / h * 2
    X, Y = np.meshgrid(x, y)

    def unproject(z):
        p = np.stack([X, Y, np.full_like(X, z), np.ones_like(X)], -1) @ inv.T
        return p[..., :3] / p[..., 3:]

    near, far = unproject(0.0), unproject(1.0)
    ground_y = float(scene.sky_ground.material.uniform_buffer.data["ground"][1])
    d = far - near
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (ground_y - near[..., 1]) / d[..., 1]
    hit = near + s[..., None] * d
    on = (s > 0) & (np.abs(hit[..., 0]) <= half) & (np.abs(hit[..., 2]) <= half)
    return float(on.mean())


@pytest.mark.slow  # 2.5-4.5 s on lavapipe (the scene's first pipelines, four renders)
def test_soil_share_counts_the_bare_field_and_nothing_else(looks, bare_scene):
    scene = bare_scene
    scene.look(position=(0.0, 9.0, 9.0), target=(0.0, 0.0, 0.0), fov_deg=50)
    share, picture, mask = looks.soil_share(scene)
    # the soil is the roots' rectangle, its edge soft over 0.5 m (half inside, half out)
    v0 = np.asarray(scene.field.blades.v0, np.float64)
    half = float(np.abs(v0[:, [0, 2]]).max())
    inner, outer = _rays_on_rectangle(scene, half - 0.25), _rays_on_rectangle(scene, half + 0.25)
    assert 0.2 < inner < outer < 0.8  # the view shows the field, ground beyond it and sky
    assert inner <= share <= outer, (inner, share, outer)
    assert mask.shape == (SIZE[1], SIZE[0]) and mask.sum() == round(share * mask.size)
    # the soil's colour is restored: the next render is the first one again
    assert np.array_equal(np.asarray(scene.render()), picture)

    # the camera away from the field, looking away from it: ground beyond and sky only, no soil
    scene.look(position=(0.0, 3.0, 40.0), target=(0.0, 0.0, 80.0))
    assert _rays_on_rectangle(scene, HALF) == 0.0
    share, picture, mask = looks.soil_share(scene)
    assert share == 0.0
    assert picture[..., :3].std() > 1.0  # a picture of something (sky over ground), not a blank frame


def test_changed_share_is_the_share_of_pixels_moved_more_than_the_step(looks):
    a = np.zeros((10, 10, 4), np.uint8)
    b = a.copy()
    b[:3, :, 2] = looks.SOIL_STEP + 1  # 30 pixels move past the step
    b[5, :, 0] = looks.SOIL_STEP  # 10 pixels move by exactly the step: not counted
    share, mask = looks.changed_share(a, b)
    assert share == pytest.approx(0.3) and mask.sum() == 30
    with pytest.raises(ValueError):
        looks.changed_share(a, b[:5])


def test_near_density_counts_the_roots_within_the_radius(looks, bare_scene):
    scene = bare_scene
    scene.look(position=(3.0, 2.0, -1.0), target=(0.0, 0.0, 0.0))
    density, count = looks.near_density(scene, radius=2.5)
    v0 = np.asarray(scene.field.blades.v0, np.float64)
    expected = int(np.count_nonzero(np.hypot(v0[:, 0] - 3.0, v0[:, 2] + 1.0) <= 2.5))
    assert count == expected > 0
    assert density == pytest.approx(expected / (math.pi * 2.5 ** 2))
