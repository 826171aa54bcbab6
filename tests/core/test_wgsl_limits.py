"""The size limits checked before any user WGSL compiles (pure: no GPU).

Each submission that took a grading kernel down (issue 38) is refused here, by its text,
with the student's line and column; the teacher's solutions and the starters pass.
"""

import pytest

import grasswidget as gw
from grasswidget.core import wgsl_limits
from grasswidget.core.exercises import exercise_spec
from grasswidget.core.wgsl_overrides import FunctionOverrides, limit_problem

FORCES = exercise_spec("forces")
LAST = "return W * (fd * fr);"


def _forces_with(old, new):
    code = FORCES.solution.replace(old, new)
    assert code != FORCES.solution
    return code


def _refusal(code):
    """The ExerciseShaderError the forces exercise's checks raise for ``code``."""
    from grasswidget.core.shader_files import render_wgsl

    with pytest.raises(gw.ExerciseShaderError) as info:
        FunctionOverrides(code, FORCES.names, label="your forces code").check(render_wgsl("blade_math.wgsl"))
    return info.value


def _line_of(code, text):
    return next(k + 1 for k, row in enumerate(code.split("\n")) if text in row)


def test_the_solutions_and_starters_keep_every_limit():
    for name in gw.EXERCISES:
        spec = exercise_spec(name)
        assert limit_problem(spec.solution) is None and limit_problem(spec.starter) is None


def test_an_expression_nested_3500_deep_is_refused_at_its_line_and_column():
    nested = "(" * 3500 + "1.0" + ")" * 3500
    code = _forces_with(LAST, f"return W * (fd * fr) * {nested};")
    err = _refusal(code)
    line = _line_of(code, nested)
    row = code.split("\n")[line - 1]
    # the function's "{" is level 1 ("(fd * fr)" is closed): the 48th "(" of the run is level 49
    assert (err.line, err.column) == (line, row.index("(((") + wgsl_limits.MAX_NESTING), str(err)
    assert "nested more than 48 deep" in str(err) and err.reason == "nested too deep"
    assert len(str(err)) < 600  # the huge line is cut in the message


@pytest.mark.parametrize("terms", [600, 50_000])
def test_a_sum_of_many_terms_is_refused(terms):
    code = _forces_with(LAST, "return W * (fd * fr) * (" + " + ".join(["fr"] * terms) + ");")
    err = _refusal(code)
    if terms == 600:  # within the length limit: the statement's terms, at the statement's start
        assert err.line == _line_of(code, "fr + fr") and err.reason == "statement too long", str(err)
        assert "more than 500 names and numbers" in str(err)
    else:
        assert err.reason == "code too long" and "at most 32,768" in str(err)


def test_a_private_array_of_16m_vectors_is_refused_naming_its_size():
    code = _forces_with(LAST, "var big: array<vec4<f32>, 16777216>;\n    big[0] = vec4<f32>(W, 0.0);\n"
                              "    return big[0].xyz * (fd * fr);")
    err = _refusal(code)
    assert err.line == _line_of(code, "var big") and err.column == code.split("\n")[err.line - 1].index("array") + 1
    assert "16,777,216 elements" in str(err) and f"at most {wgsl_limits.MAX_ARRAY_ELEMENTS:,}" in str(err)


@pytest.mark.parametrize("declaration", [
    "const BIG = array<f32, 100000>();",
    "const N = 100000u;\nconst BIG = array<f32, N>();",
    "const BIG = array<array<f32, 400>, 250>();",  # nested: 100,000 in all
])
def test_a_100000_element_const_array_is_refused(declaration):
    code = _forces_with("fn wind_force", declaration + "\nfn wind_force")
    err = _refusal(code)
    assert err.line == _line_of(code, "const BIG") and "100,000 elements" in str(err), str(err)


def test_an_array_size_that_is_not_a_number_is_refused():
    code = _forces_with(LAST, "var a: array<f32, 4u * 4u>;\n    return W * (fd * fr);")
    err = _refusal(code)
    assert err.reason == "array size not a number" and "`4u * 4u`" in str(err)


def test_small_arrays_pass():
    code = _forces_with(LAST, "var a: array<vec4<f32>, 16>;\n    a[1] = vec4<f32>(W, 1.0);\n"
                              "    return a[1].xyz * (fd * fr);")
    assert limit_problem(code) is None


