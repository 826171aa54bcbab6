"""Self-check of the browser harness with a plain pygfx + rendercanvas widget.

Does not use grasswidget at all: it proves that the harness can open a
notebook in real JupyterLab/Chromium, see frames stream, read the view's
pixels, and that slider input and mouse drags in the page reach Python.
"""

import time

import numpy as np
import pytest

from .controls import click_button, drag, set_slider, slider_readout, toggle_checkbox
from .frames import (
    frame_count, frames_per_second, view_locator, view_pixels, wait_for_frames, wait_for_view, wait_until_quiet,
)
from .kernel_calls import kernel_eval, kernel_execute, wait_for_kernel
from .notebook_actions import cell_output_text, open_notebook, run_all_cells, wait_for_output_text, write_notebook
from .polling import HarnessTimeout, KernelExecutionError

pytestmark = pytest.mark.browser

BACKGROUND = (0x22, 0xAA, 0x66)  # "#2a6"

SETUP_CELL = """\
import pygfx as gfx, ipywidgets as w
from rendercanvas.jupyter import RenderCanvas
canvas = RenderCanvas(size=(320, 240), update_mode="continuous", max_fps=30)
renderer = gfx.WgpuRenderer(canvas, pixel_ratio=1, ppaa="none")
scene = gfx.Scene(); scene.add(gfx.Background.from_color("#2a6"))
cam = gfx.NDCCamera()
canvas.request_draw(lambda: renderer.render(scene, cam))
s = w.FloatSlider(description="gravity", min=0, max=50, value=9.8)
w.VBox([canvas, s])
"""

EVENTS_CELL = """\
pointer_events = {}
def _count_pointer(event):
    pointer_events[event["event_type"]] = pointer_events.get(event["event_type"], 0) + 1
canvas.add_event_handler(_count_pointer, "pointer_down", "pointer_move", "pointer_up")
"""


def _background_fraction(px, tol=8):
    diff = np.abs(px[..., :3].astype(int) - np.array(BACKGROUND)).max(axis=-1)
    return float((diff <= tol).mean())


def test_harness_selfcheck(page, lab_server, browser_root):
    t0 = time.monotonic()
    write_notebook(browser_root / "selfcheck.ipynb", [SETUP_CELL, EVENTS_CELL])

    open_notebook(page, lab_server, "selfcheck.ipynb")
    run_all_cells(page, timeout=120)
    view = wait_for_view(page, 0, timeout=60)

    # 1. Frames stream.
    wait_for_frames(page, 5, timeout=30)
    fps = frames_per_second(page, seconds=3.0, index=0)
    print(f"\n[selfcheck] frames/s reaching the page (320x240, continuous): {fps:.1f}")
    assert fps > 2.0, f"frames barely stream: {fps:.1f} frames/s"

    # 2. Pixels are the background green (JPEG while animating: tolerance).
    px = view_pixels(page, 0)
    # The frame size follows the view's measured CSS size, which is a couple
    # of pixels smaller than the requested canvas size (wrapper border).
    h, w_, c = px.shape
    assert c == 4 and abs(h - 240) <= 4 and abs(w_ - 320) <= 4, px.shape
    print(f"[selfcheck] frame size in the page: {w_}x{h}")
    frac = _background_fraction(px, tol=10)
    assert frac > 0.95, f"only {frac:.1%} of pixels are background green; mean colour {px[..., :3].mean((0, 1))}"

    # 3. Typing a slider value in the page reaches Python.
    assert kernel_eval(page, "s.value") == pytest.approx(9.8)
    shown = set_slider(page, "gravity", 25.5)
    assert shown == "25.50", shown
    wait_for_kernel(page, "s.value", 25.5, timeout=15)
    assert slider_readout(page, "gravity") == "25.50"

    # 4. A mouse drag over the canvas reaches Python as pointer events.
    before = kernel_eval(page, "dict(pointer_events)")
    assert before == {}, before
    drag(page, view_locator(page, 0), 80, 40)
    counts = wait_for_kernel(
        page,
        "dict(pointer_events)",
        predicate=lambda d: d.get("pointer_down", 0) >= 1 and d.get("pointer_move", 0) >= 3 and d.get("pointer_up", 0) >= 1,
        timeout=15,
    )
    print(f"[selfcheck] pointer events seen by Python: {counts}")

    # 5. Stop the animation; the view goes quiet and ends on a lossless PNG
    #    that is exactly the background colour.
    kernel_execute(page, "canvas.set_update_mode('ondemand'); canvas.request_draw()")
    n = wait_until_quiet(page, quiet_s=1.0, timeout=20)
    px = view_pixels(page, 0)
    assert _background_fraction(px, tol=1) == 1.0, px[..., :3].reshape(-1, 3)[:5]
    assert frame_count(page) == n  # nothing new came while we read the pixels

    # 6. kernel_execute reports Python errors clearly.
    with pytest.raises(KernelExecutionError, match="ZeroDivisionError"):
        kernel_execute(page, "1/0")
    assert kernel_execute(page, "print('hello')").stdout == "hello\n"
    print(f"[selfcheck] test body took {time.monotonic() - t0:.1f} s")


