"""The exercise grader on the GPU (lavapipe here): the student's WGSL in the real passes,
against the NumPy reference.

The starter never passes and the solution always does; a force scaled by 3 % or a wrong
frustum test fails naming exactly that function, with its worst blade; a compile
error names the student's line and column; a NaN fails with the word NaN.
"""

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.core.grade_report import format_value


@pytest.fixture(scope="module")
def forces():
    return gw.exercise("forces")


@pytest.mark.slow
@pytest.mark.parametrize("name", ["forces", "validation", "culling"])
def test_the_starter_fails_and_the_solution_passes(name):
    ex = gw.exercise(name)
    starter = ex.grade(ex.starter)
    assert not starter.passed and starter.failed == list(ex.functions), str(starter)
    for f in starter.functions:  # feedback a student can act on: the blade, its inputs, both values
        assert f.failure and f.failure["inputs"], str(starter)
        assert format_value(f.failure["expected"]) != format_value(f.failure["yours"]), str(starter)
    solution = ex.grade(ex.solution())
    assert solution.passed, str(solution)
    if ex.spec.kind == "simulation":
        assert max(f.max_error for f in solution.functions) < 1e-5  # float32 rounding of one step, far below the tolerance
    assert "all passed" in solution.to_html() and "fail" in starter.to_html()


SCALED = {
    # (function, the solution's line, the same line with that force 3 % stronger)
    "environmental_gravity": ("return d / max(length(d), 1e-12) * magnitude;",
                              "return d / max(length(d), 1e-12) * magnitude * 1.03;"),
    "integrate_tip": ("let recovery = stiffness * (iv2 - v2);", "let recovery = 1.03 * stiffness * (iv2 - v2);"),
    "wind_force": ("return W * (fd * fr);", "return W * (fd * fr) * 1.03;"),
}


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(SCALED))
def test_one_force_scaled_by_3_percent_fails_naming_that_force(forces, name):
    old, new = SCALED[name]
    code = forces.solution()
    assert old in code
    report = forces.grade(code.replace(old, new))
    assert report.failed == [name], str(report)
    bad = report[name]
    assert bad.verdict == "fail" and bad.max_error > 10 * bad.tolerance and bad.wrong > 0
    assert bad.failure["case"] and "inputs" in bad.failure
    assert f"FAIL  {name}" in str(report)


def test_a_compile_error_names_the_students_line_and_column(forces):
    code = forces.solution().replace("let fr = dot(v2 - v0, up) / height;", "let fr = dot(v2 - v0, up) / heigth;")
    line = code.split("\n").index("    let fr = dot(v2 - v0, up) / heigth;") + 1
    with pytest.raises(gw.ExerciseShaderError) as info:
        forces.grade(code)
    err = info.value
    assert isinstance(err, gw.GrassError) and isinstance(err, ValueError)
    column = code.split("\n")[line - 1].index("heigth") + 1
    assert err.line == line and err.column == column, str(err)
    assert f"line {line}, column {column}" in str(err) and "heigth" in str(err) and err.naga_message


def test_a_loop_is_refused_before_compiling(forces):
    code = forces.solution().replace("    let recovery = stiffness * (iv2 - v2);",
                                     "    var recovery = vec3<f32>(0.0);\n    loop { recovery += iv2; }")
    with pytest.raises(gw.ExerciseShaderError, match="loop"):
        forces.grade(code)


def test_a_nan_fails_with_the_word_nan(forces):
    """The classic slip: normalize(W) without the zero-wind check gives NaN in calm air."""
    code = forces.solution().replace("""    if (strength <= 1e-12) {
        return vec3<f32>(0.0);
    }
    let fd = 1.0 - abs(dot(W / strength, normalize(v2 - v0)));""", """    let fd = 1.0 - abs(dot(normalize(W), normalize(v2 - v0)));""")
    assert code != forces.solution()
    report = forces.grade(code)
    assert report.failed == ["wind_force"], str(report)
    bad = report["wind_force"]
    assert bad.verdict == "NaN" and bad.failure["case"] == "calm"
    assert np.isnan(bad.failure["your_value"]).all() and not np.isnan(bad.failure["reference"]).any()
    assert "NaN" in bad.headline() and "NaN" in str(report) and "NaN" in report.to_html()


@pytest.mark.slow
def test_a_wrong_frustum_test_fails_naming_it():
    ex = gw.exercise("culling")
    code = ex.solution().replace(
        "return outside_view(v0, view_proj, tol) && outside_view(m, view_proj, tol) && outside_view(v2, view_proj, tol);",
        "return outside_view(v0, view_proj, tol) || outside_view(m, view_proj, tol) || outside_view(v2, view_proj, tol);")
    assert code != ex.solution()
    report = ex.grade(code)
    assert report.failed == ["frustum_cull"], str(report)
    f = report["frustum_cull"].failure
    assert f["expected"] is False and f["yours"] is True  # kept by the reference (one point inside), culled by this


def test_the_engines_bindings_and_a_nul_are_refused_at_the_students_line(forces):
    """Before: u_sim gave a raw GPUValidationError at "wgsl:584", a NUL "Unable to find entry
    point 'probe_main'"; now both are ExerciseShaderError at the student's line, before compiling."""
    old = "let fr = dot(v2 - v0, up) / height;"
    for new, reason in (("let fr = u_sim.gravity / height;", "engine binding u_sim"),
                        ("let fr = dot(s_blades[0].xyz, up) / height;", "engine binding s_blades"),
                        ("let fr = dot(v2 - v0, up) /\x00 height;", "control character")):
        code = forces.solution().replace(old, new)
        line = code.split("\n").index("    " + new) + 1
        with pytest.raises(gw.ExerciseShaderError) as info:
            forces.grade(code)
        assert info.value.reason == reason and info.value.line == line, str(info.value)
        assert f"line {line}, column {info.value.column}" in str(info.value)


def test_pass_source_shows_where_tip_step_calls_the_forces(forces):
    src = forces.pass_source
    assert "main -> tip_step -> wind_force" in src and "main -> tip_step -> integrate_tip" in src
    assert "fn tip_step(" in src and "(from blade_math.wgsl)" in src
