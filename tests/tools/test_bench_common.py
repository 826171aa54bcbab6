"""benchmarks/: the shared module (result names, the header, the loops, the A/B runner), the scripts' imports and
the results folder. Fast: no GPU, no browser (the scripts' own runs are in benchmarks/README.md)."""

from __future__ import annotations

import ast
import datetime as dt
import importlib.util
import json
import re
import statistics
import urllib.request
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
BENCH = ROOT / "benchmarks"
SCRIPTS = sorted(p for p in BENCH.rglob("*.py") if ".dawn" not in p.parts)
#: <claim>-<machine>-<YYYY-MM-DD>.<ext>
RESULT_NAME = re.compile(r"^(?P<claim>[a-z0-9][a-z0-9_]*)-(?P<machine>[a-z0-9+]+(?:-[a-z0-9+]+)*)-"
                         r"(?P<date>\d{4}-\d{2}-\d{2})\.(?:json|rgba)$")


def _load(name):
    spec = importlib.util.spec_from_file_location(f"bench_{name}", BENCH / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def common():
    return _load("common")


def test_every_result_is_named_by_claim_machine_and_date_and_reads():
    files = sorted((BENCH / "results").iterdir())
    assert len(files) >= 90
    bad = [f.name for f in files if not RESULT_NAME.match(f.name)]
    assert not bad, f"not <claim>-<machine>-<date>: {bad}"
    assert not list(BENCH.glob("*.json")), "results belong in benchmarks/results/"
    for f in files:
        dt.date.fromisoformat(RESULT_NAME.match(f.name)["date"])
        if f.suffix == ".json":
            json.loads(f.read_text())


def test_no_script_imports_the_tests_or_a_private_name_of_the_package():
    offences = []
    for path in SCRIPTS:
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.ImportFrom):
                module = node.module or ""
                if module.split(".")[0] == "tests":
                    offences.append(f"{path.name}: from {module}")
                if module.startswith("grasswidget"):
                    offences += [f"{path.name}: {module}.{a.name}" for a in node.names if a.name.startswith("_")]
            elif isinstance(node, ast.Import):
                offences += [f"{path.name}: import {a.name}" for a in node.names if a.name.split(".")[0] == "tests"]
    assert not offences, offences


def test_every_script_that_writes_a_result_writes_it_through_common():
    """A script that writes JSON does it with common.save (the header and the results/ name), not by hand."""
    by_hand = []
    for path in SCRIPTS:
        if path.name in ("common.py", "lab.py", "dawn_page.py", "browser_matrix.py", "variants.py"):  # modules
            continue
        text = path.read_text()
        if "common.save(" not in text:
            by_hand.append(f"{path.relative_to(BENCH)}: no common.save")
        if re.search(r"json\.dump\(|platform\.platform\(\)|time\.strftime\(", text):
            by_hand.append(f"{path.relative_to(BENCH)}: writes its own header")
    assert not by_hand, by_hand


def test_result_path_names_claim_machine_and_day(common):
    path = common.result_path("presets_ab", "lavapipe", dt.date(2026, 11, 27))
    assert path == BENCH / "results" / "presets_ab-lavapipe-2026-11-27.json"
    assert RESULT_NAME.match(path.name)["machine"] == "lavapipe"
    today = dt.datetime.now(dt.timezone.utc).date().isoformat()
    assert common.result_path("x_1", "h200").name == f"x_1-h200-{today}.json"
    for claim in ("Presets", "a-b", "", "../x"):
        with pytest.raises(ValueError, match="claim"):
            common.result_path(claim, "lavapipe")
    with pytest.raises(ValueError, match="machine"):
        common.result_path("x", "../up")


@pytest.mark.parametrize("adapter,tag", [
    ("llvmpipe (LLVM 15.0.6, 256 bits) (CPU) via Vulkan", "lavapipe"),
    ({"vendor": "google", "architecture": "swiftshader", "device": "Subzero"}, "swiftshader"),
    ("google swiftshader", "swiftshader"),
    ({"device": "NVIDIA H200", "summary": "NVIDIA H200 (DiscreteGPU) via Vulkan"}, "h200"),
    ("NVIDIA GeForce RTX 4090 (DiscreteGPU) via Vulkan", "nvidia-geforce-rtx-4090"),
    ({"device": "AMD Radeon 780M", "description": "radv Mesa 24"}, "amd-radeon-780m"),
    (None, "unknown"),
])
def test_machine_tag(common, adapter, tag):
    assert common.machine_tag(adapter) == tag


def test_save_writes_the_header_then_the_data_and_refuses_a_header_key(common, tmp_path, capsys):
    out = tmp_path / "r.json"
    assert common.save("claim", {"rows": [1, 2]}, "llvmpipe (CPU)", out, argv=[str(BENCH / "x.py"), "--n", "3"]) == out
    data = json.loads(out.read_text())
    assert list(data)[:5] == list(common.HEADER_KEYS) and data["rows"] == [1, 2]
    assert data["adapter"] == "llvmpipe (CPU)" and data["command"] == "python benchmarks/x.py --n 3"
    assert dt.datetime.fromisoformat(data["date"]).tzinfo is not None
    assert data["machine"]["cpus"] >= 1 and re.fullmatch(r"[0-9a-f]{40}", data["commit"]["sha"])
    with pytest.raises(ValueError, match="adapter"):
        common.save("claim", {"adapter": "x"}, "llvmpipe", tmp_path / "s.json")
    assert common.save("claim", {"n": 1}, "llvmpipe", common.NO_FILE) is None
    assert '"n": 1' in capsys.readouterr().out


