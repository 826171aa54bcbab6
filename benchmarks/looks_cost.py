"""What the meadow's looks cost: this tree against the code before them, in one run.

    python benchmarks/looks_cost.py live    [--rounds 6] [--json benchmarks/looks_cost_live_lavapipe.json]
    python benchmarks/looks_cost.py export  [--rounds 3] [--json benchmarks/looks_cost_export_lavapipe.json]
    python benchmarks/looks_cost.py meadow  [--rounds 3] [--json benchmarks/looks_cost_meadow_h100.json]

On a machine without git (the GPU machine): check the baseline out beforehand, e.g.
``git worktree add --detach looks-base 6c319ec`` in the repository, and pass
``--base-tree looks-base``.

The baseline is ``--base`` (default ``6c319ec``, main before the looks: flat brown
ground, one colour ramp, no fog, exports without anti-aliasing), checked out in a
temporary git worktree. Each round runs one child process per tree, in turns (base,
new, new, base, ...), so that a machine whose speed drifts loads both alike; the
ratio new / base is taken round by round and its median reported.

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

Writes the JSON given by ``--json`` (rounds, medians, ratios, adapter).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
DEFAULT_BASE = "6c319ec"


# ------------------------------------------------------------------ children (run inside one tree)


def _child_live(frames):
    import numpy as np

    import grasswidget as gw
    from grasswidget.gpu.scene import GrassScene

    scene = GrassScene(gw.Blades.on_plane(4096, seed=0), size=(640, 480))
    for _ in range(5):
        scene.step(1)
        scene.render()
    wall, cpu = [], []
    for _ in range(frames):
        t0, c0 = time.perf_counter(), time.process_time()
        scene.step(1)
        scene.render()
        wall.append(1e3 * (time.perf_counter() - t0))
        cpu.append(1e3 * (time.process_time() - c0))
    return dict(frame_ms=float(np.median(wall)), frame_cpu_ms=float(np.median(cpu)))


def _render_at(scene, size, antialias):
    try:
        return scene.render_at(size, antialias=antialias)
    except TypeError:  # the base tree: render_at(size) has no anti-aliasing switch
        return scene.render_at(size)


def _child_export(repeats=3):
    import numpy as np

    import grasswidget as gw
    from grasswidget.gpu.scene import GrassScene

    w, h = 640, 360
    scene = GrassScene(gw.Blades.on_plane(65536, seed=0), size=(w, h))
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


def _tree_env(tree):
    """The environment of a child run in ``tree``: the tree first on the import path,
    then whatever the caller had there (the GPU machine's wheels)."""
    rest = os.environ.get("PYTHONPATH", "")
    return dict(os.environ, PYTHONPATH=tree + (os.pathsep + rest if rest else ""))


def _run_child(tree, kind, frames):
    env = _tree_env(tree)
    proc = subprocess.run([sys.executable, os.path.abspath(__file__), "--child", kind, "--frames", str(frames)],
                          cwd=tree, env=env, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise SystemExit(f"child in {tree} failed:\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _adapter(tree):
    code = "from grasswidget.gpu.adapter import adapter_info; import json; print(json.dumps(adapter_info()))"
    proc = subprocess.run([sys.executable, "-c", code], cwd=tree, env=_tree_env(tree),
                          capture_output=True, text=True, check=False)
    try:
        return json.loads(proc.stdout.strip().splitlines()[-1])
    except (IndexError, ValueError):
        return None


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("kind", nargs="?", choices=["live", "export", "meadow"], default="live")
    p.add_argument("--base", default=DEFAULT_BASE, help=f"git revision of the baseline (default {DEFAULT_BASE})")
    p.add_argument("--base-tree", default=None,
                   help="an existing checkout of the baseline (instead of --base; for a machine without git)")
    p.add_argument("--rounds", type=int, default=None, help="rounds (default: live 6, export 3, meadow 3)")
    p.add_argument("--frames", type=int, default=None, help="frames per child (default: live 30, meadow 30)")
    p.add_argument("--json", default=None, help="write the report here")
    p.add_argument("--child", choices=["live", "export", "meadow"], default=None, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.child:
        frames = args.frames or 30
        out = {"live": lambda: _child_live(frames), "export": _child_export,
               "meadow": lambda: _child_meadow(frames)}[args.child]()
        print(json.dumps(out))
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
        rows = []
        for r in range(rounds):
            order = [("base", base_tree), ("new", REPO)]
            if r % 2:
                order.reverse()
            row = {"round": r}
            for label, tree in order:
                row[label] = _run_child(tree, kind, frames)
            rows.append(row)
            print(json.dumps(row), flush=True)
        keys = sorted(k for k, v in rows[0]["new"].items() if isinstance(v, (int, float)) and k in rows[0]["base"])
        summary = {}
        for k in keys:
            new = [row["new"][k] for row in rows]
            base = [row["base"][k] for row in rows]
            ratios = [n / b for n, b in zip(new, base) if b]
            summary[k] = dict(new_median=statistics.median(new), base_median=statistics.median(base),
                              ratio_median=statistics.median(ratios) if ratios else None, ratios=ratios)
        if kind == "export":
            new = rows[0]["new"]
            summary["export_vs_base_plain_time_ratio"] = statistics.median(
                [row["new"]["export_s"] / row["base"]["plain_s"] for row in rows])
            summary["diff_to_4x"] = dict(base=rows[0]["base"]["plain_diff_to_4x"], new_export=new["export_diff_to_4x"],
                                         new_plain=new["plain_diff_to_4x"])
        report = dict(kind=kind, base=args.base if own_tree else args.base_tree, head=_git(["rev-parse", "--short", "HEAD"]),
                      adapter=_adapter(REPO), rounds=rows, summary=summary,
                      note="ratios are new / base, round by round, in one run on one machine")
        print(json.dumps(summary, indent=1))
        if args.json:
            os.makedirs(os.path.dirname(os.path.abspath(args.json)), exist_ok=True)
            with open(args.json, "w") as f:
                json.dump(report, f, indent=1)
            print(f"wrote {args.json}")
    finally:
        if own_tree:
            subprocess.run(["git", "worktree", "remove", "--force", base_tree], cwd=REPO, check=False,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return 0


def _git(cmd):
    try:
        return subprocess.run(["git", *cmd], cwd=REPO, capture_output=True, text=True).stdout.strip()
    except FileNotFoundError:  # no git (the GPU machine)
        return None


if __name__ == "__main__":
    sys.exit(main())
