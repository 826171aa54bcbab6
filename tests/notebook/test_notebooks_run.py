"""Every notebook in notebooks/ runs top to bottom headless (nbclient), without errors.

Each notebook is copied into a temporary folder and run there (files it writes,
PNGs and GIFs, land in that folder). The kernel is "python3", which ipykernel
resolves to the interpreter running the tests (the venv's); a probe cell appended
to each copy checks that. Headless, widgets have no view: the jupyter canvas
never gets a size or a draw request, and the notebooks draw offscreen.
"""

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")
pytest.importorskip("ipykernel")
pytest.importorskip("matplotlib")

ROOT = Path(__file__).resolve().parents[2]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))
PROBE = "import sys as _sys; print('PREFIX=' + _sys.prefix)"


def test_there_are_notebooks():
    names = [p.stem for p in NOTEBOOKS]
    assert names[:5] == ["01_tour", "02_blade_model", "03_culling", "04_performance", "05_colliders_and_wind"], names


def _files_written_by_notebooks():
    """File names in the notebooks' code that end in a picture/movie extension."""
    names = set()
    for path in NOTEBOOKS:
        nb = nbformat.read(str(path), as_version=4)
        for cell in nb.cells:
            if cell.cell_type == "code":
                names.update(re.findall(r'"([^"\n]+\.(?:png|gif|mp4|jpg|jpeg))"', cell.source))
    return names


def test_notebook_outputs_are_ignored_by_git():
    """What the notebooks (and the widget's Save PNG, ``grass-<time>.png`` next to the
    notebook) write is ignored by git, so a run leaves no untracked files."""
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    names = _files_written_by_notebooks()
    assert {"tour.png", "tour.gif", "trampled.png"} <= names, names
    # the notebooks write into output/ (relative to notebooks/)
    candidates = [f"notebooks/output/{n}" for n in names] + ["notebooks/grass-20260101-120000.png"]
    r = subprocess.run(["git", "check-ignore", "--no-index", *candidates], cwd=ROOT, capture_output=True, text=True)
    ignored = set(r.stdout.split())
    assert ignored == set(candidates), f"not ignored: {sorted(set(candidates) - ignored)}"
    # and the notebooks do name that folder for what they save
    for path in NOTEBOOKS:
        text = path.read_text()
        for name in names:
            if f'\\"{name}\\"' in text:
                assert f'out / \\"{name}\\"' in text, f"{path.name} saves {name} outside output/"


def test_readmes_name_no_machine_specific_paths():
    """READMEs and docs give paths relative to the checkout, not folders of one machine."""
    readmes = [ROOT / "README.md", ROOT / "benchmarks" / "README.md", *sorted((ROOT / "docs").glob("*.md")),
               *sorted((ROOT / "tests").rglob("README.md"))]
    for readme in readmes:
        text = readme.read_text()
        bad = re.findall(r"(?:/work/|/home/\w+|/root/|/Users/\w+|/tmp/\w+)[^\s`)]*", text)
        assert not bad, f"{readme.relative_to(ROOT)} names machine-specific paths: {bad}"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_is_stripped(path):
    nb = nbformat.read(str(path), as_version=4)
    for cell in nb.cells:
        if cell.cell_type == "code":
            assert cell.outputs == [] and cell.execution_count is None, f"{path.name}: outputs not stripped"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_runs_headless(path, tmp_path, monkeypatch):
    import os

    monkeypatch.setenv("MPLBACKEND", "module://matplotlib_inline.backend_inline")
    # the kernel imports this checkout's grasswidget even where it is not pip-installed
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    work = tmp_path / path.name
    shutil.copy(path, work)
    nb = nbformat.read(str(work), as_version=4)
    nb.cells.append(nbformat.v4.new_code_cell(PROBE))
    client = nbclient.NotebookClient(
        nb, timeout=300, kernel_name="python3", resources={"metadata": {"path": str(tmp_path)}}
    )
    client.execute()  # raises CellExecutionError with the traceback on any error
    probe = "".join(o.get("text", "") for o in nb.cells[-1].outputs if o.output_type == "stream")
    assert f"PREFIX={sys.prefix}" in probe, f"kernel ran in another environment: {probe!r}"
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs if o.output_type == "error"]
    assert not errors
    if path.stem == "01_tour":
        assert (tmp_path / "output" / "tour.png").stat().st_size > 1000
        assert (tmp_path / "output" / "tour.gif").stat().st_size > 1000
    if path.stem == "02_blade_model":  # the inspector in calm air, in wind, under a ball
        assert (tmp_path / "output" / "inspector.png").stat().st_size > 1000
        text = "".join(o.get("text", "") for c in nb.cells if c.cell_type == "code" for o in c.outputs)
        assert "against a ball" in text and "collision push" in text
    if path.stem == "03_culling":  # each test seen from above through a frozen camera, with counts
        assert (tmp_path / "output" / "culling_birdseye.png").stat().st_size > 1000
        text = "".join(o.get("text", "") for c in nb.cells if c.cell_type == "code" for o in c.outputs)
        assert "drawn per LOD class, GPU" in text and "orientation" in text
    if path.stem == "05_colliders_and_wind":
        for name in ("trampled.png", "vortex.png", "planet.png"):
            assert (tmp_path / "output" / name).stat().st_size > 1000
        text = "".join(o.get("text", "") for c in nb.cells if c.cell_type == "code" for o in c.outputs)
        assert "refused: wind_wgsl line 2" in text  # the bad snippet's error names its line
    if path.stem in ("07_exercise_forces", "08_exercise_validation", "09_exercise_culling"):
        # the starter's report is shown (not asserted in the notebook) and fails; the teacher's solution passes
        reports = [o["data"]["text/plain"] for c in nb.cells if c.cell_type == "code" for o in c.outputs
                   if o.output_type == "execute_result" and "GradeReport" in o["data"].get("text/plain", "")]
        assert len(reports) == 2 and "failed" in reports[0] and reports[1].endswith("passed>"), reports
        html = [o["data"]["text/html"] for c in nb.cells if c.cell_type == "code" for o in c.outputs
                if o.output_type == "execute_result" and "text/html" in o["data"]]
        assert "first failing blade" in html[0] and "all passed" in html[1]
    # nothing but the output folder (ignored by git) was written next to the notebook
    written = {p.name for p in tmp_path.iterdir()} - {work.name, "output", ".ipynb_checkpoints"}
    assert not written, f"{path.name} wrote {sorted(written)} next to itself; write into output/"
