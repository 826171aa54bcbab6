"""The wheel ships the WGSL; the CLI renders a real PNG and refuses bad input."""

import os
import subprocess
import sys
import tarfile
import zipfile
from pathlib import Path

import pytest

from conftest import require_build_backend

ROOT = Path(__file__).resolve().parents[2]


def _shader_files():
    """The WGSL files of the source tree (grasswidget/shaders)."""
    files = sorted(p.name for p in (ROOT / "grasswidget" / "shaders").glob("*.wgsl"))
    assert {"blade_math.wgsl", "simulate.wgsl", "cull.wgsl", "blade_render.wgsl", "reset_args.wgsl"} <= set(files)
    return files


def test_shaders_live_in_the_package_only():
    """One folder: the WGSL sits inside the package, not in a second top-level folder."""
    assert not (ROOT / "shaders").exists()
    from grasswidget.core.shader_files import shader_dir, shader_names

    assert shader_dir().resolve() == (ROOT / "grasswidget" / "shaders").resolve()
    assert shader_names() == _shader_files()


def test_wheel_contains_shaders(tmp_path):
    require_build_backend()
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q", "-w", str(tmp_path), str(ROOT)],
        check=True,
    )
    wheel = next(tmp_path.glob("grasswidget-*.whl"))
    names = zipfile.ZipFile(wheel).namelist()
    for f in _shader_files():
        assert f"grasswidget/shaders/{f}" in names
    # The browser engine's ES module and its own WGSL ship too (nothing is fetched at run time).
    for f in ("engine.js", "esm.py", "std.wgsl", "balls.wgsl", "js/rules.js", "js/canvas_view.js"):
        assert f"grasswidget/browser/{f}" in names
    # an installed copy (outside the checkout) finds them
    target = tmp_path / "site"
    zipfile.ZipFile(wheel).extractall(target)
    code = ("from grasswidget.core.shader_files import shader_dir, read_shader; p = shader_dir(); print(p); "
            "assert 'site' in str(p); assert 'fn main' in read_shader('simulate.wgsl')")
    # the installed copy first; the dependencies wherever they are (a --target folder on the GPU machine,
    # tests/run_on_gpu.sh), but not this checkout
    others = [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep)
              if p and Path(p).resolve() != ROOT.resolve()]
    subprocess.run([sys.executable, "-c", code], check=True, cwd=tmp_path,
                   env={**os.environ, "PYTHONPATH": os.pathsep.join([str(target), *others])})


def test_sdist_contains_shaders(tmp_path):
    require_build_backend()
    subprocess.run([sys.executable, "-m", "hatchling", "build", "-t", "sdist", "-d", str(tmp_path)], check=True, cwd=ROOT,
                   capture_output=True)
    sdist = next(tmp_path.glob("grasswidget-*.tar.gz"))
    with tarfile.open(sdist) as tar:
        names = {n.split("/", 1)[1] for n in tar.getnames() if "/" in n}
    for f in _shader_files():
        assert f"grasswidget/shaders/{f}" in names
    assert "pyproject.toml" in names and not any(n.startswith("shaders/") for n in names)


def test_cli_snapshot(tmp_path):
    import imageio.v3 as iio

    out = tmp_path / "snap.png"
    r = subprocess.run(
        [sys.executable, "-m", "grasswidget", "snapshot", str(out), "--blades", "2048", "--size", "160x90", "--steps", "20"],
        capture_output=True, text=True, check=True,
    )
    assert "wrote" in r.stdout
    img = iio.imread(out)
    assert img.shape[:2] == (90, 160)


@pytest.mark.parametrize("args, word", [(["--blades", "0"], "blades"), (["--size", "10"], "size"), (["--steps", "-2"], "steps")])
def test_cli_bad_input(tmp_path, args, word):
    r = subprocess.run([sys.executable, "-m", "grasswidget", "snapshot", str(tmp_path / "x.png"), *args],
                       capture_output=True, text=True)
    assert r.returncode == 2 and word in r.stderr


def test_console_script_declared():
    text = (ROOT / "pyproject.toml").read_text()
    assert 'grasswidget = "grasswidget.tools.cli:main"' in text


def test_no_adapter_message():
    """Without any Vulkan driver, one clear error says what to install."""
    code = "import grasswidget as gw; gw.GrassScene(64)"
    env = {**os.environ, "VK_ICD_FILENAMES": "/nonexistent.json", "VK_DRIVER_FILES": "/nonexistent.json",
           "WGPU_BACKEND_TYPE": "Vulkan"}
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert r.returncode != 0
    assert "mesa-vulkan-drivers" in r.stderr and "libvulkan1" in r.stderr
