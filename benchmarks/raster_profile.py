"""Where the compute rasterizer's time goes (issue 28 item 2): every GPU pass of a frame timed.

``python benchmarks/raster_profile.py [--frames 6] [--out PATH]``

For each view (the default view: cis565 preset, 2^16 blades, 640x480; the meadow: 2^18 blades,
1280x720; occlusion culling on, as GrassParams' default), with the compute rasterizer on and off:

1. GPU timestamps around every dispatch and every draw of a frame (the pygfx compute and render
   pipeline containers and grasswidget's ComputeProgram wrapped for this script only, needs
   ``timestamp-query-inside-passes``): milliseconds per pass, median over ``--frames`` frames,
   keyed by shader class (and step / LOD class / phase). On lavapipe a compute dispatch runs to
   its end before the next starts, so a dispatch's pair of timestamps is its cost; a render
   pass's draws are binned and rasterized when the pass ends, so the per-draw figures of a
   render pass are only where the binning happened: its ``render pass`` total (first draw's
   begin to the last's end plus the pass end, taken by the next timestamp) is the figure.
2. Wall and process CPU milliseconds per frame (step excluded; render + one GPU sync): on, off,
   and on with the resolve draws, the walks or the clear skipped, and off with the ribbons skipped
   (knock-outs: what each costs; the last one is the frame's floor, what neither path draws),
   interleaved frame by frame, medians.
3. What the walks did: blades listed, pixels covered (depth words read back).

Writes benchmarks/results/raster_profile-<machine>-<date>.json (or ``--out``) and prints a table. CPU adapters only make sense here (the issue is lavapipe's).
"""

from __future__ import annotations

import argparse
import collections
import os
import statistics
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402  (benchmarks/common.py)

VIEWS = {
    "default 2^16 640x480": ("cis565", 1 << 16, (640, 480)),
    "meadow 2^18 1280x720": ("meadow", 1 << 18, (1280, 720)),
}


class Stamps:
    """A timestamp query set written around every dispatch / draw; labels in order."""

    def __init__(self, device, count=512):
        import wgpu

        self.device = device
        self.count = count
        self.qs = device.create_query_set(type="timestamp", count=count)
        self.buf = device.create_buffer(size=8 * count, usage=wgpu.BufferUsage.QUERY_RESOLVE | wgpu.BufferUsage.COPY_SRC)
        self.labels = []  # (label, index of begin) per wrapped call
        self.used = 0
        self.enabled = True  # False: write nothing (frames timed without the stamps' own cost)

    def write(self, pass_, label):
        from grasswidget import compat

        if not self.enabled or self.used + 2 > self.count:
            return None
        i = self.used
        self.used += 2
        compat.write_timestamp(pass_, self.qs, i)
        self.labels.append((label, i))
        return i + 1

    def end(self, pass_, index):
        from grasswidget import compat

        if index is not None:
            compat.write_timestamp(pass_, self.qs, index)

    def pass_writes(self, label):
        """``timestamp_writes`` for a whole pass (begin and end), or None when full or disabled."""
        if not self.enabled or self.used + 2 > self.count:
            return None
        i = self.used
        self.used += 2
        self.labels.append((label, i))
        return {"query_set": self.qs, "beginning_of_pass_write_index": i, "end_of_pass_write_index": i + 1}

    def collect_raw(self):
        """[(label, begin ns, end ns), ...] in the order written since the last collect."""
        out = []
        if self.used:
            enc = self.device.create_command_encoder()
            enc.resolve_query_set(self.qs, 0, self.used, self.buf, 0)
            self.device.queue.submit([enc.finish()])
            ts = np.frombuffer(self.device.queue.read_buffer(self.buf, 0, 8 * self.used), np.uint64).astype(np.int64)
            out = [(label, int(ts[i]), int(ts[i + 1])) for label, i in self.labels]
        self.labels, self.used = [], 0
        return out

    def collect(self):
        """{label: [ms, ...]} of the calls since the last collect."""
        out = collections.defaultdict(list)
        for label, begin, end in self.collect_raw():
            out[label].append((end - begin) / 1e6)
        return out


def _caller_label(skip_files=("raster_profile.py",), depth=2):
    """'module.function' of the nearest caller outside this script and wgpu (names a pass), from the
    frame ``depth`` levels up (3: past a pass-begin hook and grasswidget.compat's wrapper)."""
    frame = sys._getframe(depth)
    while frame is not None:
        path = frame.f_code.co_filename
        in_wgpu = f"{os.sep}wgpu{os.sep}" in path and "pygfx" not in path
        if not any(path.endswith(s) for s in skip_files) and not in_wgpu:
            module = os.path.splitext(os.path.basename(path))[0]
            owner = frame.f_locals.get("self")
            owner = f"{type(owner).__name__}." if owner is not None else ""
            return f"{module}:{owner}{frame.f_code.co_name}"
        frame = frame.f_back
    return "?"


