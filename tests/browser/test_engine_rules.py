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
from grasswidget.browser.engine_widget import BrowserEngineWidget
from grasswidget.core import camera_rules, engine_inputs, interaction
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
    from grasswidget.gpu.simulation import BLADE_STEPS_PER_DISPATCH

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


_INPUT_DRIVER = """
import { readFileSync } from "node:fs";
import * as R from %s;
const c = JSON.parse(readFileSync(0, "utf8"));
const presses = c.presses.map((events) => {
  const g = new R.PointerGesture(c.input);
  return events.map(([type, x, y, button, mods]) =>
    type === "down" ? g.down(x, y, R.domButton(button, c.input), mods) : type === "move" ? g.move(x, y) : g.up(x, y));
});
console.log(JSON.stringify({
  presses,
  keys: c.keys.map(([k, m]) => R.keyAction(k, m, c.input)),
  ratios: c.ratios.map(([d, a]) => R.displayRatio(d, a, c.input)),
}));
"""


def _random_presses(rng, n):
    """Press, moves, release sequences: DOM buttons, modifiers, moves near and past the click slop."""
    mods = [[], ["Control"], ["Meta"], ["Shift"], ["Control", "Shift"], ["Alt"], ["Shift", "Meta"]]
    out = []
    for _ in range(n):
        x, y = float(rng.uniform(0, 400)), float(rng.uniform(0, 300))
        events = [["down", x, y, int(rng.choice([0, 0, 0, 1, 2, 3])), mods[int(rng.integers(len(mods)))]]]
        scale = float(rng.choice([1.0, 3.0, 10.0]))
        for _ in range(int(rng.integers(0, 6))):
            events.append(["move", x + float(rng.normal(0, scale)), y + float(rng.normal(0, scale)), 0, []])
        events.append(["up", x + float(rng.normal(0, scale)), y + float(rng.normal(0, scale)), 0, []])
        out.append(events)
    # exactly at the slop: a drag; just short of it: a click
    slop = interaction.CLICK_SLOP_PX
    out.append([["down", 10.0, 10.0, 0, ["Control"]], ["move", 10.0 + slop, 10.0, 0, []], ["up", 10.0, 10.0, 0, []]])
    out.append([["down", 10.0, 10.0, 0, ["Control"]], ["move", 10.0, 10.0 + 0.99 * slop, 0, []],
                ["up", 10.0 + 0.99 * slop, 10.0, 0, []]])
    return out


def _python_press(events):
    g = interaction.PointerGesture(engine_inputs.frame_rules(gw.GrassParams(), gw.Blades.on_plane(16), 100.0)["input"])
    got = []
    for kind, x, y, button, mods in events:
        if kind == "down":
            got.append(g.down(x, y, interaction.DOM_BUTTONS[button], mods))
        else:
            got.append(g.move(x, y) if kind == "move" else g.up(x, y))
    return got


