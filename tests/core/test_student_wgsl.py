"""What the grader refuses in a student's WGSL before compiling, and the traps it sets (pure Python).

The engine's bindings, entry points, reserved names and control characters (a NUL included)
are refused with the student's line and column; the instrumented code wraps each divisor and
the argument of each watched call without changing what the code computes; the call paths
of ``pass_source`` are the shaders' own.
"""

import re

import pytest

from grasswidget.core.exercises import call_paths, exercise_spec, pass_source
from grasswidget.core.student_wgsl import TRAP_VAR, check_names, engine_globals, instrument
from grasswidget.errors import ExerciseShaderError

SOLUTION = exercise_spec("forces").solution


def _line_of(code, text):
    return next(k for k, line in enumerate(code.split("\n")) if text in line) + 1


@pytest.mark.parametrize("bad, where, reason", [
    ("let fr = dot(v2 - v0, u_sim.gravity_dir.xyz) / height;", "u_sim", "engine binding u_sim"),
    ("let fr = dot(s_blades[0].xyz, up) / height;", "s_blades", "engine binding s_blades"),
    ("let fr = dot(v2 - v0, up) /\x00 height;", "\x00", "control character"),
    ("let fr = dot(v2 - v0, up) / height;\x07", "\x07", "control character"),
    ("let fr = dot(v2 - v0, up) / probe_main;", "probe_main", "reserved name probe_main"),
    ("let gwtrap_x = dot(v2 - v0, up) / height; let fr = gwtrap_x;", "gwtrap_x", "reserved name gwtrap_x"),
])
def test_engine_bindings_control_characters_and_reserved_names_are_refused_at_the_line(bad, where, reason):
    code = SOLUTION.replace("let fr = dot(v2 - v0, up) / height;", bad)
    assert code != SOLUTION
    line = _line_of(code, bad[:20])
    with pytest.raises(ExerciseShaderError) as info:
        check_names(code, "your forces code")
    err = info.value
    assert isinstance(err, ValueError) and err.reason == reason
    assert err.line == line and err.column == code.split("\n")[line - 1].index(where) + 1, str(err)
    assert f"your forces code line {line}, column {err.column}" in str(err) and "\x00" not in str(err)


def test_an_entry_point_of_ones_own_is_refused_and_the_solutions_pass():
    code = SOLUTION + "\n@compute @workgroup_size(1)\nfn cheat() {}\n"
    with pytest.raises(ExerciseShaderError, match="@compute") as info:
        check_names(code)
    assert info.value.line == len(SOLUTION.split("\n")) + 1
    for name in ("forces", "validation", "culling"):
        check_names(exercise_spec(name).solution)  # no error
        check_names(exercise_spec(name).starter)
    check_names("fn f(s_eff: f32) -> f32 { let u_x = s_eff; return u_x; }  // u_sim in a comment")


def test_the_engine_bindings_are_the_shaders_globals():
    names = engine_globals()
    assert {"u_sim", "s_blades", "u_cull", "s_visible", "u_stdinfo"} <= set(names)
    assert "s_eff" not in names  # a local of blade_math.wgsl, not a binding


@pytest.mark.parametrize("expr, divisor", [
    ("a / b", "b"), ("a / b.x", "b.x"), ("a / f(x, g(y))", "f(x, g(y))"), ("a / vec3<f32>(1.0, c, 2.0)",
                                                                           "vec3<f32>(1.0, c, 2.0)"),
    ("a / -b[2].y * c", "-b[2].y"), ("a / (height - height)", "(height - height)"), ("a/b/c", "b"),
])
def test_every_divisor_is_wrapped_without_changing_its_value(expr, divisor):
    code = f"fn f() -> f32 {{\n    return {expr};\n}}\n"
    out, sites = instrument(code)
    assert sites and sites[0].kind == "division by zero" and sites[0].line == 2
    assert f"select({divisor}, {divisor}, gwtrap_hit(1u, any(({divisor}) == ({divisor}) - ({divisor}))))" in out
    assert f"var<private> {TRAP_VAR}: u32;" in out


def test_literals_calls_and_comments():
    out, sites = instrument("fn f(x: f32) -> f32 { return x / 2.0; }  // y / z")
    assert sites == [] and out == "fn f(x: f32) -> f32 { return x / 2.0; }  // y / z"
    out, sites = instrument("fn f(x: f32) -> f32 {\n  var y = x;\n  y /= x + 1.0;\n  return sqrt(y) / 0.0;\n}")
    assert [(s.kind, s.line) for s in sites] == [("division by zero", 3), ("division by zero", 4),
                                                  ("sqrt of a negative number", 4)]
    assert "gwtrap_hit(2u, true)" in out  # a literal zero traps on every call
    assert re.search(r"y /= select\(\(x \+ 1\.0\), \(x \+ 1\.0\), gwtrap_hit\(1u, ", out)
    _, sites = instrument("fn f(v: vec3<f32>) -> vec3<f32> { return normalize(v); }")
    assert sites[0].describe() == ("normalize of a zero vector at your line 1, column 42: "
                                   "`fn f(v: vec3<f32>) -> vec3<f32> { return normalize(v); }`")


def test_pass_source_shows_the_path_to_every_function_without_the_answers():
    forces = pass_source(exercise_spec("forces"))
    assert "//   main -> tip_step -> wind_force" in forces and "//   main -> environmental_gravity" in forces
    assert "// ---- tip_step (from blade_math.wgsl)" in forces and "// ---- main (from simulate.wgsl)" in forces
    assert "@compute" in forces and "fn tip_step(" in forces
    assert "fn wind_force(" not in forces and "fd * fr" not in forces  # the stock answer stays out
    validation = pass_source(exercise_spec("validation"))
    assert "main -> collision_passes -> validate_pushed -> validate_state -> validate_v1" in validation
    assert "// ---- collision_passes (from collisions.wgsl)" in validation
    culling = pass_source(exercise_spec("culling"))
    assert "//   main -> frustum_cull" in culling and "// ---- main (from cull.wgsl)" in culling
    assert call_paths("fn a() { b(); c(); }\nfn b() { c(); }\nfn c() {}", "a", ("c",)) == [("a", "c"), ("a", "b", "c")]


def test_huge_or_nested_code_is_left_alone_quickly():
    import time

    nested = "fn f(a: f32) -> f32 { return " + "a / f2(" * 3000 + "a" + ")" * 3000 + "; }"
    many = "fn f(a: f32) -> f32 { return " + " + ".join(["a / 3.0"] * 50000) + "; }"
    t = time.perf_counter()
    for code in (nested, many):
        assert instrument(code) == (code, [])
    assert time.perf_counter() - t < 1.0
    check_names(many)  # linear: no error, quickly
    assert time.perf_counter() - t < 3.0