def install_pass_hooks(stamps):
    """Time every compute and render pass begun from now on (``grasswidget.compat.add_pass_begin_hook``;
    a pass's own timestamp_writes, e.g. FrameStats', are replaced by the stamps').
    Labels: 'render pass <caller>' / 'compute pass <caller>'."""
    from grasswidget import compat

    if not hasattr(compat, "add_pass_begin_hook"):
        raise SystemExit("this grasswidget has no compat.add_pass_begin_hook (a tree from before 2026-11-29): "
                         "profile it with the benchmarks of its own commit")

    def hook(kind, kwargs):
        writes = stamps.pass_writes(f"{kind} pass {_caller_label(depth=3)}")
        if writes is not None:
            kwargs["timestamp_writes"] = writes

    return compat.add_pass_begin_hook(hook)


def _label(shader):
    name = type(shader).__name__
    for key in ("step", "lod_class", "phase", "second", "from_end", "occlusion", "level"):
        try:
            value = shader[key]
        except Exception:
            continue
        name += f" {key}={value}"
    return name


def install_draw_hooks(stamps, knockout):
    """Wrap the pipeline containers' dispatch/draw and ComputeProgram.dispatch (this process only)."""
    from pygfx.renderers.wgpu.engine import pipeline

    from grasswidget.gpu import compute, indirect
    from grasswidget.gpu.indirect import IndirectRenderPipelineContainer

    indirect.install()
    original_dispatch = pipeline.ComputePipelineContainer.dispatch  # the indirect subclass where installed
    original_draw = IndirectRenderPipelineContainer.draw
    original_program_init = compute.ComputeProgram.__init__
    original_program_dispatch = compute.ComputeProgram.dispatch
    original_program_indirect = getattr(compute.ComputeProgram, "dispatch_indirect", None)

    def dispatch(self, compute_pass):
        label = _label(self.shader)
        if any(label.startswith(skip) for skip in knockout["skip"]):
            return
        k = stamps.write(compute_pass, label)
        original_dispatch(self, compute_pass)
        stamps.end(compute_pass, k)

    def draw(self, render_pass, renderstate):
        label = _label(self.shader)
        if label.split()[0] in knockout["skip"]:
            return
        k = stamps.write(render_pass, label)
        original_draw(self, render_pass, renderstate)
        stamps.end(render_pass, k)

    def program_init(self, shader, wobject):
        original_program_init(self, shader, wobject)
        self.profile_label = _label(shader) + " (outside render)"

    def program_dispatch(self, compute_pass, workgroups):
        k = stamps.write(compute_pass, getattr(self, "profile_label", "ComputeProgram"))
        original_program_dispatch(self, compute_pass, workgroups)
        stamps.end(compute_pass, k)

    def program_indirect(self, compute_pass, buffer, offset=0):
        if any(self.profile_label.startswith(skip) for skip in knockout["skip"]):
            return
        k = stamps.write(compute_pass, getattr(self, "profile_label", "ComputeProgram"))
        original_program_indirect(self, compute_pass, buffer, offset)
        stamps.end(compute_pass, k)

    if original_program_indirect is not None:
        compute.ComputeProgram.dispatch_indirect = program_indirect
    pipeline.ComputePipelineContainer.dispatch = dispatch
    IndirectRenderPipelineContainer.draw = draw
    compute.ComputeProgram.__init__ = program_init
    compute.ComputeProgram.dispatch = program_dispatch


