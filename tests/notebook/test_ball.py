"""The widget's ball (a sphere collider): shift + drag, sliders, rolling, drawing."""

import math
import time

import numpy as np
import pytest
from traitlets import TraitError

import grasswidget as gw
from conftest import WIDGET_SIZE
from grasswidget.notebook.ball import ground_point

pytest.importorskip("jupyter_rfb")

SIZE = WIDGET_SIZE  # the conftest's ``widget`` fixture has this view size


def _screen_of(camera, point, size=SIZE):
    """Pixel (x, y) where a world point appears (independent of ground_point)."""
    vp = np.asarray(camera.projection_matrix, np.float64) @ np.asarray(camera.view_matrix, np.float64)
    c = vp @ np.array([*point, 1.0])
    c = c / c[3]
    return (c[0] + 1) / 2 * size[0], (1 - c[1]) / 2 * size[1]


def _pointer(kind, x, y, modifiers=(), button=1):
    """A pointer event in jupyter-rfb's current format ("type", "timestamp")."""
    return dict(type=kind, x=x, y=y, button=button, buttons=(1,) if kind != "pointer_up" else (),
                modifiers=modifiers, ntouches=0, touches={}, timestamp=0)


def test_ground_point_inverts_the_projection():
    scene = gw.GrassScene(256, size=SIZE)
    scene.render()
    rng = np.random.default_rng(1)
    for _ in range(10):
        p = (rng.uniform(-6, 6), 0.0, rng.uniform(-6, 4))
        x, y = _screen_of(scene.camera, p)
        hit = ground_point(scene.camera, x, y, SIZE)
        assert hit is not None and np.allclose(hit, (p[0], p[2]), atol=1e-6)
    # on a raised ground plane too
    p = (1.5, 0.7, -2.0)
    hit = ground_point(scene.camera, *_screen_of(scene.camera, p), SIZE, ground_y=0.7)
    assert np.allclose(hit, (1.5, -2.0), atol=1e-6)
    # the top of the view is sky: the ray never comes down to the ground
    assert ground_point(scene.camera, SIZE[0] / 2, 0.0, SIZE) is None


def _settle(controller, limit_s=10.0):
    """Tick the camera controller until its motion (damped, so paced by the wall
    clock) has run to its end; returns the number of ticks. What the user sees
    once the view stops moving, whatever the machine's speed."""
    t0, ticks = time.monotonic(), 0
    while controller.tick() is not None:
        ticks += 1
        assert time.monotonic() - t0 < limit_s, "the camera kept moving"
    return ticks


def _camera_pose(cam):
    return np.array(cam.world.position, np.float64), np.array(cam.world.rotation, np.float64)


def test_shift_drag_moves_the_ball_and_does_not_orbit(widget):
    # what the browser sends when the view appears (the controller needs the view size)
    widget.canvas.handle_event({"event_type": "resize", "width": SIZE[0], "height": SIZE[1], "pixel_ratio": 1.0})
    ball = widget.ball
    cam = widget.scene.camera
    assert not ball.enabled and list(widget.scene.colliders) == []
    widget.scene.render_at(SIZE)  # camera matrices for this view size
    pos0, rot0 = _camera_pose(cam)

    def under_pointer(px, py):
        """The ball's contact point with the ground appears at the pointer (pixels)."""
        cx, _cy, cz = ball.collider.center
        sx, sy = _screen_of(cam, (cx, 0.0, cz))
        return abs(sx - px) < 0.5 and abs(sy - py) < 0.5

    x, y = _screen_of(cam, (-3.0, 0.0, 1.0))
    widget.view.events(_pointer("pointer_down", x, y, ("Shift",)))
    assert ball.enabled and ball.collider in widget.scene.colliders  # a shift-click switches it on
    r = ball.collider.radius
    assert ball.collider.center[1] == pytest.approx(r)  # resting on the ground
    assert under_pointer(x, y)
    # a drag of several moves, as a hand makes it: the ball follows the pointer at every move
    x2, y2 = _screen_of(cam, (2.0, 0.0, -1.0))
    for k in range(1, 9):
        px, py = x + (x2 - x) * k / 8, y + (y2 - y) * k / 8
        widget.view.events(_pointer("pointer_move", px, py, ("Shift",), button=0))
        assert under_pointer(px, py)
    widget.view.events(_pointer("pointer_up", x2, y2, ("Shift",)))
    assert under_pointer(x2, y2) and ball.collider.center[1] == pytest.approx(r)
    # the camera did not orbit while shift was held: no motion pending, the pose unchanged
    assert _settle(widget.controller) == 0
    pos, rot = _camera_pose(cam)
    assert np.array_equal(pos, pos0) and np.array_equal(rot, rot0)
    assert ball.x_slider.value == pytest.approx(ball.collider.center[0], abs=0.05)

    # after the drag, a plain drag orbits again and leaves the ball alone
    center_before = ball.collider.center
    target = np.asarray(widget.controller.target, np.float64)
    widget.view.events(_pointer("pointer_down", 80, 60))
    for i in range(1, 6):
        widget.view.events(_pointer("pointer_move", 80 + 8 * i, 60, button=0))
    widget.view.events(_pointer("pointer_up", 120, 60))
    assert _settle(widget.controller) > 0
    pos, rot = _camera_pose(cam)
    # an orbit: the camera turned around the target at the same distance, still looking at it
    assert np.linalg.norm(pos - target) == pytest.approx(np.linalg.norm(pos0 - target), rel=1e-4)
    turn = math.atan2(pos[2] - target[2], pos[0] - target[0]) - math.atan2(pos0[2] - target[2], pos0[0] - target[0])
    per_px = widget.controller.controls["mouse1"][2][0]  # radians of azimuth per pixel of drag
    assert abs(math.remainder(turn, math.tau)) == pytest.approx(40 * per_px, rel=0.02)  # the whole 40 px drag
    forward = -np.asarray(cam.world.matrix, np.float64)[:3, 2]
    to_target = (target - pos) / np.linalg.norm(target - pos)
    assert np.dot(forward / np.linalg.norm(forward), to_target) > 0.999
    assert ball.collider.center == center_before


