"""Cost of the meadow to the horizon on this adapter: before/after frame times, interleaved.

Two worker processes, one per source tree (``--before`` the tree of before, e.g. the main
checkout; ``--after`` this one), each holding the same scenes; the driver asks them in turn
for one frame (``step(1)`` + ``render()``, the live view's work, not anti-aliased) of each case,
round after round, so both see the same machine load. Prints the median frame time per case
and tree and the ratios after / before.

    python benchmarks/horizon_cost.py --before /work/main --after . [--rounds 15] [--blades 65536]

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
import time

WORKER = r"""
import json, sys, time
import grasswidget as gw
from grasswidget.gpu.scene import GrassScene
n, size = int(sys.argv[1]), tuple(int(v) for v in sys.argv[2].split("x"))
print("TREE", gw.__file__, flush=True)
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
    ap = argparse.ArgumentParser()
    ap.add_argument("--before", required=True)
    ap.add_argument("--after", default=".")
    ap.add_argument("--rounds", type=int, default=15)
    ap.add_argument("--size", default="640x480", help="WxH (default 640x480, the live widget's)")
    ap.add_argument("--blades", type=int, default=1 << 16)
    args = ap.parse_args(argv)
    workers, cases = {}, {}
    for tree in ("before", "after"):
        env = dict(os.environ, PYTHONPATH=os.path.abspath(getattr(args, tree)))
        # run in the tree itself: ``python -c`` puts the working directory first on sys.path
        p = subprocess.Popen([sys.executable, "-c", WORKER, str(args.blades), args.size], stdin=subprocess.PIPE,
                             stdout=subprocess.PIPE, text=True, env=env, cwd=os.path.abspath(getattr(args, tree)))
        workers[tree] = p
        print(tree, "imports", _answer(p, "TREE").strip(), flush=True)
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
    med = {k: sorted(v)[len(v) // 2] * 1000 for k, v in times.items()}
    for (tree, case), ms in sorted(med.items()):
        print(f"{case:14s} {tree:6s} {ms:8.1f} ms (median of {len(times[tree, case])})")
    print(f"default: after / before = {med['after', 'default'] / med['before', 'default']:.2f}")
    print(f"meadow:  after (to the horizon) / before (square field) = {med['after', 'meadow'] / med['before', 'meadow']:.2f}")
    if ("after", "meadow-square") in med:
        print(f"meadow:  after horizon / after horizon=False = {med['after', 'meadow'] / med['after', 'meadow-square']:.2f}")
    print(json.dumps({f"{t}/{c}": ms for (t, c), ms in med.items()}))


if __name__ == "__main__":
    sys.exit(main())