def test_input_rules_js_decide_what_python_decides():
    """The pointer gesture (click versus drag, the ctrl gesture), the key map and the pixel ratio
    cap run in the page from frame_rules.input: under node they give what core.interaction gives,
    and the page's modules write none of those numbers themselves."""
    rng = np.random.default_rng(39)
    rules = engine_inputs.frame_rules(gw.GrassParams(), gw.Blades.on_plane(16), 100.0)
    assert rules["input"] == interaction.input_rules()
    presses = _random_presses(rng, 400)
    keys = [[k, m] for k in (" ", "s", "S", "r", "R", "Space", "x", "Enter", "spacebar") for m in ([], ["Shift"], ["Control"])]
    ratios = [[d, a] for d in (0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0) for a in (0.0, 0.75, 1.0, 3.0)]
    got = _node(_INPUT_DRIVER % json.dumps((BROWSER_DIR / "js" / "rules.js").as_uri()),
                dict(presses=presses, keys=keys, ratios=ratios, input=rules["input"]))
    for events, js in zip(presses, got["presses"]):
        assert js == _python_press(events), events
    outcomes = {o for p in got["presses"] for o in p}
    assert {"pick", "ball", "pan", "orbit", "wait", "pan_start", "inspect", "cancel"} <= outcomes  # all exercised
    assert got["presses"][-2] == ["pick", "pan_start", "pan"] and got["presses"][-1] == ["pick", "wait", "inspect"]
    assert got["keys"] == [interaction.key_action(k, m) for k, m in keys]
    assert got["ratios"] == [interaction.display_ratio(d, a) for d, a in ratios]
    assert max(got["ratios"]) == 3.0 and interaction.display_ratio(3.0) == interaction.MAX_PIXEL_RATIO == 2.0

    # a JS rule that disagrees fails: the same driver on rules.js with the slop moved
    changed = dict(rules["input"], click_slop_px=2 * interaction.CLICK_SLOP_PX)
    off = _node(_INPUT_DRIVER % json.dumps((BROWSER_DIR / "js" / "rules.js").as_uri()),
                dict(presses=presses, keys=keys, ratios=ratios, input=changed))
    assert any(js != _python_press(ev) for ev, js in zip(presses, off["presses"]))

    # the numbers are Python's: the modules that read input events write none of them
    for name in ("js/canvas_view.js", "js/messages.js", "page.js"):
        code = re.sub(r"//[^\n]*|/\*.*?\*/", "", (BROWSER_DIR / name).read_text(encoding="utf-8"), flags=re.S)
        assert not re.search(r"<\s*4\b|>\s*60\b|devicePixelRatio[^;]*,\s*2\)|0\.1\s*\*", code), name
        assert not re.search(r"""key\s*===\s*["'][sr ]["']""", code), name


#: The engine's modules (rules.js and the interaction modules aside): composition of js/*.js.
_ENGINE_MODULES = ("engine.js", "js/device.js", "js/pipelines.js", "js/culling.js", "js/resources.js", "js/passes.js",
                   "js/camera.js", "js/stats.js", "js/messages.js")
#: The only number literals those modules may write, each a fact of WebGPU or of a byte format, not
#: a rule: 4 bytes a word, 16 a vec4 / indirect args, 128 two mat4 (u_wobject), 256 the copy row
#: pitch, 255 an opaque alpha, 8 WebGPU's default storage buffers per stage and the depth pyramid's
#: 8 x 8 workgroup, 12 the grid's first three words, 6 a quad's vertices, 3 sizes kept per target,
#: 1000 ms a second, 0xFFFFFFFF all bits.
_FORMAT_LITERALS = {"0", "1", "2", "3", "4", "6", "8", "12", "16", "128", "255", "256", "1000", "0xFFFFFFFF"}

_STATS_DRIVER = """
import { readFileSync } from "node:fs";
import { EngineStats } from %s;
const c = JSON.parse(readFileSync(0, "utf8"));
const sent = [];
const stats = new EngineStats((type, message, extra) => sent.push({ type, ...extra }));
c.frames.forEach(([switches, ms]) => stats.frameDone(switches, ms, c.kept));
stats.maybeSend(0, { step_count: 7, adapter: "test", views: 1 });
console.log(JSON.stringify({ sent, frames: stats.frames }));
"""


