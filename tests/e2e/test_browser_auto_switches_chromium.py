"""The browser engine decides occlusion culling by measuring, in a real JupyterLab + Chromium
(WebGPU on SwiftShader): in the cis565 close view (rows of blades behind the front ones) "auto"
measures occlusion culling removing most blades and keeps it where it made frames faster (the
decision follows the times it reports; usually on), and the panel shows the decision; from "top"
(nothing behind anything) it turns it off: too few removed to pay.

The rule is Python's (grasswidget.core.auto_switches, the kernel's); engine.js reports its frame times
and counts and executes the state Python sends (grasswidget.browser.trial_feed). Screenshots of the
page after each decision: ``auto_switches_browser_close.png`` and ``auto_switches_browser_top.png``
in ``$GW_ARTIFACTS_DIR`` (else the Lab root's ``artifacts`` folder).
"""

from __future__ import annotations

import os
import re

import pytest

from .kernel_calls import kernel_eval, kernel_execute, wait_for_kernel
from .polling import poll
from .test_engines_alike import _artifacts, _run

pytestmark = pytest.mark.browser

N_BLADES = 1 << 13  # cis565's close view: occlusion removes ~80 % (2^15: a frame took 8 s at load 20)
SIZE = (320, 240)


def _decided(page, timeout=480):
    """The words of the browser engine's decision on occlusion culling once made (its
    AutoSwitches' own, not the last stats'), then once the panel shows them: (words, panel line)."""
    def decided():
        words = kernel_eval(page, "a.view.engine_widget.auto_switches.texts()['cull_occlusion']")
        return words.startswith(("auto (on:", "auto (off:")), words  # not "auto (on until measured again)"

    words = poll(decided, "the browser engine's decision on occlusion culling", timeout, 1.0, page=page)

    def shown():
        line = kernel_eval(page, "a.panel.switch_choices['cull_occlusion'].decision_line.value")
        return words in line, line

    return words, poll(shown, f"the panel showing {words!r}", 30, 0.5, page=page)


def test_browser_engine_decides_occlusion_by_measuring(webgpu_browser, lab_server, browser_root):
    page = webgpu_browser.page
    found = {}

    def check():
        status = wait_for_kernel(page, "a.view.gpu_status", predicate=lambda s: s["state"] != "", timeout=60)
        assert status["state"] == "ok", status
        # The view plays while it decides: a paused view runs no trial (it draws only on demand).
        # Paused for each screenshot (SwiftShader drawing on two loaded cores holds the page).
        found["close"] = _decided(page)
        kernel_execute(page, "a.pause()")
        page.screenshot(path=os.path.join(_artifacts(browser_root), "auto_switches_browser_close.png"), full_page=True)
        kernel_execute(page, "a.look_from('top')")
        assert kernel_eval(page, "a.view.engine_widget.auto_switches.state.redecided_because") == "the camera moved"
        # paused, the move starts no trial: the decision waits for frames of a playing view
        assert not kernel_eval(page, "a.view.engine_widget.auto_switches.state.measuring")
        assert kernel_eval(page, "a.view.engine_widget.auto_switches.texts()['cull_occlusion']").endswith(
            "until measured again)")
        kernel_execute(page, "a.play()")
        found["top"] = _decided(page)
        kernel_execute(page, "a.pause()")
        page.screenshot(path=os.path.join(_artifacts(browser_root), "auto_switches_browser_top.png"), full_page=True)
        found["executed"] = kernel_eval(page, "a.view.engine_widget.auto_switches.values")

    _run(page, lab_server, browser_root, "auto_switches_browser.ipynb", [
        "import grasswidget as gw\n"
        f"a = gw.GrassWidget({N_BLADES}, preset='cis565', backend='browser', size={SIZE})\na",
    ], check, webgpu_browser)
    close, close_panel = found["close"]
    top, top_panel = found["top"]
    print(f"\n[auto, browser] cis565: {close}\n[auto, browser] top: {top}")
    # Rows of blades behind the front ones: occlusion hides most; whether that pays is measured
    # (SwiftShader on a loaded 2-core machine: usually on), and the decision follows the times it reports.
    m = re.match(r"auto \((on|off): removed (\d+) % of blades,(?: but)? ([\d.]+) ms a frame against ([\d.]+) ms off\)",
                 close)
    assert m, close
    assert int(m.group(2)) >= 30, close
    assert (m.group(1) == "on") == (float(m.group(3)) < float(m.group(4))), close
    assert close in close_panel  # the panel shows the same words
    assert top.startswith("auto (off: removed") and "too few to pay" in top, top
    assert top in top_panel
    assert found["executed"]["cull_occlusion"] is False
