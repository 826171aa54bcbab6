"""gw.compare without a browser: each view after step(n) is a GrassScene with its parameters
stepped n steps; one camera (a move in one view reaches the others, no echo); one clock
(frames of every view show the same simulated time while playing, pause aligns them);
shared and differing parameters; bad input refused before any view is made."""

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.views.clock import SharedClock

pytest.importorskip("jupyter_rfb")

BLADES, SIZE = 256, (160, 120)
VARIANTS = {"soft": {"stiffness_scale": 0.5}, "stiff": {"stiffness_scale": 2.0, "wind_strength": 30.0}}


@pytest.fixture
def comparison():
    c = gw.compare(VARIANTS, blades=BLADES, size=SIZE)
    for w in c.widgets.values():  # what the browser sends when a view appears
        w.canvas.handle_event({"event_type": "resize", "width": SIZE[0], "height": SIZE[1], "pixel_ratio": 1.0})
    yield c
    c.close()


def _scene_state(params, n):
    from grasswidget.gpu.scene import GrassScene

    scene = GrassScene(gw.Blades.on_plane(BLADES), size=SIZE, params=params.copy())
    try:
        scene.step(n)
        return scene.field.read_state()
    finally:
        scene.release()


def _assert_same_state(a, b, atol=0.0):
    """Equal blade states (``atol`` metres: frames step in several GPU submissions, where
    float rounding may differ in the last bit from one submission of all the steps)."""
    for key in ("v0", "v1", "v2", "up", "height", "stiffness"):
        np.testing.assert_allclose(a[key], b[key], rtol=0.0, atol=atol, err_msg=key)


def test_step_n_equals_a_grass_scene_per_variant(comparison):
    c = comparison
    assert list(c.widgets) == ["soft", "stiff"] and c.differing == ("stiffness_scale", "wind_strength")
    assert c.widgets["soft"].params.stiffness_scale == 0.5 and c.widgets["stiff"].params.wind_strength == 30.0
    assert c.widgets["soft"].params.wind_strength == c.params.wind_strength == gw.GrassParams().wind_strength
    c.step(48)
    assert not c.playing and not any(w.playing for w in c.widgets.values())
    states = c.read_states()
    for label, w in c.widgets.items():
        _assert_same_state(states[label], _scene_state(w.params, 48))
        assert w.sim_time == pytest.approx(48 * w.params.dt)
    assert np.abs(states["soft"]["v2"] - states["stiff"]["v2"]).max() > 0.01  # the variants differ


def test_shared_parameters_reach_every_view_and_labels_show_the_differing_ones(comparison):
    c = comparison
    c.params.gravity = 5.0
    assert [w.params.gravity for w in c.widgets.values()] == [5.0, 5.0]
    c.params.stiffness_scale = 3.0  # varied by every view: theirs stay
    assert [w.params.stiffness_scale for w in c.widgets.values()] == [0.5, 2.0]
    assert "stiffness_scale = 0.5" in c.labels["soft"].value and "wind_strength = 30" in c.labels["stiff"].value
    c.widgets["soft"].params.stiffness_scale = 0.75
    assert "stiffness_scale = 0.75" in c.labels["soft"].value
    assert c.panel.sliders["stiffness_scale"].disabled and c.panel.sliders["wind_strength"].disabled
    assert not c.panel.sliders["gravity"].disabled
    c.panel.sliders["gravity"].value = 7.0  # the shared panel edits the shared params
    assert [w.params.gravity for w in c.widgets.values()] == [7.0, 7.0]


def test_a_camera_move_in_one_view_reaches_the_others_without_echo(comparison):
    c = comparison
    soft, stiff = c.widgets["soft"].view, c.widgets["stiff"].view
    heard, heard_soft = [], []
    stiff.add_camera_listener(lambda view: heard.append(view))
    stop = soft.add_camera_listener(lambda view: heard_soft.append(view))
    soft.camera_state = {"position": (3.0, 5.0, 9.0), "target": (0.5, 0.5, 0.0), "fov_deg": 50.0}  # as a drag moves it
    soft.draw()  # the frame after the drag reports the move
    for key in ("position", "target", "fov_deg"):
        assert np.allclose(stiff.camera_state[key], soft.camera_state[key], atol=1e-6)
    assert np.allclose(stiff.camera_state["position"], (3.0, 5.0, 9.0), atol=1e-5)
    stiff.draw()
    soft.draw()
    assert heard == []  # the followed view did not report the camera it was given back
    assert heard_soft == [soft]
    stop()  # add_camera_listener's remover: no more calls (and a second call does nothing)
    stop()
    soft.camera_state = {"position": (3.5, 5.0, 9.0)}
    soft.draw()
    assert heard_soft == [soft] and np.allclose(stiff.camera_state["position"], (3.5, 5.0, 9.0), atol=1e-5)
    c.camera_state = {"position": (0.0, 6.0, 12.0)}
    assert all(np.allclose(w.camera_state["position"], (0.0, 6.0, 12.0)) for w in c.widgets.values())
    with pytest.raises(gw.GrassValueError, match="fov_deg"):
        c.camera_state = {"fov_deg": 500}


