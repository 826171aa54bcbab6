"""The lab bench in the kernel engine: w.traces() against a GrassScene stepped the same steps,
the sampling rule, the rolling window, save_traces, and the chart trait and its dropdown."""

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.core.teaching import INSPECTED_BLADE_COLORS
from grasswidget.core.traces import load_traces
from conftest import WIDGET_SIZE

pytest.importorskip("ipywidgets")
pytest.importorskip("jupyter_rfb")

IDS = [3, 100, 777]


def _show(w):
    w.canvas.handle_event({"event_type": "resize", "width": WIDGET_SIZE[0], "height": WIDGET_SIZE[1],
                           "pixel_ratio": 1.0})


def test_traces_equal_a_scene_stepped_the_same_steps(widget):
    _show(widget)
    widget.params.wind_strength = 25.0
    widget.inspect(IDS)
    widget.step(7)
    widget.view.draw()
    widget.play()
    frames = 4
    for _ in range(frames):
        widget.view.draw()  # each frame while playing advances steps_per_frame steps and takes a sample
    widget.step(5)
    widget.view.draw()
    widget.view.draw()  # a redraw without time passing adds no sample
    tr = widget.traces()
    steps = tr["step"]
    assert len(steps) == 1 + frames + 1 and np.all(np.diff(steps) > 0)
    assert steps[0] == 7 and steps[-1] - steps[-2] == 5
    np.testing.assert_allclose(tr["t"], steps * widget.params.dt, rtol=1e-9)
    assert list(tr["ids"]) == IDS and tr["v2"].shape == (len(steps), 3, 3)

    scene = gw.GrassScene(widget.view.blades, size=WIDGET_SIZE, params=widget.params.copy())
    try:
        done = 0
        heights = widget.view.blades.height[IDS]
        for k, s in enumerate(steps):
            scene.step(int(s) - done)
            done = int(s)
            want = scene.field.read_state()["v2"][IDS]
            err = np.abs(tr["v2"][k] - want).max(axis=-1)
            assert np.all(err <= 1e-4 * heights), (k, s, err)
    finally:
        scene.release()
    # the derived numbers, from the recorded points
    state0 = widget.view.blades.rest_state()
    rest = state0["v0"][IDS] + state0["up"][IDS] * heights[:, None]
    np.testing.assert_allclose(tr["tip_offset"][-1], np.linalg.norm(tr["v2"][-1] - rest, axis=-1), atol=1e-6)
    assert np.all(tr["tip_offset"][-1] > 0.01)  # the wind bent them
    assert np.all((tr["bend_deg"] > 0) & (tr["bend_deg"] < 90))
    assert np.all(tr["force"]["gravity"] > 9.7) and np.all(tr["force"]["wind"] > 0)
    np.testing.assert_array_equal(tr["collision"], 0.0)  # no ball
    # whole-field numbers: the GPU's drawn count, and every test keeps no more than the one before
    kept = tr["kept"]
    # (the non-blocking stats lag a frame or two: the count of a frame a step or two away)
    assert abs(kept["occlusion"][-1] - widget.scene.stats.visible) <= 0.02 * widget.scene.stats.visible
    assert np.isfinite(kept["distance"][1:]).all()  # (the first frame's GPU counts may not be read back yet: NaN)
    for a, b in zip(("orientation", "frustum", "distance"), ("frustum", "distance", "occlusion")):
        assert not np.any(kept[a] < kept[b]), (a, b)
    assert kept["orientation"][-1] < widget.blade_count
    np.testing.assert_array_equal(tr["drawn"]["ribbons"] + np.nan_to_num(tr["drawn"]["compute"]), kept["occlusion"])


def test_every_step_call_is_sampled_whether_or_not_a_frame_is_drawn(widget):
    """Issue 37, item 1: a loop of step(n) calls with no frame drawn (a script, nbclient, a view at
    rest, one cell) gives one sample per call, each equal to a GrassScene stepped alike; its
    forces are the inspector's of a render; a frame drawn later at the same step count replaces
    the last sample (no duplicate) and adds the frame's counts."""
    widget.params.wind_strength = 25.0
    widget.inspect(IDS)
    for _ in range(6):
        widget.step(20)  # no view.draw(): nothing is drawn
    tr = widget.traces()
    assert list(tr["step"]) == [20, 40, 60, 80, 100, 120] and list(tr["ids"]) == IDS
    # no frame measured these samples: the GPU's counts and the frame times are unknown, not stale
    assert np.all(np.isnan(tr["drawn"]["ribbons"])) and np.all(np.isnan(tr["kept"]["distance"]))
    assert np.all(np.isnan(tr["frame_ms"]["render"]))
    scene = gw.GrassScene(widget.view.blades, size=WIDGET_SIZE, params=widget.params.copy())
    try:
        heights = widget.view.blades.height[IDS]
        for k in range(6):
            scene.step(20)
            err = np.abs(tr["v2"][k] - scene.field.read_state()["v2"][IDS]).max(axis=-1)
            assert np.all(err <= 1e-4 * heights), (k, err)
        scene.inspect(IDS)
        scene.render()  # the inspector's numbers of a render, for the same state
        rows = scene.read_inspected()
        for name in ("gravity", "recovery", "wind"):
            want = [np.linalg.norm(r[name]) for r in rows]
            np.testing.assert_allclose(tr["force"][name][-1], want, rtol=1e-4, atol=1e-5)
    finally:
        scene.release()
    _show(widget)
    version = widget.lab_bench.recorder.version
    widget.view.draw()  # a frame at the same step count: its sample replaces the last one
    again = widget.traces()
    assert widget.lab_bench.recorder.version > version
    assert list(again["step"]) == list(tr["step"])
    np.testing.assert_array_equal(again["v2"], tr["v2"])
    widget.view.draw()
    assert len(widget.traces()["step"]) == 6  # a redraw adds nothing


