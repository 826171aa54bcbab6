"""The built wheel alone, installed into a fresh virtual environment, is a working grasswidget.

As a user would: build the wheel (hatchling, no editable install), make a new venv
(no system site-packages), ``pip install`` the wheel file (its dependencies come from
the package index as for anyone), then, outside the checkout, render a snapshot with
the command line, make a widget of each engine and write a live page. Also checks
the metadata a package index shows (license, classifiers, URLs, readme).
"""

from __future__ import annotations

import email
import os
import subprocess
import sys
import tarfile
import zipfile
from pathlib import Path

import pytest

from conftest import require_build_backend, require_package_index

ROOT = Path(__file__).resolve().parents[2]

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    require_build_backend()
    out = tmp_path_factory.mktemp("wheel")
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w", str(out),
                    str(ROOT)], check=True, timeout=300)
    return next(out.glob("grasswidget-*.whl"))


def _metadata(text):
    return email.message_from_string(text)


def test_wheel_metadata(wheel):
    with zipfile.ZipFile(wheel) as z:
        meta = _metadata(z.read(next(n for n in z.namelist() if n.endswith(".dist-info/METADATA"))).decode())
        names = z.namelist()
    assert meta["License-Expression"] == "MIT"
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names)
    classifiers = meta.get_all("Classifier")
    assert "Framework :: Jupyter" in classifiers and "Programming Language :: Python :: 3.11" in classifiers
    assert any(u.startswith("Paper, https://") for u in meta.get_all("Project-URL"))
    assert meta["Description-Content-Type"] == "text/markdown"
    assert "grasswidget" in meta.get_payload() and len(meta.get_payload()) > 1000  # the README is the long description
    import re

    core = {re.split(r"[<>=!~ ;\[]", r)[0] for r in meta.get_all("Requires-Dist") if "extra ==" not in r}
    assert {"pygfx", "wgpu", "jupyter-rfb", "anywidget", "ipywidgets", "numpy"} <= core, core  # no extra needed
    # the live page's parts ship inside the package
    for f in ("engine.js", "esm.py", "page.js", "page.html", "page.py"):
        assert f"grasswidget/browser/{f}" in names
    # every module of the browser engine (what engine_module_text assembles)
    from grasswidget.browser.esm import module_order

    for f in module_order():
        assert f"grasswidget/browser/{f}" in names, f
    # the lab bench's chart: its module and the vendored uPlot (nothing is fetched at run time), with its licence
    for f in ("trace_chart.js", "trace_chart.py", "vendor/uplot/uPlot.iife.min.js", "vendor/uplot/uPlot.min.css",
              "vendor/uplot/LICENSE"):
        assert f"grasswidget/browser/{f}" in names, f
    # marimo's rendering of the panel and the stage (marimo itself stays optional)
    for f in ("control_mirror.py", "control_mirror.js", "control_mirror.css", "marimo_face.py", "marimo_stage.js"):
        assert f"grasswidget/notebook/{f}" in names, f
    assert "marimo" not in core


def test_sdist_metadata_and_files(tmp_path):
    require_build_backend()
    subprocess.run([sys.executable, "-m", "hatchling", "build", "-t", "sdist", "-d", str(tmp_path)], check=True,
                   cwd=ROOT, capture_output=True, timeout=300)
    sdist = next(tmp_path.glob("grasswidget-*.tar.gz"))
    with tarfile.open(sdist) as tar:
        names = {n.split("/", 1)[1] for n in tar.getnames() if "/" in n}
        pkg_info = tar.extractfile(next(m for m in tar.getmembers() if m.name.endswith("/PKG-INFO"))).read().decode()
    assert {"LICENSE", "README.md", "pyproject.toml", "grasswidget/browser/page.js"} <= names
    assert _metadata(pkg_info)["License-Expression"] == "MIT"


def test_wheel_alone_in_a_fresh_venv(wheel, tmp_path):
    require_package_index()  # its dependencies come from the index, as for anyone
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=120)
    python = venv / "bin" / "python"
    # pip of the test interpreter installs into the new venv (pip >= 22.3: --python); --no-compile:
    # no bytecode compiled ahead for every installed package (half the install's time here; Python
    # compiles what is imported when it is imported)
    subprocess.run([sys.executable, "-m", "pip", "--python", str(python), "install", "-q", "--no-compile", str(wheel)],
                   check=True, timeout=600)
    work = tmp_path / "work"
    work.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}

    def start(*args):
        return subprocess.Popen([str(python), *args], cwd=work, env=env, stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True)

    def finish(proc):
        out, err = proc.communicate(timeout=300)
        return subprocess.CompletedProcess(proc.args, proc.returncode, out, err)

    # a widget of each engine (and where grasswidget comes from) first: it compiles the modules it
    # imports; then a snapshot and a live page with the command line, side by side
    widget = finish(start("-c", "import grasswidget as gw, sys\n"
                                "print('FILE', gw.__file__); print('PREFIX', sys.prefix)\n"
                                "k = gw.GrassWidget(256, size=(160, 120)); b = gw.GrassWidget(256, backend='browser', size=(160, 120))\n"
                                "k.step(3); print('ENGINES', k.backend, b.backend, k.scene.field.step_count)\n"
                                "k.chart = 'tip'; print('CHART', k.lab_bench.chart.data['y_label'])\n"
                                "k.close(); b.close()"))
    procs = [start("-m", "grasswidget", "snapshot", "snap.png", "--blades", "1024", "--size", "160x120",
                   "--steps", "10"),
             start("-m", "grasswidget", "html", "page.html", "--blades", "256", "--size", "160x120", "--no-still")]
    snap, page = (finish(p) for p in procs)
    assert widget.returncode == 0, widget.stderr
    probe = [line for line in widget.stdout.splitlines() if line.startswith(("FILE ", "PREFIX "))]
    assert len(probe) == 2 and all(str(venv) in line for line in probe)  # the installed copy ...
    assert str(ROOT) not in "\n".join(probe)  # ... not the checkout
    assert snap.returncode == 0, snap.stderr
    import imageio.v3 as iio

    img = iio.imread(work / "snap.png")
    rgb = img[60:, :, :3].astype(int)
    assert img.shape[:2] == (120, 160) and ((rgb[..., 1] > rgb[..., 0] + 8) & (rgb[..., 1] > rgb[..., 2] + 8)).mean() > 0.3
    assert "ENGINES kernel browser 3" in widget.stdout
    assert "CHART tip offset (cm)" in widget.stdout
    assert page.returncode == 0, page.stderr
    assert "export default" in (work / "page.html").read_text()
