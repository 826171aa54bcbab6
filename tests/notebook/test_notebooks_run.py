"""The notebooks as files: the course's five come first, they are committed without outputs, what
they write is ignored by git, and the READMEs name no machine's folders.

Running them is ``tests/e2e/test_notebooks_run_all.py``: Run All of every notebook in
JupyterLab, its widgets alive and drawing, and what each computed (``tests/notebook_outputs.py``).
"""

import re
import shutil
import subprocess
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")

ROOT = Path(__file__).resolve().parents[2]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))


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
    """What the notebooks (and the widget's Save PNG, ``output/grass-<time>.png`` beside the
    notebook) write is ignored by git, so a run leaves no untracked files."""
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    names = _files_written_by_notebooks()
    assert {"tour.png", "tour.gif", "trampled.png"} <= names, names
    # the notebooks write into output/ (relative to notebooks/)
    candidates = [f"notebooks/output/{n}" for n in names] + ["notebooks/output/grass-20260101-120000.png"]
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
