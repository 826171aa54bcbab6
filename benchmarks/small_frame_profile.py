"""Where a small culled frame's time goes on a CPU adapter (issue 28 item 4): the cis565 view.

``python benchmarks/small_frame_profile.py [--preset cis565|default] [--blades 8192] [--frames 12] [--cull on|off]
[--occlusion on|off|auto] [--out PATH]`` (default benchmarks/results/small_frame_profile-<machine>-<date>.json)

``--preset default``: the default widget's view (``Blades.on_plane``, 640x480; ``--blades 4096`` is its
count). ``--cull off``: no culling test, no LOD. ``--occlusion`` (culled frames): ``on`` (the default,
as ``grasswidget bench`` sets it), ``off`` or ``auto`` (the widget's default: decided by measuring).
The target is an rgba8unorm-srgb texture, the live view's canvas format.

The frame is ``grasswidget bench``'s: ``field.step(1)``, a readback, ``scene.draw_into(renderer)``
(occlusion culling's two phases), a readback; culling on (every test, occlusion forced on), the
compute rasterizer off; cis565 preset at 640x480 with the live view's renderer (``make_renderer``).

1. GPU timestamps of every compute and render pass (``raster_profile.install_pass_hooks``) and of
   every dispatch / draw inside them (``install_draw_hooks``): median ms per frame per label. On
   lavapipe a render pass's draws are binned and rasterized at the pass end: its ``render pass``
   figure is what counts.
2. Wall and process CPU ms per frame, and per part (step + readback, render + readback), with
   knock-outs (a shader class's dispatches / draws skipped), interleaved frame by frame, medians;
   the stamps are off while these are timed.
3. The host side: cProfile of ``--frames`` frames, the functions with the most own time and the
   cumulative time of the frame's main calls.
"""

from __future__ import annotations

import argparse
import collections
import cProfile
import os
import pstats
import statistics
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import common  # noqa: E402  (benchmarks/common.py)
import raster_profile as rp  # noqa: E402

