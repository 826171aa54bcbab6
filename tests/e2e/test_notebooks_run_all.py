"""Run All in JupyterLab leaves every widget a notebook showed alive and drawing.

For every notebook in notebooks/ (a glob: notebooks added later are covered), in the shared
JupyterLab and Chromium of tests/e2e/conftest.py: copy it into the served folder, open it,
run "Run All", wait until the kernel is idle with no cell queued, and then check

* in the kernel: every ``GrassWidget`` the notebook made is open (``w.view`` is not None), and
  as many jupyter-rfb views are in the page as kernel-engine widgets;
* in the page, for each kernel view (jupyter-rfb ``img``): it is brought into view, a *new* frame
  arrives after the kernel is asked to draw (``w.canvas.request_draw()``), and the picture is
  not blank (not one flat colour: a grey box fails);
* for each visible browser-engine canvas: its screenshot is not blank;
* where a notebook's last cells set state it then prints (05: the ball's radius and speed), the
  kernel still holds it once the page has drawn every view (checked after the views);
* for the tour (01), in the run without WebGPU: what its widget does for a user, on the same page
  and kernel (sliders, checkboxes, drags, keys, Save PNG, real time: ``tour_checks.py``), so the
  tour runs once for all of it;
* what the notebook computed: the notebook is saved and its outputs, the pictures it wrote into
  ``output/`` and, for 03, a probe of its live widget's culling checkboxes are checked by
  ``tests/notebook_outputs.py`` (03's count tables against the NumPy reference, 07-09's grade
  reports: the starter fails, the solution passes); it wrote nothing else beside itself.

Notebooks that make a ``backend="auto"`` or ``"browser"`` widget are also run in a Chromium with
WebGPU (SwiftShader), where that widget is a browser-engine view: its canvas must draw a picture
(and one per browser-engine widget must). Without WebGPU it falls back to kernel streaming and is
checked as a kernel view.

With ``GW_SHOTS_DIR`` set, the first widget of each notebook (view and panel) is saved there as
``nb-<notebook>.png`` right after Run All, for a person to look at.
"""

from __future__ import annotations

import io
import json
import os
import re
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from notebook_outputs import LIVE_CULLING_PROBE, WRITTEN, check_notebook_outputs

from .tour_checks import check_tour
from .chromium import save_debug_artifacts
from .frames import view_locator, view_pixels, wait_for_frames, wait_for_view
from .kernel_calls import kernel_eval, kernel_execute
from .notebook_actions import leave_notebook, open_notebook, run_all_cells
from .polling import poll

pytestmark = [pytest.mark.browser, pytest.mark.slow]

#: Each notebook runs on a new kernel, as a reader's Run All would (conftest.py: the others reuse one, reset).
FRESH_KERNELS = True

#: What a notebook's last cells set and say, checked in the kernel after Run All (a control drawn late
#: by a busy page must not send an older value over it): notebook stem -> (expression, expected value).
STATE_AFTER_RUN_ALL = {
    "05_colliders_and_wind": ("[round(w.ball.collider.radius, 6), w.ball.roll_speed, w.ball.rolling]", [2.0, 3.0, True]),
}

ROOT = Path(__file__).resolve().parents[2]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))

#: Kernel code listing the notebook's GrassWidgets: (backend, open) for each.
WIDGETS = ("[(x.backend if x.view is not None else None, x.view is not None) for x in "
           "sorted((o for o in __import__('gc').get_objects() "
           "if type(o).__name__ == 'GrassWidget' and type(o).__module__.startswith('grasswidget')), key=id)]")


def _not_blank(px) -> tuple[bool, float]:
    """A picture is drawn when its pixels are not one flat colour (spread over the image)."""
    rgb = px[..., :3].astype(np.float32)
    spread = float(rgb.reshape(-1, 3).std(axis=0).max())
    return spread > 12.0, spread


def _widget_output(locator):
    """The notebook output that holds a view: the widget with its panel."""
    return locator.locator("xpath=ancestor::div[contains(@class, 'jp-OutputArea-output')][1]")


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_run_all_leaves_every_widget_drawing(path, page, lab_server, browser_root):
    """Chromium without WebGPU: every widget streams from the kernel (``backend="auto"`` falls back)."""
    _run_all_and_check(page, lab_server, browser_root, path, shots=os.environ.get("GW_SHOTS_DIR"))


#: Notebooks that make a browser-engine widget (``backend="auto"`` or ``"browser"``).
def _code(path) -> str:
    return "\n".join("".join(c["source"]) for c in json.loads(path.read_text())["cells"] if c["cell_type"] == "code")


BROWSER_ENGINE_NOTEBOOKS = [p for p in NOTEBOOKS if re.search(r"backend\s*=\s*[\"'](auto|browser)[\"']", _code(p))]



