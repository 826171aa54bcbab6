"""One view interface (grasswidget.views.api.EngineView) that the kernel
and the browser views implement in full; the widget talks to it only."""

import ast
import inspect
import re
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("ipywidgets")

import grasswidget as gw  # noqa: E402
from grasswidget.views.browser import BrowserEngineView  # noqa: E402
from grasswidget.views.kernel import KernelView  # noqa: E402
from grasswidget.views.api import (MAX_STEPS_PER_FRAME, EngineView, ViewHost, ViewReadings, check_camera_state,  # noqa: E402
                                   reading_doc)

SIZE = (160, 120)


def _interface_members():
    return {name for name in dir(EngineView) if not name.startswith("_")}


#: The interface's public members, counted by hand: what both engines do, nothing one of them fakes.
INTERFACE = {"backend", "widget", "blades", "colliders", "attach_ball", "set_blades", "read_state", "set_wind_wgsl",
             "set_function_overrides", "readings", "step", "reset_blades", "request_draw", "camera_state",
             "add_camera_listener", "accept_camera", "reset_camera", "set_options", "inspect", "read_inspected",
             "snapshot", "stats", "refresh_stats", "on_key", "close"}


def test_the_interface_is_narrow_and_has_no_kernel_only_member():
    """EngineView's public members are exactly INTERFACE (from 49 and 7 constructor callbacks): no
    kernel-only member (scene, canvas, controller), no ball stand-in, no pushed play state, no time
    scale setter that does nothing, one picture call, no names of before; its constructor takes one
    host (ViewHost) instead of callbacks."""
    assert _interface_members() == INTERFACE
    for gone in ("scene", "canvas", "controller", "ball_scene", "set_playing", "set_time_scale", "save_png",
                 "save_png_later", "playback", "actions", "clock_source", "current_stats", "nominal_steps",
                 "remove_camera_listener", "look", "set_camera_floor", "set_culling_frozen", "max_fps",
                 "steps_per_frame", "sim_time", "target_fps", "render_scale", "depth_range", "orbit_limits",
                 "inspected"):
        assert not hasattr(EngineView, gone), gone
    assert list(inspect.signature(EngineView.__init__).parameters) == ["self", "size", "params", "host"]
    assert {n for n in dir(ViewHost) if not n.startswith("_")} | set(ViewHost.__annotations__) == {
        "play", "toggle_play", "step", "reset_camera", "inspect", "show_error", "show_stats", "show_inspected",
        "engine_unavailable", "engine_adapter"}


def _stub_bodies(source: str, class_name: str) -> list[str]:
    """Methods of ``class_name`` in ``source`` whose body does nothing: ``pass``, ``...``,
    ``return None`` or ``return`` (a docstring aside)."""
    cls = next(n for n in ast.walk(ast.parse(source)) if isinstance(n, ast.ClassDef) and n.name == class_name)
    found = []
    for fn in cls.body:
        if isinstance(fn, ast.FunctionDef) and not fn.name.startswith("__"):
            body = [ast.unparse(st) for st in fn.body
                    if not (isinstance(st, ast.Expr) and isinstance(st.value, ast.Constant)
                            and isinstance(st.value.value, str))]
            if body in ([], ["pass"], ["..."], ["return None"], ["return"]):
                found.append(f"{class_name}.{fn.name}")
    return found


@pytest.mark.parametrize("view_class", [KernelView, BrowserEngineView])
def test_both_views_implement_the_whole_interface_with_no_fakes(view_class):
    """Every member, in both engines, documented once in EngineView, and no method of either view
    that does nothing (the kernel's ``set_time_scale`` that passed is gone)."""
    assert issubclass(view_class, EngineView)
    assert not view_class.__abstractmethods__, f"{view_class.__name__} leaves {sorted(view_class.__abstractmethods__)}"
    for name in _interface_members():
        assert hasattr(view_class, name), name
    for name in _interface_members():
        member = inspect.getattr_static(EngineView, name)
        doc = getattr(member, "__doc__", None) if not isinstance(member, str) else "constant"
        assert name in ("backend",) or (doc and doc.strip()), f"EngineView.{name} has no docstring"
    source = Path(inspect.getsourcefile(view_class)).read_text()
    assert _stub_bodies(source, view_class.__name__) == []


def test_the_stub_check_can_fail():
    source = ("class Faked:\n"
              "    def request_draw(self):\n"
              "        pass\n"
              "    def reset_camera(self):\n"
              "        '''Nothing here.'''\n"
              "        return None\n"
              "    def look(self, p, t, f):\n"
              "        self.aim(p, t, f)\n")
    assert _stub_bodies(source, "Faked") == ["Faked.request_draw", "Faked.reset_camera"]


