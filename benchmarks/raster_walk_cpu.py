"""The compute rasterizer's walks alone: CPU and wall time of walking one frame's listed blades again,
trees interleaved (issue 28 item 2: the walk written like the thin-blade probe's).

``python benchmarks/raster_walk_cpu.py --tree before=/path/to/old/checkout --tree after=. --tree two=.:two
--rounds 2 --json benchmarks/raster_walk_cpu_lavapipe.json``

A tree given as ``NAME=PATH:two`` runs with ``raster_walks.prefer_two_walks(True)``: the two walks (the
browser engine's layout) of a tree that would walk once.

Per round, each tree in turn in a fresh process (its ``grasswidget`` on PYTHONPATH): the meadow preset
at 2^18 blades, 1280x720, ``compute_raster_max_px`` ``--raster-max-px`` (default 8: most visible blades
go to the compute path), occlusion culling off (one list); two frames drawn, then the tree's walk steps
(one "packed" walk, or "depth" and "payload") dispatched again from the same indirect arguments,
``--repeats`` times per submission, ``--samples`` submissions; CPU (the process's, lavapipe's threads
included) and wall milliseconds per walk of the whole list, medians. The words already hold the
frame's winners, so the atomics do the same work as in the frame (a compare-exchange per pixel).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import time


def worker(raster_max_px, repeats, samples, two_walks=False):
    import pygfx as gfx

    import grasswidget
    from grasswidget import compat
    from grasswidget.gpu.adapter import ensure_device
    from grasswidget.gpu.compute import ComputeProgram
    from grasswidget.gpu.scene import GrassScene
    from grasswidget.gpu.shader_classes import RasterShader

    if two_walks:
        from grasswidget.gpu import raster_walks

        raster_walks.prefer_two_walks(True)
    scene = GrassScene.preset("meadow", blades=1 << 18, size=(1280, 720))
    p = scene.params
    p.compute_raster, p.compute_raster_max_px, p.cull_occlusion = True, raster_max_px, False
    renderer = gfx.WgpuRenderer(gfx.Texture(dim=2, size=(1280, 720, 1), format="rgba8unorm"), pixel_ratio=1,
                                ppaa="none", enable_events=False)
    field = scene.field
    device = ensure_device()
    for _ in range(2):
        scene.draw_into(renderer)
    steps = ("packed",) if getattr(field, "raster_packed", False) else ("depth", "payload")
    programs = [ComputeProgram(RasterShader(field, step), field) for step in steps]

    def walk(k):
        encoder = device.create_command_encoder()
        cpass = encoder.begin_compute_pass()
        for _ in range(k):
            for program in programs:
                program.dispatch_indirect(cpass, field.raster_dispatch_buffer)
        cpass.end()
        device.queue.submit([encoder.finish()])
        device.queue.read_buffer(compat.gpu_buffer(field.args_buffer))

    walk(1)
    cpu, wall = [], []
    for _ in range(samples):
        t, c = time.perf_counter(), time.process_time()
        walk(repeats)
        wall.append(1e3 * (time.perf_counter() - t) / repeats)
        cpu.append(1e3 * (time.process_time() - c) / repeats)
    out = {"grasswidget": os.path.dirname(grasswidget.__file__), "steps": steps, "listed": field.read_raster_count(),
           "cpu_ms": cpu, "wall_ms": wall, "compute_raster_max_px": raster_max_px}
    print("RESULT " + json.dumps(out), flush=True)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--tree", action="append", default=[], help="NAME=PATH (a checkout of grasswidget); repeatable")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--raster-max-px", type=float, default=8.0)
    ap.add_argument("--repeats", type=int, default=4)
    ap.add_argument("--samples", type=int, default=5)
    ap.add_argument("--json", default=None)
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--two-walks", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        worker(args.raster_max_px, args.repeats, args.samples, args.two_walks)
        return 0
    trees = [t.split("=", 1) for t in args.tree] or [["this", os.getcwd()]]
    runs = []
    for r in range(args.rounds):
        for name, spec in trees:
            path, two = (spec[:-4], True) if spec.endswith(":two") else (spec, False)
            env = dict(os.environ, PYTHONPATH=os.path.abspath(path))
            cmd = [sys.executable, os.path.abspath(__file__), "--worker", "--raster-max-px", str(args.raster_max_px),
                   "--repeats", str(args.repeats), "--samples", str(args.samples)] + (["--two-walks"] if two else [])
            proc = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=os.path.abspath(path))
            line = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")]
            if proc.returncode or not line:
                raise RuntimeError(f"worker failed ({name}, round {r}): {proc.stderr[-3000:]}")
            data = json.loads(line[-1][len("RESULT "):])
            runs.append({"round": r, "tree": name, **data})
            print(f"round {r} {name:8s} steps {'+'.join(data['steps']):14s} listed {data['listed']:6d} "
                  f"walk CPU ms {statistics.median(data['cpu_ms']):7.1f}  wall ms {statistics.median(data['wall_ms']):7.1f}",
                  flush=True)
    summary = {name: {key: statistics.median([statistics.median(x[key]) for x in runs if x["tree"] == name])
                      for key in ("cpu_ms", "wall_ms")} for name, _ in trees}
    print("medians over rounds: " + "; ".join(f"{n} CPU {s['cpu_ms']:.1f} ms, wall {s['wall_ms']:.1f} ms"
                                              for n, s in summary.items()))
    if args.json:
        report = {"date": time.strftime("%Y-%m-%d %H:%M:%S"), "trees": dict(trees), "rounds": args.rounds,
                  "machine": {"platform": platform.platform(), "cpus": os.cpu_count(), "load_at_end": os.getloadavg()},
                  "summary": summary, "runs": runs}
        with open(args.json, "w") as fh:
            json.dump(report, fh, indent=1)
        print("wrote", args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
