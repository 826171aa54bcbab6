"""What the lab bench's live chart costs the live view: frames/s with ``w.chart`` None vs "tip".

Runs JupyterLab and Debian's headless Chromium, shows ``GrassWidget()`` (the kernel
engine, 4096 blades, 640 x 480) playing with three blades inspected, then alternates
windows of ``--seconds`` with the chart hidden and with the "tip" chart, ``--rounds``
times each (interleaved in one run, so the machine's drift hits both alike), counting
the frames the browser receives. It also counts how often the chart's data changes in
the page while playing (updates/s; the goal is at least 4), the time the kernel spends
making the updates and the page spends drawing them (uPlot, from an update to its draw
hook), per second of wall time: the chart's cost measured directly, which this shared
machine's load does not blur as it does frames/s; and saves a screenshot of the widget
with the chart (``--shot``).

Usage (from the repository root)::

    .venv/bin/python benchmarks/chart_cost.py [--out PATH] [--shot chart-tip.png]

Prints the figures and writes benchmarks/results/chart_cost-<machine>-<date>.json (or ``--out``): per-window
frames/s and the ratio. JupyterLab and Chromium are driven by benchmarks/lab.py.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402  (benchmarks/common.py)
from lab import (  # noqa: E402  (benchmarks/lab.py)
    Browser,
    JupyterLabServer,
    frames_per_second,
    kernel_eval,
    kernel_execute,
    open_notebook,
    run_all_cells,
    wait_for_frames,
    write_notebook,
)

common.use_this_checkout()
ROOT = common.ROOT

COUNT_UPDATES = """(seconds) => new Promise((done) => {
  const c = document.querySelector(".gw-trace-chart");
  let n = 0;
  const obs = new MutationObserver(() => { n += 1; });
  obs.observe(c, {attributes: true, attributeFilter: ["data-x-last"]});
  setTimeout(() => { obs.disconnect(); done(n / seconds); }, seconds * 1000);
})"""


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--blades", type=int, default=4096)
    ap.add_argument("--seconds", type=float, default=5.0, help="length of each window (default 5)")
    ap.add_argument("--rounds", type=int, default=5, help="windows per setting (default 5)")
    common.add_out_argument(ap, "chart_cost")
    ap.add_argument("--shot", default=None, help="PNG screenshot of the widget with the tip chart")
    args = ap.parse_args(argv)

    root = Path(tempfile.mkdtemp(prefix="gw-chart-cost-"))
    write_notebook(root / "chart_cost.ipynb", [
        f"import grasswidget as gw\nw = gw.GrassWidget(blades={args.blades})\n"
        "w.params.wind_strength = 20\nw.inspect([3, 50, 700])\nw",
    ])
    env = {"PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    windows = []
    with JupyterLabServer(root, env=env) as server, Browser() as browser:
        page = browser.page
        open_notebook(page, server, "chart_cost.ipynb")
        run_all_cells(page, timeout=180)
        wait_for_frames(page, 10, timeout=120)
        adapter = kernel_eval(page, "__import__('grasswidget.gpu.adapter', fromlist=['x']).ensure_device()"
                                    ".adapter.summary")
        time.sleep(3.0)  # past the start-up frames and the first scale changes
        for r in range(args.rounds):
            for chart in (None, "tip"):
                kernel_execute(page, f"w.chart = {chart!r}")
                page.wait_for_timeout(1000)
                fps = frames_per_second(page, seconds=args.seconds)
                scale = kernel_eval(page, "w.render_scale")
                windows.append({"round": r, "chart": chart, "frames_per_s": round(fps, 2), "render_scale": scale})
                print(f"round {r}: chart {chart!s:5}  {fps:6.2f} frames/s  (render scale {scale})")
        kernel_execute(page, "w.chart = 'tip'")
        page.wait_for_timeout(1500)
        kernel_execute(page, "_p0, _s0, _f0 = w.lab_bench.pushes, w.lab_bench.push_seconds, w.view.stats['fps']")
        before = page.evaluate("() => { const c = document.querySelector('.gw-trace-chart'); "
                               "return [+c.dataset.draws, +c.dataset.drawMs, performance.now()]; }")
        t_kernel = time.monotonic()
        updates = page.evaluate(COUNT_UPDATES, 5)
        after = page.evaluate("() => { const c = document.querySelector('.gw-trace-chart'); "
                              "return [+c.dataset.draws, +c.dataset.drawMs, performance.now()]; }")
        kernel = kernel_eval(page, "[w.lab_bench.pushes - _p0, w.lab_bench.push_seconds - _s0]")
        wall = time.monotonic() - t_kernel
        browser_ms_per_s = (after[1] - before[1]) / ((after[2] - before[2]) / 1000.0)
        kernel_ms_per_s = 1000.0 * kernel[1] / wall
        print(f"chart updates while playing: {updates:.1f}/s; kernel {kernel_ms_per_s:.2f} ms/s making them "
              f"({kernel[0]} pushes), browser {browser_ms_per_s:.2f} ms/s drawing them ({after[0] - before[0]} draws)")
        if args.shot:
            page.locator(".grasswidget").first.screenshot(path=args.shot)
            print(f"screenshot: {args.shot}")
        stats = kernel_eval(page, "{k: v for k, v in w.stats.items() if isinstance(v, (int, float)) or v is None}")
        samples = kernel_eval(page, "len(w.traces()['t'])")

    def mean(chart):
        v = [w["frames_per_s"] for w in windows if w["chart"] == chart]
        return sum(v) / len(v)

    off, on = mean(None), mean("tip")
    result = {
        "benchmark": "chart_cost", "blades": args.blades, "size": [640, 480],
        "seconds_per_window": args.seconds, "windows": windows,
        "frames_per_s_chart_none": round(off, 2), "frames_per_s_chart_tip": round(on, 2),
        "ratio_tip_over_none": round(on / off, 3), "chart_updates_per_s": round(updates, 2),
        "chart_kernel_ms_per_s": round(kernel_ms_per_s, 3), "chart_browser_ms_per_s": round(browser_ms_per_s, 3),
        "chart_cost_fraction_of_wall": round((kernel_ms_per_s + browser_ms_per_s) / 1000.0, 4),
        "samples_in_window": samples, "last_stats": stats,
    }
    print(f"chart None {off:.2f} frames/s, 'tip' {on:.2f} frames/s: ratio {on / off:.3f}")
    common.save("chart_cost", result, adapter, args.out)
    return result


if __name__ == "__main__":
    main()
