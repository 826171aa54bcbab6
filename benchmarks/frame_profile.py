"""Is the kernel engine's pipelined frame bound by the host or by the GPU, and where does each spend it?

    python benchmarks/frame_profile.py --preset meadow --blades 1048576 16777216   # GPU machine
    python benchmarks/frame_profile.py --blades 4096 --size 320x240 --frames 20                     # lavapipe

Per blade count, one GrassScene of ``--preset`` (its defaults: the "auto" switches, unless
``--occlusion`` / ``--compute-raster`` force them) rendered offscreen with the live view's renderer
(``make_renderer``, as ``grasswidget bench`` uses it; ``--ppaa`` other than auto: a plain pygfx
renderer with that post-process anti-aliasing instead), after ``--warmup`` GPU-synchronised frames (the "auto" trials settle there):

1. **pipelined**: ``field.step(1)`` + ``GrassScene.draw_into`` back to back for ``--frames``
   frames, one GPU sync at the end (the bench's "pipelined frames/s"): wall ms per frame and the
   main thread's CPU ms per frame (the host's work; waits in wgpu-native are not in it).
2. **GPU passes**: every compute and render pass of a frame timed with timestamp writes, and
   inside them every dispatch and draw (benchmarks/raster_profile.py's hooks: with
   ``timestamp-query-inside-passes``), over ``--gpu-frames`` GPU-synchronised frames: median ms
   per label; their sum is the GPU's busy time of a frame.
3. **GPU period while pipelined**: the same frames back to back with the pass timestamps on:
   the time between the ends of consecutive frames' last passes on the GPU, against its busy
   time; a period well above the busy time means the GPU waited for the host.
4. **host profile** (``--cprofile``): cProfile over ``--frames`` pipelined frames, the
   functions with the most own time and cumulative time. ``--host-only``: 1 (and 4 with
   ``--cprofile``) alone, with no timestamp hooks installed (their wrappers would be in the profile).

Writes benchmarks/results/frame_profile-<machine>-<date>.json (or ``--out``) and prints tables. Imports no notebook or browser package.
"""

from __future__ import annotations

import argparse
import cProfile
import collections
import io
import os
import pstats
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402  (benchmarks/common.py)
from raster_profile import Stamps, install_draw_hooks, install_pass_hooks  # noqa: E402


def _frame_fn(scene):
    field = scene.field

    def frame(renderer):
        field.step(1)
        scene.draw_into(renderer)

    return frame


def _pipelined(frame, renderer, sync, frames):
    return common.time_pipelined(lambda: frame(renderer), frames, sync)


def _split_frames(raw, frames):
    """The raw pass stamps of ``frames`` frames, split where each frame's first pass (simulation) began."""
    starts = [i for i, (label, _, _) in enumerate(raw) if label.startswith("compute pass") and "simulation" in label]
    if len(starts) != frames:
        return None
    return [raw[a:b] for a, b in zip(starts, starts[1:] + [len(raw)])]


def _host_profile(frame, renderer, sync, frames, top):
    prof = cProfile.Profile()
    sync()
    prof.enable()
    for _ in range(frames):
        frame(renderer)
    prof.disable()
    sync()
    out = {}
    for key in ("tottime", "cumulative"):
        s = io.StringIO()
        pstats.Stats(prof, stream=s).sort_stats(key).print_stats(top)
        out[key] = s.getvalue()
    return out


