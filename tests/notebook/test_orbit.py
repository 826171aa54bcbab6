"""The widget's orbit keeps the camera above the ground and the field in sight;
zoom and pan have limits. Checked on what the user sees: camera height, the
target on screen, and pictures without sky under the grass."""

import math
import time

import numpy as np
import pytest

from conftest import WIDGET_SIZE, grass_mask, sky_mask
from grasswidget.views.orbit import OrbitLimits, clamp_orbit

pytest.importorskip("jupyter_rfb")

SIZE = WIDGET_SIZE


def _pointer(kind, x, y, button=1, modifiers=()):
    """A pointer event in jupyter-rfb's current format ("type", "timestamp")."""
    return dict(type=kind, x=x, y=y, button=button, buttons=(button,) if kind != "pointer_up" else (),
                modifiers=modifiers, ntouches=0, touches={}, timestamp=time.perf_counter())


def _drag(widget, start, delta, button=1, steps=12):
    x, y = start
    widget.view.events(_pointer("pointer_down", x, y, button))
    for k in range(1, steps + 1):
        widget.view.events(_pointer("pointer_move", x + delta[0] * k / steps, y + delta[1] * k / steps, button=0))
    widget.view.events(_pointer("pointer_up", x + delta[0], y + delta[1], button))
    _settle(widget.controller)


def _wheel(widget, dy, times=10):
    for _ in range(times):
        widget.view.events(dict(type="wheel", x=SIZE[0] / 2, y=SIZE[1] / 2, dx=0.0, dy=dy, buttons=(),
                                modifiers=(), timestamp=time.perf_counter()))
    _settle(widget.controller)


def _settle(controller, limit_s=10.0):
    t0 = time.monotonic()
    while controller.tick() is not None:
        assert time.monotonic() - t0 < limit_s, "the camera kept moving"


def _screen_of(camera, point):
    vp = np.asarray(camera.projection_matrix, np.float64) @ np.asarray(camera.view_matrix, np.float64)
    c = vp @ np.array([*point, 1.0])
    return c[:3] / c[3]


@pytest.fixture
def view(widget):
    widget.canvas.handle_event({"event_type": "resize", "width": SIZE[0], "height": SIZE[1], "pixel_ratio": 1.0})
    widget.scene.render_at(SIZE)
    return widget


def _check_view(widget):
    """Camera above the ground, looking at a target over the field, the target on screen."""
    cam = widget.scene.camera
    limits = widget.controller.limits
    pos = np.asarray(cam.world.position, np.float64)
    target = np.asarray(widget.controller.target, np.float64)
    assert pos[1] >= limits.ground_y + limits.clearance - 1e-4
    d = np.linalg.norm(pos - target)
    assert limits.min_distance - 1e-4 <= d <= limits.max_distance + 1e-4
    assert limits.lo[0] - 1e-4 <= target[0] <= limits.hi[0] + 1e-4
    assert limits.lo[1] - 1e-4 <= target[2] <= limits.hi[1] + 1e-4
    ndc = _screen_of(cam, target)
    assert abs(ndc[0]) < 1e-3 and abs(ndc[1]) < 1e-3 and 0 < ndc[2] < 1  # the view is centred on it
    return pos, target


