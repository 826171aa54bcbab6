"""Run All in JupyterLab leaves every widget a notebook showed alive and drawing.

For every notebook in notebooks/ (a glob: notebooks added later are covered), in the shared
JupyterLab and Chromium of tests/browser/conftest.py: copy it into the served folder, open it,
run "Run All", wait until the kernel is idle with no cell queued, and then check

* in the kernel: every ``GrassWidget`` the notebook made is open (``w.view`` is not None), and
  as many jupyter-rfb views are in the page as kernel-engine widgets;
* in the page, for each kernel view (jupyter-rfb ``img``): it is brought into view, a *new* frame
  arrives after the kernel is asked to draw (``w.canvas.request_draw()``), and the picture is
  not blank (not one flat colour: a grey box fails);
* for each visible browser-engine canvas: its screenshot is not blank;
* where a notebook's last cells set state it then prints (05: the ball's radius and speed), the
  kernel still holds it once the page has drawn every view (checked after the views).

With ``GW_SHOTS_DIR`` set, the first widget of each notebook (view and panel) is saved there as
``nb-<notebook>.png`` right after Run All, for a person to look at.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from .harness import (
    kernel_eval,
    kernel_execute,
    open_notebook,
    run_all_cells,
    view_locator,
    view_pixels,
    wait_for_frames,
    wait_for_view,
)

pytestmark = [pytest.mark.browser, pytest.mark.slow]

#: What a notebook's last cells set and say, checked in the kernel after Run All (a control drawn late
#: by a busy page must not send an older value over it): notebook stem -> (expression, expected value).
STATE_AFTER_RUN_ALL = {
    "05_colliders_and_wind": ("[round(w.ball.collider.radius, 6), w.ball.roll_speed, w.ball.rolling]", [2.0, 3.0, True]),
}

ROOT = Path(__file__).resolve().parents[2]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))

#: Kernel code listing the notebook's GrassWidgets: (backend, open) for each, in creation order.
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
    name = f"runall_{path.name}"
    shutil.copy(path, browser_root / name)
    open_notebook(page, lab_server, name)
    run_all_cells(page, name, timeout=420)

    widgets = kernel_eval(page, WIDGETS, name, timeout=60)
    assert all(is_open for _backend, is_open in widgets), f"{path.name} left a widget closed: {widgets}"
    kernel_views = sum(1 for backend, _ in widgets if backend == "kernel")
    n_views = page.locator("div.renderview-wrapper img.renderview-view").count()
    assert n_views == kernel_views, f"{n_views} views in the page for {kernel_views} kernel-engine widgets"

    shots = os.environ.get("GW_SHOTS_DIR")
    for i in range(n_views):
        wait_for_view(page, i, timeout=120)  # scrolls it into view: jupyter-rfb draws only visible views
        # a new frame after a change: ask every open kernel-engine widget to draw
        kernel_execute(page, "for _w in [o for o in __import__('gc').get_objects() if type(o).__name__ == "
                             "'GrassWidget' and getattr(o, 'view', None) is not None and o.backend == 'kernel']:\n"
                             "    _w.canvas.request_draw()", name, timeout=60)
        wait_for_frames(page, 1, timeout=120, index=i)
        drawn, spread = _not_blank(view_pixels(page, i))
        assert drawn, f"{path.name}: view #{i} is blank (colour spread {spread:.1f})"
        if i == 0 and shots:
            Path(shots).mkdir(parents=True, exist_ok=True)
            _widget_output(view_locator(page, 0)).screenshot(path=str(Path(shots) / f"nb-{path.stem}.png"))

    if path.stem in STATE_AFTER_RUN_ALL:  # every view has drawn a new frame: its controls were drawn before
        expr, expected = STATE_AFTER_RUN_ALL[path.stem]
        assert kernel_eval(page, expr, name, timeout=60) == expected, expr

    canvases = page.locator("canvas.grasswidget-canvas")
    for i in range(canvases.count()):
        canvas = canvases.nth(i)
        if not canvas.is_visible():  # a browser view that fell back to kernel streaming
            continue
        canvas.scroll_into_view_if_needed()
        from PIL import Image
        import io

        px = np.asarray(Image.open(io.BytesIO(canvas.screenshot())).convert("RGBA"))
        drawn, spread = _not_blank(px)
        assert drawn, f"{path.name}: browser canvas #{i} is blank (colour spread {spread:.1f})"
    print(f"\n[run all] {path.name}: {len(widgets)} widgets, {n_views} kernel views drawing, "
          f"{canvases.count()} browser canvases")
