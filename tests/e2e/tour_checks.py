"""What the tour notebook's widget does for a user in a real JupyterLab + Chromium.

:func:`check_tour` runs in the Run All test of ``notebooks/01_tour.ipynb``
(``tests/e2e/test_notebooks_run_all.py``, the run without WebGPU), on the page and kernel
that Run All left, once that test has checked the notebook's outputs and that every widget draws;
so the tour runs once in the suite. Through the page and the kernel it checks:

* the tour's ``backend="browser"`` widget fell back to kernel streaming in a Chromium without
  WebGPU, said so, steps and has a ``camera_state`` (its panel's slider reaching the kernel after the
  fall-back: ``test_front_ends.py::test_fallback_in_front_end``);
* frames stream and show grass (green-dominant pixels in the lower part);
* a slider moved in the page reaches Python (``w.params.wind_strength``), and
  junk or out-of-range text typed into a slider readout breaks nothing;
* toggling a culling checkbox changes the number of visible blades;
* a mouse drag orbits the camera (its position changes in the kernel); shift + drag puts the ball
  under the pointer;
* the keyboard works only through the focused view (space = play/pause);
* "Save PNG" writes a PNG into output/ beside the notebook;
* while playing, simulated time follows the wall clock (``w.sim_time`` against
  the kernel's clock over several seconds, within 10%).

With GRASSWIDGET_SAVE_BENCH=1 it is also a benchmark: it measures, at 640 x 480 for the
default widget and for 2^14 blades, the frames/s reaching Chromium, the kernel's
render-only rate (step + render + readback, offscreen, at the full size), the
simulated/wall ratio and the render scale in use, prints them and writes
benchmarks/results/browser_fps-<adapter>-<date>.json; a plain test run measures only what it asserts.
"""

from __future__ import annotations

import json
import os
import platform
import time
from pathlib import Path

import numpy as np

from .controls import click_button, drag, panel_label, set_slider, toggle_checkbox
from .frames import frames_per_second, view_locator, view_pixels, wait_for_frames, wait_for_view
from .kernel_calls import kernel_eval, kernel_execute, wait_for_kernel
from .notebook_actions import wait_for_output_text
from .polling import poll

ROOT = Path(__file__).resolve().parents[2]
BENCH_BLADES = 1 << 14


def _grass_fraction(px):
    rgb = px[..., :3].astype(np.int32)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    return float(((g > r + 8) & (g > b + 8)).mean())


def _settled_camera(page, timeout=30.0):
    """The camera position once two readings 0.5 s apart (several frames) agree."""
    last = [None]

    def check():
        p = np.array(kernel_eval(page, "w.scene.camera.world.position.tolist()"))
        ok = last[0] is not None and bool(np.allclose(p, last[0], atol=1e-6))
        last[0] = p
        return ok, p

    return poll(check, "the camera to come to rest after the drag", timeout, interval=0.5, page=page)


def _adapter_tag(summary: str) -> str:
    s = summary.lower()
    if "llvmpipe" in s or "lavapipe" in s:
        return "lavapipe"
    return "".join(c if c.isalnum() else "_" for c in s.split("(")[0].strip())[:40] or "unknown"


# Kernel-side helpers: the render-only rate at the widget's full size, and the clocks.
KERNEL_HELPERS = """
def _gw_render_only_fps(w, scale=1.0, frames=15):
    import time
    from rendercanvas.offscreen import RenderCanvas
    from grasswidget.gpu.scene import make_renderer
    canvas = RenderCanvas(size=w.size, pixel_ratio=scale)
    renderer = make_renderer(canvas)
    renderer.pixel_scale = 1  # render at the canvas's physical size, as the widget does
    canvas.request_draw(lambda: renderer.render(w.scene.scene, w.scene.camera))
    canvas.draw()
    t0 = time.perf_counter()
    for _ in range(frames):
        w.scene.field.step(1)
        canvas.draw()
    rate = frames / (time.perf_counter() - t0)
    canvas.close()
    return rate

def _gw_clocks(w):
    import time
    return [time.perf_counter(), w.sim_time]
"""


#: Benchmark mode (GRASSWIDGET_SAVE_BENCH=1): also the render-only rate and the 2^14-blade figures,
#: written to benchmarks/results/; a plain test run measures only what it asserts.
BENCH_MODE = os.environ.get("GRASSWIDGET_SAVE_BENCH") == "1"


def _live_figures(page, seconds):
    """Frames/s reaching Chromium over ``seconds`` while playing, the simulated/wall
    ratio over the same window, the render scale in use; in benchmark mode then the
    render-only rate (paused, so nothing else runs in the kernel meanwhile)."""
    kernel_execute(page, "w.play()", timeout=30)
    view_locator(page, 0).scroll_into_view_if_needed()  # jupyter-rfb draws only while the view is visible
    wait_for_frames(page, 40, timeout=120, index=0)  # the adaptive scale settles over these frames
    a = kernel_eval(page, "_gw_clocks(w)")
    fps = frames_per_second(page, seconds=seconds, index=0)
    b = kernel_eval(page, "_gw_clocks(w)")
    scale = kernel_eval(page, "w.render_scale")
    stats = kernel_eval(page, "{k: v for k, v in w.stats.items() if k != 'gpu_ms'}")
    render_only = float("nan")
    if BENCH_MODE:
        kernel_execute(page, "w.pause()", timeout=30)
        render_only = kernel_eval(page, f"_gw_render_only_fps(w, {scale})", timeout=120)
        kernel_execute(page, "w.play()", timeout=30)
    return dict(delivered_fps=round(fps, 2), render_only_fps=round(render_only, 2),
                delivered_over_render_only=round(fps / render_only, 3),
                sim_over_wall=round((b[1] - a[1]) / (b[0] - a[0]), 3), render_scale=scale, widget_stats=stats)


