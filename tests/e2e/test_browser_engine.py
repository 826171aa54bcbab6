"""The browser engine in a real JupyterLab + Chromium (WebGPU on SwiftShader).

One notebook shows ``GrassWidget(backend="browser")`` in a Chromium started with
the WebGPU flags (``Browser(webgpu=True)``); the test checks, through the page
and the kernel:

* the browser found a WebGPU adapter, the canvas shows grass under a sky, and
  the meadow moves while playing;
* physics: from the same blades, parameters and steps, the browser's state
  (``w.read_state()``, waited for inside a running cell) equals the kernel
  engine's (a GrassField on lavapipe) within 1e-4 of the blade height, also with
  a crowd of 60 balls (the collider grid built in Python, looked up in both);
* culling checkboxes in the page change the browser's visible count (all off:
  exactly every blade);
* a mouse drag on the canvas moves ``w.camera_state``; assigning it moves the view;
* Save PNG writes a picture of grass rendered by the browser, anti-aliased there;
* a custom wind that does not compile comes back with its line, the old wind kept;
* a lost WebGPU device is recovered with a message, and a request to a view
  that is not shown raises TimeoutError naming the browser view.

A second notebook in a Chromium without the WebGPU flags (requestAdapter() gives
null there) checks that ``backend="auto"`` falls back to kernel streaming with
one line saying WebGPU is not available, and that the controls keep working.
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest

from .controls import choose_option, click_button, drag, panel_label, set_slider, toggle_checkbox
from .frames import wait_for_frames, wait_for_view
from .kernel_calls import kernel_eval, kernel_execute, wait_for_kernel
from .notebook_actions import leave_notebook, open_notebook, run_all_cells, write_notebook
from .polling import poll

pytestmark = pytest.mark.browser

N_BLADES = 4096
#: The view's CSS size (a small one: SwiftShader draws every pixel on the CPU; Save PNG renders 2 x 2 x as many).
SIZE = (320, 240)


def _grass_fraction(px):
    rgb = px[..., :3].astype(np.int32)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    return float(((g > r + 8) & (g > b + 8)).mean())


def _sky_fraction(px):
    rgb = px[..., :3].astype(np.int32)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    return float(((b > r + 10) & (b >= g)).mean())


def _show_view(page):
    """Scroll the canvas back into sight (a control clicked under it may have scrolled it away):
    a view off screen rests, its engine neither steps nor sends stats."""
    loc = page.locator("canvas.grasswidget-canvas").first
    loc.scroll_into_view_if_needed()
    return loc


def _canvas_pixels(page):
    import imageio.v3 as iio

    return iio.imread(_show_view(page).screenshot(), extension=".png")


def test_browser_engine(webgpu_browser, lab_server, browser_root):
    page = webgpu_browser.page
    write_notebook(browser_root / "browser_engine.ipynb", [
        "import numpy as np\nimport grasswidget as gw\n"
        f"w = gw.GrassWidget({N_BLADES}, backend='browser', size={SIZE})\nw",
    ])
    try:
        _check_browser_engine(page, lab_server, browser_root)
    except BaseException:
        from .chromium import save_debug_artifacts

        out = save_debug_artifacts(page, os.environ.get("GW_ARTIFACTS_DIR") or browser_root / "artifacts",
                                   "browser_engine", webgpu_browser, lab_server)
        print(f"\n[browser engine] debug artifacts in {out}\n" + "\n".join(webgpu_browser.console[-30:]))
        raise
    finally:
        try:
            leave_notebook(page, lab_server, reload=sys.exc_info()[0] is not None)
        except Exception:
            pass


def _check_browser_engine(page, server, root):
    open_notebook(page, server, "browser_engine.ipynb")
    run_all_cells(page, timeout=120)

    # 1. WebGPU adapter, grass on the canvas, the meadow moves.
    status = wait_for_kernel(page, "w.view.gpu_status", predicate=lambda s: s["state"] != "", timeout=60)
    assert status["state"] == "ok", status
    assert kernel_eval(page, "w.backend") == "browser"
    wait_for_kernel(page, "w.stats['fps'] is not None and w.stats['visible'] is not None", True, timeout=60)
    first = _canvas_pixels(page)
    h, w = first.shape[:2]
    assert abs(w - SIZE[0]) <= 2 and abs(h - SIZE[1]) <= 2, first.shape
    lower, top = _grass_fraction(first[int(0.6 * h):]), _sky_fraction(first[: int(0.1 * h)])
    print(f"\n[browser engine] canvas {w}x{h}: grass in the lower part {lower:.0%}, sky in the top rows {top:.0%}")
    assert lower > 0.3 and top > 0.9
    steps0 = kernel_eval(page, "w.stats['step_count']")
    wait_for_kernel(page, "w.stats['step_count']", predicate=lambda s: s > steps0 + 30, timeout=30)
    moved = np.abs(_canvas_pixels(page).astype(int) - first.astype(int)).max(axis=2)
    assert (moved > 40).mean() > 0.005, "the meadow did not move while playing"
    fps = kernel_eval(page, "w.stats['fps']")
    print(f"[browser engine] presented {fps:.1f} frames/s at {N_BLADES} blades")

    # 2. Physics equals the kernel engine (waiting for the browser inside a running cell).
    out = kernel_execute(page, """