def test_the_engine_numbers_are_pythons_and_the_modules_write_none():
    """frame_rules["engine"] (core.engine_inputs.engine_rules) carries the engine's own numbers, each
    from its Python owner; the engine's modules write no other number than a format's."""
    from grasswidget.core.blades import BLADE_BYTES
    from grasswidget.core.auto_switches import FRAME_TIMES_KEPT, TRIAL_MAX_FRAMES
    from grasswidget.core.reference import FORCE_NAMES
    from grasswidget.core.teaching import INSPECTED_POINT_BYTES

    engine = engine_inputs.engine_rules()
    assert engine["frame_times_kept"] == FRAME_TIMES_KEPT >= TRIAL_MAX_FRAMES  # a message carries a trial's side
    assert engine["blade_bytes"] == BLADE_BYTES == 64
    assert engine["inspected_point_bytes"] == INSPECTED_POINT_BYTES == 36
    assert engine["inspected_force_bytes"] == 16 * len(FORCE_NAMES)
    assert engine["frames_in_flight"] == engine_inputs.FRAMES_IN_FLIGHT >= 1
    assert engine["device_loss_retries"] == engine_inputs.DEVICE_LOSS_RETRIES >= 0
    # the balls' mesh is balls.wgsl's
    balls = (BROWSER_DIR / "balls.wgsl").read_text(encoding="utf-8")
    rings = int(re.search(r"const BALL_RINGS: u32 = (\d+)u;", balls).group(1))
    segments = int(re.search(r"const BALL_SEGMENTS: u32 = (\d+)u;", balls).group(1))
    assert (rings, segments) == (engine_inputs.BALL_RINGS, engine_inputs.BALL_SEGMENTS)
    assert engine["ball_vertices"] == 6 * rings * segments
    # the widget sends them
    view = BrowserEngineWidget(gw.Blades.on_plane(64), size=(160, 120))
    try:
        assert view.frame_rules["engine"] == engine
    finally:
        view.close()
    for rel in _ENGINE_MODULES:
        text = re.sub(r"//[^\n]*|/\*.*?\*/", "", (BROWSER_DIR / rel).read_text(encoding="utf-8"), flags=re.S)
        text = re.sub(r"`[^`]*`|\"[^\"\n]*\"", "\"\"", text)  # strings and messages aside
        literals = set(re.findall(r"(?<![\w.$])(0x[0-9A-Fa-f]+|\d+(?:\.\d+)?(?:e[-+]?\d+)?)\b", text))
        assert literals <= _FORMAT_LITERALS, (rel, sorted(literals - _FORMAT_LITERALS))


def test_the_uniforms_reach_the_gpu_by_one_route():
    """Every uniform Python packs (u_sim among them) is written by resources.js's writeUniform from
    the trait frame_rules.engine.uniforms names: the table names every packed-uniform trait of the
    widget and a uniform the WGSL declares, and no module writes a uniform's buffer another way."""
    synced = set(BrowserEngineWidget.class_trait_names(sync=True))
    table = dict(engine_inputs.UNIFORM_TRAITS)
    assert set(table.values()) == {name for name in synced if name.endswith("_uniform")}
    view = BrowserEngineWidget(gw.Blades.on_plane(64), size=(160, 120))
    try:
        bound = set()

        def walk(node):  # every binding of every shader Python sends: the buffers the engine binds
            if isinstance(node, dict):
                if "binding" in node and "name" in node:
                    bound.add(node.get("resource") or node["name"])
                for v in node.values():
                    walk(v)
            elif isinstance(node, list):
                for v in node:
                    walk(v)

        walk(view.shaders)
        assert view.frame_rules["engine"]["uniforms"] == [list(pair) for pair in engine_inputs.UNIFORM_TRAITS]
    finally:
        view.close()
    assert set(table) <= bound, set(table) - bound
    for rel in _ENGINE_MODULES:
        text = (BROWSER_DIR / rel).read_text(encoding="utf-8")
        for buffer in table:
            assert not re.search(rf"writeBuffer\([^)]*\b{buffer}\b", text), (rel, buffer)
    assert "writeUniform(\"u_sim\"" in (BROWSER_DIR / "js" / "passes.js").read_text(encoding="utf-8")


def test_the_stats_carry_pythons_window_of_frame_times():
    """js/stats.js keeps the newest frame_rules.engine.frame_times_kept frame times of one switch
    state (restarting when it changes), as the "auto" trial reads them (browser.trial_feed)."""
    kept = engine_inputs.engine_rules()["frame_times_kept"]
    frames = [[[False, False], 1.0]] * 5 + [[[True, False], float(ms)] for ms in range(kept + 9)]
    got = _node(_STATS_DRIVER % json.dumps((BROWSER_DIR / "js" / "stats.js").as_uri()), {"frames": frames, "kept": kept})
    (msg,) = got["sent"]
    assert got["frames"] == len(frames)
    assert msg["type"] == "stats" and msg["timed_switches"] == [True, False]
    assert msg["frame_times"] == [float(ms) for ms in range(9, kept + 9)]  # the newest `kept`, of the last state
    assert msg["step_count"] == 7 and msg["views"] == 1 and msg["adapter"] == "test"
