"""What the meadow's looks cost: this tree against the code before them, in one run.

    python benchmarks/looks_cost.py live    [--rounds 6] [--out PATH]
    python benchmarks/looks_cost.py export  [--rounds 3] [--out PATH]
    python benchmarks/looks_cost.py meadow  [--rounds 3] [--out PATH]

On a machine without git (the GPU machine): check the baseline out beforehand, e.g.
``git worktree add --detach looks-base 6c319ec`` in the repository, and pass
``--base-tree looks-base``.

The baseline is ``--base`` (default ``6c319ec``, main before the looks: flat brown
ground, one colour ramp, no fog, exports without anti-aliasing), checked out in a
temporary git worktree. Each round runs one child process per tree, in turns (base,
new, new, base, ...: common.run_ab), so that a machine whose speed drifts loads both alike;
the ratio new / base is taken round by round and its median reported.

- ``live``: the widget's default view (4096 blades, 640 x 480, default camera):
  one step + one render with its pixel readback per frame, as the kernel view
  streams it; median wall ms and process CPU ms per frame over ``--frames``.
  On lavapipe the CPU ms is the rendering work itself and moves much less than
  wall time when other processes load the machine. Goal: within 10 %.
- ``export``: the CLI snapshot's scene (65536 blades, 640 x 360, 240 steps):
  seconds per ``render_at`` (new: anti-aliased, what save_png / snapshot /
  save_animation use; base: its plain render) and the mean |difference| (0..255,
  RGB) to a 4 x 4 supersample of the same tree (rendered at 2560 x 1440 without
  anti-aliasing, box-filtered). Goal: time at most about 2x, difference halved.
- ``meadow``: ``python -m grasswidget bench --preset meadow --blades 1048576`` in
  each tree (frame ms, GPU-synchronised, no readback). For the GPU machine; goal
  within 10 %.

Writes benchmarks/results/looks_cost_<kind>-<machine>-<date>.json (or ``--out``): rounds, medians, ratios.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402  (benchmarks/common.py)

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
DEFAULT_BASE = "6c319ec"


# ------------------------------------------------------------------ children (run inside one tree)


def _scene_class():
    try:  # the package's public name
        from grasswidget import GrassScene
    except ImportError:  # a baseline from before it was public
        from grasswidget.gpu.scene import GrassScene
    return GrassScene


def _child_live(frames):
    import grasswidget as gw

    scene = _scene_class()(gw.Blades.on_plane(4096, seed=0), size=(640, 480))

    def frame():
        scene.step(1)
        scene.render()

    times = common.time_frames(frame, frames, warmup=5)
    return dict(frame_ms=common.median(times["wall_ms"]), frame_cpu_ms=common.median(times["cpu_ms"]))


def _render_at(scene, size, antialias):
    try:
        return scene.render_at(size, antialias=antialias)
    except TypeError:  # the base tree: render_at(size) has no anti-aliasing switch
        return scene.render_at(size)


def _child_export(repeats=3):
    import numpy as np

    import grasswidget as gw

    w, h = 640, 360
    scene = _scene_class()(gw.Blades.on_plane(65536, seed=0), size=(w, h))
    scene.step(240)
    ref = _render_at(scene, (4 * w, 4 * h), False)[..., :3].astype(np.float64)
    ref = ref.reshape(h, 4, w, 4, 3).mean(axis=(1, 3))
    out = {}
    for label, aa in (("plain", False), ("export", True)):
        img = _render_at(scene, (w, h), aa)
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            _render_at(scene, (w, h), aa)
            times.append(time.perf_counter() - t0)
        out[f"{label}_s"] = float(np.median(times))
        out[f"{label}_diff_to_4x"] = float(np.abs(img[..., :3] - ref).mean())
    return out


def _child_meadow(frames):
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "bench.json")
        subprocess.run([sys.executable, "-m", "grasswidget", "bench", "--preset", "meadow", "--blades", "1048576",
                        "--frames", str(frames), "--json", path, "--no-progress"], check=True,
                       stdout=subprocess.DEVNULL)
        with open(path) as f:
            row = json.load(f)["results"][0]
    return dict(frame_ms=row["frame_ms"]["median"], frame_cpu_ms=row.get("frame_cpu_ms"),
                gpu_draw_ms=row.get("gpu_draw_ms"), pipelined_fps=row.get("pipelined_fps"))


# ------------------------------------------------------------------ parent


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("kind", nargs="?", choices=["live", "export", "meadow"], default="live")
    p.add_argument("--base", default=DEFAULT_BASE, help=f"git revision of the baseline (default {DEFAULT_BASE})")
    p.add_argument("--base-tree", default=None,
                   help="an existing checkout of the baseline (instead of --base; for a machine without git)")
    p.add_argument("--rounds", type=int, default=None, help="rounds (default: live 6, export 3, meadow 3)")
    p.add_argument("--frames", type=int, default=None, help="frames per child (default: live 30, meadow 30)")
    common.add_out_argument(p, "looks_cost_<kind>")
    p.add_argument("--child", choices=["live", "export", "meadow"], default=None, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.child:
        frames = args.frames or 30
        out = {"live": lambda: _child_live(frames), "export": _child_export,
               "meadow": lambda: _child_meadow(frames)}[args.child]()
        from grasswidget.gpu.adapter import adapter_info

        common.emit({**out, "adapter": adapter_info()})
        return 0

    kind = args.kind
    rounds = args.rounds or (6 if kind == "live" else 3)
    frames = args.frames or 30
    own_tree = args.base_tree is None
    base_tree = tempfile.mkdtemp(prefix="looks-base-") if own_tree else os.path.abspath(args.base_tree)
    if own_tree:
        subprocess.run(["git", "worktree", "add", "--detach", base_tree, args.base], cwd=REPO, check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        trees = [("base", base_tree), ("new", REPO)]

        def measure(_name, tree, _case):
            return common.run_in_tree(tree, [os.path.abspath(__file__), "--child", kind, "--frames", str(frames)])

        rows = common.run_ab(trees, [kind], rounds, measure)
        keys = sorted(k for k, v in rows[0]["new"].items() if isinstance(v, (int, float)) and k in rows[0]["base"])
        summary = common.ab_summary(rows, trees, keys)[kind]
        if kind == "export":
            new = rows[0]["new"]
            summary["export_vs_base_plain_time_ratio"] = common.median(
                row["new"]["export_s"] / row["base"]["plain_s"] for row in rows)
            summary["diff_to_4x"] = dict(base=rows[0]["base"]["plain_diff_to_4x"], new_export=new["export_diff_to_4x"],
                                         new_plain=new["plain_diff_to_4x"])
        print(json.dumps(summary, indent=1))
        common.save(f"looks_cost_{kind}", dict(kind=kind, base=args.base if own_tree else args.base_tree,
                                                 rounds=rows, summary=summary,
                                                 note="ratios are new / base, round by round, in one run on one machine"),
                    rows[0]["new"]["adapter"], args.out)
    finally:
        if own_tree:
            subprocess.run(["git", "worktree", "remove", "--force", base_tree], cwd=REPO, check=False,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return 0


if __name__ == "__main__":
    sys.exit(main())
