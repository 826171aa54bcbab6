"""``gw.compare(...)`` and ``ex.compare(code)`` in marimo, without a browser: what marimo shows is
anywidgets only (marimo draws no ipywidgets container), and the shared panel, drawn by the
ControlMirror, drives every view (the page's messages are fed to the mirror's ``receive``).
The page itself (marimo run, Chromium) is ``tests/e2e/test_marimo.py``."""

from __future__ import annotations

import pytest

import grasswidget as gw
from grasswidget.notebook.panel import control_label

mo = pytest.importorskip("marimo")

SIZE = (160, 120)


def _nodes(node):
    yield node
    for child in node.get("children", ()):
        yield from _nodes(child)


def test_a_comparison_shows_in_marimo_and_its_panel_drives_both_views():
    c = gw.compare({"soft": {"stiffness_scale": 1.0}, "stiff": {"stiffness_scale": 3.0}}, blades=64, size=SIZE,
                   backend="browser")  # the kernel needs no GPU for this engine
    try:
        text = mo.as_html(c).text  # marimo asks the display protocol, as for a GrassWidget
        assert "not supported" not in text and "grasswidget-compare" in text
        columns, panel = c.marimo_parts()
        assert text.count("<marimo-anywidget") == 3 * len(c.widgets) + 1  # label, stage, status per view; the panel
        assert [stage for _head, stage, _status in columns] == [w.marimo_stage() for w in c.widgets.values()]
        for (_head, stage, _status), w in zip(columns, c.widgets.values()):
            assert stage.shown[0] is w.view.widget  # each view's own canvas
        assert c.marimo_parts() == (columns, panel)  # shown again: the same anywidgets
        heads = [n.get("value", "") for head, _stage, _status in columns for n in _nodes(head.snapshot())]
        assert any("soft" in h and "stiffness_scale = 1" in h for h in heads)
        assert any("stiff" in h and "stiffness_scale = 3" in h for h in heads)

        label = control_label("wind_strength", gw.GrassParams.class_traits()["wind_strength"])
        wind = [n for n in _nodes(panel.snapshot()) if n["kind"] == "slider" and n.get("description") == label]
        assert len(wind) == 1
        panel.receive({"type": "set", "id": wind[0]["id"], "value": 17.0})  # the page moves the shared slider
        assert c.params.wind_strength == 17.0
        assert [w.params.wind_strength for w in c.widgets.values()] == [17.0, 17.0]
        play = [n for n in _nodes(panel.snapshot()) if n["kind"] == "button" and n.get("description") == "Pause"]
        assert play and c.playing
        panel.receive({"type": "click", "id": play[0]["id"]})  # the camera bar's Pause: every view pauses
        assert not c.playing and not any(w.playing for w in c.widgets.values())
    finally:
        c.close()
    assert "closed" in mo.as_html(c).text


@pytest.mark.slow
def test_an_exercise_comparison_shows_in_marimo_in_both_engines():
    ex = gw.exercise("forces")
    c = ex.compare(ex.starter, blades=64, size=SIZE)  # the kernel engine: a gw.compare comparison
    try:
        text = mo.as_html(c).text
        assert "not supported" not in text and text.count("<marimo-anywidget") == 7
        columns, _panel = c.marimo_parts()
        # each stage shows the view's jupyter-rfb canvas (an anywidget), as a GrassWidget alone does
        assert [stage.shown[0] for _h, stage, _s in columns] == [w.view.widget for w in c.widgets.values()]
    finally:
        c.close()
    row = ex.compare(ex.starter, blades=64, size=SIZE, backend="browser")
    try:
        text = mo.as_html(row).text
        assert "not supported" not in text
        assert list(row.widgets) == ["yours", "reference"] and "yours" in text and "reference" in text
        assert text.count("grasswidget-marimo") == 3  # the row, and each widget as marimo shows it alone
        assert text.count("<marimo-anywidget") == 4   # stage and panel of each
        assert row.widgets["yours"].marimo_stage().shown[0] is row.widgets["yours"].view.widget
    finally:
        row.close()
    assert all(w.closed for w in row.widgets.values())


def test_a_closed_row_shows_its_text_in_marimo_instead_of_raising():
    from grasswidget.notebook.compare import SideBySide  # what ex.compare(code, backend="browser") returns

    row = SideBySide({title: gw.GrassWidget(blades=64, size=SIZE, backend="browser")
                      for title in ("yours", "reference")})  # the browser engine: no GPU needed in the kernel
    try:
        assert not row.closed and "<marimo-anywidget" in mo.as_html(row).text
    finally:
        row.close()
    assert row.closed and repr(row) == "<SideBySide yours, reference: closed>"
    text = mo.as_html(row).text  # was WidgetClosedError from inside marimo's display
    assert "SideBySide yours, reference: closed" in text.replace("&lt;", "<") and "<marimo-anywidget" not in text