from grasswidget.gpu.field import GrassField
w.pause()
w.params.wind_strength = 12.0
w.params.wind_field = 'wave'
w.reset_blades()
w.step(200)
w.params.wind_field = 'vortex'
w.step(100)
mine = w.read_state()
kernel_params = w.params.copy()
kernel_params.wind_field = 'wave'
field = GrassField(w.view.engine_widget.blades, params=kernel_params)
field.step(200)
kernel_params.wind_field = 'vortex'
field.step(100)
theirs = field.read_state()
field.release()
b = w.view.engine_widget.blades
err = float((np.abs(mine['v2'] - theirs['v2']).max(axis=1) / b.height).max())
err1 = float((np.abs(mine['v1'] - theirs['v1']).max(axis=1) / b.height).max())
bent = float((np.linalg.norm(theirs['v2'] - b.v0 - b.up * b.height[:, None], axis=1) / b.height).mean())
print('PHYSICS', err, err1, bent)
""", timeout=180)
    err, err1, bent = map(float, out.stdout.split("PHYSICS")[1].split())
    print(f"[browser engine] 300 steps (wave, then vortex wind): |v2 browser - v2 kernel| <= {err:.2e} h, "
          f"v1 {err1:.2e} h; the tips moved {bent:.2f} h on average")
    assert bent > 0.05, "the wind did not bend the grass: the comparison would prove nothing"
    assert err < 1e-4 and err1 < 1e-4

    # 2b. A crowd of 60 balls (set_array): the browser's grid lookup gives the kernel's physics.
    out = kernel_execute(page, """
w.pause()
w.params.wind_field = 'wave'
w.reset_blades()
rng = np.random.default_rng(4)
r = rng.uniform(0.3, 0.8, 60)
crowd = np.column_stack([rng.uniform(-8, 8, 60), r + 0.05, rng.uniform(-8, 8, 60), r])  # resting on the grass
view = w.view.engine_widget
view.colliders.set_array(crowd)
view.colliders_changed()
w.step(100)
mine = w.read_state()
field = GrassField(view.blades, params=w.params.copy())
field.colliders.set_array(crowd)
field.step(100)
theirs = field.read_state()
field.release()
view.colliders.set_array([])
view.colliders_changed()
b = view.blades
e = np.maximum(np.abs(mine['v2'] - theirs['v2']).max(axis=1), np.abs(mine['v1'] - theirs['v1']).max(axis=1)) / b.height
print('CROWD', float(np.percentile(e, 99)), float(e.max()), int((e > 1e-3).sum()), float((theirs['collision'] > 0).mean()),
      float(np.abs(mine['collision'] - theirs['collision']).max()))
