"""Views at rest off screen, in both engines (JupyterLab + Chromium).

A notebook shows three playing widgets (256 blades, 160 x 120), and the first
one again at the end, with 1600 px of empty output between the four views, so
the page's 1000 px viewport holds one at a time.
Scrolled to the second widget, the test counts the frames each view draws over
a few seconds (the browser engine: draws into each canvas, the engine's
``canvas.grasswidgetFramesDrawn``; the kernel engine: new ``img`` sources per
jupyter-rfb view, counted by the harness's MutationObserver): the one on
screen draws many, the two off screen none (in the first window after a
scroll, only the frames already on their way), and the first one's simulated time stands still
over the second window. Then the first widget is
scrolled back: it draws again, and its simulated time goes on from where it
stopped, the seconds it spent out of sight not simulated (the rule both
engines share: off screen, the clock stops as ``pause()`` stops it). The first
widget's second display stays off screen: the browser engine draws nothing
into it (one simulation per widget, drawn into the visible canvas only).
"""

from __future__ import annotations

import sys
import time

import imageio.v3 as iio
import pytest

from .frames import frame_counts
from .kernel_calls import kernel_eval, kernel_execute, wait_for_kernel
from .notebook_actions import leave_notebook, open_notebook, run_all_cells, write_notebook
from .polling import poll

from grasswidget.views.kernel import MAX_BUFFERED_FRAMES

pytestmark = pytest.mark.browser

N_BLADES = 256
SIZE = (160, 120)
SPACER = "from IPython.display import HTML\nHTML('<div style=\"height:1600px\"></div>')"
#: Wall seconds each counting window lasts (at least).
WINDOW_S = 3.0
#: Frames the view on screen must draw in a window (SwiftShader / lavapipe on 2 shared cores).
MIN_FRAMES_SHOWN = 10



def _counts_js(selector):
    return f"() => [...document.querySelectorAll('{selector}')].map((c) => c.grasswidgetFramesDrawn || 0)"


class _Engine:
    """How one engine's views are found and their frames counted in the page."""

    def __init__(self, backend):
        self.backend = backend
        self.selector = "canvas.grasswidget-canvas" if backend == "browser" else "img.renderview-view"
        # Frames a view scrolled away may still show: the browser engine draws in the frame of the
        # scroll and may draw once more, since the IntersectionObserver's answer is queued as a task
        # after the rendering step and the next animation frame can run first (seen in CI: 2);
        # jupyter-rfb's frames already sent (at most MAX_BUFFERED_FRAMES in flight) and its one
        # lossless picture after the last frame.
        self.on_their_way = 2 if backend == "browser" else MAX_BUFFERED_FRAMES + 1

    def counts(self, page):
        if self.backend == "browser":
            return page.evaluate(_counts_js(self.selector))
        return frame_counts(page)[:4]  # the four views read at one instant

    def show(self, page, index):
        page.locator(self.selector).nth(index).scroll_into_view_if_needed()


def _sim_time(page, index):
    return kernel_eval(page, f"ws[{index}].sim_time or 0.0")


def _on_screen(page, engine):
    """Which of the views have a pixel inside the viewport (as the IntersectionObservers see it)."""
    return page.evaluate(
        f"() => [...document.querySelectorAll('{engine.selector}')].map((e) => {{"
        "const r = e.getBoundingClientRect(); return r.bottom > 0 && r.top < innerHeight && r.width > 0; })")


def _count_window(page, engine, shown):
    """Frames each view drew over a window of at least WINDOW_S seconds, which also lasts
    until the view on screen drew MIN_FRAMES_SHOWN (60 s at most)."""
    before = engine.counts(page)
    t0 = time.monotonic()
    poll(lambda: time.monotonic() - t0 >= WINDOW_S
         and engine.counts(page)[shown] - before[shown] >= MIN_FRAMES_SHOWN,
         f"view {shown} on screen drawing {MIN_FRAMES_SHOWN} frames", timeout=60, interval=0.25, page=page)
    after = engine.counts(page)
    return [a - b for a, b in zip(after, before)], time.monotonic() - t0


