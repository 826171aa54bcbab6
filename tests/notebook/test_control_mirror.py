"""The panel described once, drawn twice: ControlMirror (marimo's rendering of the panel's
ipywidgets) against the ipywidgets themselves, without a browser (the page's messages are
fed to ``receive``; what the mirror sends is recorded)."""

from __future__ import annotations

import sys

import ipywidgets as ipw
import pytest

import grasswidget as gw
from grasswidget.notebook.control_mirror import ControlMirror, describe
from grasswidget.notebook.panel import CULL_CHECKBOXES, LOOK_SLIDERS, PARAM_SLIDERS, control_label


class RecordingMirror(ControlMirror):
    """A mirror that keeps what it would send to the page."""

    def __init__(self, root, **kwargs):
        self.sent = []
        super().__init__(root, **kwargs)

    def send(self, content, buffers=None):
        self.sent.append(content)


def _nodes(node):
    yield node
    for child in node.get("children", ()):
        yield from _nodes(child)


@pytest.fixture
def browser_widget():
    w = gw.GrassWidget(256, backend="browser", size=(320, 240))  # the kernel needs no GPU for this engine
    yield w
    w.close()


@pytest.fixture
def mirror(browser_widget):
    m = RecordingMirror(_column(browser_widget), on_error=browser_widget.panel.show_error)
    yield m
    m.close()


def _column(widget):
    """The panel column the widget shows beside its view (the GrassWidget's second child)."""
    return widget.children[1]


def _node(snapshot, kind, description):
    found = [n for n in _nodes(snapshot) if n["kind"] == kind and n.get("description") == description]
    assert len(found) == 1, (kind, description, len(found))
    return found[0]


def test_the_description_carries_every_control_with_the_traits_ranges(browser_widget):
    snap = describe(_column(browser_widget))
    traits = gw.GrassParams.class_traits()
    for name, step, fmt in (*PARAM_SLIDERS, *LOOK_SLIDERS):
        node = _node(snap, "slider", control_label(name, traits[name]))
        assert (node["min"], node["max"], node["step"]) == (traits[name].lo, traits[name].hi, step)
        assert node["readout_format"] == fmt and node["value"] == getattr(browser_widget.params, name)
    for label, name in CULL_CHECKBOXES:
        assert _node(snap, "checkbox", label)["value"] is getattr(browser_widget.params, name)
    for button in ("Pause", "Step", "Reset blades", "Reset camera", "Save PNG", "home", "top", "low", "Clear"):
        assert _node(snap, "button", button)["layout"].get("display") != "none" or button == "Pause"
    colour = _node(snap, "dropdown", control_label("color_by"))
    assert colour["labels"][colour["index"]] == browser_widget.params.color_by
    blades = _node(snap, "selection_slider", control_label("blades"))
    assert blades["labels"][blades["index"]] == f"{browser_widget.blade_count:,}"
    assert not [n for n in _nodes(snap) if n["kind"] == "unsupported"]
    assert len({n["id"] for n in _nodes(snap)}) == len(list(_nodes(snap)))  # one number per control


def test_the_page_drives_params_and_the_widget(browser_widget, mirror):
    mirror.receive({"type": "ready"})
    snap = mirror.sent[-1]["root"]
    assert mirror.sent[-1]["type"] == "snapshot"
    wind = _node(snap, "slider", control_label("wind_strength", gw.GrassParams.class_traits()["wind_strength"]))
    mirror.receive({"type": "set", "id": wind["id"], "value": 12.5})
    assert browser_widget.params.wind_strength == 12.5

    colour = _node(snap, "dropdown", control_label("color_by"))
    mirror.receive({"type": "set", "id": colour["id"], "value": colour["labels"].index("lod")})
    assert browser_widget.params.color_by == "lod"

    lod = _node(snap, "checkbox", "LOD")
    mirror.receive({"type": "set", "id": lod["id"], "value": False})
    assert browser_widget.params.lod is False

    pause = [n for n in _nodes(snap) if n["kind"] == "button" and n.get("description") == "Pause"
             and n["layout"].get("display") != "none"]
    assert browser_widget.playing
    mirror.receive({"type": "click", "id": pause[0]["id"]})
    assert browser_widget.playing is False

    chart = _node(snap, "dropdown", "chart")
    mirror.receive({"type": "set", "id": chart["id"], "value": 1})
    assert browser_widget.chart is not None and browser_widget.lab_bench.chart.hidden is False
    mirror.receive({"type": "set", "id": 10_000, "value": 1})  # an id the page kept from an older snapshot


def test_python_moves_the_page(browser_widget, mirror):
    snap = mirror.snapshot()
    wind = _node(snap, "slider", control_label("wind_strength", gw.GrassParams.class_traits()["wind_strength"]))
    mirror.sent.clear()
    browser_widget.params.wind_strength = 20.0
    patches = [m for m in mirror.sent if m["type"] == "patch" and m["id"] == wind["id"]]
    assert patches and patches[-1]["props"]["value"] == 20.0

    mirror.sent.clear()
    browser_widget.pause()  # the play button's text follows
    texts = {m["props"].get("description") for m in mirror.sent if m["type"] == "patch"}
    assert "Play" in texts

    mirror.sent.clear()
    browser_widget.panel_folded = True  # rows hidden through layout.display: the page hides them too
    assert any(m["props"]["layout"].get("display") == "none" for m in mirror.sent if m["type"] == "patch")


