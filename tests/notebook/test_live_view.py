"""The live view's real-time clock, adaptive resolution and stats line.

Wall time is simulated (conftest.TickingWall) so the checks are exact; the
browser test checks real time against a real clock.
"""

import math

import numpy as np
import pytest

import grasswidget as gw
from conftest import WIDGET_SIZE, TickingWall
from grasswidget.views.adaptive import SCALES
from grasswidget.views.clock import SimClock

pytest.importorskip("jupyter_rfb")

DT = 1.0 / 120


def _resize(w, ratio=1.0):
    w.canvas.handle_event({"event_type": "resize", "width": WIDGET_SIZE[0], "height": WIDGET_SIZE[1],
                           "pixel_ratio": ratio})


def test_clock_spends_wall_time_in_whole_fixed_steps():
    wall = TickingWall()
    clock = SimClock(max_steps=64, now=wall)
    assert clock.frame_steps(DT) == 0  # stopped: no time
    clock.start()
    rng = np.random.default_rng(0)
    total_wall, total_steps = 0.0, 0
    for _ in range(500):
        s = float(rng.uniform(0.005, 0.09))
        wall.advance(s)
        total_wall += s
        n = clock.frame_steps(DT)
        clock.count(n, DT)
        total_steps += n
    # simulated time trails the wall clock by less than one step, never more
    assert 0 <= total_wall - total_steps * DT < DT
    assert clock.steps == total_steps and clock.sim_time == pytest.approx(total_steps * DT, abs=1e-12)
    assert clock.speed == pytest.approx(1.0, abs=0.05) and not clock.capped
    # time_scale halves the steps
    before = clock.steps
    for _ in range(100):
        wall.advance(0.05)
        clock.count(clock.frame_steps(DT, time_scale=0.5), DT)
    assert abs((clock.steps - before) * DT - 100 * 0.05 * 0.5) < DT


def test_clock_cap_means_slow_motion_and_stop_is_exact():
    wall = TickingWall()
    clock = SimClock(max_steps=64, now=wall)
    clock.start()
    for _ in range(10):  # 0.8 s frames would need 96 steps each
        wall.advance(0.8)
        n = clock.frame_steps(DT)
        clock.count(n, DT)
        assert n == 64 and clock.capped
    assert clock.speed == pytest.approx(64 * DT / 0.8, rel=1e-6)  # 0.67x
    clock.stop()
    wall.advance(100.0)
    assert clock.frame_steps(DT) == 0
    clock.start()  # no time is owed for the pause
    wall.advance(0.05)
    assert clock.frame_steps(DT) == 6
    with pytest.raises(ValueError, match="max_steps"):
        SimClock(max_steps=0)


def test_widget_real_time_pause_and_step_are_exact(widget):
    _resize(widget)
    wall = TickingWall()
    widget.view.clock.now = wall
    f = widget.scene.field
    assert widget.playing and widget.sim_time == 0.0
    for k in range(30):
        wall.advance(0.02 + 0.03 * (k % 3))  # uneven frames
        widget.view.draw()
    played = 10 * (0.02 + 0.05 + 0.08) - 0.02  # the first frame starts the clock
    assert 0 <= played - widget.sim_time < DT
    assert widget.sim_time == pytest.approx(f.step_count * widget.params.dt)
    widget.pause()
    steps, t = f.step_count, widget.sim_time
    for _ in range(5):
        wall.advance(1.0)
        widget.view.draw()
    assert f.step_count == steps and widget.sim_time == t  # paused: exactly no time
    widget.step(7)
    assert f.step_count == steps + 7 and widget.sim_time == pytest.approx(t + 7 * widget.params.dt)
    with pytest.raises(AttributeError):
        widget.sim_time = 3.0
    widget.reset_blades()
    assert widget.sim_time == 0.0 and f.step_count == 0
    widget.play()
    wall.advance(5.0)  # time while paused is not owed
    widget.view.draw()
    wall.advance(0.05)
    widget.view.draw()
    assert f.step_count == 6


