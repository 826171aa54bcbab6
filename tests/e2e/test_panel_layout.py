"""The widget's control panel in real Chromium: nothing clipped, nothing wider than the view.

For a 640 x 480 view and a narrower 400 x 300 one, in the default state and with
the widest values every control can show (the largest blade count, -360 degrees,
two-digit readouts, the ball's row switched on, a saved file's name, an error
message), the test measures in the page:

* the panel column (beside the view, or under it where the notebook is narrow;
  grasswidget.notebook.layout) is no wider than the view and every control lies
  inside it (rows wrap instead of running past the column's edge);
* no text is clipped: every readout, description label, checkbox label, button
  and the stats line shows its whole text (the text's own width, measured with a
  DOM Range, fits the element's box);
* no control is squeezed to nothing (each visible one keeps its width).

It saves a screenshot of each state (``panel-<view>-<state>.png`` in
``$GW_ARTIFACTS_DIR`` or a temporary folder, path printed) to look at.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import pytest

from .frames import wait_for_view
from .kernel_calls import kernel_eval, kernel_execute, wait_for_kernel
from .notebook_actions import open_notebook, run_all_cells, write_notebook
from .polling import poll_until_stable

pytestmark = pytest.mark.browser

MEASURE = """
(root) => {
  const view = root.querySelector(".renderview-wrapper") || root.firstElementChild;
  const viewWidth = view.getBoundingClientRect().width;
  // the panel column (beside the view, or under it in a narrow notebook): every control lies inside it
  const panel = root.querySelector(".grasswidget-panel") || root;
  const rootBox = panel.getBoundingClientRect();
  const viewBox = rootBox;
  const problems = [];
  const texts = [];
  const inked = [];  // [name, rect] of every piece of text on screen
  const sel = ".widget-readout, .widget-label, .widget-label-basic, .jupyter-button, .widget-html-content, select";
  for (const el of root.querySelectorAll(sel)) {
    const box = el.getBoundingClientRect();
    const style = getComputedStyle(el);
    // hidden (display: none here or above it, e.g. the status details while folded): not on screen
    if (style.display === "none" || style.visibility === "hidden" || el.getClientRects().length === 0) continue;
    const text = (el.tagName === "SELECT" ? el.options[el.selectedIndex]?.text : el.innerText || "").trim();
    if (!text) continue;
    texts.push(text);
    const name = `${el.className.split(" ").filter(c => c.startsWith("widget") || c.startsWith("jupyter")).join(".")} "${text.slice(0, 40)}"`;
    if (box.width < 4) { problems.push(`${name}: squeezed to ${box.width.toFixed(1)} px`); continue; }
    if (box.left < viewBox.left - 0.5 || box.right > viewBox.right + 0.5)
      problems.push(`${name}: spans ${Math.round(box.left - viewBox.left)}..${Math.round(box.right - viewBox.left)} px, the panel is ${Math.round(viewBox.width)} px wide`);
    // the control it belongs to (a slider, checkbox, button ...) holds it whole
    const control = el.parentElement.closest(".widget-inline-hbox, .jupyter-widgets") || root;
    const cbox = control.getBoundingClientRect();
    if (control !== el && (box.left < cbox.left - 0.5 || box.right > cbox.right + 0.5))
      problems.push(`${name}: sticks out of its control (${Math.round(box.left - cbox.left)}..${Math.round(box.right - cbox.left)} px of ${Math.round(cbox.width)})`);
    if (el.tagName === "SELECT") { inked.push([name, box]); continue; }
    const range = document.createRange();
    range.selectNodeContents(el);
    for (const r of Array.from(range.getClientRects())) {
      if (r.width === 0) continue;
      inked.push([name, r]);
      if (r.left < box.left - 0.5 || r.right > box.right + 0.5)
        problems.push(`${name}: text ${Math.round(r.width)} px wide is clipped by its ${Math.round(box.width)} px box`);
    }
  }
  // no two texts overlap (a readout running into the next label)
  for (let i = 0; i < inked.length; i++) for (let j = i + 1; j < inked.length; j++) {
    const [na, a] = inked[i], [nb, b] = inked[j];
    if (na === nb) continue;
    const w = Math.min(a.right, b.right) - Math.max(a.left, b.left);
    const h = Math.min(a.bottom, b.bottom) - Math.max(a.top, b.top);
    if (w > 1 && h > 1) problems.push(`${na} overlaps ${nb}`);
  }
  return {rootWidth: rootBox.width, viewWidth, problems, texts};
}
"""

STATES = {
    "default": "w.pause()",
    "squeezed": "w.panel.sliders['blades'].layout.width = '150px'; w.pause()",  # not a state a user meets: proves the checks bite
    # the blade control shows its top value (as after a drag to the end) and asks before building
    # that many blades: the longest count and question
    "widest": ("w.panel.blade_slider.value = w.max_blades\n"
               "w.params.wind_direction = -360; w.params.wind_strength = 200; w.params.wind_speed = 50\n"
               "w.params.gravity = 50; w.params.stiffness_scale = 20; w.time_scale = 10\n"
               "w.ball.enabled = True; w.ball.set_radius(w.ball.radius_slider.max)\n"
               "w.ball.move_to(w.ball.x_slider.min, w.ball.z_slider.min)\n"
               "w.panel.show_file('grass-20261123-101010-2.png', (1280, 960))\n"
               "w.panel.show_error('blades: count=1,000,000,000,000 blades would take 268.2 GiB of memory')\n"
               "w.params.color_by = 'cull'; w.culling_frozen = True\n"
               "w.inspect([0, 1, 2, 3, 4]); w.view.refresh_stats()\n"
               "w.params.patch_size = 100; w.params.fog_density = 1; w.panel.details_button.value = True\n"
               "w.pause()"),
}


def _artifacts() -> Path:
    out = Path(os.environ.get("GW_ARTIFACTS_DIR") or tempfile.mkdtemp(prefix="gw-panel-"))
    out.mkdir(parents=True, exist_ok=True)
    return out


@pytest.mark.parametrize("size", [(640, 480), (400, 300)], ids=["640", "400"])
def test_panel_fits_the_view_and_clips_nothing(page, lab_server, browser_root, size):
    name = f"panel_{size[0]}.ipynb"
    write_notebook(browser_root / name, [
        "import grasswidget as gw",
        f"w = gw.GrassWidget(blades=256, size={size})\nw",
    ])
    open_notebook(page, lab_server, name)
    old_viewport = page.viewport_size
    page.set_viewport_size({"width": 1280, "height": 1800})  # the whole widget on screen, above the status bar
    try:
        _check_states(page, size)
    finally:
        page.set_viewport_size(old_viewport)


def _check_states(page, size):
    run_all_cells(page, timeout=180)
    wait_for_view(page, 0, timeout=60)
    out = _artifacts()
    w_slider = kernel_execute(page, "print(w.panel.sliders['blades'].layout.width)").stdout.strip()
    for state, code in STATES.items():
        kernel_execute(page, code, timeout=120)
        wait_for_kernel(page, "w.playing", False, timeout=30)
        root = page.locator(".grasswidget").first
        # the browser lays the new values out; wait until two measurements agree
        m = poll_until_stable(lambda: root.evaluate(MEASURE), f"the panel's layout in state {state!r} to settle",
                              30, 0.3, page=page)
        shot = out / f"panel-{size[0]}-{state}.png"
        root.screenshot(path=str(shot))
        print(f"\n[panel] {size[0]}x{size[1]} {state}: screenshot {shot}")
        if state == "squeezed":  # the measurement sees a clipped readout; then back to the real layout
            assert any("blades" in p or "4096" in p or "256" in p for p in m["problems"]), m["problems"]
            kernel_execute(page, f"w.panel.sliders['blades'].layout.width = {w_slider!r}", timeout=30)
            continue
        assert abs(m["viewWidth"] - size[0]) <= 4, m["viewWidth"]
        assert m["rootWidth"] <= m["viewWidth"] + 0.5, (m["rootWidth"], m["viewWidth"])
        assert not m["problems"], "\n".join(m["problems"])
        if state == "widest":  # the widest values are on screen, whole
            ball = kernel_eval(page, "[f'{s.value:.2f}' for s in (w.ball.x_slider, w.ball.radius_slider)]")
            ball = [t.replace("-", "\u2212") for t in ball]  # the readouts write a minus sign
            for text in ("262,144", "Apply 262,144 blades?", "−360", "200.0", "20.00", "10.00", *ball, "orientation culling",
                         "blade 0: height", "freeze culling"):
                assert any(text in t for t in m["texts"]), (text, m["texts"])
