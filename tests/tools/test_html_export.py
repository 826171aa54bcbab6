"""The live page (save_html, ``grasswidget html``): its content, its controls, its limits.

The page's controls are state patches computed in Python; here they are applied
the way page.js applies them and compared with what the kernel side would send
(the uniforms packed by grasswidget.browser.uniforms for the changed params).
Chromium runs the page in tests/e2e/test_live_page.py.
"""

from __future__ import annotations

import base64
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.browser import uniforms
from grasswidget.browser.esm import engine_module_text
from grasswidget.browser.page import PAGE_MAX_BLADES, page_html
from grasswidget.browser.engine_widget import BrowserEngineWidget
from grasswidget.core.colliders import SphereCollider


def _data(text):
    m = re.search(r'<script type="application/json" id="gw-data">(.*?)</script>', text, re.S)
    return json.loads(m.group(1))


def _apply(state, control, index):
    """page.js applyPatch, in Python."""
    patch = control["patches"][index]
    for name, runs in control["footprint"]["bin"].items():
        b = bytearray(state[name])
        src, o = base64.b64decode(patch["bin"][name]), 0
        for a, e in runs:
            b[a:e] = src[o:o + e - a]
            o += e - a
        state[name] = bytes(b)
    state.update(patch["json"])


def _place(state, ball, x, z):
    """page.js placeBall (without the clamp), in Python."""
    for name, off, c, ax, az in ball["slots"]["bin"]:
        b = bytearray(state[name])
        b[off:off + 4] = np.float32(c + ax * x + az * z).tobytes()
        state[name] = bytes(b)
    for name, path, c, ax, az in ball["slots"]["json"]:
        node = state[name]
        for k in path[:-1]:
            node = node[k]
        node[path[-1]] = c + ax * x + az * z


@pytest.fixture(scope="module")
def page_data():
    params = gw.GrassParams(wind_strength=7.0)
    view = BrowserEngineWidget(gw.Blades.on_plane(256, seed=3), params=params, size=(320, 240))
    text = page_html(view, title="a <test> page")
    yield view, text, _data(text)
    view.close()


def test_page_is_self_contained(page_data):
    view, text, data = page_data
    # nothing fetched: no src/href to anything but data: URLs, no http(s) URL in the markup
    refs = re.findall(r'(?:src|href)\s*=\s*"([^"]*)"', text.split('id="gw-data"')[0])
    assert refs and all(r.startswith("data:") for r in refs), refs
    assert data["engine"] == engine_module_text()  # the one module text, as the anywidget's
    assert "</script" not in text.split('id="gw-data">')[1].split("</script>")[0]
    assert "<title>a &lt;test&gt; page</title>" in text
    # the state is every synced trait of the engine; binary traits round-trip
    assert set(data["binary"]) >= {"blade_data", "sim_uniform", "cull_uniform"}
    assert base64.b64decode(data["state"]["blade_data"]) == view.blade_data
    assert data["state"]["camera"] == json.loads(json.dumps(view.camera))
    assert data["blades"] == 256 and data["size"] == [320, 240]


@pytest.mark.parametrize("where", ["title", "wind_wgsl"])
def test_user_text_cannot_change_the_page(where):
    # Text that reads like the template's slots, closes the data block or starts a new script:
    # the page keeps its structure (one data block, one module) and the text comes back intact.
    hostile = "{{SCRIPT}} {{DATA}} {{TITLE}} </script><script>alert(1)</script> <!-- \u2028 &amp;"
    params = gw.GrassParams()
    if where == "wind_wgsl":
        params.wind_wgsl = "// " + hostile + "\nreturn vec3<f32>(0.0);"
    view = BrowserEngineWidget(gw.Blades.on_plane(64, seed=1), params=params, size=(64, 48))
    try:
        text = page_html(view, title=hostile if where == "title" else "plain")
    finally:
        view.close()
    assert text.count("<script") == 2 and text.count("</script>") == 2
    assert text.count('id="gw-data"') == 1
    data = _data(text)
    if where == "title":
        assert data["title"] == hostile
        title = re.search(r"<title>(.*?)</title>", text, re.S).group(1)
        import html

        assert html.unescape(title) == hostile and "<" not in title
    else:
        assert params.wind_wgsl in data["state"]["shaders"]["simulate"]["code"]  # the WGSL the page compiles
    # the page's own script is there once, after the data block
    assert text.index('id="gw-data"') < text.index('<script type="module">')
    assert data["engine"] == engine_module_text()


