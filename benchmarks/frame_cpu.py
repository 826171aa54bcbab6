"""Where a frame's CPU time goes, and what compute_raster_max_px does to the look.

``python benchmarks/frame_cpu.py --blades 1048576 [--out PATH] [--png-dir DIR]``

1. CPU breakdown (kernel engine, meadow preset, its own size unless ``--size``): frames
   submitted back to back as in ``grasswidget bench``'s pipelined figure (one
   ``field.step(1)`` + ``GrassScene.draw_into`` each, one sync at the end), once with the
   compute rasterizer off and once on. Wall milliseconds per frame of each part
   (``field.step``, ``renderer.render`` calls, the occlusion culling's second phase,
   ``renderer.flush``, ``queue.submit`` inside them) and the process's CPU ms per frame,
   then a cProfile of the same loop (top functions by own time).
2. Look per ``compute_raster_max_px`` (``--raster-max-px``): the picture with the compute
   rasterizer against the one without, same state and camera: mean |difference| of
   4 x 4-pixel block means (0..255, tests/gpu/test_compute_raster.py's measure), the
   share of grass pixels on and off, and the blades each path drew.

Prints a summary and writes benchmarks/results/frame_cpu-<machine>-<date>.json (or ``--out``; and PNGs of the pictures with ``--png-dir``). Imports no
browser or notebook package: it runs on a headless GPU machine.
"""

from __future__ import annotations

import argparse
import collections
import cProfile
import io
import os
import pstats
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402  (benchmarks/common.py)


