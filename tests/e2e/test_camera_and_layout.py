"""Camera presets and the two layouts in real JupyterLab + Chromium at 1920 x 1080.

* default layout (640 x 480 view): the whole widget (view and panel) is less than
  1000 px tall, so nothing needs scrolling on a 1080p screen;
* the "top" button: the kernel's ``w.camera_state`` looks straight down over the
  field and the picture becomes a top view (no sky, grass in the middle); "low"
  and "home" too; in both engines (the browser engine in a Chromium with WebGPU);
* lecture layout: a 1280 x 720 view with the panel folded to one line (the bar);
  "more" unfolds the panel, "less" folds it again.

Screenshots of both layouts (``camera-default.png``, ``camera-lecture.png``,
``camera-lecture-more.png``, ``camera-top-<engine>.png``) go to ``$GW_ARTIFACTS_DIR``
or a temporary folder (path printed).
"""

from __future__ import annotations

import os
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest

from .controls import click_button
from .frames import view_pixels, wait_for_view, wait_until_quiet
from .kernel_calls import kernel_eval, kernel_execute, wait_for_kernel
from .notebook_actions import leave_notebook, open_notebook, run_all_cells, write_notebook
from .polling import poll, poll_until_stable

pytestmark = pytest.mark.browser

FULL_HD = {"width": 1920, "height": 1080}
STRAIGHT_DOWN = ("(lambda c: (c['target'][1] - c['position'][1]) / "
                 "sum((a - b) ** 2 for a, b in zip(c['target'], c['position'])) ** 0.5)(w.camera_state)")

BOXES = """
(root) => {
  const box = (el) => { const r = el.getBoundingClientRect(); return [r.left, r.top, r.width, r.height]; };
  const view = root.querySelector(".renderview-wrapper, canvas.grasswidget-canvas") || root.firstElementChild;
  const bar = root.querySelector(".grasswidget-camera-bar");
  const panel = root.querySelector(".grasswidget-panel");
  return {root: box(root), view: box(view), bar: box(bar), panel: box(panel)};
}
"""


def _artifacts() -> Path:
    out = Path(os.environ.get("GW_ARTIFACTS_DIR") or tempfile.mkdtemp(prefix="gw-camera-"))
    out.mkdir(parents=True, exist_ok=True)
    return out


def _grass(px):
    rgb = px[..., :3].astype(np.int32)
    return float(((rgb[..., 1] > rgb[..., 0] + 8) & (rgb[..., 1] > rgb[..., 2] + 8)).mean())


def _sky(px):
    rgb = px[..., :3].astype(np.int32)
    return float(((rgb[..., 2] > rgb[..., 0] + 10) & (rgb[..., 2] >= rgb[..., 1])).mean())


def _settled_boxes(page):
    root = page.locator(".grasswidget").first
    return poll_until_stable(lambda: root.evaluate(BOXES), "the widget's boxes to settle (two reads alike)", 30,
                             0.3, page=page)


def _kernel_picture(page):
    kernel_execute(page, "w.pause()")
    wait_until_quiet(page, 1.0, timeout=30)
    return view_pixels(page, 0)


@pytest.fixture
def full_hd(page):
    """The shared page at 1920 x 1080 for one test (then back to its size)."""
    old = page.viewport_size
    page.set_viewport_size(FULL_HD)
    yield page
    page.set_viewport_size(old)