def test_orbit_down_stops_above_the_ground_and_no_sky_shows_under_the_grass(view):
    # drag the camera down as far as a hand can (pygfx: dragging up lowers the camera)
    for _ in range(4):
        _drag(view, (80, 100), (0, -100))
    pos, target = _check_view(view)
    limits = view.controller.limits
    assert pos[1] == pytest.approx(limits.ground_y + limits.clearance, abs=0.05)  # it went as low as allowed
    img = view.scene.render_at(SIZE)
    sky = sky_mask(img)
    # what the user saw before: sky in the lower part of the picture. Now the ground is there.
    assert sky[SIZE[1] * 2 // 3:].mean() < 0.01
    assert grass_mask(img).mean() > 0.2
    # and straight back up at once (no stored overshoot to undo)
    before = pos.copy()
    _drag(view, (80, 20), (0, 30))
    assert view.scene.camera.world.position[1] > before[1] + 0.3


def test_orbit_up_stops_short_of_straight_down(view):
    for _ in range(4):
        _drag(view, (80, 10), (0, 100))
    pos, target = _check_view(view)
    off = pos - target
    elevation = math.degrees(math.asin(off[1] / np.linalg.norm(off)))
    assert elevation == pytest.approx(view.controller.limits.max_elevation_deg, abs=0.5)
    img = view.scene.render_at(SIZE)  # looking down on the meadow: grass and ground, no sky
    assert grass_mask(img).mean() > 0.15 and sky_mask(img).mean() == 0


def test_zoom_has_limits_and_the_field_stays_in_sight(view):
    limits = view.controller.limits
    _wheel(view, 2000, times=15)  # far out
    pos, target = _check_view(view)
    assert np.linalg.norm(pos - target) == pytest.approx(limits.max_distance, rel=0.01)
    assert limits.max_distance < 0.8 * view.scene.camera.depth_range[1]  # inside the far plane
    assert grass_mask(view.scene.render_at(SIZE, antialias=False)).mean() > 0.02  # the field is still there
    _wheel(view, -2000, times=15)  # all the way in
    pos, target = _check_view(view)
    assert np.linalg.norm(pos - target) == pytest.approx(limits.min_distance, rel=0.01)


def test_pan_keeps_the_target_over_the_field(view):
    for _ in range(4):
        _drag(view, (20, 60), (120, 0), button=2)  # right-drag: pan sideways
    _check_view(view)
    for _ in range(4):
        _drag(view, (80, 10), (0, 100), button=2)  # pan towards the horizon
    _check_view(view)
    # the field is still in view (4.7-6 % grass pixels with hard edges, by the blades' draw)
    assert grass_mask(view.scene.render_at(SIZE, antialias=False)).mean() > 0.03


def test_clamp_orbit_is_the_least_move():
    limits = OrbitLimits(lo=(-5, -5), hi=(5, 5), ground_y=0.0, top_y=3.0, min_distance=1.0, max_distance=20.0)
    # inside: unchanged
    p, t = clamp_orbit((0, 4, 10), (0, 1, 0), limits)
    assert np.allclose(p, (0, 4, 10)) and np.allclose(t, (0, 1, 0))
    # under the ground: raised along its vertical arc, same distance and azimuth
    p, t = clamp_orbit((6, -2, 8), (0, 1, 0), limits)
    assert p[1] == pytest.approx(limits.clearance)
    assert np.linalg.norm(p - t) == pytest.approx(np.linalg.norm(np.subtract((6, -2, 8), (0, 1, 0))))
    assert math.atan2(p[2], p[0]) == pytest.approx(math.atan2(8, 6))
    # too far, too near
    p, _ = clamp_orbit((0, 1, 100), (0, 1, 0), limits)
    assert np.linalg.norm(p - (0, 1, 0)) == pytest.approx(20.0)
    p, _ = clamp_orbit((0, 1.2, 0.1), (0, 1, 0), limits)
    assert np.linalg.norm(p - (0, 1, 0)) == pytest.approx(1.0)
    # straight down: tilted back to the highest elevation allowed
    p, t = clamp_orbit((0, 10, 0), (0, 0.5, 0), limits)
    assert math.degrees(math.asin((p[1] - t[1]) / np.linalg.norm(p - t))) == pytest.approx(limits.max_elevation_deg)
    # target off the field: back over it, the camera moved with it
    p, t = clamp_orbit((50, 4, 10), (40, 1, 0), limits)
    assert np.allclose(t, (5, 1, 0)) and np.allclose(p, (15, 4, 10))
    # a field on a sphere: no ground limit
    planet = OrbitLimits.for_field(np.float32([[0, -3, 0], [0, 3, 0]]), np.float32([[0, -1, 0], [0, 1, 0]]),
                                   np.float32([1, 1]), far=100)
    assert planet.ground_y is None


def _tallest_tip(widget):
    b = widget.view.blades
    return float(np.max(b.v0[:, 1] + b.height))


def test_one_huge_drag_or_wheel_flick_stays_above_the_blades(view):
    top = _tallest_tip(view)
    assert view.camera_floor == "grass"
    _drag(view, (80, 10), (-150, -2000), steps=1)  # one diagonal drag, all in one pointer move
    pos, _ = _check_view(view)
    assert pos[1] >= top + 0.3 - 1e-4
    _wheel(view, -20000, times=1)  # one wheel flick, all the way in
    pos, target = _check_view(view)
    assert pos[1] >= top + 0.3 - 1e-4
    img = view.scene.render_at(SIZE)  # above the grass: sky and grass, not a wall of blades
    assert sky_mask(img).mean() < 0.6 and grass_mask(img).mean() > 0.1


def test_look_from_top_low_home_in_the_kernel_engine(view):
    from grasswidget.errors import GrassValueError

    home = view.camera_state
    view.look_from("top")
    cam = view.camera_state
    d = np.subtract(cam["target"], cam["position"])
    assert d[1] / np.linalg.norm(d) < -0.999  # straight down
    img = view.scene.render_at(SIZE)
    assert sky_mask(img).mean() == 0 and grass_mask(img).mean() > 0.05
    pos, _ = _check_view(view)  # inside the limits: the next drag starts from here
    view.look_from("low")
    y = view.camera_state["position"][1]
    assert _tallest_tip(view) + 0.3 <= y <= _tallest_tip(view) + 0.5
    with pytest.raises(GrassValueError, match="'home', 'top', 'low'"):
        view.look_from("side")
    assert view.camera_state["position"][1] == pytest.approx(y)  # nothing moved
    view.look_from("home")
    assert np.allclose(view.camera_state["position"], home["position"], atol=1e-4)


def test_camera_floor_ground_lets_the_camera_down_and_grass_lifts_it_back(view):
    from grasswidget.errors import ParameterError

    with pytest.raises(ParameterError, match="'grass', 'ground'"):
        view.camera_floor = "sky"
    assert view.camera_floor == "grass"
    view.camera_floor = "ground"
    assert view.controller.limits.clearance == pytest.approx(0.3)
    _drag(view, (80, 10), (0, -2000), steps=1)
    pos, _ = _check_view(view)
    assert pos[1] == pytest.approx(view.controller.limits.ground_y + 0.3, abs=0.05)  # among the blades
    view.camera_floor = "grass"  # the camera rises at once, not at the next drag
    assert view.camera_state["position"][1] >= _tallest_tip(view) + 0.3 - 1e-4
    assert view.camera_bar.floor_checkbox.value is True


def test_a_start_camera_below_the_grass_starts_on_the_ground_floor():
    import grasswidget as gw

    w = gw.GrassWidget(blades=256, preset="cis565", size=SIZE)
    try:
        assert w.camera_floor == "ground" and w.camera_state["position"][1] == pytest.approx(1.0)
        w.look_from("top")
        assert w.camera_floor == "ground"  # no preset raises the floor
        w.camera_floor = "grass"
        w.look_from("home")  # the course view is lower than the grass: the floor comes down with it
        assert w.camera_floor == "ground" and w.camera_state["position"][1] == pytest.approx(1.0)
    finally:
        w.close()
