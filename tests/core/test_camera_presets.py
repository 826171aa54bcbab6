"""Camera presets and the orbit floor, in NumPy: where "top" and "low" put the camera
(checked by projecting the field through the preset camera), and that one huge drag,
wheel flick or pan keeps the camera above the blades and out of the field."""

import math

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.core.camera_presets import CAMERA_PRESETS, camera_preset
from grasswidget.core.orbit_limits import GRASS_CLEARANCE, GROUND_CLEARANCE, OrbitLimits, clamp_orbit
from grasswidget.errors import GrassValueError

ASPECT = 640 / 480


def _field(size=15.0, n=2000, height=(1.3, 2.5)):
    return gw.Blades.on_plane(n, size, seed=3, height=height)


def _home(blades):
    """A start camera for the presets to go back to: from above one edge of the field, looking at its
    middle (the pose the engines start from; the presets take any home pose, so the core's tests
    need no engine)."""
    lo, hi = blades.v0.min(axis=0), blades.v0.max(axis=0)
    d = 0.95 * float(max(hi[0] - lo[0], hi[2] - lo[2], 1.0))
    c = 0.5 * (lo + hi)
    return {"position": [float(c[0]), 0.28 * d + 1.0, float(c[2]) + d], "target": [float(c[0]), 0.6, float(c[2])],
            "fov_deg": 45.0}


def _project(cam, points, aspect=ASPECT):
    """NDC (x, y) and view depth of world points seen by cam (a right-handed look-at, y up)."""
    eye, target = np.asarray(cam["position"], float), np.asarray(cam["target"], float)
    f = target - eye
    f /= np.linalg.norm(f)
    r = np.cross(f, [0.0, 1.0, 0.0])
    r /= np.linalg.norm(r)
    u = np.cross(r, f)
    rel = np.asarray(points, float) - eye
    x, y, depth = rel @ r, rel @ u, rel @ f
    t = math.tan(math.radians(cam["fov_deg"]) / 2)
    return x / (depth * t * aspect), y / (depth * t), depth


def _tips(blades):
    return blades.v0 + blades.up * blades.height[:, None]


@pytest.mark.parametrize("size", [15.0, 40.0])
def test_top_looks_straight_down_at_the_whole_field(size):
    blades = _field(size)
    limits = OrbitLimits.for_field(blades.v0, blades.up, blades.height, far=400.0)
    cam = camera_preset("top", blades.v0, blades.height, home=_home(blades), aspect=ASPECT, limits=limits)
    view = np.subtract(cam["target"], cam["position"])
    view /= np.linalg.norm(view)
    assert view[1] < -math.sin(math.radians(88.0))  # straight down, within 2 degrees
    # over the middle of the field
    assert abs(cam["target"][0]) < 0.05 * size and abs(cam["target"][2]) < 0.05 * size
    for pts in (blades.v0, _tips(blades)):  # every root and every tip is in the picture
        x, y, depth = _project(cam, pts)
        assert np.all(depth > 0) and np.all(np.abs(x) < 1) and np.all(np.abs(y) < 1)
    # ... and the field fills it: the footprint spans most of the picture's height
    x, y, _ = _project(cam, blades.v0)
    assert y.max() - y.min() > 1.5
    assert limits.allows(cam["position"], cam["target"])  # a drag from here does not jump


def test_low_is_a_students_eye_just_above_the_grass_looking_across():
    blades = _field()
    home = _home(blades)
    limits = OrbitLimits.for_field(blades.v0, blades.up, blades.height, far=100.0)
    cam = camera_preset("low", blades.v0, blades.height, home=home, aspect=ASPECT, limits=limits)
    top = float(np.max(_tips(blades)[:, 1]))
    eye = cam["position"][1]
    assert top + GRASS_CLEARANCE <= eye <= top + 0.5  # above every tip, but low
    assert limits.allows(cam["position"], cam["target"])
    off = np.subtract(cam["position"], cam["target"])
    elevation = math.degrees(math.asin(off[1] / np.linalg.norm(off)))
    assert 0 < elevation < 12  # looking across, slightly down
    # on home's side of the field, looking towards the far side (home is at +z)
    assert cam["position"][2] > 7.0 and cam["target"][2] < -6.0
    # the field is seen across: near grass at the bottom of the picture, the far edge near the middle
    x, y, depth = _project(cam, blades.v0)
    seen = (np.abs(x) < 1) & (np.abs(y) < 1) & (depth > 0)
    assert seen.mean() > 0.5 and y[seen].min() < -0.6