@pytest.mark.parametrize("backend", ["browser", "kernel"])
def test_views_off_screen_rest(webgpu_browser, lab_server, browser_root, backend):
    page = webgpu_browser.page
    engine = _Engine(backend)
    name = f"views_at_rest_{backend}.ipynb"
    write_notebook(browser_root / name, [
        "import grasswidget as gw\n"
        f"ws = [gw.GrassWidget({N_BLADES}, backend='{backend}', size={SIZE}) for _ in range(3)]",
        "ws[0]", SPACER, "ws[1]", SPACER, "ws[2]", SPACER, "ws[0]",  # the first widget shown twice
    ])
    try:
        open_notebook(page, lab_server, name)
        run_all_cells(page, timeout=180)
        poll(lambda: page.locator(engine.selector).count() == 4, "four views", timeout=60, page=page)
        if backend == "browser":
            wait_for_kernel(page, "[w.view.gpu_status['state'] for w in ws]", ["ok"] * 3, timeout=90)
        assert kernel_eval(page, "[w.backend for w in ws]") == [backend] * 3
        assert kernel_eval(page, "all(w.playing for w in ws)") is True

        # The first widget on screen until its simulated time runs.
        engine.show(page, 0)
        wait_for_kernel(page, "ws[0].sim_time or 0", predicate=lambda t: t > 0.2, timeout=90)

        # Scrolled to the second: the first and the third are off screen.
        engine.show(page, 1)
        hidden_at = time.monotonic()
        assert _on_screen(page, engine) == [False, True, False, False]
        wait_for_kernel(page, "ws[1].sim_time or 0", predicate=lambda t: t > 0.2, timeout=90)
        on_way, _ = _count_window(page, engine, 1)
        # After the first window (the frames on their way have arrived) the first widget is at rest: over
        # the second window it draws nothing and its simulated time stands still.
        stopped_at = _sim_time(page, 0)
        frames, seconds = _count_window(page, engine, 1)
        print(f"\n[views at rest, {backend}] scrolled to view 1: frames per view over {seconds:.1f} s: {frames} "
              f"(in the first window after the scroll: {on_way})")
        assert frames[1] >= MIN_FRAMES_SHOWN
        assert on_way[0] <= engine.on_their_way and on_way[2] == 0 and on_way[3] <= on_way[0], on_way
        assert frames[0] == 0 and frames[2] == 0 and frames[3] == 0, frames
        assert _sim_time(page, 0) == pytest.approx(stopped_at, abs=1e-9), "simulated time ran off screen"
        # Its stats say so (issue 37, item 4): at rest, stale, and the status line says it; the view on
        # screen, drawing, is fresh and never "waiting for frames" (polled over a second).
        rest = kernel_eval(page, "{k: ws[0].stats[k] for k in ('at_rest', 'stale', 'frame_age_s')}")
        assert rest["at_rest"] and rest["stale"] and rest["frame_age_s"] > 0, rest
        assert "at rest (out of sight)" in kernel_eval(page, "ws[0].panel.stats_line.value")
        lines = []
        for _ in range(5):
            lines.append(kernel_eval(page, "(ws[1].panel.stats_line.value, ws[1].stats['at_rest'], ws[1].stats['waiting'])"))
            time.sleep(0.2)  # paces the reads only: each read is checked
        print(f"[views at rest, {backend}] view 1's status line while drawing: {lines[-1][0]}")
        assert not any(at_rest or waiting or "waiting for frames" in line for line, at_rest, waiting in lines), lines
        # At rest, each step(n) still records a sample (issue 37, item 1): the third widget, out of sight.
        kernel_execute(page, "ws[2].inspect([1])\nfor _ in range(2):\n    ws[2].step(6)")
        wait_for_kernel(page, "(lambda s: [int(x) for x in s[-2:]])(ws[2].traces()['step'])",
                        predicate=lambda s: len(s) == 2 and s[1] - s[0] == 6, timeout=60)
        assert kernel_eval(page, "[int(i) for i in ws[2].traces()['ids']]") == [1]

        # Back to the first: it draws again; simulated time goes on from where it stopped.
        engine.show(page, 0)
        back_at = time.monotonic()
        away_s = back_at - hidden_at
        assert _on_screen(page, engine) == [True, False, False, False]
        if backend == "kernel":
            # The first frames back are a frame's worth of steps each, not one capped frame
            # (64 steps, 0.53 s) owed for the time away (the kernel's sim_time is exact).
            first_back = wait_for_kernel(page, "ws[0].sim_time", predicate=lambda t: t > stopped_at,
                                         timeout=30, interval=0.05) - stopped_at
            print(f"[views at rest, kernel] view 0's first simulated time back: +{first_back:.3f} s")
            assert first_back < 0.45, first_back
        on_way_back, _ = _count_window(page, engine, 0)
        frames_back, seconds_back = _count_window(page, engine, 0)
        print(f"[views at rest, {backend}] scrolled back to view 0 after {away_s:.1f} s away: "
              f"frames per view over {seconds_back:.1f} s: {frames_back} (in the first window: {on_way_back})")
        assert on_way_back[0] >= MIN_FRAMES_SHOWN and frames_back[0] >= MIN_FRAMES_SHOWN
        assert kernel_eval(page, "ws[0].stats['at_rest']") is False  # drawing again: no longer at rest
        assert on_way_back[1] <= engine.on_their_way and on_way_back[2] == 0, on_way_back
        assert frames_back[1] == 0 and frames_back[2] == 0, frames_back
        if backend == "browser":
            # The first widget's second display, off screen: the engine simulates once for the
            # widget and draws only the canvas in sight.
            assert on_way_back[3] == 0 and frames_back[3] == 0, frames_back
        else:
            # jupyter-rfb sets the one frame it got on every view of the widget: the kernel
            # rendered and sent each frame once, the second <img> is handed the same picture. The
            # two counters are read a moment apart at each end of the window: one frame each end.
            assert abs(frames_back[3] - frames_back[0]) <= 2, frames_back
        # What the view shows once back: sky above, blades on soil below (256 blades are a
        # sparse meadow: a few percent of green in the lower half; saved for a look).
        shot = browser_root / f"views_at_rest_{backend}.png"
        page.locator(engine.selector).nth(0).screenshot(path=str(shot))
        rgb = iio.imread(shot)[..., :3].astype(int)
        top, lower = rgb[: rgb.shape[0] // 8], rgb[rgb.shape[0] // 2:]
        sky = float(((top[..., 2] > top[..., 0] + 10) & (top[..., 2] >= top[..., 1])).mean())
        grass = float(((lower[..., 1] > lower[..., 0] + 8) & (lower[..., 1] > lower[..., 2] + 8)).mean())
        print(f"[views at rest, {backend}] view 0 back on screen: {shot}, sky in its top rows {sky:.0%}, "
              f"green in its lower half {grass:.1%}")
        assert sky > 0.8 and grass > 0.01, (sky, grass)
        resumed = wait_for_kernel(page, "ws[0].sim_time", predicate=lambda t: t > stopped_at + 0.1, timeout=30)
        gained = _sim_time(page, 0) - stopped_at
        since_back = time.monotonic() - back_at
        print(f"[views at rest, {backend}] view 0 simulated time: {stopped_at:.2f} s when hidden, "
              f"+{gained:.2f} s in the {since_back:.1f} s since it came back ({away_s:.1f} s away)")
        assert resumed > stopped_at
        # Not the time away, not even one capped frame of it (64 steps of 1/120 s = 0.53 s): at
        # most the wall time since the return (time_scale 1; the clock starts again at the first
        # frame after it), with 0.25 s of slack.
        assert gained <= since_back + 0.25, (gained, since_back, away_s)
    finally:
        try:
            leave_notebook(page, lab_server, reload=sys.exc_info()[0] is not None)
        except Exception:
            pass
