"""The widget in Jupyter Notebook 7 and in Voila, in Chromium (the JupyterLab tests' harness).

For each front end, two notebooks, as in tests/e2e/test_browser_engine.py:

* ``GrassWidget(backend="browser")`` in a Chromium with WebGPU (SwiftShader): the
  canvas shows grass under a sky, the panel's stats line counts frames and
  visible blades, culling checkboxes turned off make every blade visible, a
  shift + drag switches the ball on and moves it (and in Notebook 7 a drag
  orbits ``w.camera_state``);
* ``GrassWidget(backend="auto")`` in a Chromium without WebGPU: the widget falls
  back to the kernel engine (one line says WebGPU is not available), frames
  stream into the jupyter-rfb view, the wind slider and Pause reach the kernel.

Notebook 7 is driven like JupyterLab (the app is exposed as ``window.jupyterapp``),
so the kernel side is checked too. Voila shows outputs only: everything is checked
through the page, as a visitor of the app would see it.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from .controls import choose_option, drag, panel_label, set_slider, slider_readout, toggle_checkbox
from .frames import wait_for_frames, wait_for_view, wait_until_quiet
from .kernel_calls import kernel_eval, wait_for_kernel
from .notebook_actions import open_notebook, run_all_cells, write_notebook
from .polling import poll
from .servers import JupyterLabServer

pytestmark = [pytest.mark.browser, pytest.mark.slow]

N_BLADES = 2048
BROWSER_CELL = f"import grasswidget as gw\nw = gw.GrassWidget({N_BLADES}, backend='browser', size=(320, 240))\nw"
FALLBACK_CELL = "import grasswidget as gw\nw = gw.GrassWidget(1024, backend='auto', size=(320, 240))\nw"
VISIBLE = re.compile(r"([\d,]+) of ([\d,]+) blades drawn")



@pytest.fixture(scope="module")
def front_end_root(tmp_path_factory):
    root = tmp_path_factory.mktemp("front-ends")
    write_notebook(root / "browser_engine.ipynb", [BROWSER_CELL])
    write_notebook(root / "fallback.ipynb", [FALLBACK_CELL])
    return root


@pytest.fixture(scope="module", params=["notebook", "voila"])
def server(request, front_end_root):
    # Notebook 7's kernel is reset and kept for the module's next notebook (JupyterLabServer.shutdown_kernels)
    with JupyterLabServer(front_end_root, app=request.param, reuse_kernels=request.param == "notebook") as s:
        yield s
    s.cleanup()


def _grass_fraction(px):
    rgb = px[..., :3].astype(np.int32)
    return float(((rgb[..., 1] > rgb[..., 0] + 8) & (rgb[..., 1] > rgb[..., 2] + 8)).mean())


def _sky_fraction(px):
    rgb = px[..., :3].astype(np.int32)
    return float(((rgb[..., 2] > rgb[..., 0] + 10) & (rgb[..., 2] >= rgb[..., 1])).mean())


def _canvas_pixels(page):
    import imageio.v3 as iio

    loc = page.locator("canvas.grasswidget-canvas").first
    loc.scroll_into_view_if_needed()
    return iio.imread(loc.screenshot(), extension=".png")


def _stats_text(page):
    return page.locator(".grasswidget").first.inner_text()


def _visible(page):
    m = VISIBLE.search(_stats_text(page))
    return (int(m.group(1).replace(",", "")), int(m.group(2).replace(",", ""))) if m else None


def _open(page, server, name):
    if server.app == "voila":  # Voila runs the notebook while it renders the page
        page.goto(server.url_for(name), wait_until="domcontentloaded", timeout=180_000)
        poll(lambda: page.locator(".grasswidget").count() > 0, f"Voila to show the widget of {name}", 180, 0.5,
             page=page)
    else:
        open_notebook(page, server, name)
        run_all_cells(page, timeout=120)


def _leave(page, server):
    try:
        page.goto("about:blank")
        if server.app != "voila":  # Voila shuts a page's kernel down when the page goes
            server.shutdown_kernels()
    except Exception:
        pass


def test_browser_engine_in_front_end(server, webgpu_browser):
    page = webgpu_browser.page
    kernel = server.app != "voila"
    try:
        _open(page, server, "browser_engine.ipynb")
        # grass under a sky, frames counted on the stats line
        visible = poll(lambda: _visible(page), "the stats line to count visible blades", 90, 0.5, page=page)
        first = _canvas_pixels(page)
        h = first.shape[0]
        lower, top = _grass_fraction(first[int(0.6 * h):]), _sky_fraction(first[: int(0.1 * h)])
        print(f"\n[{server.app}] browser engine: grass {lower:.0%} in the lower part, sky {top:.0%} on top; "
              f"{visible[0]} of {visible[1]} blades drawn")
        assert lower > 0.3 and top > 0.9
        assert visible[1] == N_BLADES and visible[0] < N_BLADES
        if kernel:
            assert kernel_eval(page, "w.backend") == "browser"
            assert kernel_eval(page, "w.view.gpu_status['state']") == "ok"
        # culling off in the panel: every blade is drawn
        for label in ("orientation culling", "frustum culling", "distance culling"):
            toggle_checkbox(page, label, False)
        choose_option(page, "occlusion culling", "off")  # the panel's auto / on / off choice
        # back in sight: a view scrolled away (by the clicks under it) rests and sends no stats
        page.locator("canvas.grasswidget-canvas").first.scroll_into_view_if_needed()
        poll(lambda: (_visible(page) or (0,))[0] == N_BLADES, "every blade visible with culling off", 30, 0.3,
             page=page)
        # pointer input reaches the engine: shift + drag (below) moves the ball; in Notebook 7 a
        # plain drag also orbits the kernel's camera_state (orbiting itself: test_browser_engine.py)
        canvas = page.locator("canvas.grasswidget-canvas").first
        if kernel:
            before = kernel_eval(page, "list(w.camera_state['position'])")
            drag(page, canvas, 120, 0)
            wait_for_kernel(page, "list(w.camera_state['position'])",
                            predicate=lambda p: np.abs(np.subtract(p, before)).max() > 0.5, timeout=20)
        # shift + drag: the ball switches on and follows the pointer (its x slider moves)
        x_before = slider_readout(page, "x")
        page.keyboard.down("Shift")
        try:
            drag(page, canvas, -60, 20, start=(200, 180))
        finally:
            page.keyboard.up("Shift")
        poll(lambda: page.locator(".widget-checkbox", has_text="sphere").locator("input").is_checked(),
             "shift + drag to switch the ball on", 20, 0.2, page=page)
        x_after = poll(lambda: (lambda r: (r != x_before, r))(slider_readout(page, "x")),
                       "the ball's x to follow the pointer", 20, 0.2, page=page)
        print(f"[{server.app}] ball x {x_before} -> {x_after}")
        if kernel:
            assert kernel_eval(page, "w.ball.enabled") is True
    finally:
        _leave(page, server)


def test_fallback_in_front_end(server, browser):
    page = browser.page
    kernel = server.app != "voila"
    try:
        _open(page, server, "fallback.ipynb")
        poll(lambda: "WebGPU is not available in this browser" in _stats_text(page),
             "the line saying WebGPU is not available", 90, 0.3, page=page)
        wait_for_view(page, 0, timeout=90)
        from .frames import install_frame_counter

        install_frame_counter(page)
        wait_for_frames(page, 3, timeout=60, index=0)
        if kernel:
            wait_for_kernel(page, "w.backend", "kernel", timeout=30)
        set_slider(page, panel_label("wind_strength"), 21.5)
        if kernel:
            wait_for_kernel(page, "w.params.wind_strength", 21.5, timeout=20)
        # Pause reaches the kernel: its stream stops (in Voila the only way to see the kernel act)
        page.locator("button.jupyter-button", has_text=re.compile(r"^\s*Pause\s*$")).first.click()
        wait_until_quiet(page, 0.8, timeout=30, index=0)
        if kernel:
            assert kernel_eval(page, "w.playing") is False
        print(f"\n[{server.app}] fallback: kernel frames stream, the wind slider and Pause reach the kernel")
    finally:
        _leave(page, server)