def test_home_is_the_start_camera_and_unknown_names_are_refused():
    blades = _field(n=200)
    home = _home(blades)
    cam = camera_preset("home", blades.v0, blades.height, home=home, aspect=ASPECT)
    assert np.allclose(cam["position"], home["position"]) and np.allclose(cam["target"], home["target"])
    assert CAMERA_PRESETS == ("home", "top", "low")
    with pytest.raises(GrassValueError, match="'home', 'top', 'low'"):
        camera_preset("side", blades.v0, blades.height, home=home, aspect=ASPECT)
    with pytest.raises(GrassValueError, match="aspect"):
        camera_preset("top", blades.v0, blades.height, home=home, aspect=0)


def _drag(position, target, d_az, d_el):
    """One drag step as the browser takes it (engine.js onPointerMove): azimuth and
    elevation change, elevation held short of the poles, then the limits."""
    off = np.subtract(position, target)
    r = np.linalg.norm(off)
    az = math.atan2(off[0], off[2]) + d_az
    el = max(-1.55, min(1.55, math.asin(off[1] / r) + d_el))
    return np.asarray(target) + r * np.array([math.cos(el) * math.sin(az), math.sin(el), math.cos(el) * math.cos(az)])


def _assert_above_the_blades(position, blades, limits):
    top = float(np.max(_tips(blades)[:, 1]))
    assert position[1] >= top + GRASS_CLEARANCE - 1e-9, (position, top)
    assert limits.ground_y + limits.clearance == pytest.approx(top + GRASS_CLEARANCE)


def test_one_big_drag_or_wheel_flick_keeps_the_camera_above_the_blades():
    blades = _field()
    limits = OrbitLimits.for_field(blades.v0, blades.up, blades.height, far=100.0)
    home = _home(blades)
    pos, tgt = np.asarray(home["position"], float), np.asarray(home["target"], float)
    # the teacher's diagonal drag, all in one event (what took the camera to grass height before)
    for d_az, d_el in ((2.5, -3.0), (-0.3, -1.5), (0.0, -100.0)):
        p, t = clamp_orbit(_drag(pos, tgt, d_az, d_el), tgt, limits)
        _assert_above_the_blades(p, blades, limits)
    # a wheel flick all the way in (the camera 1 mm from the target, in the grass), and out
    for k in (1e-3, 0.05, 0.5, 50.0):
        p, t = clamp_orbit(tgt + k * (pos - tgt), tgt, limits)
        _assert_above_the_blades(p, blades, limits)
        assert limits.min_distance - 1e-9 <= np.linalg.norm(p - t) <= limits.max_distance + 1e-9
    # a wheel flick at a target down on the ground, in the middle of the field
    p, t = clamp_orbit((0.0, 0.4, 0.3), (0.0, 0.0, 0.0), limits)
    _assert_above_the_blades(p, blades, limits)
    # a pan that drags target and camera down into the grass
    p, t = clamp_orbit(pos + (0, -6, -10), tgt + (0, -6, -10), limits)
    _assert_above_the_blades(p, blades, limits)


def test_random_big_steps_never_enter_the_field():
    blades = _field(height=(0.5, 1.0))
    limits = OrbitLimits.for_field(blades.v0, blades.up, blades.height, far=100.0)
    rng = np.random.default_rng(11)
    pos, tgt = np.array([0.0, 5.0, 14.0]), np.array([0.0, 0.5, 0.0])
    for _ in range(2000):
        kind = rng.integers(3)
        if kind == 0:
            pos = _drag(pos, tgt, *rng.uniform(-4, 4, 2))
        elif kind == 1:
            pos = tgt + (pos - tgt) * math.exp(rng.uniform(-8, 8))
        else:
            move = rng.uniform(-20, 20, 3)
            pos, tgt = pos + move, tgt + move
        pos, tgt = clamp_orbit(pos, tgt, limits)
        _assert_above_the_blades(pos, blades, limits)


def test_the_ground_floor_lets_the_camera_down_among_the_blades():
    blades = _field()
    grass = OrbitLimits.for_field(blades.v0, blades.up, blades.height, far=100.0)
    ground = OrbitLimits.for_field(blades.v0, blades.up, blades.height, far=100.0, floor="ground")
    assert ground.clearance == GROUND_CLEARANCE and ground.min_distance < grass.min_distance
    p, _ = clamp_orbit((0.0, -3.0, 10.0), (0.0, 1.0, 0.0), ground)
    assert p[1] == pytest.approx(GROUND_CLEARANCE)  # down to 0.3 m above the ground
    assert not grass.allows((0.0, 1.0, 10.0), (0.0, 1.0, 0.0))  # the cis565 view needs the ground floor
    assert ground.allows((0.0, 1.0, 10.0), (0.0, 1.0, 0.0))
    with pytest.raises(GrassValueError, match="'grass', 'ground'"):
        OrbitLimits.for_field(blades.v0, blades.up, blades.height, far=100.0, floor="sky")