""", timeout=180)
    p99, worst, off, touched, eta = map(float, out.stdout.split("CROWD")[1].split())
    print(f"[browser engine] 60 balls, 100 steps: |browser - kernel| / h 99th percentile {p99:.2e}, max {worst:.2e} "
          f"({off:.0f} blades > 1e-3); "
          f"{touched:.0%} of the blades touched; eta differs by <= {eta:.2e}")
    assert touched > 0.1, "the balls hit too few blades: the comparison would prove little"
    # float32 rounding differs between SwiftShader and lavapipe; a few blades wedged between touching
    # balls amplify it (the kernel's grid equals its loop over every ball bit for bit: tests/test_colliders.py)
    assert p99 < 1e-4 and off <= 0.002 * 4096

    # 3. Culling checkboxes change the browser's visible count; all off: every blade (none occluded).
    kernel_execute(page, "w.play()")
    visible_on = wait_for_kernel(page, "w.stats['visible']", predicate=lambda v: v is not None, timeout=20)
    culling = ("orientation culling", "frustum culling", "distance culling")
    for label in culling:
        toggle_checkbox(page, label, False)
    choose_option(page, "occlusion culling", "off")  # auto / on / off
    _show_view(page)
    wait_for_kernel(page, "w.stats['visible']", N_BLADES, timeout=30)
    assert kernel_eval(page, "w.stats['occluded']") is None  # occlusion culling off: no count
    for label in culling:
        toggle_checkbox(page, label, True)
    choose_option(page, "occlusion culling", "auto")  # the browser engine runs "auto" as on
    _show_view(page)
    visible_again = wait_for_kernel(page, "w.stats['visible']", predicate=lambda v: v < N_BLADES, timeout=30)
    print(f"[browser engine] visible with culling: {visible_on} then {visible_again}; without: {N_BLADES}")

    # 3b. Colour by: LOD classes and cull tests drawn flat in their colours (the shared ribbon shader).
    from grasswidget.core.teaching import CULL_COLORS, LOD_COLORS, hex_to_rgb

    def share_of(colors, px):
        rgb = px[..., :3].astype(int)
        return sum(float((np.abs(rgb - np.array(hex_to_rgb(c))).max(axis=-1) <= 12).mean()) for c in colors)

    kernel_execute(page, "w.params.color_by = 'lod'")
    lod = poll(lambda: (lambda f: (f > 0.2, f))(share_of(LOD_COLORS, _canvas_pixels(page))),
               "the LOD colours to cover the grass", 30, 0.3, page=page)
    kernel_execute(page, "w.params.color_by = 'cull'")
    cull = poll(lambda: (lambda f: (f > 0.01, f))(share_of(CULL_COLORS.values(), _canvas_pixels(page))),
                "culled blades in the cull-test colours", 30, 0.3, page=page)
    kernel_execute(page, "w.params.color_by = 'natural'")
    print(f"[browser engine] colour by lod: {lod:.0%} of the view in LOD colours; by cull: {cull:.1%} in cull colours")
    assert "not available" not in kernel_eval(page, "w.panel.message_line.value")

    # 4. A drag on the canvas moves w.camera_state; assigning it moves the view.
    before = kernel_eval(page, "list(w.camera_state['position'])")
    canvas = page.locator("canvas.grasswidget-canvas").first
    drag(page, canvas, 120, 0)
    after = wait_for_kernel(page, "list(w.camera_state['position'])",
                            predicate=lambda p: np.abs(np.subtract(p, before)).max() > 0.5, timeout=20)
    print(f"[browser engine] drag moved the camera from {np.round(before, 2)} to {np.round(after, 2)}")
    shot_a = _canvas_pixels(page)
    kernel_execute(page, "w.pause(); w.camera_state = {'position': (0.0, 8.0, 0.3), 'target': (0.0, 0.0, 0.0)}")
    poll(lambda: _sky_fraction(_canvas_pixels(page)) < 0.05, "a top-down camera to show no sky", 20, 0.3, page=page)
    kernel_execute(page, "w.reset_camera()")
    poll(lambda: _sky_fraction(_canvas_pixels(page)[:20]) > 0.9, "reset_camera to bring the sky back", 20, 0.3,
         page=page)
    assert shot_a.shape == first.shape

    # 5. Save PNG: rendered by the browser at 2x, anti-aliased there (rendered 2x larger again and
    # filtered down), written into output/ beside the notebook by Python. Paused, so the picture can be retaken.
    kernel_execute(page, "w.pause()")
    old = set((root / "output").glob("grass-*.png"))
    click_button(page, "Save PNG")
    new = poll(lambda: set((root / "output").glob("grass-*.png")) - old, "Save PNG to write a file", 60, 0.3, page=page)
    import imageio.v3 as iio

    img = poll(lambda: (True, iio.imread(next(iter(new)))), "the saved PNG to be readable", 10, 0.2, page=page)
    assert img.shape[:2] == (2 * SIZE[1], 2 * SIZE[0]), img.shape
    frac = _grass_fraction(img[int(0.6 * img.shape[0]):])
    print(f"[browser engine] Save PNG wrote {next(iter(new)).name} {img.shape[1]}x{img.shape[0]}, grass {frac:.0%}")
    assert frac > 0.3
    out = kernel_execute(page, f"""
