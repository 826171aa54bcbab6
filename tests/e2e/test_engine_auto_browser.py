"""backend="auto" (the default) in JupyterLab + Chromium, the page's adapter deciding the engine.

The kernel here renders on lavapipe (a CPU adapter), so the page's adapter decides
(grasswidget.core.engine_choice; the tiny probe grasswidget.browser.adapter_probe reports it):

* Chromium with WebGPU on SwiftShader: a fallback adapter, so the kernel engine stays; its
  frames stream from the start (they never wait for the decision) and the message line says why.
* The same Chromium with a hardware adapter simulated (a test-only page global that makes the
  probe report vendor "nvidia", not a fallback): the widget switches to the browser engine,
  which then really draws grass in its canvas (on SwiftShader underneath); save_png (browser)
  and save_animation (kernel engine, from the browser's state) still work.

The third outcome, a Chromium without WebGPU (kernel engine, "WebGPU is not available in this
browser"), is test_browser_engine.py::test_browser_without_webgpu_falls_back.
"""

from __future__ import annotations

import html
import os
import sys

import numpy as np
import pytest

from .frames import wait_for_frames, wait_for_view
from .kernel_calls import kernel_eval, kernel_execute, wait_for_kernel
from .notebook_actions import leave_notebook, open_notebook, run_all_cells, write_notebook
from .polling import poll

pytestmark = pytest.mark.browser

CELL = "import grasswidget as gw\nw = gw.GrassWidget(1024, size=(320, 240))\nw"
SIMULATED_GPU = "globalThis.__grasswidgetTestAdapterInfo = {vendor: 'nvidia', architecture: 'ampere', fallback: false};"


def _grass_fraction(px):
    rgb = px[..., :3].astype(np.int32)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    return float(((g > r + 8) & (g > b + 8)).mean())


def _finish(page, lab_server):
    try:
        leave_notebook(page, lab_server, reload=sys.exc_info()[0] is not None)
    except Exception:
        pass


def test_auto_with_swiftshader_keeps_the_kernel_engine(webgpu_browser, lab_server, browser_root):
    page = webgpu_browser.page
    write_notebook(browser_root / "auto_swiftshader.ipynb", [CELL])
    try:
        open_notebook(page, lab_server, "auto_swiftshader.ipynb")
        run_all_cells(page, timeout=120)
        # Kernel frames stream whatever the probe says (the first frame does not wait for it).
        wait_for_view(page, 0, timeout=60)
        wait_for_frames(page, 3, timeout=60, index=0)
        reason = wait_for_kernel(page, "w.engine_reason", predicate=lambda r: "no view has reported" not in r,
                                 timeout=30)
        print(f"\n[auto, SwiftShader] {reason}")
        assert reason == ("kernel engine: the kernel renders on a CPU adapter (llvmpipe) and this browser's "
                          "WebGPU adapter is a CPU fallback too (google swiftshader)")
        assert kernel_eval(page, "w.backend") == "kernel"
        assert kernel_eval(page, "w.adapter_probe.report['architecture']") == "swiftshader"
        assert reason in html.unescape(kernel_eval(page, "w.panel.message_line.value"))
        assert page.locator("canvas.grasswidget-canvas").count() == 0  # no browser engine was started
    finally:
        _finish(page, lab_server)


def test_auto_with_a_hardware_adapter_runs_the_browser_engine(webgpu_browser, lab_server, browser_root, tmp_path):
    page = webgpu_browser.new_page()  # its own tab: the simulated adapter stays in it
    page.add_init_script(SIMULATED_GPU)
    write_notebook(browser_root / "auto_hardware.ipynb", [CELL])
    try:
        open_notebook(page, lab_server, "auto_hardware.ipynb")
        run_all_cells(page, timeout=120)
        wait_for_kernel(page, "w.backend", "browser", timeout=60)
        reason = kernel_eval(page, "w.engine_reason")
        print(f"\n[auto, simulated GPU] {reason}")
        assert reason == ("browser engine: the kernel renders on a CPU adapter (llvmpipe) and this browser offers a "
                          "GPU (nvidia ampere)")
        assert reason in html.unescape(kernel_eval(page, "w.panel.message_line.value"))
        # The switch really draws: the browser engine's canvas counts frames and shows grass.
        wait_for_kernel(page, "w.view.gpu_status['state']", "ok", timeout=90)
        canvas = page.locator("canvas.grasswidget-canvas").first
        canvas.scroll_into_view_if_needed()
        count = "document.querySelector('canvas.grasswidget-canvas').grasswidgetFramesDrawn || 0"
        first = page.evaluate(count)
        poll(lambda: (page.evaluate(count) >= first + 5, page.evaluate(count)), "5 browser-engine frames", 60, 0.3,
             page=page)
        assert page.locator(".renderview-wrapper img.renderview-view").count() == 0  # the kernel view is gone
        import imageio.v3 as iio

        px = iio.imread(canvas.screenshot(), extension=".png")
        assert _grass_fraction(px) > 0.2, _grass_fraction(px)
        # What needs the kernel engine, and Save PNG, still work from the browser engine.
        png, gif = os.path.join(tmp_path, "auto.png"), os.path.join(tmp_path, "auto.gif")
        out = kernel_execute(page, f"w.pause(); w.step(10); print(w.save_png({png!r}, size=(160, 120)))\n"
                                   f"print(w.save_animation({gif!r}, seconds=0.4, fps=5, size=(80, 60), "
                                   f"progress=False))", timeout=180)
        assert png in out.stdout and gif in out.stdout, out
        picture = iio.imread(png)
        assert picture.shape[:2] == (120, 160) and _grass_fraction(picture) > 0.2
        film = iio.imread(gif, index=None)
        assert film.shape[:3] == (2, 60, 80) and _grass_fraction(film[-1]) > 0.2  # 0.4 s at 5 frames/s
        iio.imwrite(os.path.join(tmp_path, "auto_browser_canvas.png"), px)
        print(f"[auto, simulated GPU] canvas: {os.path.join(tmp_path, 'auto_browser_canvas.png')}, save_png: {png}")
    finally:
        _finish(page, lab_server)
        page.close()
