"""Cost of the meadow to the horizon on this adapter: before/after frame times, interleaved.

Two worker processes, one per source tree (``--before`` the tree of before, e.g. the main
checkout; ``--after`` this one), each holding the same scenes; the driver asks them in turn
for one frame (``step(1)`` + ``render()``, the live view's work, not anti-aliased) of each case,
round after round, so both see the same machine load. Prints the median frame time per case
and tree and the ratios after / before.

    python benchmarks/horizon_cost.py --before /work/main --after . [--rounds 15] [--blades 65536] [--out PATH]

Writes benchmarks/results/horizon_cost-<machine>-<date>.json unless ``--out`` says otherwise.

Cases: ``default`` (``GrassScene(Blades.on_plane(N))`` at 640 x 480, its default view) and
``meadow`` (``GrassScene.preset("meadow", N)`` at 640 x 480, the live widget's size: in the tree
of before the square field, in this one the field to the horizon), plus ``meadow-square`` in
this tree (``horizon=False``).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402  (benchmarks/common.py)

WORKER = r"""
import json, sys, time
import grasswidget as gw
from grasswidget.gpu.scene import GrassScene
n, size = int(sys.argv[1]), tuple(int(v) for v in sys.argv[2].split("x"))
print("TREE", gw.__file__, flush=True)
from grasswidget.gpu.adapter import adapter_info
print("ADAPTER", adapter_info().get("summary", ""), flush=True)
scenes = {"default": GrassScene(gw.Blades.on_plane(n), size=size),
          "meadow": GrassScene.preset("meadow", blades=n, size=size)}
try:
    scenes["meadow-square"] = GrassScene.preset("meadow", blades=n, size=size, horizon=False)
except TypeError:
    pass
for s in scenes.values():
    s.step(1); s.render()
print("READY " + json.dumps(sorted(scenes)), flush=True)
for line in sys.stdin:
    s = scenes[line.strip()]
    t0 = time.perf_counter(); s.step(1); s.render(); dt = time.perf_counter() - t0
    print("T", dt, flush=True)
"""


def _answer(proc, tag):
    """The rest of the worker's next line starting with ``tag`` (other lines, e.g. the adapter's notice, skipped)."""
    while True:
        line = proc.stdout.readline()
        if not line:
            raise RuntimeError(f"the worker ended before answering {tag}")
        if line.startswith(tag + " "):
            return line[len(tag) + 1:]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", required=True, help="a folder holding the grasswidget package of before")
    ap.add_argument("--after", default=".", help="a folder holding the grasswidget package of after (default .)")
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--size", default="640x480", help="WxH (default 640x480, the live widget's)")
    ap.add_argument("--blades", type=int, default=1 << 16)
    common.add_out_argument(ap, "horizon_cost")
    args = ap.parse_args(argv)
    common.parse_trees([f"before={args.before}", f"after={args.after}"])
    workers, cases = {}, {}
    for tree in ("before", "after"):
        env = dict(os.environ, PYTHONPATH=os.path.abspath(getattr(args, tree)))
        # run in the tree itself: ``python -c`` puts the working directory first on sys.path
        p = subprocess.Popen([sys.executable, "-c", WORKER, str(args.blades), args.size], stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, text=True, env=env, cwd=os.path.abspath(getattr(args, tree)))
        workers[tree] = p
        print(tree, "imports", _answer(p, "TREE").strip(), flush=True)
        adapter = _answer(p, "ADAPTER").strip()
        cases[tree] = json.loads(_answer(p, "READY"))
    times = {(t, c): [] for t in workers for c in cases[t]}
    for _ in range(args.rounds):
        for case in ("default", "meadow", "meadow-square"):
            for tree, p in workers.items():
                if case in cases[tree]:
                    p.stdin.write(case + "\n"); p.stdin.flush()
                    times[tree, case].append(float(_answer(p, "T")))
    for p in workers.values():
        p.stdin.close(); p.wait()
    med = {k: common.median(v) * 1000 for k, v in times.items()}
    for (tree, case), ms in sorted(med.items()):
        print(f"{case:14s} {tree:6s} {ms:8.1f} ms (median of {len(times[tree, case])})")
    print(f"default: after / before = {med['after', 'default'] / med['before', 'default']:.2f}")
    print(f"meadow:  after (to the horizon) / before (square field) = {med['after', 'meadow'] / med['before', 'meadow']:.2f}")
    if ("after", "meadow-square") in med:
        print(f"meadow:  after horizon / after horizon=False = {med['after', 'meadow'] / med['after', 'meadow-square']:.2f}")
    common.save("horizon_cost", {"trees": {"before": args.before, "after": args.after}, "blades": args.blades,
                                 "size": args.size, "rounds": args.rounds,
                                 "median_frame_ms": {f"{t}/{c}": ms for (t, c), ms in med.items()},
                                 "frame_s": {f"{t}/{c}": v for (t, c), v in times.items()}}, adapter, args.out)


if __name__ == "__main__":
    sys.exit(main())