import imageio.v3 as iio, numpy as np
png = iio.imread({str(next(iter(new)))!r})[..., :3].astype(int)
size = (png.shape[1], png.shape[0])
aa = w.view.engine_widget.snapshot(size, supersample=2)[..., :3].astype(int)
plain = w.view.engine_widget.snapshot(size)[..., :3].astype(int)
print('DIFF', np.abs(png - aa).mean(), np.abs(png - plain).mean())
""", timeout=120)
    to_aa, to_plain = map(float, out.stdout.split("DIFF")[1].split())
    print(f"[browser engine] Save PNG vs a supersampled snapshot of the paused meadow: mean {to_aa:.3f}/255; "
          f"vs a plain one: {to_plain:.2f}/255")
    # the button's picture is the anti-aliased one (a few blades may draw in another order: not 0)
    assert to_aa < 0.2 * to_plain and to_plain > 0.3
    art = os.environ.get("GW_ARTIFACTS_DIR")
    if art:
        os.makedirs(art, exist_ok=True)
        iio.imwrite(os.path.join(art, "browser_engine_save_png.png"), img)
        iio.imwrite(os.path.join(art, "browser_engine_canvas.png"), first)

    # 6. A custom wind that does not compile: its line comes back, the old wind stays.
    kernel_execute(page, "w.params.wind_wgsl = 'let k = 2.0;\\nreturn vec3<f32>(k * oops, 0.0, 0.0);'")
    msg = wait_for_kernel(page, "w.panel.message_line.value", predicate=lambda m: "wind_wgsl line" in m, timeout=30)
    assert "wind_wgsl line 2" in msg and "browser" in msg, msg
    assert kernel_eval(page, "w.params.wind_wgsl") == ""
    out = kernel_execute(page, """
try:
    w.set_wind_wgsl('return vec3<f32>(oops);')
except gw.WindShaderError as e:
    print('RAISED', e.line)
w.set_wind_wgsl('return vec3<f32>(4.0, 0.0, 0.0);')
print('WIND', w.params.wind_field, w.params.wind_wgsl)
""", timeout=60)
    assert "RAISED 1" in out.stdout and "WIND custom return vec3<f32>(4.0" in out.stdout, out.stdout

    # 6b. A custom wind that returns NaN: the browser's simulation puts the blades back at rest
    # (validate_finite), read_state is finite and warns once; a normal wind moves them again.
    out = kernel_execute(page, """
