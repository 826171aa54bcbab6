"""The coverage of the exercise cases, shown: plausible wrong solutions a student writes, each
with the case that catches it, graded in the real passes (lavapipe here).

Each row of MISTAKES is one edit of the teacher's solution (old text -> new text) that a
student could plausibly make, the function it breaks and the case the grader must name
among the failing ones. Rows of one exercise that break different functions are graded
together in one submission (the grader grades each function alone, the others stock), so the
whole table costs a few grades, not one per row. A mistake no case catches belongs in
docs/teaching.md's "Known limits" (checked below).
"""

import collections
import functools

import pytest

import grasswidget as gw

Mistake = collections.namedtuple("Mistake", "key exercise function what old new case")

_CLIP = "return !(abs(c.x) <= lim && abs(c.y) <= lim && c.z >= 0.0 && c.z <= c.w);"
_ORIENT = "return abs(dot(normalize(v0 - cam_pos), t1)) > threshold;"
_KEEP = "let keep = ceil(f32(buckets) * max(1.0 - d_ground / d_max, 0.0));"

MISTAKES = [
    # ---- forces: environmental_gravity
    Mistake("gravity-point-reversed", "forces", "environmental_gravity", "point gravity pushes away (v0 - center)",
            "d = center - v0;", "d = v0 - center;", "point gravity"),
    Mistake("gravity-upwards", "forces", "environmental_gravity", "wrong gravity direction (sign flipped)",
            "return d / max(length(d), 1e-12) * magnitude;", "return -d / max(length(d), 1e-12) * magnitude;",
            "calm"),
    Mistake("gravity-along-y", "forces", "environmental_gravity", "direction parameter ignored: (0, -g, 0)",
            "return d / max(length(d), 1e-12) * magnitude;", "return vec3<f32>(0.0, -magnitude, 0.0);",
            "noise gusts on a slope"),
    # ---- forces: front_gravity
    Mistake("front-along-gravity", "forces", "front_gravity", "front gravity along gE instead of the front f",
            "return factor * length(g_env) * f;", "return factor * g_env;", "calm"),
    Mistake("front-fixed-quarter", "forces", "front_gravity", "the paper's 1/4 hard-coded instead of factor",
            "return factor * length(g_env) * f;", "return 0.25 * length(g_env) * f;", "point gravity"),
    Mistake("front-no-factor", "forces", "front_gravity", "factor left out",
            "return factor * length(g_env) * f;", "return length(g_env) * f;", "calm"),
    # ---- forces: wind_force
    Mistake("wind-no-alignment", "forces", "wind_force", "directional alignment fd left out",
            "return W * (fd * fr);", "return W * fr;", "gusts"),
    Mistake("wind-no-abs", "forces", "wind_force", "fd without abs(): 1 - dot instead of 1 - |dot|",
            "let fd = 1.0 - abs(dot(W / strength, normalize(v2 - v0)));",
            "let fd = 1.0 - dot(W / strength, normalize(v2 - v0));", "gusts"),
    Mistake("wind-divide-by-zero", "forces", "wind_force", "a division by zero (/ 0.0)",
            "let fr = dot(v2 - v0, up) / height;", "let fr = dot(v2 - v0, up) / 0.0;", "gusts"),
    # ---- forces: integrate_tip
    Mistake("explicit-euler", "forces", "integrate_tip", "the paper's explicit Euler step",
            "return v2 + dt * (accel + recovery) / (1.0 + stiffness * dt);", "return v2 + dt * (accel + recovery);",
            "stiff"),
    Mistake("recovery-sign", "forces", "integrate_tip", "recovery pushes away from rest (v2 - iv2)",
            "let recovery = stiffness * (iv2 - v2);", "let recovery = stiffness * (v2 - iv2);", "calm"),
    Mistake("dt-squared", "forces", "integrate_tip", "dt squared (position from an acceleration)",
            "return v2 + dt * (accel + recovery) / (1.0 + stiffness * dt);",
            "return v2 + dt * dt * (accel + recovery) / (1.0 + stiffness * dt);", "calm"),
    # ---- validation
    Mistake("ground-max", "validation", "validate_ground", "max instead of min: every tip pulled to the ground",
            "return v2 - up * min(dot(up, v2 - v0), 0.0);", "return v2 - up * max(dot(up, v2 - v0), 0.0);", "calm"),
    Mistake("ground-world-y", "validation", "validate_ground", "the world's y axis instead of the blade's up",
            "return v2 - up * min(dot(up, v2 - v0), 0.0);",
            "return vec3<f32>(v2.x, max(v2.y, v0.y), v2.z);", "lying flat"),
    Mistake("v1-no-floor", "validation", "validate_v1", "the 0.05 floor of eq. 7 left out",
            "return v0 + up * (height * max(1.0 - ratio, 0.05 * max(ratio, 1.0)));",
            "return v0 + up * (height * (1.0 - ratio));", "lying flat"),
    Mistake("v1-no-projection", "validation", "validate_v1", "l_proj as |v2 - v0| (not projected on the ground)",
            "let l_proj = length(d - up * dot(d, up));", "let l_proj = length(d);", "calm"),
    Mistake("v1-no-height", "validation", "validate_v1", "height factor left out",
            "return v0 + up * (height * max(1.0 - ratio, 0.05 * max(ratio, 1.0)));",
            "return v0 + up * max(1.0 - ratio, 0.05 * max(ratio, 1.0));", "calm"),
    Mistake("length-chord", "validation", "validate_length", "L = L0 (the chord) instead of (2 L0 + L1) / 3",
            "let r = height / max((2.0 * l0 + l1) / 3.0, 1e-12);", "let r = height / max(l0, 1e-12);", "calm"),
    Mistake("length-ratio-inverted", "validation", "validate_length", "r = L / h instead of h / L",
            "let r = height / max((2.0 * l0 + l1) / 3.0, 1e-12);", "let r = max((2.0 * l0 + l1) / 3.0, 1e-12) / height;",
            "calm"),
    Mistake("length-mean", "validation", "validate_length", "L = (L0 + L1) / 2 instead of (2 L0 + L1) / 3",
            "let r = height / max((2.0 * l0 + l1) / 3.0, 1e-12);", "let r = height / max((l0 + l1) / 2.0, 1e-12);",
            "calm"),
    # ---- culling: orientation_cull
    Mistake("orientation-no-abs", "culling", "orientation_cull", "no abs(): only one side's edge-on blades culled",
            _ORIENT, "return dot(normalize(v0 - cam_pos), t1) > threshold;", "low, edge-on"),
    Mistake("orientation-flipped", "culling", "orientation_cull", "< instead of >: the blades facing the eye culled",
            _ORIENT, "return abs(dot(normalize(v0 - cam_pos), t1)) < threshold;", "overview"),
    Mistake("orientation-not-normalized", "culling", "orientation_cull", "view direction not normalized",
            _ORIENT, "return abs(dot(v0 - cam_pos, t1)) > threshold;", "overview"),
    # ---- culling: frustum_cull
    Mistake("frustum-no-z", "culling", "frustum_cull", "no depth test (0 <= z <= w left out)",
            _CLIP, "return !(abs(c.x) <= lim && abs(c.y) <= lim);", "eye at a tip"),
    Mistake("frustum-opengl-depth", "culling", "frustum_cull", "OpenGL's depth range |z| <= w",
            _CLIP, "return !(abs(c.x) <= lim && abs(c.y) <= lim && abs(c.z) <= c.w);", "eye at a tip"),
    Mistake("frustum-root-only", "culling", "frustum_cull", "only v0 tested",
            "return outside_view(v0, view_proj, tol) && outside_view(m, view_proj, tol) && outside_view(v2, view_proj, tol);",
            "return outside_view(v0, view_proj, tol);", "overview"),
    # ---- culling: distance_cull
    Mistake("distance-off-by-one", "culling", "distance_cull", "> instead of >= (one bucket too many kept)",
            "return f32(id % buckets) >= keep;", "return f32(id % buckets) > keep;", "overview"),
    Mistake("distance-floor", "culling", "distance_cull", "floor instead of ceil",
            _KEEP, "let keep = floor(f32(buckets) * max(1.0 - d_ground / d_max, 0.0));", "overview"),
    Mistake("distance-3d", "culling", "distance_cull", "the 3D distance instead of the distance on the ground",
            "let d_ground = length(d - up * dot(d, up));", "let d_ground = length(d);", "overview"),
]