def test_shift_press_on_the_sky_switches_the_ball_on_where_it_was(widget):
    """A shift + drag that starts above the horizon (no ground under the pointer) still
    switches the ball on, at its place; it follows once the pointer is over the ground."""
    widget.canvas.handle_event({"event_type": "resize", "width": SIZE[0], "height": SIZE[1], "pixel_ratio": 1.0})
    widget.scene.render_at(SIZE)
    ball, cam = widget.ball, widget.scene.camera
    before = ball.collider.center
    sky = (SIZE[0] / 2, 1.0)  # the top row of the view: sky in the default view
    assert ball_ground(widget, *sky) is None
    widget.view.events(_pointer("pointer_down", *sky, ("Shift",)))
    assert ball.enabled and ball.collider in widget.scene.colliders and ball.collider.center == before
    x, y = _screen_of(cam, (1.0, 0.0, 1.0))
    widget.view.events(_pointer("pointer_move", x, y, ("Shift",), button=0))
    widget.view.events(_pointer("pointer_up", x, y, ("Shift",)))
    assert ball.collider.center[0] == pytest.approx(1.0, abs=1e-3) and ball.collider.center[2] == pytest.approx(1.0, abs=1e-3)


def ball_ground(widget, x, y):
    """The ground point under (x, y) px of the view, or None (sky)."""
    import grasswidget.notebook.ball as wb

    scene, collider = widget.scene, widget.ball.collider
    ground_y = collider.center[1] - collider.radius  # the ball rests on the ground
    return wb.ground_point(scene.camera, x, y, SIZE, ground_y, np.asarray(scene.field.world.inverse_matrix))


def test_sliders_checkbox_and_bad_values(widget):
    ball = widget.ball
    ball.checkbox.value = True
    assert ball.enabled and widget.scene.colliders == [ball.collider]
    ball.x_slider.value = 2.5
    ball.z_slider.value = -1.0
    ball.radius_slider.value = 2.0
    assert ball.collider.center == pytest.approx((2.5, 2.0, -1.0))  # stays on the ground
    assert ball.collider.radius == 2.0
    ball.collider.center = (1.0, 2.0, 3.0)  # from code: the sliders follow
    assert (ball.x_slider.value, ball.z_slider.value) == pytest.approx((1.0, 3.0))
    with pytest.raises(TraitError, match="radius"):
        ball.set_radius(-1.0)
    with pytest.raises(ValueError, match="ball x"):
        ball.move_to(x=float("nan"))
    assert ball.collider.radius == 2.0 and ball.collider.center == pytest.approx((1.0, 2.0, 3.0))
    with pytest.raises(TraitError, match="roll_speed"):
        ball.roll_speed = 0.0
    with pytest.raises(TraitError, match="path"):
        ball.path = 3
    assert ball.path is None
    ball.checkbox.value = False
    assert not ball.enabled and list(widget.scene.colliders) == []
    widget.scene.step(10)  # the widget keeps working
    assert np.isfinite(widget.scene.field.read_state()["v2"]).all()


