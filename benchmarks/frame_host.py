"""The kernel engine's host work per frame: this tree against a baseline tree, in one run.

    python benchmarks/frame_host.py --blades 1048576 [--out PATH]
    python benchmarks/frame_host.py --blades 256 --size 64x36 --rounds 6          # lavapipe: GPU work tiny

Each round runs one child process per tree, in turns (base, new, new, base, ...: common.run_ab), so that a
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

Prints a table and writes benchmarks/results/frame_host-<machine>-<date>.json (or ``--out``). Imports no browser or notebook package: it runs
on a headless GPU machine.
"""

from __future__ import annotations

import argparse
import collections
import os
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402  (benchmarks/common.py)

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
    timed = common.time_pipelined(frame, args.frames, sync)

    def synced_frame():  # each frame followed by a GPU sync: the GPU's work shows here too
        frame()
        sync()

    synced = common.time_frames(synced_frame, max(10, args.frames // 4), warmup=0)["wall_ms"]

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
                main_thread_cpu_ms=timed["main_thread_cpu_ms"], process_cpu_ms=timed["cpu_ms"],
                pipelined_ms=timed["wall_ms"], pipelined_fps=timed["fps"], synced_ms=common.median(synced),
                per_frame=per_frame)


def _gpu(buffer):
    from grasswidget import compat

    return compat.gpu_buffer(buffer)


# ------------------------------------------------------------------ parent


def _child_argv(args):
    out = ["--preset", args.preset, "--blades", str(args.blades), "--frames", str(args.frames),
           "--count-frames", str(args.count_frames), "--occlusion", args.occlusion,
           "--compute-raster", args.compute_raster]
    if args.size:
        out += ["--size", args.size]
    if args.live_stats:
        out.append("--live-stats")
    return out


TIMES = ("main_thread_cpu_ms", "process_cpu_ms", "pipelined_ms", "pipelined_fps", "synced_ms")


def _summary(rows, labels):
    out = {}
    for key in TIMES:
        out[key] = {label: common.median(row[label][key] for row in rows) for label in labels}
        if "base" in labels:
            out[key]["ratio_new_base"] = common.median(row["new"][key] / row["base"][key] for row in rows)
    return out


def _print(report, adapter):
    labels = report["labels"]
    print(f"{adapter}: {report['preset']} {report['blades']} blades {report['size']}, occlusion "
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
    common.add_out_argument(p, "frame_host")
    p.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.child:
        common.emit(_child(args))
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

        def measure(_name, tree, _case):
            return common.run_in_tree(tree, [os.path.abspath(__file__), "--child", *_child_argv(args)])

        rows = common.run_ab(trees, [args.preset], args.rounds, measure)
        labels = [label for label, _ in trees]
        first = rows[0]["new"]
        report = dict(what="the kernel engine's host work per frame (benchmarks/frame_host.py)",
                      preset=args.preset, blades=first["blades"], size=first["size"],
                      occlusion=first["occlusion"], compute_raster=first["compute_raster"],
                      live_stats=args.live_stats, frames=args.frames, rounds_run=len(rows), labels=labels,
                      base=args.base or args.base_tree, summary=_summary(rows, labels), rounds=rows,
                      note="medians over rounds; ratios new / base taken round by round, one run on one machine")
        _print(report, first["adapter"])
        common.save("frame_host", report, first["adapter"], args.out)
    finally:
        if own_tree:
            subprocess.run(["git", "worktree", "remove", "--force", base_tree], cwd=REPO, check=False,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return 0


if __name__ == "__main__":
    sys.exit(main())