def test_playing_frames_show_the_same_simulated_time_and_pause_aligns(comparison):
    c = comparison
    wall = [100.0]
    c.clock.now = lambda: wall[0]
    soft, stiff = c.widgets["soft"].view, c.widgets["stiff"].view
    c.play()
    for _frame in range(5):
        wall[0] += 0.05
        soft.draw()
        stiff.draw()
        assert soft.readings.sim_time == pytest.approx(stiff.readings.sim_time)
    assert soft.clock.steps == stiff.clock.steps > 0
    # one view draws on alone: it waits for the other (the shared time holds) ...
    before = soft.clock.steps
    wall[0] += 0.05
    soft.draw()
    wall[0] += 0.05
    soft.draw()
    assert soft.clock.steps - before <= int(round(0.05 / c.params.dt)) + 1
    # ... and pausing brings the view behind up to the shared time
    c.pause()
    assert soft.clock.steps == stiff.clock.steps
    states = c.read_states()
    for label, w in c.widgets.items():
        _assert_same_state(states[label], _scene_state(w.params, w.view.clock.steps), atol=1e-5)
    # stepping after playing keeps them together, and playing on does not stall
    c.step(3)
    assert soft.clock.steps == stiff.clock.steps
    c.play()
    wall[0] += 0.1
    soft.draw()
    stiff.draw()
    assert soft.clock.steps == stiff.clock.steps > before


def test_keys_and_ctrl_click_act_on_every_view(comparison):
    c = comparison
    c.widgets["soft"].view.on_key({"key": " ", "modifiers": []})  # space in one view
    assert c.playing is False and not any(w.playing for w in c.widgets.values())
    c.widgets["stiff"].view.on_key({"key": "s", "modifiers": []})
    steps = {w.view.clock.steps for w in c.widgets.values()}
    assert len(steps) == 1 and steps.pop() >= 1
    c.widgets["soft"].view.host.inspect([5])
    assert all(w.inspected == (5,) for w in c.widgets.values())


def test_shared_clock_stall_limit():
    wall = [0.0]
    clock = SharedClock(now=lambda: wall[0])
    a, b = clock.follower(), clock.follower()
    clock.start()
    dt = 0.01
    wall[0] = 0.1
    n = a.frame_steps(dt)
    a.count(n, dt)
    b.count(b.frame_steps(dt), dt)
    assert a.steps == b.steps == 10
    wall[0] = 0.2
    a.count(a.frame_steps(dt), dt)  # b has not drawn since: a may not run ahead
    wall[0] = 0.3
    a.count(a.frame_steps(dt), dt)
    assert a.steps == 20
    wall[0] = 0.3 + SharedClock.STALL_S + 0.01  # b hidden for longer than the stall limit
    a.count(a.frame_steps(dt), dt)
    assert a.steps > 20


@pytest.mark.parametrize("variants, error, words", [
    ({"a": {}}, gw.GrassValueError, "2 to 4 views; got 1"),
    ({k: {} for k in "abcde"}, gw.GrassValueError, "2 to 4 views; got 5"),
    ({"a": {"stiffness_scale": 50}, "b": {}}, gw.ParameterError, r"variant 'a': stiffness_scale .*\[0.01, 20\]"),
    ({"a": {"stifness": 1}, "b": {}}, gw.UnknownNameError, "variant 'a'.*stiffness_scale"),
    ({"a": 3, "b": {}}, gw.GrassTypeError, "variant 'a'"),
    ([("a", {})], gw.GrassTypeError, "dict"),
])
def test_bad_variants_raise_before_any_view(monkeypatch, variants, error, words):
    import grasswidget.notebook.widget as widget_module

    def no_view(*args, **kwargs):
        raise AssertionError("a view was made for bad variants")

    monkeypatch.setattr(widget_module, "GrassWidget", no_view)
    with pytest.raises(error, match=words):
        gw.compare(variants, blades=64)