@pytest.mark.parametrize("path", BROWSER_ENGINE_NOTEBOOKS, ids=[p.stem for p in BROWSER_ENGINE_NOTEBOOKS])
def test_run_all_with_webgpu_leaves_browser_views_drawing(path, webgpu_browser, lab_server, browser_root):
    """Chromium with WebGPU (SwiftShader): the browser-engine widgets draw on their canvases too."""
    page = webgpu_browser.page
    try:
        n_canvases = _run_all_and_check(page, lab_server, browser_root, path, prefix="runall_webgpu_")
        assert n_canvases >= 1, f"{path.name}: no browser-engine canvas drew in a Chromium with WebGPU"
    except BaseException:
        out = save_debug_artifacts(page, os.environ.get("GW_ARTIFACTS_DIR") or browser_root / "artifacts",
                                   f"runall_webgpu_{path.stem}", webgpu_browser, lab_server)
        print(f"\n[run all, WebGPU] debug artifacts in {out}")
        raise
    finally:
        try:
            leave_notebook(page, lab_server, reload=sys.exc_info()[0] is not None)
        except Exception:
            pass


def _canvas_drawn(canvas):
    px = np.asarray(Image.open(io.BytesIO(canvas.screenshot())).convert("RGBA"))
    drawn, spread = _not_blank(px)
    return drawn, spread


def _run_all_and_check(page, lab_server, browser_root, path, prefix="runall_", shots=None) -> int:
    """Run All, then check every widget (see the module's docstring); returns how many browser canvases drew."""
    name = f"{prefix}{path.name}"
    out_dir = browser_root / "output"
    for written in WRITTEN.get(path.stem, ()):  # what this run writes, not an earlier run's file
        (out_dir / written).unlink(missing_ok=True)
    shutil.copy(path, browser_root / name)
    beside_before = {p.name for p in browser_root.iterdir()}
    open_notebook(page, lab_server, name)
    run_all_cells(page, name, timeout=420)
    check_outputs = prefix == "runall_"  # once per notebook: in the run without WebGPU
    if check_outputs:
        probe = kernel_execute(page, LIVE_CULLING_PROBE, name, timeout=300).stdout if path.stem == "03_culling" else ""
        page.evaluate("async () => { await window.jupyterapp.commands.execute('docmanager:save'); }")
        import nbformat

        check_notebook_outputs(path.stem, nbformat.read(str(browser_root / name), as_version=4), out_dir, probe)
        written = {p.name for p in browser_root.iterdir()} - beside_before - {"output", ".ipynb_checkpoints"}
        assert not written, f"{path.name} wrote {sorted(written)} next to itself; write into output/"

    widgets = kernel_eval(page, WIDGETS, name, timeout=60)
    assert all(is_open for _backend, is_open in widgets), f"{path.name} left a widget closed: {widgets}"
    kernel_views = sum(1 for backend, _ in widgets if backend == "kernel")
    n_views = page.locator("div.renderview-wrapper img.renderview-view").count()
    assert n_views == kernel_views, f"{n_views} views in the page for {kernel_views} kernel-engine widgets"

    for i in range(n_views):
        wait_for_view(page, i, timeout=120)  # scrolls it into view: jupyter-rfb draws only visible views
        # a new frame after a draw request: ask every open kernel-engine widget to draw, and its canvas
        # to send the frame even where its pixels equal the last one's (a paused view's would: the skip
        # of unchanged frames has its own tests, tests/test_compat.py and tests/notebook/test_live_view.py)
        kernel_execute(page, "for _w in [o for o in __import__('gc').get_objects() if type(o).__name__ == "
                             "'GrassWidget' and getattr(o, 'view', None) is not None and o.backend == 'kernel']:\n"
                             "    _w.canvas.skip_unchanged = False; _w.canvas.request_draw()", name, timeout=60)
        wait_for_frames(page, 1, timeout=120, index=i)
        drawn, spread = _not_blank(view_pixels(page, i))
        assert drawn, f"{path.name}: view #{i} is blank (colour spread {spread:.1f})"
        if i == 0 and shots:
            Path(shots).mkdir(parents=True, exist_ok=True)
            _widget_output(view_locator(page, 0)).screenshot(path=str(Path(shots) / f"nb-{path.stem}.png"))

    if path.stem in STATE_AFTER_RUN_ALL:  # every view has drawn a new frame: its controls were drawn before
        expr, expected = STATE_AFTER_RUN_ALL[path.stem]
        assert kernel_eval(page, expr, name, timeout=60) == expected, expr

    browser_views = sum(1 for backend, _ in widgets if backend == "browser")
    canvases = page.locator("canvas.grasswidget-canvas")
    drawn_canvases = 0
    for i in range(canvases.count()):
        canvas = canvases.nth(i)
        if not canvas.is_visible():  # a browser view that fell back to kernel streaming
            continue
        canvas.scroll_into_view_if_needed()
        # the first frame of a software WebGPU takes seconds: wait for it, then it must show a picture
        poll(lambda: _canvas_drawn(canvas), f"browser canvas #{i} of {path.name} to draw", 120, 1.0, page=page)
        drawn_canvases += 1
    assert drawn_canvases == browser_views, f"{drawn_canvases} browser canvases drew for {browser_views} browser widgets"
    print(f"\n[run all] {path.name}: {len(widgets)} widgets, {n_views} kernel views and {drawn_canvases} "
          f"browser canvases drawing")
    if check_outputs and path.stem == "01_tour":  # the tour's user-facing checks, on the kernel Run All left
        check_tour(page, browser_root)
    return drawn_canvases