def run(args):
    import pygfx as gfx

    from grasswidget import compat
    from grasswidget.gpu.adapter import adapter_info, ensure_device
    from grasswidget.gpu.trial_timing import switch_texts
    from grasswidget.gpu.scene import GrassScene, make_renderer, parse_size

    device = ensure_device()
    stamps = Stamps(device, count=4096)
    stamps.enabled = False
    if not args.host_only:
        install_draw_hooks(stamps, {"skip": set()})
        install_pass_hooks(stamps)
    ppaa = args.ppaa
    report = dict(what="benchmarks/frame_profile.py", preset=args.preset, ppaa=ppaa, rows=[])
    for n in args.blades:
        size = parse_size(args.size) if args.size else None
        scene = GrassScene.preset(args.preset, blades=n, size=size)
        if args.occlusion != "default":
            scene.params.cull_occlusion = args.occlusion == "on"
        if args.compute_raster != "default":
            scene.params.compute_raster = args.compute_raster == "on"
        w, h = scene.size
        target = gfx.Texture(dim=2, size=(w, h, 1), format="rgba8unorm-srgb", colorspace="tex-srgb")
        if args.ppaa == "auto":
            renderer = make_renderer(target)
        else:
            renderer = gfx.WgpuRenderer(target, pixel_ratio=1, ppaa=ppaa, enable_events=False)
        field = scene.field
        frame = _frame_fn(scene)

        def sync():
            device.queue.read_buffer(compat.gpu_buffer(field.args_buffer))

        for _ in range(args.warmup):
            frame(renderer)
            sync()
        row = dict(blades=n, size=f"{w}x{h}", switches=switch_texts(field),
                   effect_passes=[f"{type(p).__module__}.{type(p).__name__}" for p in renderer.effect_passes])
        row["pipelined"] = _pipelined(frame, renderer, sync, args.frames)

        if args.host_only:
            if args.cprofile:
                row["host_profile"] = _host_profile(frame, renderer, sync, args.frames, args.top)
            report["rows"].append(row)
            _print_row(row)
            continue
        stamps.enabled = True
        stamps.collect_raw()
        per_label = collections.defaultdict(list)
        busy = []
        for _ in range(args.gpu_frames):
            frame(renderer)
            sync()
            raw = stamps.collect_raw()
            sums = collections.defaultdict(float)
            for label, begin, end in raw:
                sums[label] += (end - begin) / 1e6
            for label, ms in sums.items():
                per_label[label].append(ms)
            busy.append(sum(ms for label, ms in sums.items() if " pass " in label))
        row["gpu_ms"] = {label: statistics.median(v) for label, v in per_label.items()}
        row["gpu_busy_ms"] = statistics.median(busy)

        k = min(args.frames, 4096 // (2 * max(1, len(per_label) + 8)))
        sync()
        stamps.collect_raw()
        for _ in range(k):
            frame(renderer)
        sync()
        raw = [r for r in stamps.collect_raw() if " pass " in r[0]]
        stamps.enabled = False
        split = _split_frames(raw, k)
        if split:
            ends = [max(e for _, _, e in f) for f in split]
            periods = [(b - a) / 1e6 for a, b in zip(ends, ends[1:])]
            busies = [sum((e - b) / 1e6 for _, b, e in f) for f in split]
            row["gpu_pipelined"] = dict(frames=k, period_ms=statistics.median(periods),
                                        busy_ms=statistics.median(busies),
                                        idle_share=1 - statistics.median(busies) / statistics.median(periods))
        if args.cprofile:
            row["host_profile"] = _host_profile(frame, renderer, sync, args.frames, args.top)
        report["rows"].append(row)
        _print_row(row)
        del scene, renderer, frame
    common.save("frame_profile", report, adapter_info(), args.out)
    return report


def _print_row(row):
    p = row["pipelined"]
    print(f"\n== {row['blades']} blades {row['size']}; switches: {row['switches']}; effect passes "
          f"{row['effect_passes']}")
    print(f"pipelined: {p['wall_ms']:.3f} ms/frame ({p['fps']:.1f} frames/s), main thread CPU "
          f"{p['main_thread_cpu_ms']:.3f} ms/frame")
    if "gpu_pipelined" in row:
        g = row["gpu_pipelined"]
        print(f"GPU while pipelined: period {g['period_ms']:.3f} ms, busy {g['busy_ms']:.3f} ms "
              f"(idle {100 * g['idle_share']:.0f} %) over {g['frames']} frames")
    if "gpu_busy_ms" in row:
        print(f"GPU busy per synced frame (sum of passes): {row['gpu_busy_ms']:.3f} ms")
        for label, ms in sorted(row["gpu_ms"].items(), key=lambda kv: -kv[1]):
            print(f"  {ms:8.3f}  {label}")
    if "host_profile" in row:
        print(row["host_profile"]["tottime"])
        print(row["host_profile"]["cumulative"])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--preset", default="meadow")
    ap.add_argument("--blades", type=int, nargs="+", default=[1 << 20])
    ap.add_argument("--size", default=None, help="WxH (default: the preset's)")
    ap.add_argument("--ppaa", default="auto", choices=["auto", "default", "none", "fxaa", "ddaa"],
                    help="the renderer's post-process anti-aliasing (auto: as the bench and the live view)")
    ap.add_argument("--occlusion", choices=["default", "on", "off"], default="default")
    ap.add_argument("--compute-raster", choices=["default", "on", "off"], default="default")
    ap.add_argument("--warmup", type=int, default=60, help="GPU-synchronised frames first (default 60)")
    ap.add_argument("--frames", type=int, default=200, help="pipelined frames (default 200)")
    ap.add_argument("--gpu-frames", type=int, default=20, help="synced frames with every pass timed (default 20)")
    ap.add_argument("--cprofile", action="store_true", help="profile the host over --frames pipelined frames")
    ap.add_argument("--host-only", action="store_true",
                    help="no GPU timestamps (no hooks installed): pipelined frames and the host profile only")
    ap.add_argument("--top", type=int, default=30, help="functions listed by the host profile (default 30)")
    common.add_out_argument(ap, "frame_profile")
    run(ap.parse_args(argv))
    return 0


if __name__ == "__main__":
    sys.exit(main())
