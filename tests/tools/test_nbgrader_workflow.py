"""nbgrader's workflow on the exercise notebooks, as docs/teaching.md gives it to a teacher.

One course folder (the notebooks as nbgrader source, the course's ``nbgrader_config.py``):

* ``nbgrader generate_assignment "*"`` makes the student copies of all six notebooks (07-09 and their
  "derive it" variants): no line of the teacher's answer and no call that prints it is left, the code
  cell holds exactly ``ex.starter``, the task cells are read-only and the test cells give one point per
  function;
* ``nbgrader autograde forces`` grades a batch of generated submissions of 07, each in its own kernel:
  the solution (full marks), the starter (none), one function 3 % off (all but that function), one that
  loops and one with a typo (no points, the reason in the feedback: the loop's line, the misspelt name),
  and one that crashes the shader compiler (nested 3,500 deep);
* ``nbgrader export`` gives the grade table, with every student of the batch in it.

The crashing submission takes its kernel down until student code is compiled outside the kernel
(issue 38, item 1): its own test is an expected failure until then (strict=False).
"""

from __future__ import annotations

import csv
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import grasswidget as gw

pytest.importorskip("nbgrader")
nbformat = pytest.importorskip("nbformat")

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[2]
NOTEBOOKS = ROOT / "notebooks"

#: assignment -> (exercise, variant, the source notebook)
ASSIGNMENTS = {
    "forces": ("forces", "equations", NOTEBOOKS / "07_exercise_forces.ipynb"),
    "validation": ("validation", "equations", NOTEBOOKS / "08_exercise_validation.ipynb"),
    "culling": ("culling", "equations", NOTEBOOKS / "09_exercise_culling.ipynb"),
    "forces_derive": ("forces", "derive", NOTEBOOKS / "derive" / "07_exercise_forces_derive.ipynb"),
    "validation_derive": ("validation", "derive", NOTEBOOKS / "derive" / "08_exercise_validation_derive.ipynb"),
    "culling_derive": ("culling", "derive", NOTEBOOKS / "derive" / "09_exercise_culling_derive.ipynb"),
}

NESTED = "(" * 3500 + "W" + ")" * 3500
LOOP = "    var k = 0;\n    loop { k = k + 1; }\n"


def _submissions(solution: str) -> dict:
    """student -> the WGSL handed in (None: the starter left as it was)."""
    return {
        "ada": solution,
        "bob": None,
        "cy": solution.replace("return W * (fd * fr);", f"return {NESTED} * (fd * fr);"),
        "dee": solution.replace("    let recovery = stiffness * (iv2 - v2);",
                                LOOP + "    let recovery = stiffness * (iv2 - v2);"),
        "eve": solution.replace("let fr = dot(v2 - v0, up) / height;", "let fr = dot(v2 - v0, up) / heigth;"),
        "fay": solution.replace("return W * (fd * fr);", "return W * (fd * fr) * 1.03;"),
    }


def _nbgrader(course: Path, *args, timeout=900) -> subprocess.CompletedProcess:
    env = dict(os.environ)
    bin_dir = str(Path(sys.executable).parent)  # nbgrader runs alembic from the environment's bin
    env["PATH"] = bin_dir + os.pathsep + env.get("PATH", "")
    env["PYTHONPATH"] = str(ROOT) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    return subprocess.run([sys.executable, "-m", "nbgrader", *args], cwd=course, env=env, capture_output=True,
                          text=True, timeout=timeout)


def _nbgrader_meta(cell) -> dict:
    return cell.metadata.get("nbgrader", {})


@pytest.fixture(scope="module")
def course(tmp_path_factory):
    """A course folder with every exercise notebook as an assignment, and the student copies made."""
    root = tmp_path_factory.mktemp("course")
    shutil.copy(NOTEBOOKS / "nbgrader_config.py", root / "nbgrader_config.py")
    for assignment, (_name, _variant, path) in ASSIGNMENTS.items():
        (root / "source" / assignment).mkdir(parents=True)
        shutil.copy(path, root / "source" / assignment / path.name)
    made = _nbgrader(root, "generate_assignment", "*")
    assert made.returncode == 0, made.stderr[-3000:]
    return root