def test_the_widget_does_not_probe_or_reach_through_its_view():
    """No hasattr/getattr on the view in widget.py, and no view.<part>.<...> chains into a view's parts."""
    import grasswidget.notebook.widget as widget_module

    tree = ast.parse(Path(widget_module.__file__).read_text())
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in ("hasattr", "getattr"):
            if node.args and "view" in ast.unparse(node.args[0]):
                found.append(ast.unparse(node))
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Attribute) \
                and isinstance(node.value.value, ast.Attribute) and node.value.value.attr == "view" \
                and node.value.attr not in {n for n in _interface_members()}:
            found.append(ast.unparse(node))
    assert not found, found


@pytest.fixture(scope="module", params=["kernel", "browser"])
def both(request):
    w = gw.GrassWidget(256, size=SIZE, backend=request.param)
    yield w
    w.close()


def test_shared_steps_per_frame_formula(both):
    w = both
    w.time_scale = 1.0
    expected = round(1.0 * (1.0 / w.view.readings.max_fps) / w.params.dt)
    assert w.steps_per_frame == expected  # (the browser's average of its frames once it reports; none here)
    w.time_scale = 10.0
    assert w.steps_per_frame == min(round(10.0 / w.view.readings.max_fps / w.params.dt), MAX_STEPS_PER_FRAME)
    w.time_scale = 0.0
    assert w.steps_per_frame == 0
    w.time_scale = 1.0


def test_readings_are_one_read_that_agrees_with_the_widget(both):
    """``view.readings`` gathers the view's read-only figures in one value, the same the widget's
    members give, each field documented."""
    import dataclasses

    w = both
    w.inspect([3, 1])
    r = w.view.readings
    assert isinstance(r, ViewReadings)
    assert (r.max_fps, r.steps_per_frame, r.render_scale, r.inspected) == (
        w.max_fps, w.steps_per_frame, w.render_scale, w.inspected)
    assert r.target_fps == w.target_fps and 1 <= r.target_fps <= 240
    assert set(r.inspected) == {1, 3}
    near, far = r.depth_range
    assert 0 < near < far
    assert r.orbit_limits is not None
    assert (r.sim_time is None) if w.backend == "browser" else r.sim_time == w.sim_time
    w.inspect([])
    assert w.view.readings.inspected == ()
    before = w.view.readings.target_fps
    w.view.set_options()  # nothing given: nothing changes
    assert w.view.readings.target_fps == before
    w.target_fps = 30  # the widget checks it, the view takes it through set_options
    assert w.view.readings.target_fps == 30.0 == w.target_fps
    w.target_fps = before
    assert all(reading_doc(f.name) for f in dataclasses.fields(ViewReadings))


def test_shared_camera_setter(both):
    w = both
    before = w.camera_state
    w.camera_state = {"position": (1.0, 3.0, 8.0), "target": (0.0, 0.5, 0.0)}
    cam = w.camera_state
    assert np.allclose(cam["position"], (1, 3, 8)) and np.allclose(cam["target"], (0, 0.5, 0))
    assert cam["fov_deg"] == pytest.approx(before["fov_deg"], abs=1e-4)  # left out: kept
    for bad, match in (({"fov_deg": 0.5}, "fov_deg must be a number in \\[1, 179\\]"),
                       ({"position": (0, 0.5, 0)}, "must differ"), ({"zoom": 2}, "keys are"),
                       ({"target": (1, 2)}, "3 finite numbers")):
        with pytest.raises(ValueError, match=match):
            w.camera_state = bad
    assert w.camera_state == cam  # a refused state changes nothing
    w.reset_camera()
    assert np.allclose(w.camera_state["position"], before["position"], atol=1e-5)
    with pytest.raises(TypeError, match="must be a dict"):
        check_camera_state([1, 2, 3])


def test_shared_keys(both):
    """Space, s and r do the same in both engines (the browser sends its keys to Python)."""
    w = both
    w.play()

    def press(key, modifiers=()):
        if w.backend == "browser":
            w.view.engine_widget.handle_message({"type": "key", "key": key, "modifiers": list(modifiers)})
        else:
            w.view.on_key({"type": "key_down", "key": key, "modifiers": modifiers})

    press(" ")
    assert not w.playing
    press(" ", ("Control",))  # the notebook's, not ours
    assert not w.playing
    press(" ")
    assert w.playing
    press("s")
    assert not w.playing  # a step pauses
    home = w.camera_state
    w.camera_state = {"position": (2.0, 4.0, 9.0)}
    press("r")
    assert np.allclose(w.camera_state["position"], home["position"], atol=1e-5)


def _hand_written_pass_throughs(source: str, class_name: str) -> list[str]:
    """Members of ``class_name`` whose whole body (a docstring and ``self._check_open()`` aside) is
    ``self.view.<same name>``: read, called with the same arguments, or assigned."""
    found = []
    for cls in ast.walk(ast.parse(source)):
        if not (isinstance(cls, ast.ClassDef) and cls.name == class_name):
            continue
        for fn in cls.body:
            if not isinstance(fn, ast.FunctionDef):
                continue
            body = [st for st in fn.body
                    if not (isinstance(st, ast.Expr) and isinstance(st.value, ast.Constant))
                    and "_check_open" not in ast.unparse(st)]
            if len(body) != 1:
                continue
            text = ast.unparse(body[0])
            if re.fullmatch(rf"(return )?self\.view\.{fn.name}(\(.*\))?|self\.view\.{fn.name} = \w+", text):
                found.append(f"{class_name}.{fn.name}: {text}")
    return found


