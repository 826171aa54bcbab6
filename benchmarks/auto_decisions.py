"""How steady the "auto" switches' decisions are: the same view decided again and again, each time in a fresh process.

``python benchmarks/auto_decisions.py [--tree NAME=DIR ...] [--preset meadow] [--blades 1048576] [--size 1920x1080]
[--runs 3] [--out PATH]``

Each run is a new Python process (``--tree``: with ``PYTHONPATH=DIR``, a folder holding a ``grasswidget`` package,
e.g. ``git archive HEAD grasswidget | tar -x -C DIR``; default: this checkout) that makes
``GrassScene.preset(preset, blades=..., size=...)`` with both switches on "auto" and renders until both are
decided (``grasswidget.core.auto_switches``), then prints each decision, its reason (the two sides' median frame
times) and what the trial frames were timed by (``trial_clock``: "gpu", "wall" or "cpu"; a tree without it:
"wall or cpu"). The trees' runs alternate. A view whose decisions differ from run to run has a trial that
cannot tell its two sides apart: the issue this measures was the compute rasterizer decided on in one run and
off in the next on an H200 (2^20 meadow, 1920 x 1080), where a frame's wall time is mostly the host's.
Writes benchmarks/results/auto_decisions-<machine>-<date>.json (or ``--out``) and prints a table.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402  (benchmarks/common.py)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

CHILD = r"""
import json, sys, time
import grasswidget as gw
from grasswidget.gpu.adapter import adapter_info
from grasswidget.gpu.trial_timing import switches_of
try:
    from grasswidget.gpu.trial_timing import trial_clock
    clock = trial_clock()
except ImportError:
    clock = "wall or cpu"
preset, blades, w, h = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
scene = gw.GrassScene.preset(preset, blades=blades, size=(w, h))
state = switches_of(scene.field)
t0, frames = time.perf_counter(), 0
while frames < 1000 and (state.measuring or len(state.decisions) < 2):
    scene.render()
    frames += 1
out = {"adapter": adapter_info(), "clock": clock, "frames": frames, "seconds": time.perf_counter() - t0,
       "decisions": {k: {"on": bool(d.on), "reason": d.reason} for k, d in state.decisions.items()}}
print("RESULT " + json.dumps(out))
"""


def run_one(tree, preset, blades, size, timeout):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in (tree, os.environ.get("PYTHONPATH", "")) if p))
    p = subprocess.run([sys.executable, "-c", CHILD, preset, str(blades), str(size[0]), str(size[1])], cwd=tree,
                       env=env, capture_output=True, text=True, timeout=timeout)
    for line in p.stdout.splitlines():
        if line.startswith("RESULT "):
            return json.loads(line[len("RESULT "):])
    return {"error": (p.stdout + p.stderr)[-2000:]}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--tree", action="append", default=[], metavar="NAME=DIR",
                    help="a folder holding a grasswidget package (repeat for an A/B; default: this checkout)")
    ap.add_argument("--preset", choices=("cis565", "meadow", "default"), default="meadow")
    ap.add_argument("--blades", type=int, default=1 << 20)
    ap.add_argument("--size", default="1920x1080", help="WxH pixels (default 1920x1080)")
    ap.add_argument("--runs", type=int, default=3, help="fresh processes per tree (default 3)")
    ap.add_argument("--timeout", type=float, default=300.0, help="seconds a run may take (default 300)")
    common.add_out_argument(ap, "auto_decisions")
    a = ap.parse_args(argv)
    trees = dict(t.split("=", 1) for t in a.tree) or {"checkout": ROOT}
    w, h = (int(v) for v in a.size.lower().split("x"))
    runs, adapter = [], None
    for k in range(a.runs):
        for name, tree in (trees.items() if k % 2 == 0 else reversed(list(trees.items()))):
            t0 = time.perf_counter()
            r = run_one(os.path.abspath(tree), a.preset, a.blades, (w, h), a.timeout)
            r.update(run=k, tree=name, wall_s=round(time.perf_counter() - t0, 1))
            adapter = adapter or r.pop("adapter", None)
            r.pop("adapter", None)
            runs.append(r)
            if "error" in r:
                print(f"run {k} {name}: failed: {r['error'][-300:]}", flush=True)
                continue
            said = "; ".join(f"{s}: {'on' if d['on'] else 'off'} ({d['reason']})" for s, d in sorted(r["decisions"].items()))
            print(f"run {k} {name:8} clock {r['clock']:4} {r['frames']:4} frames: {said}", flush=True)
    summary = {}
    for name in trees:
        seen = [r["decisions"] for r in runs if r["tree"] == name and "decisions" in r]
        summary[name] = {s: [d[s]["on"] for d in seen if s in d] for s in ("cull_occlusion", "compute_raster")}
        print(f"{name}: " + ", ".join(f"{s} on in {sum(v)} of {len(v)} runs" for s, v in summary[name].items()))
    common.save("auto_decisions", dict(preset=a.preset, blades=a.blades, size=[w, h], trees=trees, runs=runs,
                                       summary=summary), adapter or "unknown", a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