def test_a_refused_value_snaps_back_and_is_said(browser_widget, mirror):
    snap = mirror.snapshot()
    time = _node(snap, "slider", control_label("time_scale", gw.GrassWidget.class_traits()["time_scale"]))
    mirror.sent.clear()
    mirror.receive({"type": "set", "id": time["id"], "value": "fast"})  # not a number
    assert browser_widget.time_scale == 1.0
    assert "time" in browser_widget.panel.message_line.value and "fast" in browser_widget.panel.message_line.value
    assert [m["props"]["value"] for m in mirror.sent if m["id"] == time["id"]] == [1.0]  # the page shows 1.0 again


def test_marimo_is_optional_and_asked_only_at_display_time():
    import subprocess

    code = ("import sys, grasswidget as gw\n"
            "w = gw.GrassWidget(64, backend='browser', size=(160, 120))\n"
            "assert 'marimo' not in sys.modules, 'importing or building the widget loaded marimo'\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


def test_display_in_marimo_shows_anywidgets_only(browser_widget):
    mo = pytest.importorskip("marimo")
    html = mo.as_html(browser_widget).text  # what marimo shows (it asks the widget's display protocol)
    assert "grasswidget-marimo" in html and html.count("<marimo-anywidget") == 2  # the stage and the panel
    stage, mirror = browser_widget.marimo_parts()
    assert stage.shown == (browser_widget.view.widget, browser_widget.lab_bench.chart)  # the view, then the chart under it
    assert stage.html.count("<marimo-anywidget") == 2
    # shown again: the same
    assert browser_widget.marimo_parts() == (stage, mirror) and mirror is browser_widget.control_mirror()
    # the stage follows a new view (what the fallback to the kernel engine does to the widget's stage)
    replacement = type(browser_widget.lab_bench.chart)()
    browser_widget.children[0].children = [replacement, *browser_widget.children[0].children[1:]]
    assert stage.shown == (replacement, browser_widget.lab_bench.chart)
    replacement.close()


def test_outside_marimo_modules_go_as_text_and_a_closed_widget_shows_its_repr():
    from grasswidget.views.front_end import esm_for_front_end, running_in_marimo

    assert not running_in_marimo()  # pytest is no marimo notebook, marimo loaded or not
    assert esm_for_front_end("export default {};") == "export default {};"
    mo = pytest.importorskip("marimo")
    # the classes a message handler may make (the "auto" switch) are the plain ones outside marimo
    from grasswidget.browser.engine_widget import BrowserEngineWidget
    from grasswidget.views.front_end import class_for_front_end

    assert class_for_front_end(BrowserEngineWidget) is BrowserEngineWidget
    w = gw.GrassWidget(64, backend="browser", size=(160, 120))
    w.close()
    assert "closed" in mo.as_html(w).text


def test_the_browser_view_takes_only_a_browser_engine_widget_class(browser_widget):
    from grasswidget.views.browser import BrowserEngineView
    with pytest.raises(gw.GrassTypeError, match="widget_class must be BrowserEngineWidget or a subclass"):
        BrowserEngineView(16, (160, 120), gw.GrassParams(), host=browser_widget.engine, widget_class=ipw.HTML)


def test_a_non_widget_root_is_refused():
    with pytest.raises(gw.GrassTypeError, match="root must be an ipywidget"):
        ControlMirror(42)
    assert isinstance(ipw.HTML(), ipw.Widget)


def test_any_tree_of_the_kinds_it_knows():
    """The mirror knows kinds, not the panel: a tree of its own is drawn and driven the same way."""
    count = ipw.IntSlider(value=3, min=0, max=10, description="count")
    note = ipw.Label(value="a <b>plain</b> label")
    other = ipw.ColorPicker(value="#00ff00")
    root = ipw.VBox([ipw.HBox([count, note]), other])
    mirror = RecordingMirror(root)
    try:
        kinds = {n["kind"] for n in _nodes(mirror.snapshot())}
        assert kinds == {"box", "slider", "text", "unsupported"}
        unsupported = [n for n in _nodes(mirror.snapshot()) if n["kind"] == "unsupported"]
        assert unsupported[0]["class_name"] == "ColorPicker"
        slider = _node(mirror.snapshot(), "slider", "count")
        mirror.receive({"type": "set", "id": slider["id"], "value": 6.7})
        assert count.value == 7  # an IntSlider takes the nearest integer
        mirror.sent.clear()
        root.children = [count]  # a box's children change: a new snapshot of the whole tree
        assert [m["type"] for m in mirror.sent] == ["snapshot"]
        assert mirror.node_count == 2
    finally:
        mirror.close()
