"""One view interface (grasswidget.core.view_api.EngineView) that the kernel
and the browser views implement in full; the widget talks to it only."""

import ast
import inspect
import re
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("ipywidgets")

import grasswidget as gw  # noqa: E402
from grasswidget.browser.engine_view import BrowserEngineView  # noqa: E402
from grasswidget.notebook.kernel_view import KernelView  # noqa: E402
from grasswidget.core.view_api import MAX_STEPS_PER_FRAME, EngineView, check_camera_state  # noqa: E402

SIZE = (160, 120)


def _interface_members():
    return {name for name in dir(EngineView) if not name.startswith("_")}


@pytest.mark.parametrize("view_class", [KernelView, BrowserEngineView])
def test_both_views_implement_the_whole_interface(view_class):
    assert issubclass(view_class, EngineView)
    assert not view_class.__abstractmethods__, f"{view_class.__name__} leaves {sorted(view_class.__abstractmethods__)}"
    for name in _interface_members():
        assert hasattr(view_class, name), name
    # and documented: every member of the interface says what it is
    for name in _interface_members():
        member = inspect.getattr_static(EngineView, name)
        doc = getattr(member, "__doc__", None) if not isinstance(member, str) else "constant"
        assert name in ("backend",) or (doc and doc.strip()), f"EngineView.{name} has no docstring"


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
    expected = round(1.0 * (1.0 / w.view.max_fps) / w.params.dt)
    assert w.view.nominal_steps() == expected and w.steps_per_frame == expected
    w.time_scale = 10.0
    assert w.view.nominal_steps() == min(round(10.0 / w.view.max_fps / w.params.dt), MAX_STEPS_PER_FRAME)
    w.time_scale = 0.0
    assert w.view.nominal_steps() == 0
    w.time_scale = 1.0


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
    from grasswidget.core.view_api import ViewMember

    assert _hand_written_pass_throughs(Path(widget_module.__file__).read_text(), "GrassWidget") == []
    forwarded = {name for name, member in vars(gw.GrassWidget).items() if isinstance(member, ViewMember)}
    assert {"read_inspected", "read_state", "inspect", "camera_state", "stats"} <= forwarded
    for name in forwarded:
        assert inspect.getdoc(vars(gw.GrassWidget)[name]) == inspect.getdoc(inspect.getattr_static(EngineView, name))
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


def test_a_view_member_of_a_closed_widget_raises_and_old_names_are_gone():
    """After close, a forwarded method raises WidgetClosedError (as the widget's own do); the
    attributes' names of before are gone (one name each: ``engine_widget``, ``playback``)."""

    w = gw.GrassWidget(64, size=SIZE, backend="browser")
    with pytest.raises(gw.ReadOnlyAttributeError, match="GrassWidget.stats can only be read"):
        w.stats = {}
    assert isinstance(w.stats, dict) and w.inspected == ()
    assert w.view.playback is w
    # names-rename: off (the names of before, which must be gone)
    assert not hasattr(w.view, "browser_view") and not hasattr(w.view, "clock_source")
    # names-rename: on
    w.close()
    for call in (lambda: w.read_inspected(), lambda: w.inspect([0]), lambda: w.read_state(), lambda: w.play(),
                 lambda: w.pause(), lambda: w.toggle_play(), lambda: w.step(1), lambda: w.save_png("x.png")):
        with pytest.raises(gw.WidgetClosedError, match="GrassWidget is closed"):
            call()
    with pytest.raises(gw.WidgetClosedError):
        w.camera_state = {"fov_deg": 40.0}