def run(frames, views, out_path, raster_max_px=None):
    import pygfx as gfx

    from grasswidget import compat
    from grasswidget.gpu.adapter import adapter_info, ensure_device
    from grasswidget.gpu.scene import GrassScene

    from pygfx.renderers.wgpu import get_shared

    ensure_device()

    device = get_shared().device
    stamps = Stamps(device)
    knockout = {"skip": set()}
    install_draw_hooks(stamps, knockout)
    report = dict(frames=frames, views={})
    for view, (preset, n, size) in VIEWS.items():
        if views and not any(v in view for v in views):
            continue
        scene = GrassScene.preset(preset, blades=n, size=size)
        if raster_max_px is not None:
            scene.params.compute_raster_max_px = raster_max_px
        w, h = size
        target = gfx.Texture(dim=2, size=(w, h, 1), format="rgba8unorm")
        renderer = gfx.WgpuRenderer(target, pixel_ratio=1, ppaa="none", enable_events=False)
        field = scene.field

        def sync():
            device.queue.read_buffer(compat.gpu_buffer(field.args_buffer))

        walks = ("RasterShader step=packed", "RasterShader step=depth", "RasterShader step=payload")
        modes = {"on": (True, set()), "off": (False, set()), "on, resolve skipped": (True, {"RasterResolveShader"}),
                 "on, walks skipped": (True, set(walks)), "on, clear skipped": (True, {"RasterShader step=clear"}),
                 "off, ribbons skipped": (False, {"BladeRenderShader"})}
        for raster, skip in modes.values():  # warm-up: compile every pipeline
            field.params.compute_raster = raster
            knockout["skip"] = skip
            for _ in range(2):
                scene.draw_into(renderer)
                sync()
        stamps.collect()
        wall = {m: [] for m in modes}
        cpu = {m: [] for m in modes}
        gpu = {m: collections.defaultdict(list) for m in modes}
        for _ in range(frames):
            for mode, (raster, skip) in modes.items():
                field.params.compute_raster = raster
                knockout["skip"] = skip
                scene.draw_into(renderer)  # settle the switch (pygfx rebuilds nothing after the warm-up)
                sync()
                stamps.collect()
                t, c = time.perf_counter(), time.process_time()
                scene.draw_into(renderer)
                sync()
                wall[mode].append(1e3 * (time.perf_counter() - t))
                cpu[mode].append(1e3 * (time.process_time() - c))
                for label, values in stamps.collect().items():
                    gpu[mode][label].append(sum(values))
        field.params.compute_raster = True
        knockout["skip"] = set()
        scene.draw_into(renderer)
        sync()
        listed = field.read_raster_count()
        if hasattr(field, "read_raster_pixels"):  # (depth, payload) whatever the layout (one walk or two)
            pixels = field.read_raster_pixels()
            covered = int((pixels[0] != 0xFFFFFFFF).sum()) if pixels is not None else 0
        else:  # a tree from before the one walk: a u32 depth word per pixel
            depth = np.frombuffer(device.queue.read_buffer(compat.gpu_buffer(field.raster_depth_buffer)), np.uint32)
            covered = int((depth != 0xFFFFFFFF).sum())
        drawn = int(field.read_draw_args()[:, 1].sum())
        entry = dict(preset=preset, blades=n, size=f"{w}x{h}", compute_raster_max_px=field.params.compute_raster_max_px,
                     listed_for_compute=listed, pixels_covered=covered,
                     pixels=w * h, ribbons_drawn_when_on=drawn,
                     wall_ms={m: statistics.median(v) for m, v in wall.items()},
                     cpu_ms={m: statistics.median(v) for m, v in cpu.items()},
                     gpu_ms={m: {k: statistics.median(v) for k, v in d.items()} for m, d in gpu.items()})
        entry["wall_on_over_off"] = entry["wall_ms"]["on"] / entry["wall_ms"]["off"]
        entry["cpu_on_over_off"] = entry["cpu_ms"]["on"] / entry["cpu_ms"]["off"]
        report["views"][view] = entry
        print(f"\n== {view}: listed {listed} blades, {covered} px covered of {w * h}; ribbons drawn {drawn}")
        print("wall ms: " + ", ".join(f"{m} {v:.1f}" for m, v in entry["wall_ms"].items())
              + f"; on/off {entry['wall_on_over_off']:.2f}")
        print("CPU ms: " + ", ".join(f"{m} {v:.1f}" for m, v in entry["cpu_ms"].items())
              + f"; on/off {entry['cpu_on_over_off']:.2f}")
        labels = sorted(set().union(*(d.keys() for d in entry["gpu_ms"].values())))
        print(f"{'pass':58s} " + " ".join(f"{m[:12]:>12s}" for m in modes))
        for label in labels:
            print(f"{label[:58]:58s} " + " ".join(f"{entry['gpu_ms'][m].get(label, float('nan')):12.2f}" for m in modes))
        del scene, renderer
    common.save("raster_profile", report, adapter_info(), out_path)
    return report


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--frames", type=int, default=6)
    ap.add_argument("--view", nargs="*", default=None, help="substring(s) of the views to run (default all)")
    ap.add_argument("--raster-max-px", type=float, default=None, help="compute_raster_max_px (default: the params')")
    common.add_out_argument(ap, "raster_profile")
    a = ap.parse_args(argv)
    run(a.frames, a.view, a.out, a.raster_max_px)


if __name__ == "__main__":
    sys.exit(main())
