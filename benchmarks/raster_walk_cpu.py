"""The compute rasterizer's walks alone: CPU and wall time of walking one frame's listed blades again,
trees interleaved (issue 28 item 2: the walk written like the thin-blade probe's).

``python benchmarks/raster_walk_cpu.py --tree before=/path/to/old/checkout --tree after=. --tree two=.:two
--rounds 2 [--out PATH]``

A tree given as ``NAME=PATH:two`` runs with ``raster_walks.prefer_two_walks(True)``: the two walks (the
browser engine's layout) of a tree that would walk once.

Per round, each tree in turn in a fresh process (its ``grasswidget`` on PYTHONPATH): the meadow preset
at 2^18 blades, 1280x720, ``compute_raster_max_px`` ``--raster-max-px`` (default 8: most visible blades
go to the compute path), occlusion culling off (one list); two frames drawn, then the tree's walk steps
(one "packed" walk, or "depth" and "payload") dispatched again from the same indirect arguments,
``--repeats`` times per submission, ``--samples`` submissions; CPU (the process's, lavapipe's threads
included) and wall milliseconds per walk of the whole list, medians. Writes
benchmarks/results/raster_walk_cpu-<machine>-<date>.json unless ``--out`` says otherwise. The words already hold the
frame's winners, so the atomics do the same work as in the frame (a compare-exchange per pixel).
"""

from __future__ import annotations

import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402  (benchmarks/common.py)


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

    times = common.time_frames(lambda: walk(repeats), samples, warmup=1)
    from grasswidget.gpu.adapter import adapter_info

    common.emit({"grasswidget": os.path.dirname(grasswidget.__file__), "steps": steps,
                 "listed": field.read_raster_count(), "cpu_ms": [v / repeats for v in times["cpu_ms"]],
                 "wall_ms": [v / repeats for v in times["wall_ms"]], "compute_raster_max_px": raster_max_px,
                 "adapter": adapter_info().get("summary", "")})


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--tree", action="append", default=[], help="NAME=PATH (a checkout of grasswidget); repeatable")
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--raster-max-px", type=float, default=8.0)
    ap.add_argument("--repeats", type=int, default=4)
    ap.add_argument("--samples", type=int, default=5)
    common.add_out_argument(ap, "raster_walk_cpu")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--two-walks", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.worker:
        worker(args.raster_max_px, args.repeats, args.samples, args.two_walks)
        return 0
    trees = common.parse_trees(args.tree or [f"this={os.getcwd()}"], minimum=1, suffixes=(":two",))

    def measure(name, spec, _case):
        path, two = (spec[:-4], True) if spec.endswith(":two") else (spec, False)
        data = common.run_in_tree(path, [os.path.abspath(__file__), "--worker", "--raster-max-px",
                                         str(args.raster_max_px), "--repeats", str(args.repeats), "--samples",
                                         str(args.samples)] + (["--two-walks"] if two else []))
        print(f"{name:8s} steps {'+'.join(data['steps']):14s} listed {data['listed']:6d} walk CPU ms "
              f"{common.median(data['cpu_ms']):7.1f}  wall ms {common.median(data['wall_ms']):7.1f}", flush=True)
        return data

    rows = common.run_ab(trees, ["meadow 2^18 1280x720"], args.rounds, measure)
    for row in rows:
        for name, _ in trees:
            row[name]["cpu_ms_median"] = common.median(row[name]["cpu_ms"])
            row[name]["wall_ms_median"] = common.median(row[name]["wall_ms"])
    summary = common.ab_summary(rows, trees, ("cpu_ms_median", "wall_ms_median"))
    print("medians over rounds: " + "; ".join(f"{n} CPU {s['cpu_ms_median']:.1f} ms, wall {s['wall_ms_median']:.1f} ms"
                                              for n, s in next(iter(summary.values())).items()))
    common.save("raster_walk_cpu", {"trees": dict(trees), "rounds": args.rounds, "summary": summary, "runs": rows},
                rows[0][trees[0][0]]["adapter"], args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