def test_browser_engine_views_follow_the_camera_the_browser_sends():
    """Browser engine, no browser: a camera the page sends for one view (a drag there) is
    given to the other; play and pause reach both views' browser models."""
    c = gw.compare(VARIANTS, blades=BLADES, size=SIZE, backend="browser")
    try:
        assert c.backend == "browser" and c.clock is None
        soft, stiff = c.widgets["soft"].view, c.widgets["stiff"].view
        heard = []
        soft.add_camera_listener(lambda view: heard.append(view))
        soft.engine_widget.camera = dict(soft.engine_widget.camera, position=[3.0, 4.0, 9.0], target=[0.5, 0.5, 0.0])
        assert np.allclose(stiff.camera_state["position"], (3.0, 4.0, 9.0))
        assert np.allclose(stiff.camera_state["target"], (0.5, 0.5, 0.0))
        assert len(heard) == 1  # the drag itself; the follower's copy did not come back
        c.pause()
        assert [w.view.engine_widget.playing for w in c.widgets.values()] == [False, False]
        c.play()
        assert [w.view.engine_widget.playing for w in c.widgets.values()] == [True, True]
    finally:
        c.close()


def test_rerunning_the_cell_closes_the_earlier_comparison_and_its_views(monkeypatch):
    """Cell A makes a comparison (displayed: it lands in the output history), runs again: the
    first comparison and both its views are closed, the new one stays open."""
    from IPython.core.interactiveshell import InteractiveShell

    from grasswidget.notebook import cell_rerun

    shell = InteractiveShell.instance()
    monkeypatch.setattr(cell_rerun, "current_cell_id", lambda: "A")
    make = ("import grasswidget as gw\n"
            f"c = gw.compare({VARIANTS!r}, blades=64, size={SIZE!r})\nc\n")
    try:
        shell.run_cell(make, store_history=True).raise_error()
        first = shell.user_ns["c"]
        shell.run_cell(make, store_history=True).raise_error()
        second = shell.user_ns["c"]
        assert first.closed and all(w.closed for w in first.widgets.values())
        assert not second.closed and not any(w.closed for w in second.widgets.values())
    finally:
        shell.user_ns["c"].close()
        shell.reset()
        InteractiveShell.clear_instance()


def test_views_that_fall_back_to_the_kernel_stay_linked():
    """A browser without WebGPU: each browser view's GrassWidget switches to kernel streaming;
    the new views keep the shared camera, follow the shared clock and step in lockstep."""
    c = gw.compare(VARIANTS, blades=BLADES, size=SIZE, backend="browser")
    try:
        c.camera_state = {"position": (2.0, 5.0, 11.0)}
        for w in c.widgets.values():  # what a page without WebGPU reports
            w.view.engine_widget.gpu_status = {"state": "unavailable", "detail": "no adapter (test)"}
        assert c.backend == "kernel" and c.clock is not None
        assert all(np.allclose(w.camera_state["position"], (2.0, 5.0, 11.0), atol=1e-5) for w in c.widgets.values())
        soft, stiff = c.widgets["soft"].view, c.widgets["stiff"].view
        soft.camera_state = {"position": (4.0, 5.0, 9.0), "target": (0.0, 0.5, 0.0), "fov_deg": 45.0}
        soft.draw()
        assert np.allclose(stiff.camera_state["position"], (4.0, 5.0, 9.0), atol=1e-5)
        c.step(24)
        for label, w in c.widgets.items():
            _assert_same_state(w.read_state(), _scene_state(w.params, 24))
    finally:
        c.close()


def test_camera_presets_move_every_view(comparison):
    """The shared camera bar's presets (c.look_from) and key r (reset_camera) move every view alike."""
    c = comparison
    home = c.camera_state
    c.look_from("top")
    top = [w.camera_state for w in c.widgets.values()]
    assert np.allclose(top[0]["position"], top[1]["position"]) and top[0]["position"][1] > home["position"][1] + 1
    c.widgets["stiff"].view.on_key({"key": "r", "modifiers": []})
    assert all(np.allclose(w.camera_state["position"], home["position"], atol=1e-5) for w in c.widgets.values())
    c.camera_floor = "ground"
    assert [w.camera_floor for w in c.widgets.values()] == ["ground", "ground"]
    with pytest.raises(gw.GrassValueError):
        c.look_from("sideways")
