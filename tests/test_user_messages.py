"""What a new user meets first: the CPU-adapter notice, no Vulkan loader noise,
typos in parameter names, and the command line's errors."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import grasswidget as gw

ROOT = Path(__file__).resolve().parents[1]


def _python(code, env=None, args=()):
    return subprocess.run([sys.executable, *args, "-c", code], capture_output=True, text=True, cwd=ROOT,
                          env=env or dict(os.environ), timeout=300)


def _cli(*args, cwd=None):
    return subprocess.run([sys.executable, "-m", "grasswidget", *map(str, args)], capture_output=True, text=True,
                          cwd=cwd or ROOT, timeout=300)


def _cli_together(*arg_lists, cwd=None):
    """Several command lines at once (separate processes, started together, all awaited):
    the same results as one ``_cli`` after the other, in about the time of the slowest."""
    procs = [subprocess.Popen([sys.executable, "-m", "grasswidget", *map(str, args)], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True, cwd=cwd or ROOT) for args in arg_lists]
    results = []
    for args, proc in zip(arg_lists, procs):
        out, err = proc.communicate(timeout=300)
        results.append(subprocess.CompletedProcess(proc.args, proc.returncode, out, err))
    return results


# ---------------------------------------------------------------- CPU-adapter notice and XDG_RUNTIME_DIR

@pytest.fixture(scope="module")
def first_renders(tmp_path_factory):
    """One fresh process, as a new user starts it: no XDG_RUNTIME_DIR (TMPDIR is a fresh folder,
    where the private one goes), warnings are errors (-W error: a warning, with its source line,
    would be an exception), two scenes rendered (one at a second size). Returns (the run,
    its TMPDIR, the environment)."""
    tmp = tmp_path_factory.mktemp("first-renders")
    env = {k: v for k, v in os.environ.items() if k != "XDG_RUNTIME_DIR"}
    env["TMPDIR"] = str(tmp)
    code = ("import os, stat, grasswidget as gw\n"
            "d = os.environ['XDG_RUNTIME_DIR']\n"
            "st = os.stat(d)\n"
            "print('DIR', d, oct(stat.S_IMODE(st.st_mode)), st.st_uid == os.getuid())\n"
            "a = gw.GrassScene(64, size=(32, 24)); a.render(); a.render_at((48, 32))\n"
            "b = gw.GrassScene(64, size=(32, 24)); b.render()\n")
    return _python(code, env=env, args=("-W", "error")), tmp, env


def test_cpu_notice_is_one_line_of_information_once(first_renders):
    from grasswidget.gpu.adapter import cpu_notice, is_cpu_adapter

    if not is_cpu_adapter():
        pytest.skip("rendering runs on a GPU here: no CPU notice")
    r, _, _ = first_renders
    assert r.returncode == 0, r.stderr
    lines = [line for line in r.stdout.splitlines() if "CPU adapter" in line]
    assert lines == [cpu_notice()], r.stdout  # once, one line, on stdout
    assert "CPU adapter" not in r.stderr and "Warning" not in r.stderr


def test_cpu_notice_in_the_widget_stats_line(widget):
    from grasswidget.gpu.adapter import cpu_notice

    note = cpu_notice(short=True)
    details = widget.panel.details_line.value
    assert "CPU adapter" not in widget.panel.stats_line.value  # the one-line status speaks to students
    if note is None:
        assert "CPU adapter" not in details
    else:
        assert note in details and "\n" not in note


def test_no_vulkan_loader_noise_without_xdg_runtime_dir(first_renders):
    r, tmp_path, env = first_renders
    assert r.returncode == 0, r.stderr
    assert "XDG_RUNTIME_DIR" not in r.stderr and "XDG_RUNTIME_DIR" not in r.stdout
    line = next(x for x in r.stdout.splitlines() if x.startswith("DIR "))
    _, d, mode, mine = line.split()
    assert Path(d).parent == tmp_path and mode == "0o700" and mine == "True"
    # the loader really does complain without it (so the check above can fail)
    bare = _python("import wgpu; wgpu.gpu.enumerate_adapters_sync()", env=env)
    if "XDG_RUNTIME_DIR" not in bare.stderr:
        pytest.skip("this machine's Vulkan loader does not complain without XDG_RUNTIME_DIR")


def test_runtime_dir_never_uses_a_dir_open_to_others(tmp_path, monkeypatch):
    from grasswidget.core.runtime_dir import ensure_runtime_dir

    monkeypatch.delenv("XDG_RUNTIME_DIR", raising=False)
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", None)  # re-read TMPDIR
    squatted = tmp_path / f"grasswidget-runtime-{os.getuid()}"
    squatted.mkdir(mode=0o777)
    os.chmod(squatted, 0o777)
    d = ensure_runtime_dir()
    assert Path(d) != squatted and Path(d).parent == tmp_path
    assert (os.stat(d).st_mode & 0o777) == 0o700 and os.environ["XDG_RUNTIME_DIR"] == d
    # a directory already set is left alone
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))
    assert ensure_runtime_dir() == str(tmp_path)


# ---------------------------------------------------------------- typos in names

def test_params_refuse_unknown_names_and_suggest_the_closest():
    p = gw.GrassParams()
    with pytest.raises(AttributeError, match=r"GrassParams has no trait 'wind_strenght'; did you mean 'wind_strength'\?"):
        p.wind_strenght = 3
    assert p.wind_strength == 5.0 and not hasattr(p, "wind_strenght")
    with pytest.raises(AttributeError, match="did you mean 'gravity'"):
        gw.GrassParams(gravty=3)
    with pytest.raises(AttributeError, match="did you mean 'cull_frustum'"):
        p.cull_frustrum
    with pytest.raises(AttributeError, match="its traits are: blade_shape, "):
        p.zzz = 1
    ball = gw.SphereCollider()
    with pytest.raises(AttributeError, match="did you mean 'radius'"):
        ball.raduis = 2.0
    assert ball.radius == 1.0
    # traits, methods and copies work as before
    p.wind_strength = 7.0
    assert p.copy().wind_strength == 7.0 and gw.GrassParams(**p.values()).values() == p.values()
    import copy

    assert copy.deepcopy(ball).radius == 1.0


# ---------------------------------------------------------------- command line

@pytest.mark.parametrize("args, word", [
    (["--wind", "nan"], "--wind: wind_strength must be a finite number in [0, 200]"),
    (["--wind", "-1"], "--wind"),
    (["--wind", "breeze"], "--wind"),
    (["--seed", "-1"], "--seed"),
    (["--blades", "1000000000000"], "--blades: count=1,000,000,000,000"),
    (["--blades", "ten"], "--blades"),
    (["--size", "0x5"], "--size"),
    (["--preset", "lawn"], "--preset"),
])
def test_cli_bad_arguments_are_one_line_argument_errors(tmp_path, args, word):
    r = _cli("snapshot", tmp_path / "x.png", *args)
    assert r.returncode == 2
    assert r.stderr.count("\n") == 1 and "Traceback" not in r.stderr, r.stderr
    assert r.stderr.startswith("grasswidget snapshot: error: argument ") and word in r.stderr
    assert not (tmp_path / "x.png").exists()


def test_cli_gpu_limit_is_an_argument_error(tmp_path):
    from grasswidget.gpu.adapter import ensure_device
    from grasswidget.core.memory import max_blades_for_gpu

    n = max_blades_for_gpu(ensure_device().limits) + 1
    r = _cli("snapshot", tmp_path / "x.png", "--blades", n)
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert f"argument --blades: count={n:,}" in r.stderr and "max_storage_buffer_binding_size" in r.stderr


def test_cli_extension_chooses_the_format_or_is_refused(tmp_path):
    import imageio.v3 as iio

    bad_names = ("out.bmp", "out", "out.png.txt")
    for r in _cli_together(*(("snapshot", tmp_path / bad, "--blades", 64) for bad in bad_names)):
        assert r.returncode == 2 and r.stderr.count("\n") == 1 and ".png, .jpg, .jpeg" in r.stderr
    common = ("--blades", 512, "--size", "96x64", "--steps", 5)
    png, jpg = tmp_path / "new" / "deeper" / "a.png", tmp_path / "new" / "b.JPG"  # folders that do not exist yet
    r_png, r = _cli_together(("snapshot", png, *common), ("snapshot", jpg, *common))  # "new" made by both at once
    assert r_png.returncode == 0, r_png.stderr
    assert r.returncode == 0, r.stderr
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert jpg.read_bytes()[:3] == b"\xff\xd8\xff"  # JPEG bytes under a .jpg name
    a, b = iio.imread(png), iio.imread(jpg)
    assert a.shape == (64, 96, 4) and b.shape == (64, 96, 3)
    assert np.abs(a[..., :3].astype(int) - b.astype(int)).mean() < 8  # the same picture


def test_cli_folder_that_cannot_be_made_is_a_one_line_error(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    snapshot, bench, bare = _cli_together(("snapshot", blocker / "sub" / "x.png", "--blades", 64),
                                          ("bench", "--json", blocker / "sub" / "r.json", "--blades", 64), ())
    r = snapshot
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert "argument out: cannot create the folder" in r.stderr
    r = bench
    assert r.returncode == 2 and "argument --json: cannot create the folder" in r.stderr
    r = bare
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "command" in r.stderr
