"""The compute rasterizer on and off, two source trees interleaved (issue 28 item 2's before/after).

``python benchmarks/raster_ab.py --tree before=/path/to/old/checkout --tree after=. --rounds 3 --frames 3
[--out PATH]`` (default benchmarks/results/raster_ab-<machine>-<date>.json)

Each round runs every tree once, in turn (reversed every other round: common.run_ab), each in a fresh Python
process whose ``grasswidget`` is that tree's (PYTHONPATH). A process draws every view with the compute
rasterizer off and on, alternating frame by frame after a warm-up: a frame is ``field.step(1)``, a GPU
sync, ``GrassScene.draw_into`` and a GPU sync (as ``grasswidget bench``'s frame ms; ``draw_ms`` is the
draw alone); ``frame_cpu_ms`` is the process's CPU time over the same frame (lavapipe's threads are the
process's: on a CPU adapter that is the work done, much less sensitive than wall time to a loaded machine). Reported: per tree, view and mode the median over all rounds and frames, and on/off
(medians of each round's ratio, and the ratio of the medians). On a loaded machine only the ratios
within one run mean anything.

Views (``VIEWS``): the default view (cis565 preset, 2^16 blades, 640x480, the params' defaults:
culling, LOD and occlusion culling on), the cis565 view at 2^15 culled (defaults) and unculled
(nothing culled, no LOD, as ``bench --cull off``), and the meadow at 2^18 blades, 1280x720.
``--raster-max-px``: compute_raster_max_px for the "on" frames (default: the params' own).
"""

from __future__ import annotations

import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402  (benchmarks/common.py)

VIEWS = {
    "default (cis565 2^16 640x480)": ("cis565", 1 << 16, (640, 480), "on"),
    "cis565 2^15 culled": ("cis565", 1 << 15, (640, 480), "on"),
    "cis565 2^15 unculled": ("cis565", 1 << 15, (640, 480), "off"),
    "meadow 2^18 1280x720": ("meadow", 1 << 18, (1280, 720), "on"),
}


def worker(frames, views, raster_max_px):
    """Measure in this process (this tree's grasswidget); prints one JSON line."""
    import numpy as np  # noqa: F401
    import pygfx as gfx

    import grasswidget
    from grasswidget import compat
    from grasswidget.gpu.scene import GrassScene

    out = {"grasswidget": os.path.dirname(grasswidget.__file__), "views": {}}
    for view, (preset, n, size, cull) in VIEWS.items():
        if views and not any(v in view for v in views):
            continue
        scene = GrassScene.preset(preset, blades=n, size=size)
        common.set_culling(scene.params, cull, occlusion=cull == "on", raster_max_px=raster_max_px)
        w, h = size
        target = gfx.Texture(dim=2, size=(w, h, 1), format="rgba8unorm")
        renderer = gfx.WgpuRenderer(target, pixel_ratio=1, ppaa="none", enable_events=False)
        field = scene.field
        device = field.stats.device

        def sync():
            device.queue.read_buffer(compat.gpu_buffer(field.args_buffer))

        for on in (False, True, False, True):  # warm-up: compile both
            field.params.compute_raster = on
            field.step(1)
            scene.draw_into(renderer)
            sync()
        rows = {"off": [], "on": []}
        for _ in range(frames):
            for mode in ("off", "on"):
                field.params.compute_raster = mode == "on"
                field.step(1)
                scene.draw_into(renderer)  # the switch settles (pygfx swaps pipelines) outside the timing
                sync()
                t0, c0 = time.perf_counter(), time.process_time()
                field.step(1)
                sync()
                t1, c1 = time.perf_counter(), time.process_time()
                scene.draw_into(renderer)
                sync()
                t2, c2 = time.perf_counter(), time.process_time()
                rows[mode].append({"frame_ms": 1e3 * (t2 - t0), "draw_ms": 1e3 * (t2 - t1),
                                   "frame_cpu_ms": 1e3 * (c2 - c0), "draw_cpu_ms": 1e3 * (c2 - c1)})
        listed = field.read_raster_count()
        out["views"][view] = {"rows": rows, "listed_for_compute": listed,
                              "compute_raster_max_px": float(field.params.compute_raster_max_px)}
        del scene, renderer
    from grasswidget.gpu.adapter import adapter_info

    out["adapter"] = adapter_info().get("summary", "")
    common.emit(out)


def drive(trees, rounds, frames, views, raster_max_px, out_path):
    def measure(name, path, _case):
        cmd = [os.path.abspath(__file__), "--worker", "--frames", str(frames)]
        if views:
            cmd += ["--view", *views]
        if raster_max_px is not None:
            cmd += ["--raster-max-px", str(raster_max_px)]
        t = time.perf_counter()
        data = common.run_in_tree(path, cmd)
        return {"seconds": time.perf_counter() - t, **data}

    runs = [{"round": row["round"], "tree": name, **row[name]}
            for row in common.run_ab(trees, ["all views"], rounds, measure) for name, _ in trees]
    _median = common.median
    summary = {}
    for name, _ in trees:
        mine = [x for x in runs if x["tree"] == name]
        for view in mine[0]["views"]:
            s = {}
            for key in ("frame_ms", "draw_ms", "frame_cpu_ms", "draw_cpu_ms"):
                med = {m: _median([f[key] for x in mine for f in x["views"][view]["rows"][m]]) for m in ("off", "on")}
                per_round = [_median([f[key] for f in x["views"][view]["rows"]["on"]])
                             / _median([f[key] for f in x["views"][view]["rows"]["off"]]) for x in mine]
                s[key] = {"off": med["off"], "on": med["on"], "on_over_off": med["on"] / med["off"],
                          "on_over_off_per_round": per_round, "on_over_off_median_of_rounds": _median(per_round)}
            s["listed_for_compute"] = mine[-1]["views"][view]["listed_for_compute"]
            s["compute_raster_max_px"] = mine[-1]["views"][view]["compute_raster_max_px"]
            summary.setdefault(view, {})[name] = s
    report = {"trees": dict(trees), "rounds": rounds, "frames": frames, "summary": summary, "runs": runs}
    for key in ("frame_ms", "frame_cpu_ms"):
        print(f"\n{key}\n{'view':32s} {'tree':8s} {'off ms':>9s} {'on ms':>9s} {'on/off':>7s} {'rounds':>18s} {'listed':>7s}")
        for view, by_tree in summary.items():
            for name, s in by_tree.items():
                f = s[key]
                rr = ",".join(f"{x:.2f}" for x in f["on_over_off_per_round"])
                print(f"{view:32s} {name:8s} {f['off']:9.1f} {f['on']:9.1f} {f['on_over_off']:7.2f} {rr:>18s} "
                      f"{s['listed_for_compute']:7d}")
    common.save("raster_ab", report, runs[0]["adapter"], out_path)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--tree", action="append", default=[], help="NAME=PATH (a checkout of grasswidget); repeatable")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--frames", type=int, default=3)
    ap.add_argument("--view", nargs="*", default=None, help="substrings of the views to run (default all)")
    ap.add_argument("--raster-max-px", type=float, default=None)
    common.add_out_argument(ap, "raster_ab")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.worker:
        return worker(a.frames, a.view, a.raster_max_px)
    trees = common.parse_trees(a.tree or ["after=."], minimum=1)
    drive(trees, a.rounds, a.frames, a.view, a.raster_max_px, a.out)


if __name__ == "__main__":
    sys.exit(main())