def test_default_layout_fits_1080p_and_the_top_button_looks_down(full_hd, lab_server, browser_root):
    page = full_hd
    write_notebook(browser_root / "camera_default.ipynb", ["import grasswidget as gw\nw = gw.GrassWidget()\nw"])
    open_notebook(page, lab_server, "camera_default.ipynb")
    run_all_cells(page, timeout=180)
    wait_for_view(page, 0, timeout=60)
    out = _artifacts()
    boxes = _settled_boxes(page)
    root = page.locator(".grasswidget").first
    root.screenshot(path=str(out / "camera-default.png"))
    page.screenshot(path=str(out / "camera-default-page.png"))
    print(f"\n[camera] default layout at 1920x1080: widget {boxes['root'][2]:.0f} x {boxes['root'][3]:.0f} px, "
          f"view {boxes['view'][2]:.0f} x {boxes['view'][3]:.0f}, panel {boxes['panel'][2]:.0f} x "
          f"{boxes['panel'][3]:.0f} (screenshots in {out})")
    assert boxes["root"][3] < 1000, boxes
    assert abs(boxes["view"][2] - 640) <= 4
    assert kernel_eval(page, "w.camera_floor") == "grass"

    home = _kernel_picture(page)
    assert _sky(home[:40]) > 0.9  # the start camera sees the sky at the top
    click_button(page, "top")
    down = wait_for_kernel(page, STRAIGHT_DOWN, predicate=lambda v: v < -0.999, timeout=30)
    cam = kernel_eval(page, "w.camera_state")
    assert abs(cam["target"][0]) < 1 and abs(cam["target"][2]) < 1  # over the middle of the field
    top = _kernel_picture(page)
    h, w = top.shape[:2]
    print(f"[camera] top: view direction y {down:.5f}; grass {_grass(top):.0%} (home {_grass(home):.0%}), "
          f"sky {_sky(top):.1%} (home {_sky(home):.0%})")
    assert _sky(top) < 0.01 and _grass(top) > 0.3
    assert _grass(top[h // 3: 2 * h // 3, w // 3: 2 * w // 3]) > 0.6  # grass (and soil between) over the middle of the picture
    root.screenshot(path=str(out / "camera-top-kernel.png"))

    click_button(page, "low")
    low = wait_for_kernel(page, "w.camera_state['position'][1]", predicate=lambda y: 2.7 < y < 3.5, timeout=30)
    assert kernel_eval(page, "w.camera_floor") == "grass"
    pic = _kernel_picture(page)
    assert _sky(pic[:40]) > 0.9 and _grass(pic[-100:]) > 0.9, "low: sky above, grass across the bottom"
    print(f"[camera] low: eye {low:.2f} m")
    click_button(page, "home")
    wait_for_kernel(page, "[round(x, 3) for x in w.camera_state['position']]",
                    [round(x, 3) for x in kernel_eval(page, "w.camera_home.home['position']")], timeout=30)


def test_lecture_layout_is_a_large_view_and_one_line(full_hd, lab_server, browser_root):
    page = full_hd
    write_notebook(browser_root / "camera_lecture.ipynb",
                   ["import grasswidget as gw\nw = gw.GrassWidget(blades=1024, layout='lecture')\nw"])
    open_notebook(page, lab_server, "camera_lecture.ipynb")
    run_all_cells(page, timeout=180)
    wait_for_view(page, 0, timeout=60)
    kernel_execute(page, "w.pause()")
    out = _artifacts()
    folded = _settled_boxes(page)
    root = page.locator(".grasswidget").first
    root.screenshot(path=str(out / "camera-lecture.png"))
    page.screenshot(path=str(out / "camera-lecture-page.png"))
    print(f"\n[camera] lecture layout: widget {folded['root'][2]:.0f} x {folded['root'][3]:.0f} px, view "
          f"{folded['view'][2]:.0f} x {folded['view'][3]:.0f}, bar {folded['bar'][2]:.0f} x {folded['bar'][3]:.0f}")
    assert abs(folded["view"][2] - 1280) <= 4 and abs(folded["view"][3] - 720) <= 4
    assert folded["bar"][3] < 48, "the folded panel is one line"
    assert folded["panel"][3] == pytest.approx(folded["bar"][3], abs=2)  # nothing but the bar shows
    assert folded["root"][3] < 720 + 60 and folded["root"][3] < 1000
    assert kernel_eval(page, "w.panel_folded") is True
    for text in ("Play", "home", "top", "low", "more"):  # play/pause, the presets, "more" on the one line
        assert page.locator("button.jupyter-button", has_text=text).first.is_visible()

    click_button(page, "more")
    wait_for_kernel(page, "w.panel_folded", False, timeout=20)
    unfolded = _settled_boxes(page)
    root.screenshot(path=str(out / "camera-lecture-more.png"))
    print(f"[camera] lecture unfolded: widget {unfolded['root'][3]:.0f} px tall, panel {unfolded['panel'][3]:.0f}")
    assert unfolded["panel"][3] > folded["panel"][3] + 200  # the sliders, checkboxes ... are back
    click_button(page, "less")
    wait_for_kernel(page, "w.panel_folded", True, timeout=20)
    assert _settled_boxes(page)["panel"][3] == pytest.approx(folded["panel"][3], abs=2)



def _ctrl_gesture_in_the_page(page, canvas):
    """The ctrl gesture in Chromium, as in the kernel engine (grasswidget.core.interaction): ctrl +
    drag pans (camera and target move together, the offset kept), ctrl + click with a move under
    the click slop inspects a blade and leaves the camera where it was."""
    box = canvas.bounding_box()
    cx, cy = box["x"] + box["width"] / 2, box["y"] + box["height"] * 0.6
    before = kernel_eval(page, "w.camera_state")
    page.keyboard.down("Control")
    try:
        page.mouse.move(cx, cy)
        page.mouse.down()
        page.mouse.move(cx + 80, cy + 10, steps=8)
        page.mouse.up()
    finally:
        page.keyboard.up("Control")
    moved = lambda c: float(np.linalg.norm(np.subtract(c["target"], before["target"])))  # noqa: E731
    after = wait_for_kernel(page, "w.camera_state", predicate=lambda c: moved(c) > 0.05, timeout=20)
    offset = lambda c: np.subtract(c["position"], c["target"])  # noqa: E731
    assert np.allclose(offset(after), offset(before), atol=1e-3), (before, after)  # a pan, not an orbit
    kernel_execute(page, "w.inspect([])")
    page.keyboard.down("Control")
    try:
        page.mouse.move(cx, cy)
        page.mouse.down()
        page.mouse.move(cx + 2, cy + 1, steps=2)  # under the 4 px slop: still a click
        page.mouse.up()
    finally:
        page.keyboard.up("Control")
    wait_for_kernel(page, "len(w.inspected)", predicate=lambda n: n == 1, timeout=20)
    still = kernel_eval(page, "w.camera_state")
    assert np.allclose(still["position"], after["position"], atol=1e-6)


def test_top_button_in_the_browser_engine(webgpu_browser, lab_server, browser_root):
    page = webgpu_browser.page
    write_notebook(browser_root / "camera_browser.ipynb",
                   ["import grasswidget as gw\nw = gw.GrassWidget(blades=4096, backend='browser')\nw"])
    page.set_viewport_size(FULL_HD)
    try:
        open_notebook(page, lab_server, "camera_browser.ipynb")
        run_all_cells(page, timeout=180)
        # SwiftShader's adapter can take a minute on a loaded 2-core machine
        status = wait_for_kernel(page, "w.view.gpu_status", predicate=lambda s: s["state"] != "", timeout=150)
        assert status["state"] == "ok", status
        wait_for_kernel(page, "w.stats['fps'] is not None", True, timeout=60)
        kernel_execute(page, "w.pause()")
        canvas = page.locator("canvas.grasswidget-canvas").first

        def picture():
            import imageio.v3 as iio

            return iio.imread(canvas.screenshot(), extension=".png")

        home = picture()
        click_button(page, "top")
        wait_for_kernel(page, STRAIGHT_DOWN, predicate=lambda v: v < -0.999, timeout=30)
        # the browser draws the new camera: no sky, grass in the middle
        top = poll(lambda: (lambda p: (_sky(p) < 0.01 and _grass(p) > 0.3, (_sky(p), _grass(p))))(picture()),
                   "a top view on the canvas", timeout=30, page=page)
        print(f"\n[camera] browser engine top: sky {_sky(picture()):.1%} (home {_sky(home):.0%}), "
              f"grass {_grass(picture()):.0%}")
        page.locator(".grasswidget").first.screenshot(path=str(_artifacts() / "camera-top-browser.png"))
        # the orbit floor reaches the browser as numbers: "low" stays above the grass there too
        click_button(page, "low")
        wait_for_kernel(page, "w.camera_state['position'][1]", predicate=lambda y: 2.7 < y < 3.5, timeout=30)
        limits = kernel_eval(page, "w.view.engine_widget.frame_rules['orbit']")
        assert limits["clearance"] > 2.5  # above the tallest tip (2.5 m) + 0.3
        assert top[0] < 0.01
        _ctrl_gesture_in_the_page(page, canvas)
    except BaseException:
        from .chromium import save_debug_artifacts

        out = save_debug_artifacts(page, _artifacts(), "camera_browser_engine", webgpu_browser, lab_server)
        print(f"\n[camera] debug artifacts in {out}\n" + "\n".join(webgpu_browser.console[-30:]))
        raise
    finally:
        try:
            leave_notebook(page, lab_server, reload=sys.exc_info()[0] is not None)
        except Exception:
            pass