import warnings
w.pause()
w.reset_blades()
w.set_wind_wgsl('return vec3<f32>(sqrt(-1.0 - abs(t)));')
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter('always')
    w.step(10)
    s1 = w.read_state()
    w.step(5)
    s2 = w.read_state()
b = w.view.engine_widget.blades
rest = b.v0 + b.up * b.height[:, None]
n_warn = sum(issubclass(c.category, gw.NonFiniteStateWarning) for c in caught)
at_rest = max(float(np.abs(s[k] - rest).max()) for s in (s1, s2) for k in ('v1', 'v2'))
finite = all(np.isfinite(s[k]).all() for s in (s1, s2) for k in ('v1', 'v2', 'collision'))
w.set_wind_wgsl('return vec3<f32>(20.0, 0.0, 0.0);')
w.step(20)
s3 = w.read_state()
print('NANWIND', n_warn, at_rest, int(finite), float(np.abs(s3['v2'] - rest).max()), int(len(s3['collision']) == len(b.v0)))
""", timeout=120)
    n_warn, at_rest, finite, moved, same_len = out.stdout.split("NANWIND")[1].split()
    print(f"[browser engine] NaN wind: {n_warn} warning, blades within {float(at_rest):.1e} m of rest; "
          f"a normal wind moved the tips {float(moved):.2f} m")
    assert int(n_warn) == 1 and float(at_rest) < 1e-5 and finite == "1" and same_len == "1"
    assert float(moved) > 1e-2

    # 7. A lost device is recovered with a message; a view that is not shown times out.
    _show_view(page)
    kernel_execute(page, "w.play(); w.view.engine_widget.lose_device()")
    wait_for_kernel(page, "w.panel.message_line.value", predicate=lambda m: "lost its WebGPU device" in m, timeout=30)
    steps = kernel_eval(page, "w.stats['step_count']")
    wait_for_kernel(page, "w.stats['step_count']", predicate=lambda s: s != steps, timeout=60)
    assert kernel_eval(page, "w.view.gpu_status['state']") == "ok"
    out = kernel_execute(page, """
from grasswidget.browser import BrowserEngineWidget
hidden = BrowserEngineWidget(16)
try:
    hidden.read_state(timeout=1.0)
except TimeoutError as e:
    print('TIMEOUT', e)
""", timeout=30)
    assert "TIMEOUT" in out.stdout and "browser view" in out.stdout, out.stdout
    kernel_execute(page, "w.close()")


def test_browser_without_webgpu_falls_back(browser, lab_server, browser_root):
    """Chromium without the WebGPU flags: requestAdapter() gives null -> kernel streaming + one line."""
    page = browser.page
    write_notebook(browser_root / "browser_fallback.ipynb", [
        "import grasswidget as gw\nw = gw.GrassWidget(1024, backend='auto', size=(320, 240))\nw",
    ])
    try:
        open_notebook(page, lab_server, "browser_fallback.ipynb")
        run_all_cells(page, timeout=120)
        wait_for_kernel(page, "w.backend", "kernel", timeout=60)
        msg = kernel_eval(page, "w.panel.message_line.value")
        print(f"\n[fallback] {msg}")
        assert "WebGPU is not available in this browser" in msg
        wait_for_view(page, 0, timeout=60)
        wait_for_frames(page, 3, timeout=60, index=0)
        set_slider(page, panel_label("wind_strength"), 21.5)
        wait_for_kernel(page, "w.params.wind_strength", 21.5, timeout=20)
        kernel_execute(page, "w.step(5)")
        assert kernel_eval(page, "w.scene.field.step_count") >= 5
        assert kernel_eval(page, "sorted(w.camera_state)") == ["fov_deg", "position", "target"]
    finally:
        try:
            leave_notebook(page, lab_server, reload=sys.exc_info()[0] is not None)
        except Exception:
            pass
