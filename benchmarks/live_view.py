"""The kernel engine's live view in JupyterLab + Chromium: frames/s counted in the page, and where a frame goes.

Shows a playing ``GrassWidget`` (``--layout default``: 640 x 480, 4,096 blades; ``--layout lecture``:
1280 x 720) in JupyterLab, in headless Chromium, and counts the frames the page shows (each new ``src`` of
the jupyter-rfb image, :func:`lab.frames_per_second`; not a figure Python reports). Beside it, the kernel's
own account of a frame from ``w.stats``: ``render_ms``, ``readback_ms``, ``encode_ms``, ``send_ms``,
``ack_ms`` (a tree from before these names has ``encode_send_ms``), the render scale, the frame size, the
frames/s the kernel did not send again as unchanged, the CPU time per shown frame of the kernel, the JupyterLab server
and Chromium (from /proc: what each frame costs the machine outside the kernel too), and the machine's load
average at each window (this 2-core machine is shared: read the frames/s beside it).

``--scale full`` holds the render scale at 1.0 (``w.target_fps = 1``: the adaptive scale never steps
down), the figure the targets are about; ``--scale adaptive`` leaves the widget's own rule.
``--browser-nice 19`` runs Chromium's threads at the lowest priority before each window, so the kernel gets
the cores first, as when the browser runs on the student's own machine (a JupyterHub, Binder).

Source trees are compared in turns (``--tree NAME=DIR``, the first is the baseline; default this
checkout): each round opens one notebook per tree and layout, whose first line puts that tree first on
``sys.path``, in turn (reversed every other round, so a drifting machine loads the trees alike), one
kernel at a time.

Usage (from the repository root)::

    .venv/bin/python benchmarks/live_view.py --tree main=/tmp/trees/main --tree new=. \\
        --layout default --layout lecture --rounds 3 [--seconds 8] [--scale full] [--out PATH]

Prints one line per window and a summary; writes benchmarks/results/live_view-<machine>-<date>.json
(or ``--out``). JupyterLab and Chromium are driven by benchmarks/lab.py.
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
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

ROOT = common.ROOT
TICK = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100
LAYOUTS = ("default", "lecture")
#: The w.stats keys of a frame's parts (ms per frame over the stats window), newer and older names.
PART_KEYS = ("render_ms", "readback_ms", "encode_ms", "send_ms", "encode_send_ms", "ack_ms", "gpu_wait_ms")
#: The other w.stats keys worth keeping beside the page's count.
STAT_KEYS = ("fps", "scale", "frame_size", "blades", "visible", "unchanged_fps", "steps_per_frame", "sim_speed")

STATS_EXPR = ("{k: w.stats.get(k) for k in %r if k in w.stats}" % ((*PART_KEYS, *STAT_KEYS),))


def cpu_seconds() -> dict:
    """CPU seconds (user + system, every thread) used so far by this run's processes, by role: ``kernel``
    (ipykernel), ``server`` (JupyterLab), ``chromium`` (every Chromium process), from /proc."""
    from lab import _children  # noqa: E402  (the descendants of a process, from /proc)

    out = {"kernel": 0.0, "server": 0.0, "chromium": 0.0}
    for pid in _children(os.getpid()):
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                cmd = f.read().replace(b"\0", b" ").decode("utf-8", "replace")
            with open(f"/proc/{pid}/stat") as f:
                fields = f.read().rsplit(")", 1)[1].split()
        except OSError:
            continue
        used = (int(fields[11]) + int(fields[12])) / TICK
        role = ("kernel" if "ipykernel" in cmd else "server" if "jupyterlab" in cmd
                else "chromium" if "chrom" in cmd else None)
        if role:
            out[role] += used
    return out


def renice_chromium(niceness: int) -> int:
    """Lower every Chromium thread's priority to ``niceness`` (the processes this run started; each thread,
    as Linux's nice is per thread); returns how many threads. The kernel then gets the cores first, as when
    the browser runs on another machine (a JupyterHub): what the kernel can deliver."""
    from lab import _children  # noqa: E402  (the descendants of a process, from /proc)

    done = 0
    for pid in _children(os.getpid()):
        try:
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                if b"chrom" not in f.read():
                    continue
            for tid in os.listdir(f"/proc/{pid}/task"):
                os.setpriority(os.PRIO_PROCESS, int(tid), niceness)
                done += 1
        except (OSError, ValueError):
            continue
    return done


def notebook_cells(tree: str, layout: str, scale: str) -> list:
    """The benchmark notebook: ``tree``'s grasswidget first on sys.path, a playing widget of ``layout``."""
    setup = (f"import sys\nsys.path.insert(0, {str(Path(tree).resolve())!r})\nimport grasswidget as gw\n"
             f"assert gw.__file__.startswith({str(Path(tree).resolve())!r}), gw.__file__\n")
    make = "w = gw.GrassWidget()" if layout == "default" else "w = gw.GrassWidget(layout='lecture')"
    pin = "\nw.target_fps = 1  # the adaptive scale never steps down: full resolution" if scale == "full" else ""
    return [setup + make + pin + "\nw.play()\nw"]


