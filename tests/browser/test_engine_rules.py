"""The browser engine's modules and the rules it still computes per frame, without a browser.

* The one module text (grasswidget.browser.esm.engine_module_text, what BrowserEngineWidget._esm, the
  live page and the HTML export load) holds every module under browser/js once, no relative
  import is left in it, each top-level name is declared once, and node loads it with the
  entry's exports.
* Every rule of js/rules.js, run with Node.js on many inputs, gives what its Python twin (the
  function that decides it) gives, as the WGSL twins are checked against NumPy. SimClock,
  clampOrbit and hzbLayout are checked in tests/core/test_engine_inputs.py the same way.
* The numbers those rules use come from Python: frame_rules carries them, the modules do not
  write them.

Runs without Chromium (not marked ``browser``).
"""

from __future__ import annotations

import json
import math
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.browser import esm
from grasswidget.browser.view import BrowserEngineWidget
from grasswidget.core import camera_rules, engine_inputs
from grasswidget.errors import PageBuildError
from conftest import node_executable

BROWSER_DIR = Path(esm.__file__).resolve().parent


def _node(script: str, cases) -> dict:
    run = subprocess.run([node_executable(), "--input-type=module", "-e", script], input=json.dumps(cases),
                         capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    return json.loads(run.stdout)


def test_one_module_text_holds_every_module_once(tmp_path):
    order = esm.module_order()
    on_disk = sorted(p.relative_to(BROWSER_DIR).as_posix() for p in (BROWSER_DIR / "js").glob("*.js"))
    assert sorted(order) == sorted(on_disk + ["engine.js"]) and len(set(order)) == len(order)
    assert order[-1] == "engine.js"
    # dependencies first: each module's relative imports are already in the text before it
    for k, rel in enumerate(order):
        for dep in esm.relative_imports((BROWSER_DIR / rel).read_text(encoding="utf-8")):
            assert esm.resolve_import(rel, dep) in order[:k], (rel, dep)

    text = esm.engine_module_text()
    for rel in order:
        assert text.count(f"// ==== grasswidget/browser/{rel}\n") == 1, rel
        # every declaration of the module is in the text
        for name in esm.module_declarations((BROWSER_DIR / rel).read_text(encoding="utf-8")):
            assert re.search(rf"^(export\s+)?(async\s+)?(const|let|var|function|class)\s+{name}\b", text, re.M), name
    assert not re.search(r"""^\s*(import|export)\b[^;]*\bfrom\s*["']\.""", text, re.M)  # no relative import left
    assert not re.search(r"^\s*import\s", text, re.M)  # nor any other: the text stands alone
    names = esm.module_declarations(text)
    assert len(names) == len(set(names)) and {"CanvasView", "EngineDevice", "SimClock", "clampOrbit"} <= set(names)
    assert "GrassView" not in names  # the canvas class has its own name now

    # node loads the one text with the entry's exports (what anywidget and the live page import)
    path = tmp_path / "engine_module.mjs"
    path.write_text(text, encoding="utf-8")
    driver = """
const one = await import(%s), entry = await import(%s);
console.log(JSON.stringify({one: Object.keys(one), entry: Object.keys(entry),
  render: typeof one.default.render, initialize: typeof one.default.initialize}));
""" % (json.dumps(path.as_uri()), json.dumps((BROWSER_DIR / "engine.js").as_uri()))
    got = _node(driver, {})
    assert set(got["entry"]) <= set(got["one"]) and {"default", "SimClock", "clampOrbit", "hzbLayout",
                                                      "downsample"} <= set(got["entry"])
    assert got["render"] == got["initialize"] == "function"


def test_the_module_text_refuses_a_name_declared_twice(tmp_path, monkeypatch):
    """Two modules declaring one top-level name could not share one module text: a clear error."""
    (tmp_path / "js").mkdir()
    (tmp_path / "js" / "a.js").write_text("export function twice() {}\n", encoding="utf-8")
    (tmp_path / "js" / "b.js").write_text("function twice() {}\nexport const other = 1;\n", encoding="utf-8")
    (tmp_path / "entry.js").write_text('import { twice } from "./js/a.js";\nimport { other } from "./js/b.js";\n'
                                       'export default { twice, other };\n', encoding="utf-8")
    monkeypatch.setattr(esm, "HERE", tmp_path)
    with pytest.raises(PageBuildError, match="twice"):
        esm.assemble("entry.js")


_RULES_DRIVER = """
import { readFileSync } from "node:fs";
import * as R from %s;
const c = JSON.parse(readFileSync(0, "utf8"));
const out = {
  world: c.cameras.map(([p, t]) => Array.from(R.cameraWorld(p, t))),
  proj: c.projections.map(([f, a, n, far]) => Array.from(R.perspective(f, a, n, far))),
  orbit: c.drags.map(([p, t, dx, dy]) => R.orbitDrag(p, t, dx, dy, c.drag)),
  pan: c.pans.map(([p, t, fov, dx, dy, h]) => R.panDrag(p, t, fov, dx, dy, h)),
  wheel: c.wheels.map(([p, t, d]) => R.wheelZoom(p, t, d, c.drag)),
  wind: c.winds.map(([k, clock]) => R.windTime(k, clock)),
  perDispatch: c.blades.map((n) => R.stepsPerDispatch(n, c.dispatch)),
  groups: c.items.map((n) => R.workgroups(n, c.dispatch)),
  counters: c.readbacks.map((w) => R.readCounters(Uint32Array.from(w), c.counters)),
};
console.log(JSON.stringify(out));
"""


def test_rules_js_computes_what_its_python_twins_decide():
    from grasswidget.gpu.wgsl_templates import workgroups

    rng = np.random.default_rng(11)
    blades = gw.Blades.on_plane(300, size=6.0)
    rules = engine_inputs.frame_rules(gw.GrassParams(), blades, 100.0)
    vec = lambda lo, hi: [float(x) for x in rng.uniform(lo, hi, 3)]  # noqa: E731
    cameras = [[vec(-30, 30), vec(-5, 5)] for _ in range(200)]
    cameras += [[[0.0, 9.0, 0.0], [0.0, 0.0, 0.0]], [[0.0, -3.0, 0.0], [0.0, 1.0, 0.0]]]  # straight down and up
    projections = [[float(rng.uniform(10, 120)), float(rng.uniform(0.3, 3)), float(rng.uniform(0.01, 1)),
                    float(rng.uniform(20, 500))] for _ in range(100)]
    drags = [[vec(-30, 30), vec(-5, 5), float(rng.normal(0, 80)), float(rng.normal(0, 80))] for _ in range(200)]
    drags += [[[0.0, 10.0, 0.1], [0.0, 0.0, 0.0], 0.0, 500.0]]  # over the pole: held at max_elevation
    pans = [[vec(-30, 30), vec(-5, 5), float(rng.uniform(20, 90)), float(rng.normal(0, 50)), float(rng.normal(0, 50)),
             float(rng.integers(100, 1200))] for _ in range(100)]
    wheels = [[vec(-30, 30), vec(-5, 5), float(rng.normal(0, 400))] for _ in range(100)]
    clocks = [engine_inputs.clock_rules(gw.GrassParams(wind_field=w, dt=dt)) for w in ("wave", "radial", "vortex", "noise")
              for dt in (1 / 120, 1 / 60, 0.0037)]
    clocks.append(dict(clocks[0], wind_period=0.0))  # no period
    winds = [[int(k), clocks[int(rng.integers(len(clocks)))]] for k in rng.integers(0, 10 ** 7, 200)]
    counts = [1, 2, 255, 256, 257, 4096, 65535 * 256, 65535 * 256 + 1, 1 << 24, (1 << 24) + 1, 1 << 26, 0]
    counts += [int(n) for n in rng.integers(1, 1 << 25, 50)]
    layout = rules["counters"]
    readbacks = [[int(x) for x in rng.integers(0, 1 << 32, layout["words"], dtype=np.uint64)] for _ in range(20)]
    readbacks += [[int(x) for x in rng.integers(0, 1 << 20, layout["words"])] for _ in range(20)]
    got = _node(_RULES_DRIVER % json.dumps((BROWSER_DIR / "js" / "rules.js").as_uri()), dict(
        cameras=cameras, projections=projections, drags=drags, pans=pans, wheels=wheels, winds=winds,
        blades=counts, items=counts, drag=rules["drag"], dispatch=rules["dispatch"], readbacks=readbacks,
        counters=layout))

    for (p, t), js in zip(cameras, got["world"]):
        assert np.allclose(np.array(js).reshape(4, 4).T, camera_rules.camera_world(p, t), atol=1e-12), (p, t)
    for (f, a, n, far), js in zip(projections, got["proj"]):
        assert np.allclose(np.array(js).reshape(4, 4).T, camera_rules.perspective(f, a, n, far), rtol=1e-12)
    poles = 0
    for (p, t, dx, dy), js in zip(drags, got["orbit"]):
        want = camera_rules.orbit_drag(p, t, dx, dy, rules["drag"])
        assert np.allclose(js, want, atol=1e-9), (p, t, dx, dy)
        off = want - np.asarray(t)
        assert math.isclose(np.linalg.norm(off), np.linalg.norm(np.subtract(p, t)), rel_tol=1e-9)  # distance kept
        poles += math.isclose(abs(math.asin(off[1] / np.linalg.norm(off))), camera_rules.DRAG_MAX_ELEVATION)
    assert poles >= 1  # the elevation hold was exercised
    for (p, t, fov, dx, dy, h), (jp, jt) in zip(pans, got["pan"]):
        wp, wt = camera_rules.pan_drag(p, t, fov, dx, dy, h)
        assert np.allclose(jp, wp, atol=1e-9) and np.allclose(jt, wt, atol=1e-9)
    for (p, t, d), js in zip(wheels, got["wheel"]):
        assert np.allclose(js, camera_rules.wheel_zoom(p, t, d, rules["drag"]), atol=1e-9)
    assert any(abs(d * camera_rules.WHEEL_PER_DELTA) > camera_rules.WHEEL_MAX_LOG for _, _, d in wheels)
    for (k, clock), js in zip(winds, got["wind"]):
        assert js == engine_inputs.wind_time(k, clock["dt"], clock["wind_period"]), (k, clock)
    assert any(c["wind_period"] > 0 for _, c in winds) and any(c["wind_period"] == 0 for _, c in winds)
    assert got["perDispatch"] == [engine_inputs.steps_per_dispatch(n) for n in counts]
    assert [tuple(g) for g in got["groups"]] == [workgroups(n)[:2] for n in counts]
    for words, js in zip(readbacks, got["counters"]):
        want = engine_inputs.read_counters(np.array(words, np.uint32), layout)
        # a sum past 2^32 is a number in JS, not wrapped (a real count stays far below: 2^24 blades)
        assert js == want, words


def test_counter_layout_is_where_both_engines_copy_their_counts():
    """frame_rules.counters places the browser's copies (the occlusion args and the compute
    rasterizer's counters, sized by Python's shaders) and the kernel's staging (gpu.stats) alike."""
    from grasswidget.browser.browser_wgsl import BrowserShaders
    from grasswidget.core.reference import LOD_SEGMENTS

    layout = engine_inputs.counter_layout()
    c = len(LOD_SEGMENTS)
    assert layout["second_at"] - layout["first_at"] == 4 * c
    assert layout["raster_at"] - layout["second_at"] == BrowserShaders.occlusion()["args_words"]
    assert layout["words"] - layout["raster_at"] == BrowserShaders.compute_raster()["args_words"]
    # the counts from words written as the passes write them: instance counts in word 1 of each args row
    words = np.zeros(layout["words"], np.uint32)
    words[[4 * k + 1 for k in range(c)]] = [10 * (k + 1) for k in range(c)]
    words[[4 * c + 4 * k + 1 for k in range(c)]] = [k + 1 for k in range(c)]
    words[8 * c], words[8 * c + 4] = 7, 5
    assert engine_inputs.read_counters(words, layout) == {
        "visible_per_class": [11 * (k + 1) for k in range(c)], "occluded": 7, "rastered": 5}
    with pytest.raises(gw.GrassValueError, match="n_classes"):
        engine_inputs.counter_layout(0)
    with pytest.raises(gw.GrassValueError, match="words"):
        engine_inputs.read_counters(words[:-1], layout)


def test_the_frame_rules_carry_the_numbers_and_the_modules_do_not_write_them():
    """Each number of a frame's rules is Python's, sent in frame_rules (or a trait): the
    workgroup size, the blade steps per dispatch, the drag's rates, the stats interval; the
    engine's modules no longer write the old literals."""
    from grasswidget.core.shader_files import WORKGROUP_SIZE
    from grasswidget.core.engine_inputs import BLADE_STEPS_PER_DISPATCH

    blades = gw.Blades.on_plane(64)
    view = BrowserEngineWidget(blades, size=(160, 120))
    try:
        rules = view.frame_rules
        assert rules["dispatch"] == {"workgroup_size": WORKGROUP_SIZE, "max_groups_x": 65535,
                                     "blade_steps_per_dispatch": BLADE_STEPS_PER_DISPATCH}
        assert rules["drag"] == camera_rules.drag_rules()
        assert view.stats_interval_ms == engine_inputs.STATS_INTERVAL_MS
        assert view.camera == camera_rules.default_camera(blades.v0)
        json.dumps(rules)  # JSON-able, as the comm sends it
    finally:
        view.close()
    sources = {p.name: p.read_text(encoding="utf-8") for p in [BROWSER_DIR / "engine.js", *(BROWSER_DIR / "js").glob("*.js")]}
    code = {name: re.sub(r"//[^\n]*|/\*.*?\*/", "", s, flags=re.S) for name, s in sources.items()}
    for name, s in code.items():
        for literal in ("1 << 24", "1 << 30", "WORKGROUP", "STATS_INTERVAL", "0.008", "1.55", "0.001", "> 100"):
            assert literal not in s, (name, literal)
        assert not re.search(r"\b256\b", s) or name in ("pictures.js", "messages.js"), name  # 256: byte values, row pitch
