"""gw.exercise in a notebook: the task shows, and the live widget runs the student's functions
(kernel engine), also after the blade count changes; bad code is refused and the widget keeps
the functions it had."""

import numpy as np
import pytest

import grasswidget as gw

SIZE = (96, 72)
#: Gravity three times too strong and pointing up: the meadow stands stiffly upright.
UPWARD = ("return d / max(length(d), 1e-12) * magnitude;", "return -3.0 * d / max(length(d), 1e-12) * magnitude;")


def test_the_task_shows_what_to_compute_with_signatures_and_units():
    ex = gw.exercise("forces")
    text = ex.task
    for needle in ("eq. 1", "fd = 1 − |normalize(W)", "fn integrate_tip(v2: vec3<f32>, iv2: vec3<f32>, stiffness: f32, "
                   "accel: vec3<f32>, dt: f32) -> vec3<f32>", "m/s²", "loops are not"):
        assert needle in text, needle
    assert "fn main(" in ex.pass_source and "tip_step(" in ex.pass_source
    assert "frustum_cull(" in gw.exercise("culling").pass_source
    with pytest.raises(gw.GrassValueError, match="'forces', 'validation', 'culling'"):
        gw.exercise("gravity")


def test_the_live_widget_runs_the_students_gravity_and_keeps_it_across_blade_counts():
    ex = gw.exercise("forces")
    wrong = ex.solution().replace(*UPWARD)
    params = gw.GrassParams(wind_strength=0.0)
    w = ex.widget(wrong, blades=256, size=SIZE, params=params)
    ref = gw.GrassWidget(blades=256, size=SIZE, params=params.copy())
    try:
        for x in (w, ref):
            x.pause()
            x.step(120)
        mine, stock = w.read_state(), ref.read_state()
        up_mine = np.mean(mine["v2"][:, 1] / mine["height"])
        up_stock = np.mean(stock["v2"][:, 1] / stock["height"])
        assert up_mine > 0.95 and up_mine > up_stock + 0.05, (up_mine, up_stock)  # upright against bent
        w.blade_count = 128  # a new field: the student's functions come along
        w.step(120)
        again = w.read_state()
        assert np.mean(again["v2"][:, 1] / again["height"]) > 0.95
        # bad code is refused with its line; the student's gravity stays in force
        broken = wrong.replace("var d = direction;", "var d = direction")
        with pytest.raises(gw.ExerciseShaderError) as info:
            w.set_function_overrides(ex.overrides(broken))
        assert info.value.line is not None
        w.reset_blades()
        w.step(120)
        assert np.mean(w.read_state()["v2"][:, 1] / w.read_state()["height"]) > 0.95
    finally:
        w.close()
        ref.close()


def test_compare_runs_yours_next_to_the_reference_in_lockstep():
    """ex.compare is a gw.compare comparison: one clock, one camera; only "yours" runs the student's code."""
    ex = gw.exercise("forces")
    c = ex.compare(ex.solution().replace(*UPWARD), blades=128, size=SIZE)
    try:
        assert list(c.widgets) == ["yours", "reference"]
        mine, ref = c.widgets["yours"], c.widgets["reference"]
        assert mine.function_overrides is not None and ref.function_overrides is None
        c.params.wind_strength = 0.0  # shared: reaches both views
        assert mine.params.wind_strength == ref.params.wind_strength == 0.0
        c.pause()
        c.reset_blades()
        c.step(120)
        up = [float(np.mean(v.read_state()["v2"][:, 1] / v.read_state()["height"])) for v in (mine, ref)]
        assert up[0] > 0.95 and up[0] > up[1] + 0.05, up
        with pytest.raises(gw.ExerciseShaderError):
            ex.compare(ex.solution().replace("var d = direction;", "var d = direction"), blades=128, size=SIZE)
    finally:
        c.close()


def test_compare_in_the_browser_engine_is_two_widgets_on_one_set_of_params():
    ex = gw.exercise("culling")
    box = ex.compare(ex.starter, blades=128, size=SIZE, backend="browser")
    mine, ref = box.widgets["yours"], box.widgets["reference"]
    try:
        assert mine.params is ref.params and mine.params.color_by == "cull"
        assert mine.function_overrides is not None and ref.function_overrides is None
        assert [c.children[0].value for c in box.children] == ["<b>yours</b>", "<b>reference</b>"]
    finally:
        mine.close()
        ref.close()


def test_a_typo_in_a_notebook_shows_the_students_error_only():
    """IPython shows an ExerciseShaderError as its message: the student's line, not ~3 KB of
    the grader's and the widget's frames before it."""
    import contextlib
    import io

    from IPython.core.interactiveshell import InteractiveShell

    shell = InteractiveShell.instance(colors="NoColor")
    try:
        ex = gw.exercise("forces")
        shell.user_ns.update(ex=ex, code=ex.solution().replace("/ height;", "/ heigth;"), SIZE=SIZE)
        out = io.StringIO()
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):
            result = shell.run_cell("w = ex.widget(code, blades=64, size=SIZE)")
    finally:
        InteractiveShell.clear_instance()
    text = out.getvalue()
    assert isinstance(result.error_in_exec, gw.ExerciseShaderError)
    assert "ExerciseShaderError: your forces code line 21, column 33:" in text and "| " in text
    assert "Traceback" not in text and "kernel_view.py" not in text and len(text) < 600, text