def check_tour(page, folder):
    """The tour's checks (see the module's docstring) on ``page``, where the tour notebook has
    just run (Run All) with its kernel still up; ``folder`` is the folder the notebook is in."""
    # The tour's browser-engine section made a second widget with backend="browser": this Chromium
    # has no WebGPU, so it fell back to kernel streaming and said so. Then it is closed, so the
    # checks below find each control of the first widget by its label alone.
    # Run All checked that its view streams new frames; here it also steps and keeps its camera_state.
    wait_for_kernel(page, "wb.backend", "kernel", timeout=90)
    assert "WebGPU is not available in this browser" in kernel_eval(page, "wb.panel.message_line.value")
    kernel_execute(page, "wb.step(5)")
    assert kernel_eval(page, "wb.scene.field.step_count") >= 5
    assert kernel_eval(page, "sorted(wb.camera_state)") == ["fov_deg", "position", "target"]
    kernel_execute(page, "wb.close()")

    # 1. Frames stream and show grass.
    wait_for_view(page, 0, timeout=60)
    wait_for_frames(page, 5, timeout=60, index=0)
    px = view_pixels(page, 0)
    h, w, _ = px.shape
    # 640 x 480 at the adaptive render scale (0.5 .. 1) in use while playing
    assert 0.49 <= w / 640 <= 1.01 and abs(w / 640 - h / 480) < 0.02, px.shape
    lower = _grass_fraction(px[int(0.55 * h):int(0.85 * h)])
    upper = _grass_fraction(px[: int(0.1 * h)])
    print(f"\n[tour] frame {w}x{h}: grass in the lower part {lower:.0%}, in the top rows {upper:.0%}")
    assert lower > 0.5 and upper < 0.1
    kernel_execute(page, KERNEL_HELPERS, timeout=30)
    live_default = _live_figures(page, 5.0)
    fps_default = live_default["delivered_fps"]
    print(f"[tour] default widget: {live_default}")
    # real time: simulated seconds follow the kernel's wall clock while playing
    assert 0.9 <= live_default["sim_over_wall"] <= 1.1, live_default  # within 10% (a frame is a step of it)
    n_default = kernel_eval(page, "w.blade_count")
    print(f"[tour] {n_default} blades (the default) at 640x480: {fps_default:.1f} frames/s reach Chromium")

    # 2. A slider moved in the page reaches Python.
    set_slider(page, panel_label("wind_strength"), 37.5)
    wait_for_kernel(page, "w.params.wind_strength", 37.5, timeout=20)

    # ...and bad text typed into a readout breaks nothing: junk is refused by the
    # slider, an out-of-range number is clamped to the slider's (= the trait's) range.
    set_slider(page, panel_label("gravity"), "heavy", check=False)
    set_slider(page, panel_label("gravity"), 1e9, check=False)
    wait_for_kernel(page, "w.params.gravity", 50.0, timeout=20)
    set_slider(page, panel_label("gravity"), 9.8)
    wait_for_kernel(page, "w.params.gravity", 9.8, timeout=20)

    # 3. Toggling a culling checkbox changes the visible count.
    assert kernel_eval(page, "w.params.cull_orientation") is True
    before = kernel_eval(page, "w.scene.visible_count()")
    toggle_checkbox(page, "orientation culling")
    wait_for_kernel(page, "w.params.cull_orientation", False, timeout=20)
    after = wait_for_kernel(page, "w.scene.visible_count()", predicate=lambda v: v > before, timeout=20)
    print(f"[tour] visible blades: {before} with orientation culling, {after} without")
    toggle_checkbox(page, "orientation culling")
    wait_for_kernel(page, "w.params.cull_orientation", True, timeout=20)

    # 4. A drag orbits the camera.
    p0 = np.array(kernel_eval(page, "w.scene.camera.world.position.tolist()"))
    drag(page, view_locator(page, 0), 150, 0)
    p1 = np.array(wait_for_kernel(
        page, "w.scene.camera.world.position.tolist()",
        predicate=lambda p: float(np.linalg.norm(np.array(p) - p0)) > 0.5, timeout=20))
    # The orbit is damped: it runs on for a few frames after the drag (longer on a slow machine).
    # What the user sees next starts from where the view came to rest.
    p1 = _settled_camera(page)
    target = np.array(kernel_eval(page, "w.controller.target.tolist()"))
    print(f"[tour] camera moved {np.linalg.norm(p1 - p0):.2f} m around {np.round(target, 2)}")

    # 4b. Shift + drag puts the ball on the ground under the pointer and moves it.
    assert kernel_eval(page, "w.ball.enabled") is False
    page.keyboard.down("Shift")
    try:
        drag(page, view_locator(page, 0), 120, 0, start=(200, 400))
    finally:
        page.keyboard.up("Shift")
    wait_for_kernel(page, "w.ball.enabled", True, timeout=20)
    # the ball ends where the pointer left the ground (the camera did not move)
    foot = kernel_eval(page, "__import__('grasswidget.notebook.ball', fromlist=['x'])"
                             ".ground_point(w.scene.camera, 320, 400, w.size)")
    c1 = np.array(wait_for_kernel(
        page, "list(w.ball.collider.center)",
        predicate=lambda c: abs(c[0] - foot[0]) < 0.5 and abs(c[2] - foot[1]) < 0.5, timeout=20))
    print(f"[tour] shift + drag put the ball at {np.round(c1, 2)} (the pointer's end on the ground: "
          f"{np.round(foot, 2)})")
    assert kernel_eval(page, "len(w.scene.colliders)") == 1
    assert np.allclose(kernel_eval(page, "w.scene.camera.world.position.tolist()"), p1, atol=1e-6)  # no orbit
    kernel_execute(page, "w.ball.enabled = False", timeout=20)

    # 5. Keys reach the widget through the focused view (the drag focused it).
    page.keyboard.press("Space")
    wait_for_kernel(page, "w.playing", False, timeout=15)
    page.keyboard.press("r")
    wait_for_kernel(page, "w.scene.camera.world.position.tolist()",
                    predicate=lambda p: float(np.linalg.norm(np.array(p) - p0)) < 1e-3, timeout=15)
    page.keyboard.press("Space")
    wait_for_kernel(page, "w.playing", True, timeout=15)

    # 6. Save PNG writes a file into output/ beside the notebook and shows its name.
    saved_before = set((folder / "output").glob("grass-*.png"))  # the folder is shared with other tests
    click_button(page, "Save PNG")
    text = wait_for_output_text(page, "saved grass-", timeout=60)
    pngs = sorted(set((folder / "output").glob("grass-*.png")) - saved_before)
    assert len(pngs) == 1, (pngs, text[-300:])
    import imageio.v3 as iio

    img = iio.imread(pngs[0])
    assert img.shape[:2] == (960, 1280), img.shape
    assert _grass_fraction(img[int(0.55 * 960):int(0.85 * 960)]) > 0.5
    print(f"[tour] Save PNG wrote {pngs[0].name} {img.shape[1]}x{img.shape[0]}")

    # 7. Benchmark (GRASSWIDGET_SAVE_BENCH=1 only): frames/s reaching Chromium at 640 x 480 with 2^14 blades.
    if not BENCH_MODE:
        return
    kernel_execute(page, f"w.blade_count = {BENCH_BLADES}", timeout=60)
    view_locator(page, 0).scroll_into_view_if_needed()  # the panel above may have scrolled it away
    wait_for_kernel(page, "w.scene.field.count", BENCH_BLADES, timeout=30)
    wait_for_frames(page, 3, timeout=60, index=0)
    live = _live_figures(page, 5.0)
    fps, stats = live["delivered_fps"], live["widget_stats"]
    info = kernel_eval(page, "__import__('grasswidget.gpu.adapter', fromlist=['x']).adapter_info()['summary']")
    print(f"[tour] {BENCH_BLADES} blades at 640x480: {fps:.1f} frames/s reach Chromium ({info}); widget stats {stats}")
    assert fps > 0
    result = dict(
        what="frames/s reaching headless Chromium from GrassWidget (JupyterLab, jupyter-rfb), counted over 5 s",
        blades=BENCH_BLADES, size=[640, 480], frames_per_second=round(fps, 2), adapter=info,
        default_blades=n_default, frames_per_second_default_blades=round(fps_default, 2),
        default=live_default, bench=live, target_fps=kernel_eval(page, "w.target_fps"),
        note="sim_over_wall: simulated / kernel wall seconds while playing; render_only_fps: the kernel alone "
             "(step + render + readback, offscreen, at the render scale in use, paused widget); render_scale: the "
             "adaptive scale in use while the frames were counted. Ratios are from one run.",
        widget_stats=stats, max_fps=kernel_eval(page, "w.max_fps"), jpeg_quality=kernel_eval(page, "w.canvas.quality"),
        machine=dict(platform=platform.platform(), cpus=os.cpu_count(),
                     load_average_1min=round(os.getloadavg()[0], 2)),
        date=time.strftime("%Y-%m-%d %H:%M:%S"),
    )
    print("[tour] " + json.dumps(result))
    if BENCH_MODE:
        day = time.strftime("%Y-%m-%d", time.gmtime())
        out = ROOT / "benchmarks" / "results" / f"browser_fps-{_adapter_tag(info)}-{day}.json"
        out.parent.mkdir(parents=True, exist_ok=True)
        out.write_text(json.dumps(result, indent=2) + "\n")