def test_helpers_that_double_when_inlined_are_refused_at_the_first_too_large():
    helpers = "\n".join(["fn h0(x: f32) -> f32 { return sin(x) * 1.5; }"] + [
        f"fn h{k}(x: f32) -> f32 {{ return h{k - 1}(x) + h{k - 1}(x * 0.5); }}" for k in range(1, 21)])
    code = _forces_with(LAST, "return W * (fd * fr) * h20(fd);") + "\n" + helpers + "\n"
    err = _refusal(code)
    # h0 has 9 names and numbers ("fn h0 x f32 f32 return sin x 1.5"), h_k 11 of its own and two
    # copies of h_(k-1): 20 * 2**k - 11 in all; the first over the limit is where it grows
    k = next(k for k in range(21) if 20 * 2**k - 11 > wgsl_limits.MAX_INLINED_TERMS)
    assert err.line == _line_of(code, f"fn h{k}(") and f"`h{k}` grows to {20 * 2**k - 11:,}" in str(err), str(err)
    few = _forces_with(LAST, "return W * (fd * fr) * h3(fd);") + "\n" + "\n".join(helpers.split("\n")[:4]) + "\n"
    assert limit_problem(few) is None  # a few helpers are fine


def test_comments_do_not_count():
    code = _forces_with(LAST, "// " + "(" * 100 + " array<f32, 99999999>\n    " + LAST)
    assert limit_problem(code) is None


@pytest.mark.parametrize("declarations, culprit, elements", [
    # an alias of a legal array, then an array of the alias: 1,000 x 200 vectors (1,000 x 1,000 ran a grade
    # past the worker's 60 s)
    ("alias A = array<vec4<f32>, 200>;\nvar<private> big: array<A, 1000>;\n", "var<private> big", "200,000"),
    # a struct of arrays, each under the limit: 4 x 200 in one struct (4 x 1,024 ran the worker out of memory)
    ("struct S { a: array<vec4<f32>, 200>, b: array<vec4<f32>, 200>, c: array<vec4<f32>, 200>, "
     "d: array<vec4<f32>, 200> }\n", "struct S", "800"),
    # the size through a const, the element through an alias
    ("const N = 100;\nalias Row = array<f32, N>;\nvar<private> rows: array<Row, 4>;\n", "var<private> rows", "400"),
])
def test_an_array_grown_through_an_alias_or_a_struct_is_refused_where_it_grows(declarations, culprit, elements):
    code = declarations + FORCES.solution
    err = _refusal(code)
    assert err.line == _line_of(code, culprit) and f"{elements} elements" in str(err), str(err)
    assert limit_problem(declarations) is not None


def test_many_arrays_each_small_are_refused_where_their_sum_passes_the_limit():
    # 100 const arrays of 1,024 zeros each (a compile past 60 s), the same as arrays of a named type
    per = wgsl_limits.MAX_ARRAY_ELEMENTS
    count = wgsl_limits.MAX_TOTAL_ELEMENTS // per + 1  # the first count over the total
    consts = "\n".join(f"const T{k} = array<f32, {per}>();" for k in range(count)) + "\n"
    code = consts + FORCES.solution
    err = _refusal(code)
    assert err.line == count and f"{count * per:,} elements in all" in str(err), str(err)
    named = f"alias A = array<f32, {per}>;\n" + "\n".join(f"var<private> p{k}: A;" for k in range(count)) + "\n"
    err = _refusal(named + FORCES.solution)  # the alias's own array and each variable of it
    assert err.line == count and f"{count * per:,} elements in all" in str(err), str(err)
    assert limit_problem("\n".join(consts.split("\n")[:count - 1])) is None  # one array fewer is fine


def test_small_structs_and_aliases_pass():
    code = ("struct Pair { a: vec3<f32>, b: array<f32, 8> }\nalias Pairs = array<Pair, 16>;\n"
            "var<private> pairs: Pairs;\n" + FORCES.solution)
    assert limit_problem(code) is None  # 16 x (1 + 8) = 144 elements


@pytest.mark.parametrize("body, line", [
    ("return vec3<f32>(0.0);\n}\n@group(0) @binding(17) var<storage, read_write> x: array<f32>;\nfn rest() {", 2),
    ("return vec3<f32>(0.0);\n}\n@compute @workgroup_size(1) fn other() {", 2),
    ("if (t > 1.0) { return vec3<f32>(1.0); } }\nfn more() {\nreturn;", 1),
])
def test_a_wind_body_that_closes_its_function_is_refused_at_that_brace(body, line):
    from grasswidget.core.wgsl_overrides import wind_limit_error

    err = wind_limit_error(body)
    assert isinstance(err, gw.WindShaderError) and err.line == line and err.reason == "closes user_wind", err
    assert "closes the function `user_wind`" in str(err)
    assert wind_limit_error("if (t > 1.0) { return vec3<f32>(1.0); }\n// } in a comment\nreturn vec3<f32>(0.0);") is None
