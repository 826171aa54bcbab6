"""What a lecture meets first, in JupyterLab and Chromium: a fresh page, the
status line, shift + drag and the blade count control.

* ``test_fresh_page_status_and_shift_drag``: from a freshly opened notebook, every text
  the status line shows is true: never "0.0 frames/s" or "real time" before a frame
  arrived (a MutationObserver records each text from the moment the widget appears).
  As soon as the view shows, shift + drag switches the ball on, with a key hit while
  shift is held (the hand on the keyboard types "S"): no page error is logged. Before
  the fix (grasswidget.compat.fixed_rfb_esm) each typed character threw
  ``Cannot set properties of undefined (setting 'value')`` from jupyter-rfb's
  renderview.js.
* ``test_blade_control_keyboard``: the real blade control, driven with the arrow keys:
  one key press doubles or halves ``w.blade_count`` in the kernel, never more; a
  count past what the measured frame rate keeps at ``target_fps`` asks (Apply /
  Cancel) before anything is built, End (the top) too. A screenshot of the panel with
  the question is saved (``blade-control-question.png`` in ``$GW_ARTIFACTS_DIR`` or a
  temporary folder, path printed). ``test_blade_control_keyboard_browser_engine``: the
  same control over the browser engine (backend="browser", WebGPU in Chromium), whose
  frame rate comes from the browser's stats: a press halves, one past the target asks and
  Apply builds it.
"""

from __future__ import annotations

import os
import re
import sys
import tempfile
from pathlib import Path

import pytest

from .controls import drag
from .frames import view_locator, wait_for_view
from .kernel_calls import kernel_eval, kernel_execute, wait_for_kernel
from .notebook_actions import leave_notebook, open_notebook, run_all_cells, write_notebook
from .polling import poll

pytestmark = pytest.mark.browser

# Every text the status line (a <small> in the widget's HTML) shows, in order, from now on.
RECORD_STATUS = r"""
() => {
  window.__gwStatus = [];
  const seen = (text) => { const a = window.__gwStatus; if (a[a.length - 1] !== text) a.push(text); };
  const scan = () => {
    for (const el of document.querySelectorAll('.grasswidget .widget-html-content small')) {
      const t = el.textContent;
      if (/blades/.test(t) && !/blade \d+:/.test(t)) seen(t);  // the status, not the inspector
    }
  };
  new MutationObserver(scan).observe(document.body, {subtree: true, childList: true, characterData: true});
  scan();
}
"""


def _fps(status):
    """The frame rate a status text starts with, or -1."""
    m = re.match(r"\s*([\d.]+) frames/s", status)
    return float(m.group(1)) if m else -1.0


def _page_errors(browser, since):
    return [line for line in browser.console[since:] if line.startswith("[pageerror]")]


def test_fresh_page_status_and_shift_drag(page, browser, lab_server, browser_root):
    name = "lecture_fresh_page.ipynb"
    write_notebook(browser_root / name, ["import grasswidget as gw",
                                         "w = gw.GrassWidget(blades=256, size=(400, 300))\nw"])
    open_notebook(page, lab_server, name)
    since = len(browser.console)
    page.evaluate(RECORD_STATUS)
    run_all_cells(page, timeout=180)
    view = view_locator(page, 0)
    view.wait_for(state="visible", timeout=60_000)  # at once: no wait for the first frame
    page.keyboard.down("Shift")
    try:
        drag(page, view, -60, 20, start=(150, 200), steps=6)
        page.keyboard.press("S")  # a key hit while shift is held (the hidden key input gets "S")
        drag(page, view, 40, 0, start=(150, 200), steps=6)
    finally:
        page.keyboard.up("Shift")
    wait_for_kernel(page, "w.ball.enabled", True, timeout=30)
    poll(lambda: page.locator(".widget-checkbox", has_text="sphere").locator("input").is_checked(),
         "the sphere checkbox to show the ball switched on", 15, 0.2, page=page)
    wait_for_view(page, 0, timeout=60)
    texts = poll(lambda: (lambda t: (any("real time" in x for x in t), t))(page.evaluate("() => window.__gwStatus")),
                 "the status line to say real time (measured)", 90, 0.5, page=page)
    print(f"\n[lecture] status texts from a fresh page: {texts}")
    assert texts[0].startswith(("starting…", "waiting for frames", "paused")) or _fps(texts[0]) > 0, texts
    for text in texts:
        assert not re.search(r"(?<![\d.])0\.0 frames/s|(?<![\d.])0\.0x", text), texts  # not "10.0 frames/s"
        if "real time" in text or "slow motion" in text:  # only after a measured frame rate
            assert _fps(text) > 0, texts
    errors = _page_errors(browser, since)
    assert not errors, errors
    # the hidden key input was cleared by its own listener (it kept every character before)
    assert page.evaluate("() => Array.from(document.querySelectorAll("
                         "'#rendercanvas-focus-element-container input')).map((i) => i.value).join('')") == ""


def _artifacts() -> Path:
    out = Path(os.environ.get("GW_ARTIFACTS_DIR") or tempfile.mkdtemp(prefix="gw-lecture-"))
    out.mkdir(parents=True, exist_ok=True)
    return out


def _blade_handle(page):
    slider = page.locator(".widget-slider").filter(
        has=page.locator(".widget-label:not(.widget-readout)", has_text=re.compile(r"^\s*blades\s*$")))
    return slider.locator(".noUi-handle").first, slider.locator(".widget-readout").first