WIDGETS_CELL = """\
import ipywidgets as w
clicks = 0
status = w.Label(value="clicks: 0")
def _on_click(b):
    global clicks
    clicks += 1
    status.value = f"clicks: {clicks}"
button = w.Button(description="Press me")
button.on_click(_on_click)
check = w.Checkbox(description="wind", value=False)
n = w.IntSlider(description="blades", min=0, max=1000, value=10)
note = w.HTML(value="<b>hello html</b>")
w.VBox([button, status, check, n, note])
"""


def test_harness_widget_helpers(page, lab_server, browser_root):
    """Buttons, checkboxes, IntSlider and output text, without a canvas;
    also checks that the previous test's notebook is gone (its panel and view closed, the frame
    counter at 0) and that its kernel, when
    kept for this notebook (``reuse_kernels``), holds nothing of it: no name, no widget."""
    write_notebook(browser_root / "widgets.ipynb", [WIDGETS_CELL])
    reused = lab_server.kernels_reused
    open_notebook(page, lab_server, "widgets.ipynb")
    # opened in the Lab the test before left loaded (notebook_actions.leave_notebook) or in a new one: either way
    # the only notebook is this one, no view of the one before is left and the frame counter starts at 0
    panels = page.evaluate("() => [...window.jupyterapp.shell.widgets('main')].filter((w) => w.context)"
                           ".map((w) => w.context.path)")
    assert panels == ["widgets.ipynb"], panels
    assert page.locator("img.renderview-view").count() == 0
    assert frame_count(page) == 0
    left = kernel_eval(page, "[n for n in ('s', 'canvas', 'pointer_events', 'Out') if n in globals() and "
                             "(n != 'Out' or globals()['Out'])] + "
                             "list(__import__('ipywidgets').widgets.widget._instances)")
    print(f"\n[widget helpers] kernel {'kept from the test before' if lab_server.kernels_reused > reused else 'new'};"
          f" left from before: {left}")
    assert left == [], left
    run_all_cells(page)
    assert len(lab_server.api("api/sessions")) == 1, lab_server.api("api/sessions")

    wait_for_output_text(page, "clicks: 0")
    assert "hello html" in cell_output_text(page, 0)
    click_button(page, "Press me")
    click_button(page, "Press me")
    wait_for_output_text(page, "clicks: 2")
    assert kernel_eval(page, "clicks") == 2

    assert toggle_checkbox(page, "wind") is True
    wait_for_kernel(page, "check.value", True)
    assert toggle_checkbox(page, "wind", value=False) is False
    wait_for_kernel(page, "check.value", False)

    assert set_slider(page, "blades", 640) == "640"
    wait_for_kernel(page, "n.value", 640)

    with pytest.raises(HarnessTimeout, match="exactly one slider labelled 'nope'.*blades"):
        set_slider(page, "nope", 1, timeout=1)