def test_ball_pushes_grass_in_the_widget_and_survives_a_new_blade_count(widget):
    ball = widget.ball
    ball.enabled = True
    ball.move_to(0.0, 0.0)
    widget.step(30)
    s = widget.scene.field.read_state()
    under = np.linalg.norm(s["v0"][:, [0, 2]], axis=1) < 0.5 * ball.collider.radius
    assert under.sum() > 5 and (s["collision"][under] > 0).mean() > 0.75
    widget.set_blades(2048)
    assert widget.scene.colliders == [ball.collider]
    assert ball.collider.center == pytest.approx((0.0, ball.collider.radius, 0.0))
    # the old field is released; the new one is pushed
    widget.step(30)
    assert widget.scene.field.read_state()["collision"].max() > 0


def test_roll_follows_a_circle_with_simulated_time(widget):
    ball = widget.ball
    widget.pause()
    ball.move_to(4.0, 0.0)
    ball.roll_button.value = True
    assert ball.rolling and ball.enabled and widget.playing  # Roll also plays
    assert ball.roll_button.description == "Stop"
    dt = widget.params.dt
    start = np.array(ball.collider.center)
    frames = 12
    for _ in range(frames):
        widget.view.draw()
    steps = frames * widget.steps_per_frame
    assert widget.scene.field.step_count == steps
    end = np.array(ball.collider.center)
    # on the circle around the field's centre through the start, at roll_speed
    cx, cz = ball.roll_center
    r0 = math.hypot(start[0] - cx, start[2] - cz)
    assert math.hypot(end[0] - cx, end[2] - cz) == pytest.approx(r0, rel=1e-6)
    arc = r0 * abs(math.atan2(end[2] - cz, end[0] - cx) - math.atan2(start[2] - cz, start[0] - cx))
    assert arc == pytest.approx(ball.roll_speed * steps * dt, rel=1e-6)
    assert end[1] == pytest.approx(ball.collider.radius)
    # a chunk never moves the ball more than a quarter of its radius
    chunks = ball.step_chunks(64, dt)
    assert sum(chunks) == 64 and max(chunks) * dt * ball.roll_speed <= 0.25 * ball.collider.radius
    # the trail: blades the ball went over carry collision strength
    s = widget.scene.field.read_state()
    assert s["collision"].max() > 0.5
    # paused: no time, no rolling
    widget.pause()
    widget.view.draw()
    assert np.allclose(ball.collider.center, end)
    # a custom path
    ball.path = lambda dist: (-2.0 + dist, 1.0)
    widget.play()
    widget.view.draw()
    x, _y, z = ball.collider.center
    assert z == 1.0 and x == pytest.approx(-2.0 + ball.roll_speed * widget.steps_per_frame * dt)
    # a path that fails stops the rolling with a message; the widget goes on
    ball.path = lambda dist: 1 / 0
    widget.view.draw()
    assert not ball.rolling and "ball path: ZeroDivisionError" in widget.panel.message_line.value
    steps = widget.scene.field.step_count
    widget.view.draw()
    assert widget.scene.field.step_count == steps + widget.steps_per_frame
    ball.path = None
    ball.roll_button.value = True
    ball.roll_button.value = False
    assert not ball.rolling and ball.roll_button.description == "Roll"


def test_the_ball_is_drawn_translucent():
    scene = gw.GrassScene(256, size=SIZE)
    scene.camera.local.position = (0, 6, 9)
    scene.camera.look_at((0, 1.5, 0))
    plain = scene.render().copy()
    scene.colliders.append(gw.SphereCollider(center=(0, 3.5, 0), radius=1.2))  # above the blades
    with_ball = scene.render().copy()
    x, y = (int(round(v)) for v in _screen_of(scene.camera, (0, 3.5, 0)))
    patch = (slice(y - 3, y + 4), slice(x - 3, x + 4))
    a, b = plain[patch][..., :3].astype(int), with_ball[patch][..., :3].astype(int)
    assert np.abs(a - b).max() > 20  # the ball shows ...
    scene.collider_balls.ball_material.opacity = 1.0
    opaque = scene.render()[patch][..., :3].astype(int)
    scene.collider_balls.ball_material.opacity = 0.35
    # ... and what is behind it shows through: nearer the plain picture than an opaque ball is
    assert np.abs(b - a).mean() < 0.8 * np.abs(opaque - a).mean()
    changed = np.abs(plain[..., :3].astype(int) - with_ball[..., :3]).max(axis=-1) > 8
    # about the projected disc of the ball (radius in pixels from the projection)
    rx, _ = _screen_of(scene.camera, (1.2, 3.5, 0))
    disc = math.pi * (rx - x) ** 2
    assert 0.5 * disc < changed.sum() < 2.0 * disc
    scene.show_colliders = False
    hidden = scene.render()
    assert np.array_equal(hidden[patch], plain[patch])
    with pytest.raises(TypeError, match="show_colliders"):
        scene.show_colliders = "yes"