def _press(page, handle, key):
    handle.focus()
    page.keyboard.press(key)


def test_blade_control_keyboard(page, browser, lab_server, browser_root):
    name = "lecture_blades.ipynb"
    write_notebook(browser_root / name, ["import grasswidget as gw",
                                         "w = gw.GrassWidget(blades=256, size=(400, 300), target_fps=1)\nw"])
    open_notebook(page, lab_server, name)
    since = len(browser.console)
    page.set_viewport_size({"width": 1280, "height": 1800})  # the whole panel on screen
    try:
        run_all_cells(page, timeout=180)
        wait_for_view(page, 0, timeout=60)
        # a frame rate measured while playing: the estimate's base
        wait_for_kernel(page, "w.panel.blade_control.measured is not None", True, timeout=60)
        handle, readout = _blade_handle(page)
        assert readout.inner_text().strip() == "256"
        counts = [256]
        for key, want in (("ArrowRight", 512), ("ArrowLeft", 256), ("ArrowLeft", 128)):
            _press(page, handle, key)
            counts.append(wait_for_kernel(page, "w.blade_count", want, timeout=30))
            assert readout.inner_text().strip() == f"{want:,}"
        assert all(max(a, b) <= 2 * min(a, b) for a, b in zip(counts, counts[1:])), counts
        # past the target frame rate: one press asks, builds nothing; Cancel goes back
        kernel_execute(page, "w.target_fps = 240")
        _press(page, handle, "ArrowRight")
        question = page.locator(".grasswidget .widget-html-content", has_text="Apply 256 blades?")
        question.wait_for(state="visible", timeout=20_000)
        assert re.search(r"Apply 256 blades\? about [\d.]+ frames/s here \(target 240\)", question.inner_text())
        assert kernel_eval(page, "w.blade_count") == 128
        shot = _artifacts() / "blade-control-question.png"
        page.locator(".grasswidget").first.screenshot(path=str(shot))
        print(f"\n[lecture] blade control asking: {question.inner_text()!r}; screenshot {shot}")
        page.locator("button.jupyter-button", has_text="Cancel").click()
        poll(lambda: readout.inner_text().strip() == "128", "the control back on 128", 15, 0.2, page=page)
        assert kernel_eval(page, "(w.blade_count, w.panel.blade_control.pending)") == [128, None]
        # End jumps to the top: asks too, nothing is built
        _press(page, handle, "End")
        top = kernel_eval(page, "w.max_blades")
        page.locator(".grasswidget .widget-html-content", has_text=f"Apply {top:,} blades?").wait_for(timeout=20_000)
        assert kernel_eval(page, "w.blade_count") == 128
        page.locator("button.jupyter-button", has_text="Cancel").click()
        poll(lambda: readout.inner_text().strip() == "128", "the control back on 128", 15, 0.2, page=page)
        # asked, then applied
        _press(page, handle, "ArrowRight")
        question.wait_for(state="visible", timeout=20_000)
        page.locator("button.jupyter-button", has_text="Apply").click()
        wait_for_kernel(page, "w.blade_count", 256, timeout=30)
        assert readout.inner_text().strip() == "256"
        errors = _page_errors(browser, since)
        assert not errors, errors
    finally:
        page.set_viewport_size({"width": 1280, "height": 1000})



def test_blade_control_keyboard_browser_engine(webgpu_browser, lab_server, browser_root):
    page = webgpu_browser.page
    name = "lecture_blades_browser.ipynb"
    write_notebook(browser_root / name, ["import grasswidget as gw",
                                         "w = gw.GrassWidget(blades=256, size=(400, 300), backend='browser', "
                                         "target_fps=1)\nw"])
    try:
        open_notebook(page, lab_server, name)
        since = len(webgpu_browser.console)
        run_all_cells(page, timeout=180)
        assert kernel_eval(page, "w.backend") == "browser"
        # the browser's frame rate, measured while playing
        wait_for_kernel(page, "w.panel.blade_control.measured is not None", True, timeout=90)
        handle, readout = _blade_handle(page)
        handle.scroll_into_view_if_needed()
        # one press halves (fewer blades never ask)
        _press(page, handle, "ArrowLeft")
        wait_for_kernel(page, "w.blade_count", 128, timeout=30)
        poll(lambda: readout.inner_text().strip() == "128", "the readout on 128", 15, 0.2, page=page)
        # one press doubles; past the target frame rate it asks first, Apply builds it
        kernel_execute(page, "w.target_fps = 240")
        _press(page, handle, "ArrowRight")
        question = page.locator(".grasswidget .widget-html-content", has_text="Apply 256 blades?")
        question.wait_for(timeout=20_000)
        print(f"\n[lecture] browser engine: {question.inner_text()!r}")
        assert "(target 240)" in question.inner_text()
        assert kernel_eval(page, "(w.blade_count, w.panel.blade_control.pending)") == [128, 256]
        page.locator("button.jupyter-button", has_text="Apply").click()
        wait_for_kernel(page, "w.blade_count", 256, timeout=30)
        wait_for_kernel(page, "w.stats['blades']", 256, timeout=30)  # the browser draws the new field
        errors = _page_errors(webgpu_browser, since)
        assert not errors, errors
    finally:
        leave_notebook(page, lab_server, reload=sys.exc_info()[0] is not None)
