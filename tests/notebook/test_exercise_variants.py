"""The "derive it" variant of each exercise: the task in words (no equation, no formula in the
starter's comments), the same functions, signatures, cases, grader and answer; ``ex.examples`` shows
the reference's values on grading-case inputs (checked against the reference twins called here on
those inputs); bad arguments name the parameter and the allowed values."""

from __future__ import annotations

import re

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.core import reference as ref
from grasswidget.core.exercises import EXERCISES, VARIANTS

#: Pieces of the equations' task and starters that would give a formula away.
FORMULA = re.compile(r"normalize\(|dot\(|\bmax\(|\bmin\(|ceil|1 \+ s|1 − |/ h\b|\bl_proj\b|fd =|fr =|= \(|\|x\|")


@pytest.mark.parametrize("name", EXERCISES)
def test_the_derive_task_gives_the_physics_in_words_only(name):
    plain, derive = gw.exercise(name), gw.exercise(name, variant="derive")
    assert derive.variant == "derive" and plain.variant == "equations" and VARIANTS == ("equations", "derive")
    assert derive.functions == plain.functions and derive.signatures() == plain.signatures()
    assert derive.solution() == plain.solution() and derive.spec.make_cases is plain.spec.make_cases
    assert FORMULA.search(plain.task) and FORMULA.search(plain.starter)  # the pattern does find the formulas ...
    assert not FORMULA.search(derive.task), FORMULA.search(derive.task)  # ... and none is in the derive variant
    comments = "\n".join(line for line in derive.starter.splitlines() if line.strip().startswith("//"))
    assert not FORMULA.search(comments) and "=" not in comments.replace("==", ""), comments
    for f in derive.functions:  # every function is described, in the table too
        assert f"`{f}`" in derive.task
    assert "ex.examples" in derive.task and "derive" in repr(derive)


def test_examples_are_the_references_values_on_the_grading_cases():
    forces = gw.exercise("forces", variant="derive")
    rows = forces.examples("wind_force", count=12).rows
    assert len(rows) == 12 and len({r["case"] for r in rows}) >= 6  # spread over the cases
    assert any(np.linalg.norm(r["reference"]) > 1.0 for r in rows)  # wind that does something
    for r in rows:  # the reference twin, called here on the row's inputs, gives the row's value
        i = r["inputs"]
        value = ref.wind_force(i["W"][None], i["v0"][None], i["v2"][None], i["up"][None], np.array([i["height"]]))[0]
        np.testing.assert_allclose(r["reference"], value, rtol=1e-12, atol=1e-12)
    step = forces.examples("integrate_tip", count=3).rows
    for r in step:
        i = r["inputs"]
        value = ref.integrate_tip(i["v2"][None], i["iv2"][None], np.array([i["stiffness"]]), i["accel"][None], i["dt"])
        np.testing.assert_allclose(r["reference"], value[0], rtol=1e-12, atol=1e-12)
    culling = gw.exercise("culling", variant="derive").examples("distance_cull", count=40)
    kept = [r for r in culling.rows if not r["reference"]]
    assert kept and len(kept) < 40  # both verdicts among the examples
    for r in culling.rows:
        i = r["inputs"]
        culled = ref.distance_cull(i["v0"][None], i["up"][None], i["cam_pos"], np.array([i["id"]]), i["buckets"],
                                   i["d_max"])[0]
        assert bool(culled) == r["reference"]
    text, md = str(culling), culling.to_markdown()
    assert text.count("distance_cull(") == 40 and "true (cull)" in text and "false (keep)" in text
    assert md.count("\n|") == 41 and str(forces.examples("wind_force")) == str(forces.examples("wind_force"))


def test_bad_arguments_name_the_parameter_and_the_allowed_values():
    with pytest.raises(gw.GrassValueError, match=r"variant must be one of 'equations', 'derive'; got 'derived'"):
        gw.exercise("forces", variant="derived")
    with pytest.raises(ValueError, match="variant must be one of"):
        gw.exercise("forces", variant=None)
    ex = gw.exercise("validation", variant="derive")
    with pytest.raises(gw.GrassValueError, match=r"function must be one of validate_ground, validate_v1, "
                                                 r"validate_length; got 'wind_force'"):
        ex.examples("wind_force")
    with pytest.raises(gw.GrassTypeError, match="function must be a str"):
        ex.examples(3)
    for count in (0, 65, 2.5, True, "6"):
        with pytest.raises(gw.GrassValueError, match=r"count must be a whole number from 1 to 64"):
            ex.examples("validate_v1", count=count)
    with pytest.raises(gw.GrassTypeError, match="wgsl must be a str"):
        ex.grade(None)


@pytest.mark.slow
def test_the_derive_variant_is_graded_by_the_same_grader():
    ex = gw.exercise("validation", variant="derive")
    starter = ex.grade(ex.starter)
    assert starter.failed == list(ex.functions)
    solution = ex.grade(ex.solution())
    assert solution.passed, str(solution)
    assert ex.grade(ex.solution()) is solution  # the same code: graded once (nbgrader's test cells)
    wrong = ex.solution().replace("0.05 * max(ratio, 1.0)", "0.05")  # the floor without its growth
    assert ex.grade(wrong).failed == ["validate_v1"]
    assert ex.grade(ex.solution()) is not solution and ex.grade(ex.solution()).passed