def test_reset_and_a_new_blade_count_start_a_new_trace(widget):
    _show(widget)
    widget.inspect([1])
    widget.step(10)
    widget.view.draw()
    assert widget.traces()["step"].tolist() == [10]
    widget.reset_blades()
    widget.step(2)
    widget.view.draw()
    first = widget.traces()
    assert first["step"].tolist() == [2]
    widget.reset_blades()
    widget.step(2)  # the step count of before the reset, no frame drawn: a new trace, one sample
    again = widget.traces()
    assert again["step"].tolist() == [2]
    np.testing.assert_array_equal(again["v2"], first["v2"])
    widget.blade_count = 512
    widget.step(3)
    widget.view.draw()
    tr = widget.traces()
    assert tr["step"].tolist() == [3] and tr["ids"].tolist() == [1]  # a new field starts at rest


def test_trace_window_bounds_the_samples_and_refuses_bad_values(widget):
    _show(widget)
    assert widget.trace_window == 60.0
    widget.trace_window = 0.1
    for _ in range(8):
        widget.step(6)  # 0.05 s each
        widget.view.draw()
    t = widget.traces()["t"]
    assert t[-1] == pytest.approx(48 * widget.params.dt) and t[-1] - t[0] <= 0.1 + 1e-9 and len(t) == 3
    for bad in (0, 1e6, "long"):
        with pytest.raises(gw.GrassValueError, match=r"trace_window .* \[0.1, 3600\]"):
            widget.trace_window = bad
    assert widget.trace_window == 0.1 and len(widget.traces()["t"]) == 3


def test_save_traces_round_trip_and_bad_extension(widget, tmp_path):
    _show(widget)
    widget.inspect([8, 9])
    for _ in range(3):
        widget.step(4)
        widget.view.draw()
    want = widget.traces()
    for ext in (".npz", ".csv"):
        got = load_traces(widget.save_traces(tmp_path / f"t{ext}"))
        np.testing.assert_allclose(got["v2"], want["v2"], atol=0)
        np.testing.assert_array_equal(got["step"], want["step"])
        np.testing.assert_allclose(got["kept"]["frustum"], want["kept"]["frustum"])
    with pytest.raises(gw.GrassValueError, match=r"path must end in \.csv or \.npz"):
        widget.save_traces(tmp_path / "t.xlsx")


def test_chart_trait_dropdown_and_series(widget):
    _show(widget)
    bench = widget.lab_bench
    assert widget.chart is None and bench.chart.layout.display == "none"
    assert bench.dropdown.value == "none" and bench.dropdown.label == "none"
    widget.inspect([5, 6])
    widget.step(3)
    widget.view.draw()
    widget.chart = "tip"
    assert bench.dropdown.value == "tip" and bench.chart.layout.display is None
    data = bench.chart.data
    assert [s["label"] for s in data["series"]] == ["blade 5", "blade 6"]
    assert [s["color"] for s in data["series"]] == INSPECTED_BLADE_COLORS[:2]
    assert data["x"] == [pytest.approx(3 * widget.params.dt)]
    # a newly inspected blade gets its series at the next sample
    widget.inspect([5, 6, 40])
    widget.step(2)
    widget.view.draw()
    widget.view.draw()
    data = bench.chart.data
    assert [s["label"] for s in data["series"]] == ["blade 5", "blade 6", "blade 40"]
    assert data["series"][2]["values"][0] is None and data["series"][2]["values"][-1] > 0
    assert len(data["x"]) == 2
    # bad names: the project's error, naming what is allowed; nothing changes
    for bad in ("pie", 3, ""):
        with pytest.raises(gw.GrassValueError, match="chart must be None or one of 'tip', 'bend', 'culling', 'frame'"):
            widget.chart = bad
    assert widget.chart == "tip"
    bench.dropdown.value = "culling"
    assert widget.chart == "culling" and bench.chart.data["y_label"] == "blades kept"
    widget.chart = None
    assert bench.chart.layout.display == "none" and bench.dropdown.value == "none"
    bench.dropdown.value = "bend"
    assert widget.chart == "bend"
    bench.dropdown.value = "none"
    assert widget.chart is None