@pytest.fixture(scope="module")
def batch(course):
    """The submissions of 07 autograded and the grade table exported: (autograde's result, {student: row})."""
    ex = gw.exercise("forces")
    release = nbformat.read(str(course / "release" / "forces" / "07_exercise_forces.ipynb"), as_version=4)
    for student, wgsl in _submissions(ex.solution()).items():
        nb = nbformat.from_dict(release)
        if wgsl is not None:
            cell = next(c for c in nb.cells if _nbgrader_meta(c).get("grade_id") == "code")
            cell.source = 'code = """\\\n' + wgsl + '"""\n'
        folder = course / "submitted" / student / "forces"
        folder.mkdir(parents=True)
        nbformat.write(nb, str(folder / "07_exercise_forces.ipynb"))
    graded = _nbgrader(course, "autograde", "forces")
    exported = _nbgrader(course, "export")
    assert exported.returncode == 0, exported.stderr[-3000:]
    with open(course / "grades.csv", newline="") as f:
        rows = {row["student_id"]: row for row in csv.DictReader(f) if row["assignment"] == "forces"}
    return graded, rows


def _graded_cells(course, student) -> dict:
    """grade_id -> the autograded cell of ``student``'s 07."""
    nb = nbformat.read(str(course / "autograded" / student / "forces" / "07_exercise_forces.ipynb"), as_version=4)
    return {_nbgrader_meta(c)["grade_id"]: c for c in nb.cells if _nbgrader_meta(c).get("grade_id")}


def _errors(cell) -> str:
    return "\n".join(f"{o.ename}: {o.evalue}" for o in cell.get("outputs", ()) if o.output_type == "error")


@pytest.mark.parametrize("assignment", list(ASSIGNMENTS))
def test_student_copies_hold_the_starter_and_no_solution(course, assignment):
    name, variant, path = ASSIGNMENTS[assignment]
    ex = gw.exercise(name, variant)
    copy = course / "release" / assignment / path.name
    nb = nbformat.read(str(copy), as_version=4)
    text = copy.read_text()
    answer = [line.strip() for line in ex.solution().splitlines()[1:]
              if len(line.strip()) > 12 and line.strip() not in ex.starter]
    assert len(answer) >= 5
    for line in answer:  # every line of the teacher's answer is gone (the starter's own lines may stay)
        assert line not in text, f"{copy.name} keeps the answer's line {line!r}"
    assert "solution(" not in text and "BEGIN SOLUTION" not in text and "SOLUTION (teacher" not in text
    code_cells = [c for c in nb.cells if _nbgrader_meta(c).get("solution")]
    assert [_nbgrader_meta(c)["grade_id"] for c in code_cells] == ["code"]
    scope = {"ex": ex}
    exec(code_cells[0].source, scope)  # the copy's code cell runs as it is and leaves the starter to edit
    assert scope["code"] == ex.starter
    sources = "\n".join(c.source for c in nb.cells)
    assert f'gw.exercise("{name}"' in sources and (('variant="derive"' in sources) == (variant == "derive"))
    locked = [c for c in nb.cells if _nbgrader_meta(c).get("locked")]
    assert locked and all(c.metadata.get("editable") is False and c.metadata.get("deletable") is False
                          for c in locked)
    tests = {_nbgrader_meta(c)["grade_id"]: _nbgrader_meta(c)["points"] for c in nb.cells
             if _nbgrader_meta(c).get("grade")}
    assert tests == {f"test_{f}": 1 for f in ex.functions}
    for c in nb.cells:
        if _nbgrader_meta(c).get("grade"):
            assert "ex.grade(code)" in c.source and c.metadata.get("editable") is False