def measure(server, browser, root, name, tree, layout, scale, seconds, windows, browser_nice=None) -> dict:
    """Open the notebook of (tree, layout), let it play, count the page's frames over ``windows`` windows."""
    nb = f"live_{name}_{layout}.ipynb"
    write_notebook(root / nb, notebook_cells(tree, layout, scale))
    page = browser.page
    try:
        open_notebook(page, server, nb)
        run_all_cells(page, timeout=240)
        wait_for_frames(page, 10, timeout=120)
        page.wait_for_timeout(3000)  # past the first frames (pipelines, the first scale decisions)
        rows = []
        for _ in range(windows):
            if browser_nice is not None:
                renice_chromium(browser_nice)
            kernel_execute(page, "w.refresh_stats() if hasattr(w, 'refresh_stats') else None")
            load = [round(v, 2) for v in os.getloadavg()]
            cpu0, frames0 = cpu_seconds(), page.evaluate("() => window.__gwBenchFrames.total")
            fps = frames_per_second(page, seconds=seconds)
            cpu1, frames1 = cpu_seconds(), page.evaluate("() => window.__gwBenchFrames.total")
            stats = kernel_eval(page, STATS_EXPR)
            shown = max(1, frames1 - frames0)
            cpu_ms = {f"{k}_cpu_ms_per_frame": round(1000.0 * (cpu1[k] - cpu0[k]) / shown, 1) for k in cpu0}
            rows.append({"page_frames_per_s": round(fps, 2), "load_average": load, "stats": stats, **cpu_ms})
            parts = " ".join(f"{k[:-3]} {stats[k]:.1f}" for k in PART_KEYS if isinstance(stats.get(k), (int, float)))
            print(f"  {name:>8} {layout:8} {fps:6.2f} frames/s in the page · kernel fps {stats.get('fps') or 0:.1f}"
                  f" · scale {stats.get('scale')} {stats.get('frame_size')} · {parts} ms · CPU ms/frame: "
                  + " ".join(f"{k.split('_')[0]} {v}" for k, v in cpu_ms.items()) + f" · load {load[0]}",
                  flush=True)
        adapter = kernel_eval(page, "__import__('grasswidget.gpu.adapter', fromlist=['x']).ensure_device()"
                                    ".adapter.summary")
    finally:
        server.shutdown_kernels()
    return {"windows": rows, "adapter": adapter,
            "page_frames_per_s": common.median(r["page_frames_per_s"] for r in rows)}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--tree", action="append", default=None, metavar="NAME=DIR",
                    help="a source tree (repeat; the first is the baseline); default: this checkout")
    ap.add_argument("--layout", action="append", choices=LAYOUTS, default=None,
                    help="the widget's layout (repeat for both; default: default)")
    ap.add_argument("--scale", choices=("full", "adaptive"), default="full",
                    help="full: the render scale held at 1.0 (w.target_fps = 1); adaptive: the widget's rule")
    ap.add_argument("--rounds", type=int, default=1, help="rounds over the trees (default 1)")
    ap.add_argument("--windows", type=int, default=2, help="counted windows per notebook (default 2)")
    ap.add_argument("--seconds", type=float, default=6.0, help="length of a counted window (default 6)")
    ap.add_argument("--browser-nice", type=int, default=None, metavar="N",
                    help="run Chromium's threads at niceness N (e.g. 19): the kernel gets the cores first, "
                         "as with the browser on another machine")
    common.add_out_argument(ap, "live_view")
    args = ap.parse_args(argv)
    trees = common.parse_trees(args.tree or [f"this={ROOT}"], minimum=1)
    layouts = args.layout or ["default"]

    root = Path(tempfile.mkdtemp(prefix="gw-live-view-"))
    rows, adapter = [], None
    try:
        with JupyterLabServer(root) as server, Browser() as browser:
            def one(name, folder, layout):
                nonlocal adapter
                got = measure(server, browser, root, name, folder, layout, args.scale, args.seconds, args.windows,
                              args.browser_nice)
                adapter = got.pop("adapter")
                return got

            rows = common.run_ab(trees, layouts, args.rounds, one)
    finally:
        shutil.rmtree(root, ignore_errors=True)

    summary = {}
    for layout in layouts:
        summary[layout] = {}
        for name, _ in trees:
            got = [row[name] for row in rows if row["case"] == layout]
            fps = [g["page_frames_per_s"] for g in got]
            loads = [w["load_average"][0] for g in got for w in g["windows"]]
            parts = {}
            for key in PART_KEYS:
                vals = [w["stats"].get(key) for g in got for w in g["windows"]
                        if isinstance(w["stats"].get(key), (int, float))]
                if vals:
                    parts[key] = round(common.median(vals), 2)
            for role in ("kernel", "server", "chromium"):
                key = f"{role}_cpu_ms_per_frame"
                parts[key] = round(common.median(w[key] for g in got for w in g["windows"]), 1)
            summary[layout][name] = {"page_frames_per_s_median": round(common.median(fps), 2),
                                     "page_frames_per_s_rounds": fps,
                                     "load_average_1min_median": round(common.median(loads), 2), **parts}
            print(f"{layout:8} {name:>8}: {common.median(fps):6.2f} frames/s in the page (rounds {fps}), "
                  f"load {common.median(loads):.2f}; " + ", ".join(f"{k} {v}" for k, v in parts.items()))
    result = {"benchmark": "live_view", "scale": args.scale, "seconds_per_window": args.seconds,
              "browser_nice": args.browser_nice,
              "trees": [{"name": n, "folder": str(Path(f).resolve())} for n, f in trees],
              "layouts": layouts, "rounds": rows, "summary": summary}
    common.save("live_view", result, adapter, args.out)
    return result


if __name__ == "__main__":
    main()
