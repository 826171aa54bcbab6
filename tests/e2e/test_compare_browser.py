"""A comparison (gw.compare) in JupyterLab and Chromium: both views stream, a drag in one
view orbits both cameras alike, the other view's picture follows, the play button of
the shared panel pauses and plays both views, and each view shows its own chart.

Saves a screenshot of the comparison (``compare-jupyterlab.png`` in ``$GW_ARTIFACTS_DIR``
or a temporary folder, path printed) to look at.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np

from .controls import drag
from .frames import view_locator, view_pixels, wait_for_view, wait_until_quiet
from .kernel_calls import kernel_eval, wait_for_kernel
from .notebook_actions import open_notebook, run_all_cells, write_notebook
from .polling import poll

CAMERAS = "[list(w.camera_state['position']) for w in c.widgets.values()]"


def _settled_cameras(page, timeout=40.0):
    """Both views' camera positions once two readings 0.5 s apart agree (the orbit is damped)."""
    last = [None]

    def check():
        p = np.array(kernel_eval(page, CAMERAS))
        ok = last[0] is not None and bool(np.allclose(p, last[0], atol=1e-6))
        last[0] = p
        return ok, p

    return poll(check, "both cameras to come to rest after the drag", timeout, interval=0.5, page=page)


def test_drag_in_one_view_orbits_both(page, lab_server, browser_root):
    write_notebook(browser_root / "compare_views.ipynb", [
        "import grasswidget as gw",
        "c = gw.compare({'soft': {'stiffness_scale': 0.5}, 'stiff': {'stiffness_scale': 2.0}}, "
        "blades=512, size=(240, 180))\nc.pause()\nc.inspect([17])\n"
        "for view in c.widgets.values():\n    view.chart = 'tip'\nc",
    ])
    open_notebook(page, lab_server, "compare_views.ipynb")
    old_viewport = page.viewport_size
    page.set_viewport_size({"width": 1280, "height": 1600})  # views and panel on screen together:
    try:  # jupyter-rfb asks for frames only while a view is visible
        _check(page)
    finally:
        page.set_viewport_size(old_viewport)


def _check(page):
    run_all_cells(page, timeout=180)
    wait_for_view(page, 0, timeout=60)
    wait_for_view(page, 1, timeout=60)
    wait_until_quiet(page, index=1)
    before = np.array(kernel_eval(page, CAMERAS))
    assert np.allclose(before[0], before[1])
    second_before = view_pixels(page, 1)

    drag(page, view_locator(page, 0), 110, 0)
    moved = wait_for_kernel(page, CAMERAS, timeout=30,
                            predicate=lambda p: min(np.linalg.norm(np.subtract(p[k], before[k])) for k in (0, 1)) > 0.5)
    after = _settled_cameras(page)
    print(f"[compare] camera positions {np.round(before[0], 2)} -> {np.round(after[0], 2)} and {np.round(after[1], 2)}")
    assert np.allclose(after[0], after[1], atol=1e-4)  # both views moved, equally
    assert np.linalg.norm(after[1] - before[1]) > 0.5 and moved is not None
    targets = np.array(kernel_eval(page, "[list(w.camera_state['target']) for w in c.widgets.values()]"))
    assert np.allclose(targets[0], targets[1], atol=1e-4)

    # the second view's picture follows its camera (the browser got a new frame)
    wait_until_quiet(page, index=1)
    second_after = view_pixels(page, 1)
    assert second_after.shape == second_before.shape
    assert np.abs(second_after[..., :3].astype(int) - second_before[..., :3].astype(int)).mean() > 3

    # the shared panel's play button plays both views, and pauses both
    page.locator(".grasswidget-compare button:visible", has_text="Play").first.click()
    wait_for_kernel(page, "[w.playing for w in c.widgets.values()]", [True, True], timeout=20)
    wait_for_kernel(page, "min(c.sim_times.values()) > 0.2", True, timeout=60)
    page.locator(".grasswidget-compare button:visible", has_text="Pause").first.click()
    wait_for_kernel(page, "[w.playing for w in c.widgets.values()]", [False, False], timeout=20)
    times = kernel_eval(page, "[w.view.clock.steps for w in c.widgets.values()]")
    assert times[0] == times[1] > 0  # paused at the same simulated time

    # a chart under each view, each with its own view's samples
    charts = page.locator(".grasswidget-compare .gw-trace-chart canvas")
    poll(lambda: charts.count() >= 2 and charts.nth(0).is_visible() and charts.nth(1).is_visible(),
         "a chart under each view", 30, 0.5, page=page)
    counts = kernel_eval(page, "[len(w.traces()['t']) for w in c.widgets.values()]")
    assert min(counts) >= 2, counts

    out = Path(os.environ.get("GW_ARTIFACTS_DIR") or tempfile.mkdtemp(prefix="gw-compare-"))
    out.mkdir(parents=True, exist_ok=True)
    page.locator(".grasswidget-compare").first.screenshot(path=str(out / "compare-jupyterlab.png"))
    print(f"[compare] screenshot: {out / 'compare-jupyterlab.png'}")