def test_autograde_scores_each_submission_per_function(course, batch):
    graded, rows = batch
    assert set(rows) == {"ada", "bob", "cy", "dee", "eve", "fay"}, rows
    score = {student: float(row["score"]) for student, row in rows.items()}
    assert all(float(row["max_score"]) == 4.0 for row in rows.values())
    assert score["ada"] == 4.0 and score["bob"] == 0.0 and score["dee"] == 0.0 and score["eve"] == 0.0
    assert score["fay"] == 3.0, score  # wind 3 % too strong: the other three functions keep their points

    fay = _graded_cells(course, "fay")
    assert "FAIL  wind_force" in "".join(o.get("text", "") for o in fay["test_wind_force"].outputs)
    assert "AssertionError" in _errors(fay["test_wind_force"]) and not _errors(fay["test_integrate_tip"])
    bob = _graded_cells(course, "bob")
    # feedback a student can act on: a failing blade, its case, its inputs, the reference's value and the student's
    assert re.search(r"blade: #\d+ of case .*inputs: .*reference +wind_force\(\.\.\.\) = .*your +wind_force",
                     _errors(bob["test_wind_force"]), re.S), _errors(bob["test_wind_force"])
    # the untouched student copy runs top to bottom (task, grade, live views) but for its points cells
    assert [gid for gid, c in bob.items() if _errors(c)] == [f"test_{f}" for f in gw.exercise("forces").functions]
    handed_in = _submissions(gw.exercise("forces").solution())
    for student, cause, marker in (("dee", "loops are not allowed", "loop {"), ("eve", "heigth", "heigth")):
        line = next(i for i, text in enumerate(handed_in[student].splitlines(), 1) if marker in text)
        cells = _graded_cells(course, student)
        for f in gw.exercise("forces").functions:  # the reason, with the student's line, in every test cell
            error = _errors(cells[f"test_{f}"])
            assert "ExerciseShaderError" in error and cause in error and f"line {line}," in error, error
    for student in ("ada", "bob", "dee", "eve", "fay"):
        assert (course / "autograded" / student / "forces" / "07_exercise_forces.ipynb").exists()


@pytest.mark.xfail(reason="a shader nested 3,500 deep crashes the compiler in the kernel's process until student "
                          "code is compiled outside it (issue 38, item 1)", strict=False)
def test_a_compiler_crash_is_scored_with_its_reason(course, batch):
    graded, rows = batch
    assert graded.returncode == 0, graded.stderr[-2000:]
    assert float(rows["cy"]["score"]) == 0.0
    cells = _graded_cells(course, "cy")
    assert "ExerciseShaderError" in _errors(cells["test_wind_force"])
    assert "line" in _errors(cells["test_wind_force"])


def test_the_derive_notebooks_run_with_the_teachers_answer(tmp_path):
    """The three "derive it" source notebooks (outside notebooks/'s Run All) run top to bottom, one
    after the other in one kernel (one start for three): the reference's examples and charts show,
    the answer passes every points cell."""
    from nbclient import NotebookClient

    books = {a: nbformat.read(str(ASSIGNMENTS[a][2]), as_version=4)
             for a in ("forces_derive", "validation_derive", "culling_derive")}
    together = nbformat.v4.new_notebook(metadata=books["forces_derive"].metadata)
    together.cells = [cell for nb in books.values() for cell in nb.cells]
    NotebookClient(together, timeout=300, kernel_name="python3", allow_errors=True,
                   resources={"metadata": {"path": str(tmp_path)}}).execute()
    for assignment, nb in books.items():  # the cells are the same objects, now with their outputs
        name, _variant, path = ASSIGNMENTS[assignment]
        errors = [f"{o.ename}: {o.evalue}" for c in nb.cells if c.cell_type == "code" for o in c.outputs
                  if o.output_type == "error"]
        assert not errors, f"{path.name}: {errors}"
        by_id = {_nbgrader_meta(c).get("grade_id"): c for c in nb.cells}
        tables = [o for o in by_id["examples"].outputs if "text/markdown" in o.get("data", {})]
        assert len(tables) == len(gw.exercise(name).functions)
        assert all(o["data"]["text/markdown"].count("\n|") >= 7 for o in tables)  # header, rule, 6 examples
        assert any("image/png" in o.get("data", {}) for o in by_id["charts"].outputs), f"{path.name}: no chart"
        passes = "".join(o.get("text", "") for c in nb.cells if _nbgrader_meta(c).get("grade") for o in c.outputs)
        assert passes.count("PASS  ") == len(gw.exercise(name).functions), passes