def test_the_widget_forwards_to_its_view_in_one_way_documented_once():
    """GrassWidget has no hand-written member that only passes to its view's member of the same name;
    those are ``ViewMember``s, whose help is the interface's text. Each interface member is documented
    in EngineView only: the kernel and browser views' own definitions carry no docstring."""
    import grasswidget.notebook.widget as widget_module
    from grasswidget.views.api import ViewMember

    assert _hand_written_pass_throughs(Path(widget_module.__file__).read_text(), "GrassWidget") == []
    forwarded = {name for name, member in vars(gw.GrassWidget).items() if isinstance(member, ViewMember)}
    assert {"read_inspected", "read_state", "inspect", "camera_state", "stats", "sim_time", "inspected"} <= forwarded
    for name in forwarded:
        member = vars(gw.GrassWidget)[name]
        interface_doc = reading_doc(name) if member.reading else inspect.getattr_static(EngineView, name).__doc__
        assert inspect.getdoc(member) == inspect.cleandoc(interface_doc)
    redocumented = []
    for view_class in (KernelView, BrowserEngineView):
        for name in _interface_members():
            own = vars(view_class).get(name)
            if (inspect.isfunction(own) or isinstance(own, property)) and own.__doc__:
                redocumented.append(f"{view_class.__name__}.{name}")
    assert not redocumented, redocumented


def test_the_pass_through_check_can_fail():
    source = ("class GrassWidget:\n"
              "    def read_inspected(self, timeout=30.0):\n"
              "        '''doc'''\n"
              "        self._check_open()\n"
              "        return self.view.read_inspected(timeout=timeout)\n"
              "    def save_png(self, path):\n"
              "        path = str(path)\n"
              "        return self.view.save_png(path)\n")
    assert _hand_written_pass_throughs(source, "GrassWidget") == [
        "GrassWidget.read_inspected: return self.view.read_inspected(timeout=timeout)"]


def test_a_view_member_of_a_closed_widget_raises():
    """After close, a forwarded method raises WidgetClosedError (as the widget's own do)."""
    w = gw.GrassWidget(64, size=SIZE, backend="browser")
    with pytest.raises(gw.ReadOnlyAttributeError, match="GrassWidget.stats can only be read"):
        w.stats = {}
    assert isinstance(w.stats, dict) and w.inspected == ()
    w.close()
    for call in (lambda: w.read_inspected(), lambda: w.inspect([0]), lambda: w.read_state(), lambda: w.play(),
                 lambda: w.pause(), lambda: w.toggle_play(), lambda: w.step(1), lambda: w.save_png("x.png")):
        with pytest.raises(gw.WidgetClosedError, match="GrassWidget is closed"):
            call()
    with pytest.raises(gw.WidgetClosedError):
        w.camera_state = {"fov_deg": 40.0}


def test_play_state_travels_on_one_channel(both):
    """The view follows its host's play state (a trait it observes): pausing the widget pauses the
    engine (the kernel's canvas draws on demand, the browser's model stops), and the browser's own
    space key sets the same trait, which the widget shows."""
    w = both

    def engine_playing():
        if w.backend == "kernel":  # its clock runs from the next frame on while playing, stops at once on pause
            w.view.draw()
            return w.view.clock.running
        return w.view.engine_widget.playing

    w.play()
    assert w.view.play is w.state and w.state.playing and engine_playing()
    w.pause()
    assert not w.state.playing and not engine_playing()
    w.state.playing = True  # the parts' channel: the widget's trait follows
    assert w.playing and engine_playing()
    w.time_scale = 2.5
    assert w.view.play.time_scale == 2.5
    if w.backend == "browser":
        assert w.view.engine_widget.time_scale == 2.5
        w.view.engine_widget.playing = False  # the page's space key
        assert not w.playing and not w.state.playing
    w.time_scale = 1.0
    w.play()


def test_a_snapshot_is_one_call_that_returns_a_future(both, tmp_path):
    """``snapshot`` returns a concurrent.futures.Future of the written path: the kernel engine's is done
    (a PNG of the asked size is there); the browser engine's waits for the page, and with no notebook
    kernel its result() says so at once (a TimeoutError naming the browser view) and nothing is written."""
    import concurrent.futures

    import imageio.v3 as iio

    w = both
    path = str(tmp_path / f"{w.backend}.png")
    future = w.view.snapshot(path, (96, 64))
    assert isinstance(future, concurrent.futures.Future)
    if w.backend == "kernel":
        assert future.done() and future.result() == path
        assert iio.imread(path).shape[:2] == (64, 96)
    else:
        assert not future.done()
        with pytest.raises(TimeoutError, match="browser view"):
            future.result(timeout=1)
        assert future.done() and not Path(path).exists()
