"""The kernel engine's host work per frame: this tree against a baseline tree, in one run.

    python benchmarks/frame_host.py --blades 1048576 --json benchmarks/frame_host_meadow_h100.json
    python benchmarks/frame_host.py --blades 256 --size 64x36 --rounds 6          # lavapipe: GPU work tiny

Each round runs one child process per tree, in turns (base, new, new, base, ...), so that a
machine whose speed drifts (other processes, thermal) loads both alike; the ratio new / base is
taken round by round and its median reported. The baseline is ``--base`` (a git revision,
checked out into a temporary worktree) or ``--base-tree`` (a directory holding a plain copy
of the baseline's ``grasswidget`` package, e.g. made with
``mkdir -p .lean-base && git archive main grasswidget | tar -x -C .lean-base``: for a machine
without git). Without either, only this tree runs (no ratios).

A child renders the meadow preset (``--preset``) at ``--blades`` and ``--size`` (default: the
preset's) into an offscreen texture with the live view's renderer (its tree's
``grasswidget.gpu.scene.make_renderer``: pygfx's default anti-aliasing on a GPU, none on a CPU
adapter), with GrassScene's defaults
(``--occlusion`` / ``--compute-raster`` force them on or off), and measures:

- pipelined frames: ``field.step(1)`` + ``GrassScene.draw_into`` (+ ``FrameStats.after_render``
  with ``--live-stats``, as the widget's view does) submitted back to back, one GPU sync at the
  end: wall ms per frame and frames/s, the process's CPU ms per frame (all threads: on a CPU
  adapter that includes the rasterizer's threads) and the **main thread's CPU ms per frame**
  (the host work: Python, pygfx, wgpu-native's recording and submission; a CPU adapter's own
  threads are not in it);
- synced frames: the same frame followed by a GPU sync, median wall ms (the GPU's work is in it);
- what a frame asks of wgpu, counted by wrapping wgpu-native's classes for ``--count-frames``
  frames: ``renderer.render`` / ``flush`` calls, command encoders, submits,
  ``queue.write_buffer`` calls and bytes, bind groups, pipelines, shader modules, buffers,
  textures and texture views created, render and compute passes, draws and dispatches,
  ``map_async`` requests and blocking reads (``queue.read_buffer``, ``map_sync``), render bundles
  executed and the calls recorded into them (only when one is recorded), and their sum.

Prints a table and writes JSON (``--json``). Imports no browser or notebook package: it runs
on a headless GPU machine.
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)

#: (wgpu-native class name, methods) counted per frame.
COUNTED = (
    ("GPUDevice", ("create_command_encoder", "create_bind_group", "create_render_pipeline", "create_compute_pipeline",
                   "create_shader_module", "create_buffer", "create_texture", "create_bind_group_layout",
                   "create_pipeline_layout", "create_sampler", "create_render_bundle_encoder")),
    ("GPUQueue", ("submit", "read_buffer", "write_texture")),
    ("GPUCommandEncoder", ("begin_render_pass", "begin_compute_pass", "copy_buffer_to_buffer",
                           "copy_texture_to_buffer", "resolve_query_set", "clear_buffer")),
    ("GPURenderPassEncoder", ("draw", "draw_indirect", "draw_indexed", "set_pipeline", "set_bind_group",
                              "set_viewport", "execute_bundles")),
    ("GPURenderBundleEncoder", ("draw_indirect", "set_pipeline", "set_bind_group")),
    ("GPUComputePassEncoder", ("dispatch_workgroups", "set_pipeline", "set_bind_group")),
    ("GPUBuffer", ("map_async", "map_sync")),
    ("GPUTexture", ("create_view",)),
)


# ------------------------------------------------------------------ child (runs inside one tree)


def _child(args):
    import numpy as np
    import pygfx as gfx
    from wgpu.backends import wgpu_native

    from grasswidget.gpu.adapter import adapter_info, ensure_device
    from grasswidget.gpu.scene import GrassScene, make_renderer, parse_size

    size = parse_size(args.size) if args.size else None
    scene = GrassScene.preset(args.preset, blades=args.blades, size=size)
    if args.occlusion != "default":
        scene.params.cull_occlusion = args.occlusion == "on"
    if args.compute_raster != "default":
        scene.params.compute_raster = args.compute_raster == "on"
    w, h = scene.size
    target = gfx.Texture(dim=2, size=(w, h, 1), format="rgba8unorm")
    renderer = make_renderer(target)  # the live view's renderer (pygfx's DDAA in a compute pass on a GPU)
    device = ensure_device()
    field = scene.field
    stats = field.stats

    def frame():
        field.step(1)
        scene.draw_into(renderer)
        if args.live_stats:
            stats.after_render()

    def sync():
        np.frombuffer(device.queue.read_buffer(_gpu(field.args_buffer)), np.uint32)

    for _ in range(10):  # warm-up: pipelines, buffers
        frame()
    sync()
    frames = args.frames
    t0, c0, m0 = time.perf_counter(), time.process_time(), time.thread_time()
    for _ in range(frames):
        frame()
    main_ms = 1e3 * (time.thread_time() - m0) / frames
    sync()
    wall_ms = 1e3 * (time.perf_counter() - t0) / frames
    cpu_ms = 1e3 * (time.process_time() - c0) / frames

    synced = []  # each frame followed by a GPU sync: the GPU's work shows here too
    for _ in range(max(10, frames // 4)):
        t = time.perf_counter()
        frame()
        sync()
        synced.append(1e3 * (time.perf_counter() - t))

    calls, nbytes = collections.Counter(), collections.Counter()
    undo = []

    def wrap(owner, name, label, size=None):
        original = getattr(owner, name, None)
        if original is None:
            return

        def counted(*a, **k):
            calls[label] += 1
            if size is not None:
                nbytes[label] += size(*a, **k)
            return original(*a, **k)

        setattr(owner, name, counted)
        undo.append((owner, name, original))

    wrap(renderer, "render", "renderer.render")
    wrap(renderer, "flush", "renderer.flush")
    for cls_name, names in COUNTED:
        cls = getattr(wgpu_native, cls_name)
        for name in names:
            wrap(cls, name, f"{cls_name}.{name}")
    wrap(wgpu_native.GPUQueue, "write_buffer", "GPUQueue.write_buffer",
         size=lambda self, buffer, offset, data, *a, **k: memoryview(data).nbytes)
    try:
        for _ in range(args.count_frames):
            frame()
        sync()
    finally:
        for owner, name, original in reversed(undo):
            setattr(owner, name, original)
    per_frame = {k: v / args.count_frames for k, v in sorted(calls.items())}
    per_frame["GPUQueue.read_buffer"] = max(0.0, per_frame.get("GPUQueue.read_buffer", 0.0) - 1.0 / args.count_frames)
    per_frame["wgpu calls counted (all of the above)"] = sum(
        v for k, v in per_frame.items() if not k.startswith("renderer."))
    per_frame["GPUQueue.write_buffer bytes"] = nbytes["GPUQueue.write_buffer"] / args.count_frames
    import grasswidget

    return dict(adapter=adapter_info().get("summary", ""), size=f"{w}x{h}", blades=field.count,
                grasswidget=os.path.dirname(os.path.abspath(grasswidget.__file__)),
                occlusion=bool(scene.params.cull_occlusion), compute_raster=bool(scene.params.compute_raster),
                main_thread_cpu_ms=main_ms, process_cpu_ms=cpu_ms, pipelined_ms=wall_ms,
                pipelined_fps=1e3 / wall_ms, synced_ms=statistics.median(synced), per_frame=per_frame)


def _gpu(buffer):
    from grasswidget import compat

    return compat.gpu_buffer(buffer)


# ------------------------------------------------------------------ parent


def _tree_env(tree):
    rest = os.environ.get("PYTHONPATH", "")
    return dict(os.environ, PYTHONPATH=tree + (os.pathsep + rest if rest else ""))


def _child_argv(args):
    out = ["--preset", args.preset, "--blades", str(args.blades), "--frames", str(args.frames),
           "--count-frames", str(args.count_frames), "--occlusion", args.occlusion,
           "--compute-raster", args.compute_raster]
    if args.size:
        out += ["--size", args.size]
    if args.live_stats:
        out.append("--live-stats")
    return out


def _run_child(tree, args):
    proc = subprocess.run([sys.executable, os.path.abspath(__file__), "--child", *_child_argv(args)],
                          cwd=tree, env=_tree_env(tree), capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        raise SystemExit(f"child in {tree} failed:\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


TIMES = ("main_thread_cpu_ms", "process_cpu_ms", "pipelined_ms", "pipelined_fps", "synced_ms")


def _summary(rows, labels):
    out = {}
    for key in TIMES:
        out[key] = {label: statistics.median(row[label][key] for row in rows) for label in labels}
        if "base" in labels:
            out[key]["ratio_new_base"] = statistics.median(row["new"][key] / row["base"][key] for row in rows)
    return out


def _print(report):
    labels = report["labels"]
    print(f"{report['adapter']}: {report['preset']} {report['blades']} blades {report['size']}, occlusion "
          f"{report['occlusion']}, compute raster {report['compute_raster']}, {report['rounds_run']} rounds (medians)")
    head = f"{'':34s}" + "".join(f"{label:>12s}" for label in labels) + ("   new/base" if "base" in labels else "")
    print(head)
    for key, row in report["summary"].items():
        line = f"{key:34s}" + "".join(f"{row[label]:12.3f}" for label in labels)
        if "ratio_new_base" in row:
            line += f"{row['ratio_new_base']:11.3f}"
        print(line)
    print("per frame (last round):")
    last = report["rounds"][-1]
    keys = sorted(set().union(*(last[label]["per_frame"] for label in labels)))
    for key in keys:
        print(f"  {key:40s}" + "".join(f"{last[label]['per_frame'].get(key, 0.0):12.2f}" for label in labels))


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--preset", default="meadow")
    p.add_argument("--blades", type=int, default=1 << 20)
    p.add_argument("--size", default=None, help="WxH (default: the preset's)")
    p.add_argument("--occlusion", choices=["default", "on", "off"], default="default")
    p.add_argument("--compute-raster", choices=["default", "on", "off"], default="default")
    p.add_argument("--live-stats", action="store_true", help="FrameStats.after_render every frame (the widget's view)")
    p.add_argument("--frames", type=int, default=200, help="pipelined frames per child (default 200)")
    p.add_argument("--count-frames", type=int, default=20, help="frames whose wgpu calls are counted (default 20)")
    p.add_argument("--rounds", type=int, default=3, help="rounds of (base, new) children (default 3)")
    p.add_argument("--base", default=None, help="git revision of the baseline (checked out in a temporary worktree)")
    p.add_argument("--base-tree", default=None, help="a directory holding the baseline's grasswidget package")
    p.add_argument("--json", default=None)
    p.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.child:
        print(json.dumps(_child(args)))
        return 0

    own_tree = args.base is not None and args.base_tree is None
    base_tree = None
    if own_tree:
        base_tree = tempfile.mkdtemp(prefix="frame-host-base-")
        subprocess.run(["git", "worktree", "add", "--detach", base_tree, args.base], cwd=REPO, check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    elif args.base_tree:
        base_tree = os.path.abspath(args.base_tree)
    try:
        trees = [("base", base_tree), ("new", REPO)] if base_tree else [("new", REPO)]
        rows = []
        for r in range(args.rounds):
            order = list(reversed(trees)) if r % 2 else list(trees)
            row = {"round": r}
            for label, tree in order:
                row[label] = _run_child(tree, args)
            rows.append(row)
            print(json.dumps({k: (v if k == "round" else {t: round(v[t], 3) for t in TIMES}) for k, v in row.items()}),
                  flush=True)
        labels = [label for label, _ in trees]
        first = rows[0]["new"]
        report = dict(what="the kernel engine's host work per frame (benchmarks/frame_host.py)",
                      adapter=first["adapter"], preset=args.preset, blades=first["blades"], size=first["size"],
                      occlusion=first["occlusion"], compute_raster=first["compute_raster"],
                      live_stats=args.live_stats, frames=args.frames, rounds_run=len(rows), labels=labels,
                      base=args.base or args.base_tree, head=_git(["rev-parse", "--short", "HEAD"]),
                      machine=dict(platform=platform.platform(), python=platform.python_version()),
                      date=time.strftime("%Y-%m-%d %H:%M:%S"), summary=_summary(rows, labels), rounds=rows,
                      note="medians over rounds; ratios new / base taken round by round, one run on one machine")
        _print(report)
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
