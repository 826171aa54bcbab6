"""The live page (``python -m grasswidget html``) in Chromium, with no kernel.

The page is written by the command line, served from http://127.0.0.1 (WebGPU
needs a secure origin) by a static server that records every request, and opened:

* with WebGPU (SwiftShader): frames render (grass under a sky, the step count and
  frame count rise), a drag orbits (the camera changes and so does the picture),
  Pause stops the simulation and Play restarts it, the culling checkboxes make every
  blade drawn, colour by LOD paints the LOD colours, shift + drag switches the ball
  on; the page asks the server for nothing but itself;
* without WebGPU: the still picture (rendered at save time) and one line saying
  WebGPU is needed;
* from file:// (no server): as from http://127.0.0.1 (Chromium counts file:// as
  a secure context), checked so the README can say so.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from .controls import drag
from .polling import poll
from .servers import StaticServer

pytestmark = [pytest.mark.browser, pytest.mark.slow]

N_BLADES = 4096
#: The page's view (a small one: SwiftShader draws every pixel on the CPU).
SIZE = (320, 240)


@pytest.fixture(scope="module")
def live_page(tmp_path_factory):
    root = tmp_path_factory.mktemp("live-page")
    out = root / "meadow.html"
    proc = subprocess.run([sys.executable, "-m", "grasswidget", "html", str(out), "--blades", str(N_BLADES),
                           "--size", f"{SIZE[0]}x{SIZE[1]}", "--wind", "8"], capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr
    print(f"\n[live page] {proc.stdout.strip()}")
    return out



def _status(page):
    return page.evaluate("() => window.grasswidgetPage ? window.grasswidgetPage.status : 'no page object'")


def _stats(page):
    return page.evaluate("() => window.grasswidgetPage.stats")


def _pixels(page):
    import imageio.v3 as iio

    return iio.imread(page.locator("canvas.grasswidget-canvas").screenshot(), extension=".png")


def _grass(px):
    rgb = px[..., :3].astype(np.int32)
    return float(((rgb[..., 1] > rgb[..., 0] + 8) & (rgb[..., 1] > rgb[..., 2] + 8)).mean())


def _sky(px):
    rgb = px[..., :3].astype(np.int32)
    return float(((rgb[..., 2] > rgb[..., 0] + 10) & (rgb[..., 2] >= rgb[..., 1])).mean())


def _new_stats(page, after_step, what, timeout=30):
    """Wait for a stats report (every 0.5 s) whose step count is past ``after_step``... or any new one."""
    return poll(lambda: (lambda s: (s is not None and s["step_count"] > after_step, s))(_stats(page)),
                what, timeout, 0.2, page=page)


def next_report(page):
    """The next stats report (the engine sends one every 0.5 s)."""
    page.evaluate("() => { window.grasswidgetPage.stats = null; }")
    return poll(lambda: _stats(page), "the next stats report", 10, 0.1, page=page)


def _wait_ok(page):
    st = poll(lambda: (lambda s: (s != "starting", s))(_status(page)), "the page to start WebGPU", 90, 0.2, page=page)
    assert st == "ok", f"status {st}: {page.inner_text('#gw-webgpu-note')}"
    return poll(lambda: _stats(page), "the first stats report", 60, 0.2, page=page)


def _set_checkbox(page, label, value):
    page.locator("#gw-panel label", has_text=label).locator("input[type=checkbox]").set_checked(value)


def test_live_page_with_webgpu(live_page, webgpu_browser):
    page = webgpu_browser.page
    with StaticServer(live_page.parent) as static:
        page.goto(static.url_for(live_page.name))
        stats = _wait_ok(page)
        first = _pixels(page)
        h = first.shape[0]
        grass, sky = _grass(first[int(0.6 * h):]), _sky(first[: int(0.1 * h)])
        print(f"\n[live page] {page.inner_text('#gw-stats')}; grass {grass:.0%} low, sky {sky:.0%} on top")
        assert first.shape[:2] == (SIZE[1], SIZE[0]) and grass > 0.3 and sky > 0.9
        assert page.locator("#gw-still").is_hidden() and page.locator("#gw-panel").is_visible()
        # frames render and time runs
        frames0 = stats["step_count"]
        _new_stats(page, frames0 + 20, "the simulation to advance 20 steps")
        # orbit: the camera and the picture change
        cam0 = page.evaluate("() => window.grasswidgetPage.model.get('camera').position")
        canvas = page.locator("canvas.grasswidget-canvas")
        drag(page, canvas, 140, 0)
        cam1 = poll(lambda: (lambda c: (bool(np.abs(np.subtract(c, cam0)).max() > 0.5), c))(
            page.evaluate("() => window.grasswidgetPage.model.get('camera').position")),
            "a drag to orbit the camera", 20, 0.2, page=page)
        poll(lambda: (np.abs(_pixels(page).astype(int) - first.astype(int)).max(axis=2) > 40).mean() > 0.05,
             "the orbit to change the picture", 20, 0.3, page=page)
        print(f"[live page] orbit: camera {np.round(cam0, 2)} -> {np.round(cam1, 2)}")
        # pause: two later stats reports carry the same step count; play: it rises again
        page.locator("button.gw-play").click()
        assert page.locator("button.gw-play").inner_text() == "Play"
        next_report(page)  # may still count steps from before the click
        held = next_report(page)["step_count"]
        later = next_report(page)
        assert later["step_count"] == held, (held, later)
        page.locator("button.gw-play").click()
        _new_stats(page, held, "Play to advance the simulation again")
        # culling off: every blade drawn; colour by LOD: the LOD colours cover the grass
        for label in ("orientation culling", "frustum culling", "distance culling"):
            _set_checkbox(page, label, False)
        page.locator("#gw-panel label", has_text="occlusion culling").locator("select").select_option(label="off")
        poll(lambda: (lambda s: (sum(s["visible"] or [0]) == N_BLADES, s["visible"]))(_stats(page)),
             "every blade drawn with culling off", 30, 0.2, page=page)
        from grasswidget.core.teaching import LOD_COLORS, hex_to_rgb

        page.locator("#gw-panel label", has_text="colour by").locator("select").select_option(label="lod")
        share = poll(lambda: (lambda f: (f > 0.2, f))(sum(
            float((np.abs(_pixels(page)[..., :3].astype(int) - np.array(hex_to_rgb(c))).max(axis=-1) <= 12).mean())
            for c in LOD_COLORS)), "the LOD colours on the grass", 30, 0.3, page=page)
        print(f"[live page] culling off: {N_BLADES} of {N_BLADES} drawn; colour by lod: {share:.0%} in LOD colours")
        # shift + drag: the ball switches on and the page's balls follow
        ball_box = page.locator("#gw-panel label", has_text="ball").locator("input")
        assert not ball_box.is_checked()
        ball0 = page.evaluate("() => window.grasswidgetPage.controls.ball.position")
        page.keyboard.down("Shift")
        try:
            drag(page, canvas, -80, 30, start=(SIZE[0] // 2, int(0.7 * SIZE[1])))  # on the grass
        finally:
            page.keyboard.up("Shift")
        poll(lambda: ball_box.is_checked(), "shift + drag to switch the ball on", 10, 0.1, page=page)
        ball = page.evaluate("() => window.grasswidgetPage.controls.ball.position")
        assert np.abs(np.subtract(ball, ball0)).max() > 0.1, (ball0, ball)
        print(f"[live page] ball on, moved from x {ball0[0]:.2f}, z {ball0[1]:.2f} to x {ball[0]:.2f}, z {ball[1]:.2f}")
        # the keys act as Python's map says (data.input.keys, core.interaction.key_action): space
        # pauses and plays as the panel's button does (the canvas has the focus since the drag)
        assert page.locator("button.gw-play").inner_text() == "Pause"
        page.keyboard.press(" ")
        poll(lambda: page.locator("button.gw-play").inner_text() == "Play", "space to pause", 10, 0.1, page=page)
        page.keyboard.press(" ")
        poll(lambda: page.locator("button.gw-play").inner_text() == "Pause", "space to play", 10, 0.1, page=page)
        assert page.evaluate("() => window.grasswidgetPage.errors") == []
        # self-contained: the page is the only request
        assert static.requests and all(r.startswith("/meadow.html") for r in static.requests), static.requests


def test_live_page_without_webgpu(live_page, browser):
    page = browser.page
    with StaticServer(live_page.parent) as static:
        page.goto(static.url_for(live_page.name))
        poll(lambda: _status(page) == "unavailable", "the page to find no WebGPU", 30, 0.2, page=page)
        note = page.locator("#gw-webgpu-note")
        text = note.inner_text()
        print(f"\n[live page, no WebGPU] {text}")
        assert "needs WebGPU" in text and len(text.splitlines()) == 1
        still = page.locator("#gw-still")
        assert still.is_visible() and page.locator("#gw-panel").is_hidden()
        size = page.evaluate("() => [document.getElementById('gw-still').naturalWidth, "
                             "document.getElementById('gw-still').naturalHeight]")
        assert size == list(SIZE)
        import io

        from PIL import Image

        px = np.asarray(Image.open(io.BytesIO(still.screenshot())).convert("RGB"))
        assert _grass(px[int(0.6 * px.shape[0]):]) > 0.3 and _sky(px[:10]) > 0.9


def test_live_page_from_file(live_page, webgpu_browser):
    page = webgpu_browser.page
    page.goto(Path(live_page).as_uri())
    st = poll(lambda: (lambda s: (s != "starting", s))(_status(page)), "the page to start", 90, 0.2, page=page)
    secure = page.evaluate("() => window.isSecureContext")
    print(f"\n[live page, file://] secure context {secure}, status {st}")
    assert secure and st == "ok"
    poll(lambda: _stats(page), "a stats report from file://", 60, 0.2, page=page)
    page.goto("about:blank")
