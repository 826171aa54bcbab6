"""Seed 004's C++/Vulkan peer against grasswidget trees, interleaved, in the cis565 view (640 x 480).

    python benchmarks/peer_side_by_side.py --peer /tmp/peer004 --tree main=/tmp/trees/main \
        --tree looks=/tmp/trees/looks [--rounds 3] [--out PATH]

The peer is built as ``../shared/peer-seed004/README.md`` says (``run_peer.sh BLADES CULL``: CULL 0
off, 2 on with the paper's orientation test). Each ``--tree NAME=DIR`` is a folder holding a
``grasswidget`` package (e.g. ``git archive main grasswidget | tar -x -C DIR``); its
``python -m grasswidget bench`` runs with ``PYTHONPATH=DIR``: culling off (no LOD), or on with
every test and occlusion culling; the compute rasterizer off (a CPU adapter's default).

Per round, per blade count (2^13, 2^15, 2^16) and culling mode, the peer and then every tree
run once, the trees' order alternating from round to round, so that a machine whose load drifts
weighs on all alike. Reported: each run's median frame ms and drawn blades, and per
configuration the median over rounds of peer ms / tree ms (above 1: the tree is faster).
The JSON (benchmarks/results/peer_side_by_side-<machine>-<date>.json unless ``--out``) is rewritten
after every run (a cut-short run keeps its rounds).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402  (benchmarks/common.py)


def run_peer(peer_dir, blades, cull, frames, warmup):
    env = dict(os.environ, PEER_FRAMES=str(frames), PEER_WARMUP=str(warmup))
    p = subprocess.run(["./run_peer.sh", str(blades), "2" if cull == "on" else "0"], cwd=peer_dir, env=env,
                       capture_output=True, text=True)
    text = p.stdout + p.stderr
    ms = re.search(r"median_ms=([0-9.]+)", text)
    vis = re.search(r"visible=([0-9]+)", text)
    return dict(ms=float(ms.group(1)) if ms else None, visible=int(vis.group(1)) if vis else None)


def run_tree(tree_dir, python, blades, cull, frames):
    fd, out = tempfile.mkstemp(suffix=".json")
    os.close(fd)
    extra = ["--compute-raster", "off"] + (["--occlusion", "on"] if cull == "on" else [])
    cmd = [python, "-m", "grasswidget", "bench", "--preset", "cis565", "--blades", str(blades), "--cull", cull,
           *extra, "--frames", str(frames), "--no-progress", "--json", out]
    p = subprocess.run(cmd, env=dict(os.environ, PYTHONPATH=tree_dir), capture_output=True, text=True, cwd=tempfile.gettempdir())
    try:
        if p.returncode:
            return dict(ms=None, error=p.stderr[-500:])
        with open(out) as f:
            data = json.load(f)
        row = data["results"][0]
        return dict(ms=row["frame_ms"]["median"], cpu_ms=row["frame_cpu_ms"], visible=row["visible"],
                    adapter=data.get("adapter"))
    finally:
        os.unlink(out)


def summary(runs, trees):
    rows = []
    keys = sorted({(r["blades"], r["cull"]) for r in runs})
    for blades, cull in keys:
        mine = [r for r in runs if r["blades"] == blades and r["cull"] == cull]
        row = dict(blades=blades, cull=cull, rounds=len(mine),
                   peer_ms=common.median(r["peer"]["ms"] for r in mine if r["peer"]["ms"]),
                   peer_visible=mine[-1]["peer"]["visible"])
        for t in trees:
            ok = [r for r in mine if r["peer"]["ms"] and r.get(t, {}).get("ms")]
            if ok:
                row[f"{t}_ms"] = common.median(r[t]["ms"] for r in ok)
                row[f"{t}_visible"] = ok[-1][t]["visible"]
                row[f"peer_over_{t}"] = common.median(r["peer"]["ms"] / r[t]["ms"] for r in ok)
        rows.append(row)
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--peer", required=True, help="the peer's folder (run_peer.sh, bin/)")
    ap.add_argument("--tree", action="append", required=True, help="NAME=DIR holding a grasswidget package")
    ap.add_argument("--python", default=sys.executable)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--blades", type=int, nargs="+", default=[8192, 32768, 65536])
    ap.add_argument("--frames", type=int, default=6, help="grasswidget bench frames (after its 3 warm-up frames)")
    ap.add_argument("--peer-frames", type=int, default=8)
    ap.add_argument("--peer-warmup", type=int, default=5)
    common.add_out_argument(ap, "peer_side_by_side")
    a = ap.parse_args(argv)
    if not os.path.isfile(os.path.join(a.peer, "run_peer.sh")):
        ap.error(f"--peer {a.peer}: no run_peer.sh there")
    trees = dict(common.parse_trees(a.tree, minimum=1))
    runs = []
    report = dict(view="cis565 640x480", trees=trees, rounds=a.rounds,
                  frames=a.frames, peer_frames=a.peer_frames, peer_warmup=a.peer_warmup, runs=runs)
    out = a.out
    adapter = None
    for rnd in range(a.rounds):
        order = list(trees) if rnd % 2 == 0 else list(trees)[::-1]
        for blades in a.blades:
            for cull in ("off", "on"):
                run = dict(round=rnd, blades=blades, cull=cull,
                           peer=run_peer(a.peer, blades, cull, a.peer_frames, a.peer_warmup),
                           load=os.getloadavg()[0])
                for t in order:
                    run[t] = run_tree(trees[t], a.python, blades, cull, a.frames)
                runs.append(run)
                line = " | ".join(f"{t} {run[t].get('ms') or float('nan'):8.1f} ms ({run[t].get('visible')})" for t in trees)
                print(f"round {rnd} 2^{blades.bit_length() - 1} cull {cull:>3}: peer {run['peer']['ms'] or float('nan'):8.1f} ms "
                      f"({run['peer']['visible']}) | {line} | load {run['load']:.1f}", flush=True)
                report["summary"] = summary(runs, list(trees))
                adapter = adapter or next((run[t].get("adapter") for t in trees if run[t].get("adapter")), None)
                if out != common.NO_FILE:  # the same file after every run
                    out = common.save("peer_side_by_side", report, adapter, out)
    for row in report["summary"]:
        ratios = "  ".join(f"peer/{t} {row.get(f'peer_over_{t}', float('nan')):.2f}x" for t in trees)
        print(f"2^{row['blades'].bit_length() - 1} cull {row['cull']:>3} ({row['rounds']} rounds): {ratios}")


if __name__ == "__main__":
    main()