#: Mistakes no case catches (named in docs/teaching.md's known limits); empty when every one is caught.
UNCAUGHT = {}


def _batches():
    """{exercise: [[Mistake, ...], ...]}: each batch breaks each function at most once."""
    out = collections.defaultdict(list)
    for m in MISTAKES:
        for batch in out[m.exercise]:
            if all(other.function != m.function for other in batch):
                batch.append(m)
                break
        else:
            out[m.exercise].append([m])
    return out


def _batch_of(mistake):
    for k, batch in enumerate(_batches()[mistake.exercise]):
        if mistake in batch:
            return k, batch
    raise AssertionError(mistake)


@functools.cache
def _report(exercise, k):
    """The grade of batch k of ``exercise``: the solution with every edit of the batch."""
    ex = gw.exercise(exercise)
    code = ex.solution()
    for m in _batches()[exercise][k]:
        assert code.count(m.old) == 1, m.key
        code = code.replace(m.old, m.new)
    return ex.grade(code)


def test_the_table_is_large_and_every_row_is_a_real_edit():
    assert len(MISTAKES) >= 25 and len({m.key for m in MISTAKES}) == len(MISTAKES)
    for m in MISTAKES:
        ex = gw.exercise(m.exercise)
        assert m.function in ex.functions and m.old in ex.solution() and m.old != m.new, m.key
        assert m.case in [c.name for c in ex.spec.cases()], m.key
    assert sum(len(b) for bs in _batches().values() for b in bs) == len(MISTAKES)
    assert sum(len(bs) for bs in _batches().values()) <= 9  # grades the table costs


@pytest.mark.slow
@pytest.mark.parametrize("mistake", MISTAKES, ids=[m.key for m in MISTAKES])
def test_each_mistake_is_caught_by_its_case(mistake):
    k, batch = _batch_of(mistake)
    report = _report(mistake.exercise, k)
    assert sorted(report.failed) == sorted(m.function for m in batch), str(report)
    grade = report[mistake.function]
    assert mistake.case in grade.failed_cases, (mistake.key, grade.failed_cases, str(report))
    assert grade.failure and grade.failure["case"] in grade.failed_cases
    assert f'"{mistake.case}"' in str(report)


def test_the_mistakes_no_case_catches_are_named_in_the_docs():
    from pathlib import Path

    text = (Path(__file__).parents[2] / "docs" / "teaching.md").read_text(encoding="utf-8")
    assert "## Known limits" in text and f"a table of {len(MISTAKES)} plausible wrong solutions" in text
    for what in UNCAUGHT.values():
        assert what in text
