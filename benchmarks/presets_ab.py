"""Process CPU ms per frame of a few preset views in two or more source trees, interleaved in one run.

    python benchmarks/presets_ab.py --tree main=/tmp/trees/main --tree new=. [--rounds 3] [--frames 10]
        [--case default:4096:on --case cis565:32768:on ...] [--out PATH]

Each ``--tree NAME=DIR`` is a folder holding a ``grasswidget`` package (e.g.
``git archive main grasswidget | tar -x -C DIR``); the first is the baseline. Each round runs, for
every case, one child process per tree in turns (reversed every other round), so that a machine
whose speed drifts loads the trees alike; a child builds the case's scene with the adapter's
defaults (``shadows`` off on a CPU adapter) and the tree's ``make_renderer`` on an rgba8unorm-srgb texture
(the live view's renderer and canvas format), takes 3 warm-up frames, then ``--frames`` frames of one
step and one render (synchronised by a readback) and prints the median process CPU ms and wall ms
per frame. Reported: per case and tree the medians over rounds, and the median of the per-round
ratios tree / baseline (quote the CPU ratio on a loaded machine: wall times swing with the load).
Writes benchmarks/results/presets_ab-<machine>-<date>.json unless ``--out`` says otherwise.

A case is ``PRESET:BLADES:CULL[:WxH]``: PRESET ``default`` (``Blades.on_plane``, 640x480, the
widget's start), ``cis565`` or ``meadow`` (``GrassScene.preset``); CULL ``on`` (every culling test,
LOD and occlusion culling) or ``off`` (none, no LOD), as ``grasswidget bench`` sets them.
Default cases: default 4096 on, cis565 2^15 on, cis565 2^16 off, meadow 2^16 on at 960x540.
"""

from __future__ import annotations

import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402  (benchmarks/common.py)

DEFAULT_CASES = ["default:4096:on", "cis565:32768:on", "cis565:65536:off", "meadow:65536:on:960x540"]


def _child(case, frames):
    import pygfx as gfx

    import grasswidget as gw
    from grasswidget.gpu.scene import make_renderer

    preset, blades, cull, *size = case.split(":")
    size = tuple(int(v) for v in size[0].split("x")) if size else None
    scene = common.preset_scene(preset, blades, size)
    common.set_culling(scene.params, cull, occlusion=cull == "on", compute_raster=False)
    w, h = scene.size
    # The live view's renderer on the live view's canvas format (rgba8unorm-srgb).
    renderer = make_renderer(gfx.Texture(dim=2, size=(w, h, 1), format="rgba8unorm-srgb", colorspace="tex-srgb"))

    def frame():
        scene.field.step(1)
        scene.draw_into(renderer)
        scene.field.read_draw_args()  # waits for the GPU (a small readback)

    times = common.time_frames(frame, frames, warmup=3)
    from grasswidget.gpu.adapter import adapter_info

    return {"cpu_ms": common.median(times["cpu_ms"]), "wall_ms": common.median(times["wall_ms"]),
            "shadows": bool(scene.params.shadows), "package": os.path.dirname(gw.__file__),
            "adapter": adapter_info().get("summary", "")}


def _measure(frames):
    def measure(_name, tree, case):
        return common.run_in_tree(tree, [os.path.abspath(__file__), "--child", case, "--frames", str(frames)])

    return measure


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--tree", action="append", default=[], help="NAME=DIR holding a grasswidget package (first: baseline)")
    ap.add_argument("--case", action="append", default=None, help="PRESET:BLADES:CULL[:WxH] (repeatable)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--frames", type=int, default=10)
    common.add_out_argument(ap, "presets_ab")
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        common.emit(_child(args.child, args.frames))
        return 0
    trees = common.parse_trees(args.tree)
    cases = args.case or DEFAULT_CASES
    rows = common.run_ab(trees, cases, args.rounds, _measure(args.frames))
    summary = common.ab_summary(rows, trees, ("cpu_ms", "wall_ms"))
    for case, by_tree in summary.items():
        for name, entry in by_tree.items():
            ratio = f"  CPU x{entry['cpu_ms_ratio']:.3f}" if "cpu_ms_ratio" in entry else ""
            print(f"{case:28s} {name:10s} CPU {entry['cpu_ms']:8.2f} ms  wall {entry['wall_ms']:8.2f} ms{ratio}")
    adapter = rows[0][trees[0][0]]["adapter"]
    common.save("presets_ab", {"trees": dict(trees), "frames": args.frames, "rounds": rows, "summary": summary,
                               "note": "ratios: tree / first tree, median of per-round ratios, one run on one machine"},
                adapter, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