KNOCKOUTS = {
    "full frame": set(),
    "no blade draws": {"BladeRenderShader"},
    "no pyramid": {"HzbLevelShader"},
    "no cull": {"CullShader"},
    "no sky/ground": {"SkyGroundShader"},
}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--preset", choices=("cis565", "default"), default="cis565")
    ap.add_argument("--blades", type=int, default=8192)
    ap.add_argument("--cull", choices=("on", "off"), default="on")
    ap.add_argument("--occlusion", choices=("on", "off", "auto"), default="on")
    ap.add_argument("--frames", type=int, default=12)
    common.add_out_argument(ap, "small_frame_profile")
    a = ap.parse_args(argv)

    import numpy as np
    import pygfx as gfx

    from grasswidget import compat
    from grasswidget.gpu.adapter import adapter_info, ensure_device
    from grasswidget.gpu.scene import make_renderer
    from pygfx.renderers.wgpu import get_shared

    ensure_device()
    device = get_shared().device
    stamps = rp.Stamps(device, count=1024)
    knockout = {"skip": set()}
    rp.install_draw_hooks(stamps, knockout)
    rp.install_pass_hooks(stamps)

    scene = common.preset_scene(a.preset, a.blades, (640, 480))
    common.set_culling(scene.params, a.cull, occlusion=a.occlusion == "on", compute_raster=False)
    if a.cull == "on" and a.occlusion == "auto":
        scene.params.cull_occlusion = "auto"
    w, h = scene.size
    renderer = make_renderer(gfx.Texture(dim=2, size=(w, h, 1), format="rgba8unorm-srgb", colorspace="tex-srgb"))
    field = scene.field

    def sync():
        return np.frombuffer(device.queue.read_buffer(compat.gpu_buffer(field.args_buffer)), np.uint32)

    def frame():
        t0, c0 = time.perf_counter(), time.process_time()
        field.step(1)
        sync()
        t1, c1 = time.perf_counter(), time.process_time()
        scene.draw_into(renderer)
        sync()
        t2, c2 = time.perf_counter(), time.process_time()
        return dict(wall=1e3 * (t2 - t0), cpu=1e3 * (c2 - c0), step_wall=1e3 * (t1 - t0), step_cpu=1e3 * (c1 - c0),
                    render_wall=1e3 * (t2 - t1), render_cpu=1e3 * (c2 - c1))

    field.step(1)
    scene.draw_into(renderer)  # the buffers on the GPU
    for skip in KNOCKOUTS.values():  # warm-up: every pipeline compiled
        knockout["skip"] = skip
        for _ in range(3):
            frame()
    knockout["skip"] = set()
    stamps.collect()
    # 1. GPU passes
    gpu = collections.defaultdict(list)
    for _ in range(a.frames):
        frame()
        per = collections.defaultdict(float)
        for label, begin, end in stamps.collect_raw():
            per[label] += (end - begin) / 1e6
        for label, ms in per.items():
            gpu[label].append(ms)
    gpu_ms = {k: statistics.median(v) for k, v in gpu.items()}
    # 2. wall / CPU with knock-outs, stamps off
    stamps.enabled = False
    times = {m: collections.defaultdict(list) for m in KNOCKOUTS}
    for _ in range(a.frames):
        for mode, skip in KNOCKOUTS.items():
            knockout["skip"] = skip
            frame()  # settle
            for k, v in frame().items():
                times[mode][k].append(v)
    knockout["skip"] = set()
    timing = {m: {k: statistics.median(v) for k, v in d.items()} for m, d in times.items()}
    # 3. host profile
    prof = cProfile.Profile()
    prof.enable()
    for _ in range(a.frames):
        frame()
    prof.disable()
    st = pstats.Stats(prof)
    rows = []
    for (file, line, fn), (cc, nc, tt, ct, callers) in st.stats.items():
        rows.append(dict(function=f"{os.path.basename(file)}:{line}:{fn}", calls=nc / a.frames,
                         own_ms=1e3 * tt / a.frames, cum_ms=1e3 * ct / a.frames))
    by_own = sorted(rows, key=lambda r: -r["own_ms"])[:30]
    by_cum = sorted(rows, key=lambda r: -r["cum_ms"])[:45]
    drawn = int(field.read_draw_args()[:, 1].sum())
    report = dict(preset=a.preset, cull=a.cull, occlusion=a.occlusion, blades=a.blades, size=f"{w}x{h}", drawn=drawn, frames=a.frames, gpu_ms=gpu_ms, timing=timing,
                  host_own=by_own, host_cum=by_cum)
    culled = f"culled (occlusion {a.occlusion}," if a.cull == "on" else "unculled ("
    print(f"{a.preset} {a.blades} blades {culled} compute raster off), {w}x{h}; drawn {drawn}; "
          f"load {os.getloadavg()[0]:.1f}")
    print("\nGPU ms per frame (median):")
    for label, ms in sorted(gpu_ms.items(), key=lambda kv: -kv[1]):
        print(f"  {ms:8.3f}  {label}")
    print("\nms per frame (median):  " + "  ".join(f"{k:>11s}" for k in next(iter(timing.values()))))
    for mode, d in timing.items():
        print(f"  {mode:20s} " + "  ".join(f"{v:11.2f}" for v in d.values()))
    print("\nhost, own ms per frame:")
    for r in by_own[:25]:
        print(f"  {r['own_ms']:7.3f} {r['calls']:7.1f}x  {r['function']}")
    print("\nhost, cumulative ms per frame:")
    for r in by_cum:
        print(f"  {r['cum_ms']:7.3f} {r['calls']:7.1f}x  {r['function']}")
    common.save("small_frame_profile", report, adapter_info(), a.out)


if __name__ == "__main__":
    main()
