"""FunctionOverrides: user WGSL in place of stock blade-math functions (pure Python).

The replaced shader keeps every other function, drops exactly the stock definitions
of the replaced ones and appends the user's code after one marker line, so compiler
lines map back to the user's lines; the checks made before compiling name the line
and column of what is wrong.
"""

import pytest

import grasswidget as gw
from grasswidget.core.exercises import EXERCISES, exercise_spec
from grasswidget.core.shader_files import render_wgsl
from grasswidget.core.wgsl_overrides import FunctionOverrides, parse_functions, strip_comments

BLADE_MATH = render_wgsl("blade_math.wgsl")
WIND = """// my wind
fn wind_force(W: vec3<f32>, v0: vec3<f32>, v2: vec3<f32>, up: vec3<f32>, height: f32) -> vec3<f32> {
    return W * 0.5;  // } a brace in a comment
}
"""


def test_parse_finds_every_function_and_ignores_braces_in_comments():
    names = [f.name for f in parse_functions(BLADE_MATH)]
    assert len(names) == len(set(names)) >= 50
    assert {"wind_force", "validate_length", "frustum_cull", "hzb_level"} <= set(names)
    (f,) = parse_functions(WIND)
    assert (f.name, f.line, f.column, f.end_line) == ("wind_force", 2, 1, 4)
    assert f.types == (("vec3<f32>",) * 4 + ("f32",), "vec3<f32>")
    assert strip_comments("a /* x /* y */ z */ b // c\nd").split("\n") == ["a" + " " * 19 + "b" + " " * 5, "d"]


def test_apply_replaces_exactly_the_named_functions_and_maps_lines():
    o = FunctionOverrides(WIND, ["wind_force"]).check(BLADE_MATH)
    out = o.apply(BLADE_MATH)
    before = [f.name for f in parse_functions(BLADE_MATH)]
    after = [f.name for f in parse_functions(out)]
    assert sorted(after) == sorted(before)  # one wind_force: the user's
    assert out.count("fn wind_force(") == 1 and "return W * 0.5;" in out
    lines = out.split("\n")
    first = o.first_line(out)
    assert lines[first - 1] == "// my wind" and lines[first] .startswith("fn wind_force(")
    assert o.user_line(out, first + 2) == 3 and o.user_line(out, first - 1) is None
    # a shader without the blade math is left alone
    assert o.apply("fn main() {}\n") == "fn main() {}\n"


@pytest.mark.parametrize("name", EXERCISES)
def test_only_keeps_one_function_and_the_line_numbers(name):
    spec = exercise_spec(name)
    o = FunctionOverrides(spec.solution, spec.names).check(BLADE_MATH)
    for fn in spec.names:
        one = o.only(fn)
        mine = [f.name for f in parse_functions(one.code) if f.name in spec.names]
        assert mine == [fn]
        assert len(one.code.split("\n")) == len(spec.solution.split("\n"))
        (kept,) = [f for f in parse_functions(one.code) if f.name == fn]
        (orig,) = [f for f in parse_functions(spec.solution) if f.name == fn]
        assert (kept.line, kept.end_line) == (orig.line, orig.end_line)


def _error(code, names=("wind_force",)):
    with pytest.raises(gw.ExerciseShaderError) as info:
        FunctionOverrides(code, names).check(BLADE_MATH)
    return info.value


def test_a_loop_is_refused_with_its_line_and_column():
    code = WIND.replace("    return W * 0.5;", "    var s = 0.0;\n    while (s < 1.0) { s += 0.1; }\n    return W * s;")
    err = _error(code)
    assert (err.line, err.column) == (4, 5) and "while" in str(err) and "line 4, column 5" in str(err)
    # the word in a comment or inside a name is not a loop
    FunctionOverrides(WIND.replace("// my wind", "// for the wind, loop-free").replace("W * 0.5", "W * 0.5"),
                      ["wind_force"]).check(BLADE_MATH)


def test_a_missing_function_or_a_changed_signature_is_refused():
    err = _error(WIND, ("wind_force", "integrate_tip"))
    assert "integrate_tip" in str(err) and "fn integrate_tip(v2: vec3<f32>" in str(err)
    err = _error(WIND.replace("height: f32)", "height: f32, extra: f32)"))
    assert err.line == 2 and "signature" in str(err)
    err = _error(WIND + WIND.replace("// my wind", ""))
    assert err.line == 6 and "2 times" in str(err)


def test_exercise_starters_and_solutions_have_the_stock_signatures():
    assert gw.EXERCISES == ("forces", "validation", "culling")
    for name in EXERCISES:
        spec = exercise_spec(name)
        FunctionOverrides(spec.starter, spec.names).check(BLADE_MATH)
        FunctionOverrides(spec.solution, spec.names).check(BLADE_MATH)
        assert "TODO" in spec.starter and spec.solution.startswith("// SOLUTION (teacher's answer)")
    with pytest.raises(gw.GrassValueError, match="forces"):
        exercise_spec("gravity")