def test_run_ab_interleaves_the_trees_and_summarises_per_round_ratios(common):
    calls = []
    fast = {0: 10.0, 1: 30.0, 2: 20.0}  # tree b's ms per round; tree a takes 20 ms every round

    def measure(name, folder, case):
        calls.append((name, case))
        r = len([c for c in calls if c == (name, case)]) - 1
        return {"ms": 20.0 if name == "a" else fast[r]}

    rows = common.run_ab([("a", "A"), ("b", "B")], ["x", "y"], 3, measure, progress=False)
    assert calls[:4] == [("a", "x"), ("b", "x"), ("a", "y"), ("b", "y")]
    assert calls[4:8] == [("b", "x"), ("a", "x"), ("b", "y"), ("a", "y")]  # reversed every other round
    assert [(row["round"], row["case"]) for row in rows] == [(0, "x"), (0, "y"), (1, "x"), (1, "y"), (2, "x"),
                                                             (2, "y")]
    summary = common.ab_summary(rows, [("a", "A"), ("b", "B")], ["ms"])
    assert summary["x"]["a"] == {"ms": 20.0}
    assert summary["x"]["b"]["ms"] == 20.0
    assert summary["x"]["b"]["ms_ratio"] == statistics.median([10 / 20, 30 / 20, 20 / 20])


def test_interleave_and_the_timed_loops_count_their_calls(common):
    order = []
    samples = common.interleave({"p": lambda: order.append("p") or 1.0, "q": lambda: order.append("q") or 2.0},
                                rounds=3, warmup=1)
    assert order == ["p", "q", "p", "q", "q", "p", "p", "q"]
    assert samples == {"p": [1.0] * 3, "q": [2.0] * 3}
    n = []
    times = common.time_frames(lambda: n.append(1), frames=4, warmup=2, repeats=3)
    assert len(n) == 2 + 4 * 3 and len(times["wall_ms"]) == len(times["cpu_ms"]) == 4
    assert all(v >= 0 for v in times["wall_ms"])
    synced = []
    piped = common.time_pipelined(lambda: n.append(1), 5, lambda: synced.append(1))
    assert len(synced) == 2 and piped["fps"] == pytest.approx(1e3 / piped["wall_ms"])
    with pytest.raises(ValueError, match="frames"):
        common.time_frames(lambda: None, frames=0)
    assert common.percentile([1, 2, 3, 4, 5], 50) == 3 and common.percentile([0, 10], 10) == pytest.approx(1.0)


def test_set_culling_through_public_traits(common):
    from grasswidget import GrassParams

    p = GrassParams()
    common.set_culling(p, "frustum", occlusion=True, compute_raster=False, raster_max_px=3.0)
    assert (p.cull_orientation, p.cull_frustum, p.cull_distance, p.lod) == (False, True, False, True)
    assert p.cull_occlusion is True and p.compute_raster is False and p.compute_raster_max_px == 3.0
    common.set_culling(p, "off", occlusion=True)
    assert not any((p.cull_orientation, p.cull_frustum, p.cull_distance, p.lod, p.cull_occlusion))
    with pytest.raises(ValueError, match="culling must be one of"):
        common.set_culling(p, "sideways")


def test_parse_trees_checks_each_folder_holds_the_package(common, tmp_path):
    assert common.parse_trees([f"new={ROOT}", f"two={ROOT}:two"], suffixes=(":two",)) == [
        ("new", str(ROOT)), ("two", f"{ROOT}:two")]
    with pytest.raises(SystemExit, match="no grasswidget package"):
        common.parse_trees([f"a={ROOT}", f"b={tmp_path}"])
    with pytest.raises(SystemExit, match="NAME=DIR"):
        common.parse_trees([str(ROOT), str(ROOT)])
    with pytest.raises(SystemExit, match="at least 2"):
        common.parse_trees([f"a={ROOT}"])


def test_lab_driver_polls_and_serves_files(tmp_path):
    lab = _load("lab")
    seen = iter([(False, 1), (False, 2), (True, 3)])
    assert lab.poll(lambda: next(seen), "three", timeout=5, interval=0.001) == 3
    with pytest.raises(lab.DriverTimeout, match="never; last seen: 7"):
        lab.poll(lambda: (False, 7), "never", timeout=0)
    assert lab.poll(lambda: "a value", "truthy", timeout=0) == "a value"
    (tmp_path / "page.html").write_text("<p>grass</p>")
    with lab.StaticServer(tmp_path) as server:
        with urllib.request.urlopen(server.url_for("page.html"), timeout=10) as resp:
            assert resp.read() == b"<p>grass</p>"
    nb = json.loads(lab.write_notebook(tmp_path / "n.ipynb", ["a = 1", "a"]).read_text())
    assert [c["source"] for c in nb["cells"]] == ["a = 1", "a"] and nb["nbformat"] == 4