def test_chart_updates_are_bounded_while_playing(widget):
    _show(widget)
    widget.chart = "frame"
    pushes = []
    widget.lab_bench.chart.observe(lambda c: pushes.append(c), names="data")
    widget.play()
    frames = 12
    import time

    t0 = time.perf_counter()
    for _ in range(frames):
        widget.view.draw()
    elapsed = time.perf_counter() - t0
    assert len(widget.traces()["t"]) == frames
    assert 1 <= len(pushes) <= 1 + elapsed * 5.0 + 1
    widget.pause()  # the newest samples reach the chart when playing stops
    assert widget.lab_bench.chart.data["x"][-1] == pytest.approx(widget.traces()["t"][-1])


def test_the_panel_marks_each_inspected_blade_in_its_chart_colour(widget):
    _show(widget)
    widget.inspect([5, 6])
    widget.step(1)
    widget.view.draw()
    html = widget.panel.inspect_line.value
    assert html.index(INSPECTED_BLADE_COLORS[0]) < html.index("blade 5") < html.index(INSPECTED_BLADE_COLORS[1]) \
        < html.index("blade 6")


def test_collision_strength_is_the_blades_stored_factor_under_a_ball(widget):
    _show(widget)
    v0 = widget.view.blades.v0
    ids = [int(i) for i in np.argsort(np.hypot(v0[:, 0], v0[:, 2]))[:2]] + [int(np.argmax(np.hypot(v0[:, 0], v0[:, 2])))]
    widget.inspect(ids)  # two blades under the ball at the centre, one at the field's edge
    widget.ball.move_to(0.0, 0.0)
    widget.ball.enabled = True
    widget.step(40)
    widget.view.draw()
    tr = widget.traces()
    want = widget.scene.field.read_state()["collision"][ids]
    np.testing.assert_allclose(tr["collision"][-1], want, atol=1e-7)
    assert np.all(tr["collision"][-1][:2] > 0.1) and tr["collision"][-1][2] == 0.0
    assert np.all(tr["force"]["collision"][-1][:2] >= 0) and tr["force"]["collision"][-1][2] == 0.0


def test_a_lab_bench_for_any_view_without_an_owner(widget):
    """Another widget (a comparison of two views) makes its own LabBench per view."""
    from grasswidget.notebook.lab_bench import LabBench

    _show(widget)
    bench = LabBench(widget.view, 200)
    try:
        widget.inspect([2])
        widget.step(3)
        widget.view.draw()
        assert bench.traces()["step"].tolist() == [3] == widget.traces()["step"].tolist()
        bench.dropdown.value = "bend"
        assert bench.kind == "bend" and bench.chart.data["series"][0]["label"] == "blade 2"
        assert widget.chart is None  # the widget's own bench is another one
    finally:
        bench.close()
    widget.step(1)
    widget.view.draw()
    assert widget.traces()["step"].tolist() == [3, 4]


def test_browser_engine_traces_wait_for_the_answers_of_a_loop_of_steps_or_say_none_can_come(monkeypatch):
    """Issue 37, item 1, browser engine: ``step(n)`` calls in one cell, then ``traces()``: the samples
    the page is asked for are waited for (its answers come while the kernel handles messages, here
    delivered by a stand-in for that wait); with no kernel to bring them (a script), traces() raises a
    BrowserTimeoutError saying how many are missing, not an empty trace, and then gives them up."""
    from grasswidget.browser import kernel_pump

    w = gw.GrassWidget(blades=gw.Blades.on_plane(256, seed=5), size=(64, 48), backend="browser")
    try:
        page = w.view.engine_widget
        asked = []
        monkeypatch.setattr(page, "send", lambda content, *a, **k: asked.append(content))
        for _ in range(3):
            w.step(20)
        reads = [m for m in asked if m.get("type") == "read_inspected"]
        assert len(reads) == 3
        with pytest.raises(gw.BrowserTimeoutError, match=r"traces\(\): 3 sample") as info:
            w.traces()  # no kernel: none can come
        assert isinstance(info.value, TimeoutError)
        assert len(w.traces()["t"]) == 0  # given up: the next call returns what was recorded
        page.handle_message({"type": "inspected", "id": reads[0]["id"], "n": 0, "step_count": 20}, [])
        assert len(w.traces()["t"]) == 0  # a late answer of a sample given up is dropped

        asked.clear()
        for _ in range(3):
            w.step(20)
        reads = [m for m in asked if m.get("type") == "read_inspected"]

        def answering_wait(check, timeout, what):  # the page answers, in order, while the kernel waits
            assert "traces()" in what and timeout > 0
            for k, m in enumerate(reads):
                page.handle_message({"type": "inspected", "id": m["id"], "n": 0, "step_count": 80 + 20 * k}, [])
            return check()

        monkeypatch.setattr(kernel_pump, "wait_for", answering_wait)
        assert w.traces()["step"].tolist() == [80, 100, 120]
    finally:
        w.close()