def _mean_difference(a, b, block=4):
    h, w = a.shape[0] // block * block, a.shape[1] // block * block

    def blocks(x):
        return x[:h, :w, :3].astype(float).reshape(h // block, block, w // block, block, 3).mean(axis=(1, 3))

    return float(np.abs(blocks(a) - blocks(b)).mean())


def _grass_share(img):
    rgb = img[..., :3].astype(np.int32)
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    return float(((g > r + 8) & (g > b + 8)).mean())


class _Parts:
    """Wall-time counters around methods (restored by :meth:`restore`)."""

    def __init__(self):
        self.ms = collections.defaultdict(float)
        self.calls = collections.Counter()
        self._undo = []

    def wrap(self, owner, name, label, after=None):
        """Time ``owner.name``; ``after`` (e.g. a GPU sync) runs inside the timing."""
        original = getattr(owner, name)

        def timed(*args, **kwargs):
            t = time.perf_counter()
            try:
                return original(*args, **kwargs)
            finally:
                if after is not None:
                    after()
                self.ms[label] += 1e3 * (time.perf_counter() - t)
                self.calls[label] += 1

        setattr(owner, name, timed)
        self._undo.append((owner, name, original, name in vars(owner)))

    def restore(self):
        for owner, name, original, own in reversed(self._undo):
            if isinstance(owner, type) or own:
                setattr(owner, name, original)
            else:
                delattr(owner, name)


def cpu_breakdown(scene, renderer, frames, profile_top=25):
    from grasswidget import compat
    from grasswidget.gpu import occlusion

    field = scene.field
    device = field.stats.device

    def sync():
        device.queue.read_buffer(compat.gpu_buffer(field.args_buffer))

    for _ in range(5):
        field.step(1)
        scene.draw_into(renderer)
    sync()
    parts = _Parts()
    parts.wrap(renderer, "render", "renderer.render")
    parts.wrap(renderer, "flush", "renderer.flush")
    parts.wrap(occlusion.OcclusionCulling, "second_phase", "occlusion second phase")
    parts.wrap(type(field), "step", "field.step")
    parts.wrap(device.queue, "submit", "queue.submit (inside the others)")
    def frame():
        field.step(1)
        scene.draw_into(renderer)

    try:
        timed = common.time_pipelined(frame, frames, sync)
        wall, cpu = timed["wall_ms"], timed["cpu_ms"]
    finally:
        parts.restore()
    out = dict(pipelined_ms=wall, pipelined_fps=1e3 / wall, process_cpu_ms=cpu,
               parts_ms={k: v / frames for k, v in parts.ms.items()},
               calls_per_frame={k: v / frames for k, v in parts.calls.items()})
    prof = cProfile.Profile()
    prof.enable()
    for _ in range(frames):
        field.step(1)
        scene.draw_into(renderer)
    sync()
    prof.disable()
    text = io.StringIO()
    pstats.Stats(prof, stream=text).sort_stats("tottime").print_stats(profile_top)
    out["profile_tottime"] = text.getvalue().splitlines()
    text = io.StringIO()
    pstats.Stats(prof, stream=text).sort_stats("cumulative").print_stats("pygfx|grasswidget", 2 * profile_top)
    out["profile_cumulative"] = text.getvalue().splitlines()
    # The same parts, each followed by a GPU sync: CPU + GPU of each in turn (serialised).
    synced = _Parts()
    synced.wrap(renderer, "render", "renderer.render + sync", after=sync)
    synced.wrap(renderer, "flush", "renderer.flush + sync", after=sync)
    synced.wrap(occlusion.OcclusionCulling, "second_phase", "occlusion second phase + sync", after=sync)
    synced.wrap(type(field), "step", "field.step + sync", after=sync)
    try:
        t0 = time.perf_counter()
        for _ in range(frames):
            field.step(1)
            scene.draw_into(renderer)
        out["synced_frame_ms"] = 1e3 * (time.perf_counter() - t0) / frames
    finally:
        synced.restore()
    out["synced_parts_ms"] = {k: v / frames for k, v in synced.ms.items()}
    return out


def look(scene, px_values, png_dir=None):
    p = scene.params
    p.compute_raster = False
    off = scene.render()
    hardware_off = scene.drawn_counts()["hardware"]
    rows = []
    if png_dir:
        import imageio.v3 as iio

        iio.imwrite(os.path.join(png_dir, "look_off.png"), off, extension=".png")
    for px in px_values:
        p.compute_raster = True
        p.compute_raster_max_px = px
        on = scene.render()
        counts = scene.drawn_counts()
        rows.append(dict(compute_raster_max_px=px, mean_block_difference=_mean_difference(on, off),
                         grass_share_on=_grass_share(on), grass_share_off=_grass_share(off),
                         drawn_hardware=counts["hardware"], drawn_compute=counts["compute"],
                         drawn_hardware_off=hardware_off))
        if png_dir:
            import imageio.v3 as iio

            iio.imwrite(os.path.join(png_dir, f"look_on_{px:g}px.png"), on, extension=".png")
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--blades", type=int, default=1 << 20)
    ap.add_argument("--cpu-raster-max-px", type=float, default=None,
                    help="compute_raster_max_px of the CPU part (default: the params' default)")
    ap.add_argument("--frames", type=int, default=60)
    ap.add_argument("--size", default=None, help="WxH (default: the meadow preset's 1920x1080)")
    ap.add_argument("--raster-max-px", type=float, nargs="*", default=[2.0, 3.0, 4.0, 6.0, 8.0])
    ap.add_argument("--steps", type=int, default=60, help="simulation steps before the pictures")
    ap.add_argument("--png-dir", default=None)
    common.add_out_argument(ap, "frame_cpu")
    ap.add_argument("--profile", action="store_true", help="print the cProfile tables too (always in the JSON)")
    ap.add_argument("--only-cpu", action="store_true", help="skip the look part")
    args = ap.parse_args(argv)

    import pygfx as gfx

    from grasswidget.gpu.adapter import adapter_info
    from grasswidget.gpu.scene import GrassScene, make_renderer, parse_size

    size = parse_size(args.size) if args.size else None
    scene = GrassScene.preset("meadow", blades=args.blades, size=size)
    w, h = scene.size
    target = gfx.Texture(dim=2, size=(w, h, 1), format="rgba8unorm-srgb", colorspace="tex-srgb")
    renderer = make_renderer(target)  # the live view's renderer (pygfx's DDAA in a compute pass on a GPU)
    adapter = adapter_info()
    report = dict(blades=args.blades, size=f"{w}x{h}", frames=args.frames, cpu={})
    if args.cpu_raster_max_px is not None:
        scene.params.compute_raster_max_px = args.cpu_raster_max_px
    report["cpu_raster_max_px"] = scene.params.compute_raster_max_px
    for raster in (False, True):
        scene.params.compute_raster = raster
        report["cpu"]["on" if raster else "off"] = cpu_breakdown(scene, renderer, args.frames)
    report["look"] = []
    if not args.only_cpu:
        scene.step(args.steps)
        if args.png_dir:
            os.makedirs(args.png_dir, exist_ok=True)
        report["look"] = look(scene, args.raster_max_px, args.png_dir)

    print(f"{adapter.get('summary', '')}: meadow {args.blades} blades {w}x{h}")
    for key, row in report["cpu"].items():
        print(f"compute raster {key}: {row['pipelined_fps']:.1f} fps pipelined, {row['pipelined_ms']:.2f} ms/frame, "
              f"process CPU {row['process_cpu_ms']:.2f} ms/frame")
        for part, ms in sorted(row["parts_ms"].items(), key=lambda kv: -kv[1]):
            print(f"    {part:36s} {ms:7.3f} ms  x{row['calls_per_frame'][part]:.1f}")
        print(f"  each part + GPU sync: {row['synced_frame_ms']:.2f} ms/frame")
        for part, ms in sorted(row["synced_parts_ms"].items(), key=lambda kv: -kv[1]):
            print(f"    {part:36s} {ms:7.3f} ms")
        if args.profile:
            print("\n".join(row["profile_tottime"][:40]))
            print("\n".join(row["profile_cumulative"][:70]))
    print(f"{'max px':>6} {'block diff':>10} {'grass on':>8} {'grass off':>9} {'hardware':>9} {'compute':>8}")
    for r in report["look"]:
        print(f"{r['compute_raster_max_px']:6g} {r['mean_block_difference']:10.3f} {r['grass_share_on']:8.4f} "
              f"{r['grass_share_off']:9.4f} {r['drawn_hardware']:9d} {r['drawn_compute']:8d}")
    common.save("frame_cpu", report, adapter, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
