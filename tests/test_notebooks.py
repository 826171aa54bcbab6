"""Every notebook in notebooks/ runs top to bottom headless (nbclient), without errors.

Each notebook is copied into a temporary folder and run there (files it writes,
PNGs and GIFs, land in that folder). The kernel is "python3", which ipykernel
resolves to the interpreter running the tests (the venv's); a probe cell appended
to each copy checks that. Headless, widgets have no view: the jupyter canvas
never gets a size or a draw request, and the notebooks draw offscreen.
"""

import shutil
import sys
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")
pytest.importorskip("ipykernel")
pytest.importorskip("matplotlib")

ROOT = Path(__file__).resolve().parent.parent
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))
PROBE = "import sys as _sys; print('PREFIX=' + _sys.prefix)"


def test_there_are_notebooks():
    names = [p.stem for p in NOTEBOOKS]
    assert names[:5] == ["01_tour", "02_blade_model", "03_culling", "04_performance", "05_colliders_and_wind"], names


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
        assert (tmp_path / "tour.png").stat().st_size > 1000
        assert (tmp_path / "tour.gif").stat().st_size > 1000
    if path.stem == "05_colliders_and_wind":
        for name in ("trampled.png", "vortex.png", "planet.png"):
            assert (tmp_path / name).stat().st_size > 1000
        text = "".join(o.get("text", "") for c in nb.cells if c.cell_type == "code" for o in c.outputs)
        assert "refused: wind_wgsl line 2" in text  # the bad snippet's error names its line
