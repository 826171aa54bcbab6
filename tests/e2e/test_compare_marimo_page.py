"""``ex.compare(code)`` (a ``gw.compare`` comparison) in a marimo page (``marimo run``, Chromium),
through the page only, as a marimo user would: both views stream grass from the kernel and their
stats lines count frames; the shared panel's Pause pauses both views in the kernel; the shared wind
slider, moved with the keyboard, reaches both views' parameters. A screenshot goes to
``$GW_ARTIFACTS_DIR`` (or a temporary folder, printed)."""

from __future__ import annotations

import json
import os
import re
import tempfile
import textwrap
from pathlib import Path

import numpy as np
import pytest

from .controls import panel_label
from .polling import poll
from .servers import MarimoServer

pytestmark = [pytest.mark.browser, pytest.mark.slow]
pytest.importorskip("marimo")

NOTEBOOK = textwrap.dedent('''
    import marimo

    app = marimo.App(width="full")


    @app.cell
    def _():
        import html
        import json

        import ipywidgets as ipw

        import grasswidget as gw
        from grasswidget.notebook.control_mirror import ControlMirror
        return ControlMirror, gw, html, ipw, json


    @app.cell
    def _(gw):
        ex = gw.exercise("forces")
        c = ex.compare(ex.starter, blades=512, size=(240, 180))
        c
        return (c,)


    @app.cell
    def _(ControlMirror, c, html, ipw, json):
        probe = ipw.HTML()

        def show(_change=None):
            state = {label: {"wind": w.params.wind_strength, "playing": w.playing} for label, w in c.widgets.items()}
            state["shared"] = {"wind": c.params.wind_strength, "playing": c.playing}
            probe.value = "<code class='kernel-state'>" + html.escape(json.dumps(state)) + "</code>"

        c.observe(show, names="playing")
        c.params.observe(show, names="wind_strength")
        for w in c.widgets.values():
            w.params.observe(show, names="wind_strength")
            w.observe(show, names="playing")
        show()
        ControlMirror(probe)
        return


    if __name__ == "__main__":
        app.run()
''')


def _grass(px) -> float:
    low = px[int(0.6 * px.shape[0]):]
    return float(((low[..., 1] > low[..., 0] + 8) & (low[..., 1] > low[..., 2] + 8)).mean())


def test_an_exercise_comparison_draws_and_its_shared_panel_drives_both_views(tmp_path, webgpu_chromium):
    import imageio.v3 as iio

    (tmp_path / "compare.py").write_text(NOTEBOOK)
    browser = webgpu_chromium
    with MarimoServer(tmp_path / "compare.py") as server:
        page = browser.new_page()
        try:
            page.goto(server.base_url, wait_until="domcontentloaded", timeout=60_000)
            root = page.locator(".grasswidget-compare.grasswidget-marimo").first
            poll(lambda: root.count() == 1, "marimo to show the comparison", 120, 0.5, page=page)
            assert "not supported" not in page.locator("body").inner_text()
            views = root.locator("img.renderview-view")
            poll(lambda: views.count() == 2, "both views' streams", 60, 0.5, page=page)

            def both_draw_grass():
                px = [iio.imread(views.nth(i).screenshot(), extension=".png")[..., :3].astype(np.int32)
                      for i in range(2)]
                return all(_grass(p) > 0.2 for p in px), [_grass(p) for p in px]
            poll(both_draw_grass, "both views to draw grass", 90, 0.5, page=page)
            columns = root.locator(".grasswidget-compare-column")
            assert columns.count() == 2  # the labels live in the mirrors' shadow roots: read them there
            assert "yours" in columns.nth(0).locator(".gwm-root").first.inner_text()
            assert "reference" in columns.nth(1).locator(".gwm-root").first.inner_text()
            for i in range(2):  # each view's own stats line, under it
                poll(lambda: re.search(r"[\d.]+ frames/s", columns.nth(i).locator(".gwm-root").last.inner_text()),
                     f"view {i}'s stats line to count frames", 90, 0.5, page=page)
            out = Path(os.environ.get("GW_ARTIFACTS_DIR") or tempfile.mkdtemp(prefix="gw-marimo-compare-"))
            out.mkdir(parents=True, exist_ok=True)
            root.screenshot(path=str(out / "marimo-compare.png"))
            print(f"\n[marimo compare] screenshot in {out}")

            def state():
                return json.loads(page.locator("code.kernel-state").first.inner_text())
            panel = root.locator(".grasswidget-panel-column")
            panel.locator("button.gwm-button:visible", has_text=re.compile("^Pause$")).first.click()
            poll(lambda: not state()["yours"]["playing"] and not state()["reference"]["playing"],
                 "the shared Pause to pause both views in the kernel", 30, 0.2, page=page)

            import grasswidget as gw

            top = gw.GrassParams.class_traits()["wind_strength"].hi
            label = panel_label("wind_strength")
            slider = panel.locator(".gwm-slider").filter(
                has=page.locator(".gwm-label", has_text=re.compile("^" + re.escape(label) + "$")))
            slider.locator("input[type=range]").focus()
            page.keyboard.press("End")
            poll(lambda: [state()[v]["wind"] for v in ("shared", "yours", "reference")] == [top] * 3,
                 f"the shared wind slider to set {top} in both views", 30, 0.2, page=page)
        except BaseException:
            print("\n[marimo log]\n" + server.log_text(4000) + "\n[console]\n" + "\n".join(browser.console[-40:]))
            raise
        finally:
            page.close()