def test_controls_send_what_the_kernel_would(page_data):
    view, _text, data = page_data
    controls = {c["id"]: c for c in data["controls"]}
    assert {"playing", "wind_strength", "wind_direction", "wind_field", "cull_orientation", "cull_frustum",
            "cull_distance", "lod", "color_by", "ball"} <= set(controls)
    state = {k: base64.b64decode(v) if k in data["binary"] else v for k, v in data["state"].items()}
    # what the page's keys and ball drag follow is Python's: the key map, and where the ball may go
    # (the kernel's BallControl clamps to the same ball_reach: the field and a tenth of its extent)
    from grasswidget.core.interaction import ball_reach, input_rules

    assert data["input"] == input_rules() and data["input"]["keys"]["s"] == "step"
    v0 = view.blades.v0
    extent = max(np.ptp(v0[:, 0]), np.ptp(v0[:, 2]), 1.0)
    assert np.allclose(controls["ball"]["reach"], [v0[:, 0].min() - 0.1 * extent, v0[:, 0].max() + 0.1 * extent,
                                                   v0[:, 2].min() - 0.1 * extent, v0[:, 2].max() + 0.1 * extent])
    assert controls["ball"]["reach"] == list(ball_reach(v0.min(axis=0), v0.max(axis=0)))
    # several controls at once: culling off, LOD colours, a stronger wind from 90 degrees, paused
    ws, wd = controls["wind_strength"], controls["wind_direction"]
    _apply(state, controls["cull_orientation"], controls["cull_orientation"]["values"].index(False))
    _apply(state, controls["cull_distance"], controls["cull_distance"]["values"].index(False))
    _apply(state, controls["color_by"], controls["color_by"]["values"].index("lod"))
    _apply(state, ws, ws["values"].index(12.0))
    _apply(state, wd, wd["values"].index(90.0))
    _apply(state, controls["playing"], controls["playing"]["values"].index(False))
    _apply(state, controls["ball"], 1)
    _place(state, controls["ball"], 1.25, -2.5)
    p = view.params.copy()
    p.cull_orientation, p.cull_distance, p.color_by, p.wind_strength, p.wind_direction = False, False, "lod", 12.0, 90.0
    spheres = lambda: np.frombuffer(state["collider_spheres"], "<f4").reshape(-1, 4)  # noqa: E731
    n_spheres = lambda: int(np.frombuffer(state["collider_grid"], "<u4")[2])  # noqa: E731  (grid word 2)
    r = float(spheres()[0, 3])
    ball = SphereCollider(center=(1.25, float(view.blades.v0[:, 1].min()) + r, -2.5), radius=r)
    # the "auto" switches as the view had them when the page was written (a page has no Python to decide)
    assert state["cull_uniform"] == uniforms.cull_uniform(p, 256, decided=view.auto_switches.values)
    # the ball's numbers are fitted on float32 probes: equal to float32 rounding
    np.testing.assert_allclose(np.frombuffer(state["sim_uniform"], "<f4"),
                               np.frombuffer(uniforms.sim_uniform(p, 256, [ball]), "<f4"), rtol=0, atol=2e-6)
    sim = uniforms.offsets(uniforms.SIM_LAYOUT)
    assert np.frombuffer(state["sim_uniform"], "<i4")[sim["n_colliders"][0] // 4] == 1
    assert state["playing"] is False
    np.testing.assert_allclose(spheres()[0], [1.25, ball.center[1], -2.5, r], rtol=1e-6)
    assert n_spheres() == 1
    # the ball off again: no collider, as at the start
    _apply(state, controls["ball"], 0)
    assert state["sim_uniform"] == uniforms.sim_uniform(p, 256, []) and n_spheres() == 0
    # the start values: what the panel shows first
    assert ws["values"][ws["value"]] == 7.0 and controls["playing"]["values"][controls["playing"]["value"]] is True


def test_bad_input_names_the_limit(tmp_path):
    from grasswidget.tools.html_export import save_html

    with pytest.raises(gw.MissingFileError, match="nope"):
        save_html(tmp_path / "nope" / "m.html", 64)
    with pytest.raises(gw.GrassValueError, match=r"must end in \.html"):
        save_html(tmp_path / "m.htm", 64)
    with pytest.raises(gw.GrassValueError, match=f"at most {PAGE_MAX_BLADES} blades"):
        save_html(tmp_path / "m.html", PAGE_MAX_BLADES + 1)
    with pytest.raises(gw.GrassValueError, match="at most"):
        save_html(tmp_path / "m.html", 64, size=(4000, 4000), still=False)
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("args, message", [
    (["x.png"], "must end in .html"),
    (["{tmp}/missing/x.html"], "does not exist"),
    (["{tmp}/x.html", "--blades", str(PAGE_MAX_BLADES + 1)], f"at most {PAGE_MAX_BLADES} blades"),
    (["{tmp}/x.html", "--blades", "many"], "must be an integer"),
])
def test_cli_html_bad_input_is_one_line(tmp_path, args, message):
    args = [a.replace("{tmp}", str(tmp_path)) for a in args]
    proc = subprocess.run([sys.executable, "-m", "grasswidget", "html", *args], capture_output=True, text=True,
                          timeout=60)
    assert proc.returncode == 2
    assert message in proc.stderr and "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1, proc.stderr


@pytest.mark.slow
def test_widget_save_html_carries_its_view(tmp_path):
    import imageio.v3 as iio

    w = gw.GrassWidget(1024, size=(320, 240))
    try:
        w.params.wind_strength = 9.0
        w.camera_state = {"position": (0.0, 3.0, 7.0), "target": (0.0, 0.5, 0.0)}
        w.ball.enabled = True
        w.pause()
        path = w.save_html(tmp_path / "meadow.html")
    finally:
        w.close()
    data = _data(open(path, encoding="utf-8").read())
    assert data["state"]["camera"]["position"] == pytest.approx([0.0, 3.0, 7.0])
    controls = {c["id"]: c for c in data["controls"]}
    assert controls["wind_strength"]["values"][controls["wind_strength"]["value"]] == 9.0
    assert controls["ball"]["values"][controls["ball"]["value"]] is True
    assert np.frombuffer(base64.b64decode(data["state"]["collider_grid"]), "<u4")[2] == 1  # one sphere
    assert data["state"]["playing"] is False
    still = iio.imread(base64.b64decode(data["still"]), extension=".png")
    assert still.shape[:2] == (240, 320)
    rgb = still[int(0.6 * 240):, :, :3].astype(int)
    assert ((rgb[..., 1] > rgb[..., 0] + 8) & (rgb[..., 1] > rgb[..., 2] + 8)).mean() > 0.3  # grass in the still


def test_front_end_modules_import_nothing():
    """The browser engine's one module text and page.js are self-contained: no import of
    JupyterLab (or of anything), so they run in Notebook 7, Voila, VS Code, Colab and the live
    page alike; the engine's modules import only each other (relative paths)."""
    folder = Path(gw.__file__).parent / "browser"
    sources = {"the engine's module text": engine_module_text(), "page.js": (folder / "page.js").read_text(encoding="utf-8")}
    for name, source in sources.items():
        assert not re.search(r"^\s*import\s|\brequire\(|@jupyter", source, re.M), name
        assert "http://" not in source and "https://" not in source, name
    for path in [folder / "engine.js", *(folder / "js").glob("*.js")]:
        imports = re.findall(r"^\s*(?:import|export)\b[^;]*\bfrom\s*\"([^\"]+)\"", path.read_text(encoding="utf-8"), re.M)
        assert all(i.startswith("./") or i.startswith("../") for i in imports), (path.name, imports)
