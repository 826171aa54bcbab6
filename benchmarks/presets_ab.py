"""Process CPU ms per frame of a few preset views in two or more source trees, interleaved in one run.

    python benchmarks/presets_ab.py --tree main=/tmp/trees/main --tree new=. [--rounds 3] [--frames 10]
        [--case default:4096:on --case cis565:32768:on ...] [--json benchmarks/sunlight_switch_lavapipe.json]

Each ``--tree NAME=DIR`` is a folder holding a ``grasswidget`` package (e.g.
``git archive main grasswidget | tar -x -C DIR``); the first is the baseline. Each round runs, for
every case, one child process per tree in turns (reversed every other round), so that a machine
whose speed drifts loads the trees alike; a child builds the case's scene with the adapter's
defaults (``shadows`` off on a CPU adapter), takes 3 warm-up frames, then ``--frames`` frames of one
step and one render (synchronised by a readback) and prints the median process CPU ms and wall ms
per frame. Reported: per case and tree the medians over rounds, and the median of the per-round
ratios tree / baseline (quote the CPU ratio on a loaded machine: wall times swing with the load).

A case is ``PRESET:BLADES:CULL[:WxH]``: PRESET ``default`` (``Blades.on_plane``, 640x480, the
widget's start), ``cis565`` or ``meadow`` (``GrassScene.preset``); CULL ``on`` (every culling test,
LOD and occlusion culling) or ``off`` (none, no LOD), as ``grasswidget bench`` sets them.
Default cases: default 4096 on, cis565 2^15 on, cis565 2^16 off, meadow 2^16 on at 960x540.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

DEFAULT_CASES = ["default:4096:on", "cis565:32768:on", "cis565:65536:off", "meadow:65536:on:960x540"]


def _child(case, frames):
    import numpy as np
    import pygfx as gfx

    import grasswidget as gw
    from grasswidget.gpu.scene import GrassScene
    from grasswidget.tools.benchmark import _apply_mode

    preset, blades, cull, *size = case.split(":")
    size = tuple(int(v) for v in size[0].split("x")) if size else None
    if preset == "default":
        scene = GrassScene(gw.Blades.on_plane(int(blades), seed=0), size=size or (640, 480))
    else:
        scene = GrassScene.preset(preset, blades=int(blades), seed=0, size=size)
    _apply_mode(scene.params, cull, occlusion=cull == "on")
    w, h = scene.size
    renderer = gfx.WgpuRenderer(gfx.Texture(dim=2, size=(w, h, 1), format="rgba8unorm"), pixel_ratio=1,
                                ppaa="none", enable_events=False)

    def frame():
        scene.field.step(1)
        scene.draw_into(renderer)
        scene.field.read_draw_args()  # waits for the GPU (a small readback)

    for _ in range(3):
        frame()
    cpu, wall = [], []
    for _ in range(frames):
        t0, c0 = time.perf_counter(), time.process_time()
        frame()
        cpu.append(1e3 * (time.process_time() - c0))
        wall.append(1e3 * (time.perf_counter() - t0))
    return {"cpu_ms": float(np.median(cpu)), "wall_ms": float(np.median(wall)), "shadows": bool(scene.params.shadows),
            "package": os.path.dirname(gw.__file__)}


def _run_child(tree, case, frames):
    rest = os.environ.get("PYTHONPATH", "")
    env = dict(os.environ, PYTHONPATH=os.path.abspath(tree) + (os.pathsep + rest if rest else ""))
    proc = subprocess.run([sys.executable, os.path.abspath(__file__), "--child", case, "--frames", str(frames)],
                          cwd=os.path.abspath(tree), env=env, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise SystemExit(f"child {case} in {tree} failed:\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tree", action="append", default=[], help="NAME=DIR holding a grasswidget package (first: baseline)")
    ap.add_argument("--case", action="append", default=None, help="PRESET:BLADES:CULL[:WxH] (repeatable)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--frames", type=int, default=10)
    ap.add_argument("--json", default=None)
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        print(json.dumps(_child(args.child, args.frames)))
        return 0
    trees = [t.split("=", 1) for t in args.tree]
    if len(trees) < 2 or any(len(t) != 2 for t in trees):
        ap.error("give at least two --tree NAME=DIR")
    cases = args.case or DEFAULT_CASES
    rows = []
    for r in range(args.rounds):
        for case in cases:
            order = trees if r % 2 == 0 else trees[::-1]
            row = {"round": r, "case": case}
            for name, tree in order:
                row[name] = _run_child(tree, case, args.frames)
            rows.append(row)
            print(json.dumps(row), flush=True)
    base = trees[0][0]
    summary = {}
    for case in cases:
        mine = [row for row in rows if row["case"] == case]
        summary[case] = {}
        for name, _ in trees:
            entry = {k: statistics.median(row[name][k] for row in mine) for k in ("cpu_ms", "wall_ms")}
            if name != base:
                for k in ("cpu_ms", "wall_ms"):
                    entry[f"{k}_ratio"] = statistics.median(row[name][k] / row[base][k] for row in mine)
            summary[case][name] = entry
    print(json.dumps(summary, indent=1))
    if args.json:
        from grasswidget.gpu.adapter import adapter_info

        with open(args.json, "w") as f:
            json.dump({"trees": dict(trees), "rounds": rows, "summary": summary, "adapter": adapter_info(),
                       "note": "ratios: tree / first tree, median of per-round ratios, one run on one machine"},
                      f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