def test_slow_motion_in_the_stats_line(widget):
    _resize(widget)
    wall = TickingWall()
    widget.view.clock.now = wall
    widget.time_scale = 10.0  # 0.1 s frames would need 120 steps
    for _ in range(6):
        wall.advance(0.1)
        widget.view.draw()
    widget.view.refresh_stats()
    line = widget.panel.stats_line.value
    assert "slow motion 0.5x" in line, line
    assert widget.stats["steps_per_frame"] == gw.widget.MAX_STEPS_PER_FRAME
    widget.time_scale = 1.0
    for _ in range(30):
        wall.advance(0.1)
        widget.view.draw()
    widget.view.refresh_stats()
    assert "slow motion" not in widget.panel.stats_line.value


def test_adaptive_scale_goes_down_when_slow_and_back_up_when_fast(widget, tmp_path, monkeypatch):
    import imageio.v3 as iio

    _resize(widget)
    full = widget.canvas.get_physical_size()
    wall = TickingWall()
    widget.view.clock.now = wall
    widget.view.governor.now = wall
    widget.target_fps = 10
    real_draw = widget.scene.draw_frame

    def slow_draw():  # an artificially slow render: 5 frames/s on the wall clock
        wall.advance(0.2)
        real_draw()

    monkeypatch.setattr(widget.scene, "draw_frame", slow_draw)
    scales = []
    for _ in range(40):
        widget.view.draw()
        scales.append(widget.render_scale)
    assert scales[-1] == SCALES[-1] == 0.5, str(scales)
    assert sorted(set(scales), reverse=True) == list(SCALES)  # step by step, every scale on the way
    assert all(a >= b for a, b in zip(scales, scales[1:]))
    w, h = widget.canvas.get_physical_size()
    assert (w, h) == (full[0] // 2, full[1] // 2)
    widget.view.refresh_stats()
    line = widget.panel.details_line.value
    assert "scale 0.50" in line and "render" in line and " ms" in line, line

    # paused: full resolution at once, and Save PNG too
    widget.pause()
    assert widget.render_scale == 1.0 and widget.canvas.get_physical_size() == full
    monkeypatch.setattr(widget.scene, "draw_frame", real_draw)
    widget.view.draw()
    assert tuple(widget.scene.renderer.physical_size) == tuple(full)
    widget.play()
    monkeypatch.setattr(widget.scene, "draw_frame", slow_draw)
    for _ in range(12):
        widget.view.draw()
    assert widget.render_scale < 1.0
    path = widget.save_png(tmp_path / "live.png")
    assert iio.imread(path).shape[:2] == (2 * WIDGET_SIZE[1], 2 * WIDGET_SIZE[0])

    # fast again (20 frames/s on the wall clock, a real render well under the budget): back up to 1
    def fast_draw():
        wall.advance(0.05)
        real_draw()

    monkeypatch.setattr(widget.scene, "draw_frame", fast_draw)
    # the headroom test uses the real render time: a target of 4 frames/s leaves room for a slow,
    # loaded machine (a frame may take up to ~130 ms at scale 0.5 and still count as fast)
    widget.target_fps = 4
    scales = []
    for _ in range(80):
        widget.view.draw()
        scales.append(widget.render_scale)
    assert scales[-1] == 1.0, scales
    assert all(a <= b for a, b in zip(scales, scales[1:]))
    assert widget.canvas.get_physical_size() == full


def test_target_fps_defaults_and_bad_values(widget):
    from grasswidget.gpu.adapter import is_cpu_adapter

    assert widget.target_fps == (24.0 if is_cpu_adapter() else 60.0)
    assert gw.widget.streaming_defaults(False)["max_fps"] == 60
    widget.target_fps = 30
    for bad in (0, 0.5, 241, 1e9, float("nan"), float("inf"), -5, "fast", None, True, [24]):
        with pytest.raises(ValueError, match=r"target_fps.*\[1, 240\]"):
            widget.target_fps = bad
        assert widget.target_fps == 30.0  # the old value stays
    _resize(widget)
    widget.view.draw()  # still drawing
    with pytest.raises(ValueError, match="target_fps"):
        gw.GrassWidget(blades=16, size=WIDGET_SIZE, target_fps=float("nan"))
    w = gw.GrassWidget(blades=16, size=WIDGET_SIZE, target_fps=12)
    try:
        assert w.target_fps == 12.0
    finally:
        w.close()


def test_stats_line_shows_the_frame_breakdown(widget, monkeypatch):
    import grasswidget.views.kernel as kv

    monkeypatch.setattr(kv, "STATS_INTERVAL", 1e9)  # no refresh inside the draw: this test refreshes
    _resize(widget)
    wall = TickingWall()  # frames 50 ms apart: the clock measures the speed of time (real time)
    widget.view.clock.now = wall
    for _ in range(3):
        wall.advance(0.05)
        widget.view.draw()
    # what the canvas reports for a streamed frame: pixels presented, then sent
    d0, d1 = widget.view.timing.last_draw
    widget.canvas.on_present(d1 + 0.004)  # what the canvas calls for a streamed frame
    widget.canvas.on_transport("encode", 0.0025)  # the JPEG, on the worker thread
    widget.canvas.on_transport("send", 0.0015)
    widget.view.refresh_stats()
    s = widget.stats
    assert s["readback_ms"] == pytest.approx(4.0, abs=1e-6)
    assert s["encode_ms"] == pytest.approx(2.5, abs=1e-6) and s["send_ms"] == pytest.approx(1.5, abs=1e-6)
    assert s["render_ms"] is not None and s["scale"] == 1.0
    line = widget.panel.details_line.value
    for word in ("frames/s delivered", "render", "readback 4.0", "encode 2.5", "send 1.5", "scale 1.00",
                 "steps/frame"):
        assert word in line, (word, line)
    status = widget.panel.stats_line.value  # one line in words; the timings wait behind "details"
    assert "frames/s" in status and "blades drawn" in status and "real time" in status, status
    assert "readback" not in status and "ms" not in status
    assert widget.panel.details_line.layout.display == "none"
    widget.panel.details_button.value = True
    assert widget.panel.details_line.layout.display != "none"
    widget.panel.details_button.value = False
    assert math.isfinite(s["fps"])
    widget.pause()  # paused, the status says so (not "real time" at a stale rate)
    assert "paused" in widget.panel.stats_line.value and "real time" not in widget.panel.stats_line.value
    widget.play()
    assert "paused" not in widget.panel.stats_line.value


def test_stats_keys_from_the_start_a_trial_window_and_a_refresh_with_no_new_frame(widget):
    """Every stats key is there before the first window (a notebook reading w.stats['step_count']
    at once got a KeyError from the browser engine); a window in which the "auto" switches ran a
    trial says so; a refresh right after the one a frame made keeps that window's figures
    (it used to report 0.0 frames/s delivered and no stage times)."""
    from grasswidget.gpu.trial_timing import switches_of

    _resize(widget)
    for key in ("step_count", "switches", "trial", "fps", "render_ms"):
        assert key in widget.stats, key
    widget.view.draw()  # the first frame starts the trial of the undecided "auto" switches
    assert switches_of(widget.scene.field).measuring
    widget.view.refresh_stats()
    first = widget.stats
    assert first["trial"] is True and first["step_count"] == widget.scene.field.step_count
    assert first["switches"]["cull_occlusion"].startswith("auto (")
    for _ in range(200):  # until both switches are decided
        if len(switches_of(widget.scene.field).decisions) == 2 and not switches_of(widget.scene.field).measuring:
            break
        widget.view.draw()
    assert len(switches_of(widget.scene.field).decisions) == 2
    widget.view.refresh_stats()  # the window that saw the trial end
    widget.view.draw()
    widget.view.refresh_stats()
    after = widget.stats
    assert after["trial"] is False and after["fps"] > 0 and after["render_ms"] is not None
    widget.view.refresh_stats()  # no frame since: the same figures, not 0.0 frames/s
    again = widget.stats
    assert again["fps"] == after["fps"] and again["render_ms"] == after["render_ms"]


def test_a_frame_with_nothing_changed_is_not_rendered_or_sent_again(widget, monkeypatch):
    """Playing while no step runs (the clock owes none), the camera is still and no change was asked
    for, the view renders nothing (the canvas cancels the draw: no readback, nothing sent); a step
    owed, a camera moved, a resize or a parameter each bring a rendered frame back. The frames not
    rendered count in fps (the page shows them already) and in unchanged_fps; the status line reads a
    frame rate, never "waiting for frames"."""
    import grasswidget.views.kernel as kv

    monkeypatch.setattr(kv, "STATS_INTERVAL", 1e9)  # this test refreshes the stats itself
    monkeypatch.setattr(kv, "WAITING_AFTER_S", 0.0)  # no browser acknowledges the frames sent here
    _resize(widget)
    rendered = []
    real_draw = widget.scene.draw_frame

    def counting_draw():
        rendered.append(widget.scene.field.step_count)
        real_draw()

    monkeypatch.setattr(widget.scene, "draw_frame", counting_draw)
    wall = TickingWall(1.0 / widget.max_fps)
    widget.view.clock.now = wall
    widget.play()
    assert widget.view.draw() and widget.view.draw()  # time passes: steps, rendered
    shown = np.zeros((4, 4, 4), np.uint8)
    widget.canvas.send_frame(shown)  # what the canvas does with a rendered frame: the page has it
    steps = widget.scene.field.step_count
    wall.tick = 0.0  # no time passes (as with time_scale 0): no step is owed
    n = len(rendered)
    assert [widget.view.draw() for _ in range(5)] == [False] * 5
    assert len(rendered) == n and widget.scene.field.step_count == steps
    # what the skip relies on: with no step, the same camera and size, a render gives the same pixels
    first = widget.scene.render_at(WIDGET_SIZE, antialias=False)
    assert np.array_equal(first, widget.scene.render_at(WIDGET_SIZE, antialias=False)) and first.std() > 1.0
    presented, asked = [], []
    view_draw = widget.view.draw
    monkeypatch.setattr(widget.canvas, "on_present", presented.append)
    monkeypatch.setattr(widget.view, "draw", lambda: asked.append(1) or view_draw())
    widget.canvas.get_frame()  # what jupyter-rfb asks: the canvas's draw is cancelled, nothing read back
    assert asked == [1] and len(rendered) == n and presented == []
    monkeypatch.setattr(widget.view, "draw", view_draw)

    cam = widget.scene.camera  # the camera moved (as a drag moves it, without a request_draw)
    cam.local.position = tuple(np.asarray(cam.local.position) + np.array([0.3, 0.0, 0.0]))
    assert widget.view.draw() and len(rendered) == n + 1
    assert not widget.view.draw()
    widget.params.wind_strength = widget.params.wind_strength + 1.0  # a change asked for
    assert widget.view.draw() and len(rendered) == n + 2
    _resize(widget)  # a resize event of the same size (a new view, a page reload): the page may lack the frame
    assert widget.view.draw() and len(rendered) == n + 3
    widget.canvas.send_frame(shown + 1)  # the page has a frame again
    assert not widget.view.draw()
    _resize(widget, ratio=0.5)  # another frame size
    assert widget.view.draw() and len(rendered) == n + 4
    wall.tick = 1.0 / widget.max_fps  # time runs again
    assert widget.view.draw() and widget.scene.field.step_count > steps
    widget.canvas.send_frame(shown + 2)
    gw.compat.set_frame_feedback(widget.canvas, 3)  # the page showed it (the third frame sent)

    wall.tick = 0.0
    widget.view.draw()  # the clock's first reading without time
    for _ in range(10):
        assert not widget.view.draw()
    widget.view.refresh_stats()
    s = widget.stats
    assert s["unchanged_fps"] is not None and s["unchanged_fps"] > 0 and s["fps"] >= s["unchanged_fps"]
    assert not s["waiting"] and not s["stale"]
    status = widget.panel.stats_line.value
    assert "frames/s" in status and "waiting" not in status, status
    assert "unchanged" in widget.panel.details_line.value
