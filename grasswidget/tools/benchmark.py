"""Benchmark: frame time, simulation and culling+draw time, visible blades.

``python -m grasswidget bench --preset cis565 --blades 1024 65536 --cull each --json out.json``
``python -m grasswidget bench --preset meadow --blades 1048576 --occlusion both --json out.json``
``python -m grasswidget bench --preset meadow --blades 1048576 --compute-raster both --json out.json``
``python -m grasswidget bench --preset meadow --blades 1048576 --compute-raster on --raster-max-px 2 4 8``

Per blade count and culling mode it measures, after warm-up:
- frame ms (median, p10, p90): one simulation step + one render, GPU-synchronised
  every frame (a 64-byte readback waits for the queue);
- frame CPU ms (median): the process's CPU time over the same frame, all threads
  (on a CPU adapter this is the rendering work itself, and it moves much less than
  wall time when other processes load the machine);
- simulation ms and culling+draw ms: the same two halves timed separately (wall
  clock, GPU-synchronised);
- GPU ms from timestamp queries where the adapter has them: the simulation pass
  (1 step), the culling pass (reset + cull run in a pass of their own) and the
  blade draws (inside the render pass);
- visible blades (the GPU's indirect draw counts, both occlusion phases) and
  occluded blades (culled by occlusion; ``--occlusion both`` runs off, then on) and
  the blades the compute rasterizer drew (``rastered``; ``--compute-raster both`` runs
  off, then on; ``--raster-max-px`` runs the rows with it on once per
  ``GrassParams.compute_raster_max_px`` value, row key ``compute_raster_max_px``);
- pipelined frames/s: the same frames submitted back to back with one sync at the end.
Frames render into an offscreen texture (no image readback in the timing).
"""

from __future__ import annotations

import json
import platform
import socket
import statistics
import time

import numpy as np

from ..errors import GrassValueError
from .. import compat

__all__ = ["run_benchmark", "format_table", "CULL_MODES", "OCCLUSION_MODES"]

#: Culling modes: "on" (all three tests + LOD), "off" (nothing culled, no LOD), "both" (off, then on, in
#: one run: their ratio is what culling buys), "each" (on, off, and each test alone).
CULL_MODES = ("on", "off", "both", "each")
#: Occlusion culling with the culling modes that cull: "on", "off", or "both" (off, then on, in one run).
OCCLUSION_MODES = ("on", "off", "both")


def _modes(cull):
    if cull == "on":
        return ["on"]
    if cull == "off":
        return ["off"]
    if cull == "both":
        return ["off", "on"]
    if cull == "each":
        return ["off", "orientation", "frustum", "distance", "on"]
    raise GrassValueError(f"cull must be one of {', '.join(CULL_MODES)}; got {cull!r}")


def _occlusion_modes(occlusion):
    if occlusion not in OCCLUSION_MODES:
        raise GrassValueError(f"occlusion must be one of {', '.join(OCCLUSION_MODES)}; got {occlusion!r}")
    return {"on": [True], "off": [False], "both": [False, True]}[occlusion]


def _apply_mode(params, mode, occlusion=False, compute_raster=False, raster_max_px=None):
    params.compute_raster = bool(compute_raster)
    if raster_max_px is not None:
        params.compute_raster_max_px = raster_max_px
    params.cull_occlusion = bool(occlusion) and mode != "off"
    on = mode == "on"
    params.cull_orientation = on or mode == "orientation"
    params.cull_frustum = on or mode == "frustum"
    params.cull_distance = on or mode == "distance"
    params.lod = mode != "off"


def _pct(values, q):
    return float(np.percentile(np.asarray(values, np.float64), q))


class _Timer:
    """GPU timestamps of the simulation and culling passes, in passes of their own."""

    def __init__(self, scene):
        from ..gpu.compute import ComputeProgram
        from ..gpu.shader_classes import CullShader, PrefixBandsShader, ResetArgsShader

        self.scene = scene
        self.device = scene.field.stats.device
        self.ok = scene.field.stats.timestamps
        if not self.ok:
            return
        import wgpu

        self.qs = self.device.create_query_set(type="timestamp", count=4)
        self.buf = self.device.create_buffer(size=32, usage=wgpu.BufferUsage.QUERY_RESOLVE | wgpu.BufferUsage.COPY_SRC)
        self.reset = ComputeProgram(ResetArgsShader(scene.field), scene.field)
        self.count = ComputeProgram(CullShader(scene.field, "count"), scene.field)
        self.prefix = ComputeProgram(PrefixBandsShader(scene.field), scene.field)
        self.cull = ComputeProgram(CullShader(scene.field, "scatter"), scene.field)

    def cull_ms(self):
        """GPU ms of reset + cull (count, prefix, scatter) for the current camera (uniforms of the last render)."""
        from ..gpu.wgsl_templates import workgroups

        enc = self.device.create_command_encoder()
        cp = enc.begin_compute_pass(
            timestamp_writes={"query_set": self.qs, "beginning_of_pass_write_index": 0, "end_of_pass_write_index": 1}
        )
        self.reset.dispatch(cp, (1, 1, 1))
        self.count.dispatch(cp, workgroups(self.scene.field.count))
        self.prefix.dispatch(cp, (1, 1, 1))
        self.cull.dispatch(cp, workgroups(self.scene.field.count))
        cp.end()
        enc.resolve_query_set(self.qs, 0, 2, self.buf, 0)
        self.device.queue.submit([enc.finish()])
        ts = np.frombuffer(self.device.queue.read_buffer(self.buf), np.uint64)
        return float(ts[1] - ts[0]) / 1e6


def _bench_one(scene, renderer, frames, steps_per_frame):
    field = scene.field
    stats = field.stats
    device = stats.device
    args_gpu = field.args_buffer

    def sync():
        return np.frombuffer(device.queue.read_buffer(compat.gpu_buffer(args_gpu)), np.uint32).reshape(-1, 4)

    def render():
        scene.draw_into(renderer)

    for _ in range(3):  # warm-up: compile, allocate
        field.step(steps_per_frame)
        render()
        sync()
    frame, frame_cpu, sim, cull_draw, gpu_sim, gpu_draw = [], [], [], [], [], []
    for _ in range(frames):
        t0, c0 = time.perf_counter(), time.process_time()
        field.step(steps_per_frame)
        sync()
        t1 = time.perf_counter()
        render()
        sync()
        t2 = time.perf_counter()
        frame_cpu.append((time.process_time() - c0) * 1e3)
        frame.append((t2 - t0) * 1e3)
        sim.append((t1 - t0) * 1e3)
        cull_draw.append((t2 - t1) * 1e3)
        stats.after_render()
        stats.poll()
        if "simulation" in stats.gpu_ms:
            gpu_sim.append(stats.gpu_ms["simulation"])
        if "draw" in stats.gpu_ms:
            gpu_draw.append(stats.gpu_ms["draw"])
    # Throughput: frames submitted back to back, one sync at the end.
    t0 = time.perf_counter()
    for _ in range(frames):
        field.step(steps_per_frame)
        render()
    sync()
    pipelined_fps = frames / (time.perf_counter() - t0)
    visible = int(field.read_draw_args()[:, 1].sum()) + field.read_raster_count()  # both phases, both paths
    out = dict(
        pipelined_fps=pipelined_fps,
        frame_ms=dict(median=_pct(frame, 50), p10=_pct(frame, 10), p90=_pct(frame, 90)),
        fps=1000.0 / _pct(frame, 50),
        frame_cpu_ms=_pct(frame_cpu, 50),
        simulation_ms=_pct(sim, 50),
        cull_draw_ms=_pct(cull_draw, 50),
        visible=visible,
        occluded=field.read_occluded_count(),
        rastered=field.read_raster_count(),
    )
    if gpu_sim:
        out["gpu_simulation_ms"] = statistics.median(gpu_sim)
    if gpu_draw:
        out["gpu_draw_ms"] = statistics.median(gpu_draw)
    return out


def run_benchmark(preset="cis565", blades=(1024, 4096, 16384, 65536), frames=30, size=None, cull="on",
              steps_per_frame=1, progress=True, seed=0, occlusion="on", compute_raster="on",
              raster_max_px=None, horizon=True) -> dict:
    """Run the sweep; returns a JSON-ready dict (see module docstring). ``occlusion``
    ("on", "off", "both": off then on, same scene and renderer) applies to the culling
    modes that cull; each row says ``occlusion`` True/False. ``compute_raster`` ("on",
    "off", "both") likewise for ``GrassParams.compute_raster`` (row key ``compute_raster``);
    ``raster_max_px``: None (the params' default) or a sequence of
    ``GrassParams.compute_raster_max_px`` values (pixels, 0..16), each run in turn on the
    rows with the compute rasterizer on (row key ``compute_raster_max_px``). ``horizon``: the
    meadow preset to the horizon (default) or, False, its square field of before (report key
    ``horizon``)."""
    import pygfx as gfx
    import tqdm

    from ..gpu.adapter import adapter_info, ensure_device
    from ..gpu.scene import GrassScene, make_renderer

    if compute_raster not in OCCLUSION_MODES:
        raise GrassValueError(f"compute_raster must be one of {', '.join(OCCLUSION_MODES)}; got {compute_raster!r}")
    rasters = {"on": [True], "off": [False], "both": [False, True]}[compute_raster]
    if raster_max_px is None:
        widths = [None]
    else:
        from ..core.params import GrassParams

        widths = []
        for px in raster_max_px:
            probe = GrassParams()
            probe.compute_raster_max_px = px  # GrassValueError naming the parameter and its range
            widths.append(float(probe.compute_raster_max_px))
        if not widths:
            raise GrassValueError("raster_max_px must be None or one or more widths in pixels; got an empty list")
    modes = [(m, o, r, px) for m in _modes(cull) for o in ([False] if m == "off" else _occlusion_modes(occlusion))
             for r in rasters for px in (widths if r else [None])]
    if isinstance(frames, bool) or not isinstance(frames, int) or frames < 1:
        raise GrassValueError(f"frames must be an integer >= 1; got {frames!r}")
    counts = [int(n) for n in blades]
    if not counts or min(counts) < 1:
        raise GrassValueError(f"blades must be one or more counts >= 1; got {blades!r}")
    ensure_device()
    info = adapter_info()
    results = []
    bar = tqdm.tqdm(total=len(counts) * len(modes), desc="bench", disable=not progress)
    for n in counts:
        scene = GrassScene.preset(preset, blades=n, size=size, seed=seed, horizon=horizon)
        w, h = scene.size
        target = gfx.Texture(dim=2, size=(w, h, 1), format="rgba8unorm-srgb", colorspace="tex-srgb")  # the canvas format
        renderer = make_renderer(target)  # the live view's renderer (pygfx's DDAA in a compute pass on a GPU)
        timer = _Timer(scene)
        for mode, occl, raster, px in modes:
            _apply_mode(scene.params, mode, occl, raster, px)
            row = dict(blades=n, cull=mode, occlusion=occl, compute_raster=raster,
                       compute_raster_max_px=scene.params.compute_raster_max_px if raster else None, size=f"{w}x{h}")
            row.update(_bench_one(scene, renderer, frames, steps_per_frame))
            if timer.ok:
                row["gpu_cull_ms"] = statistics.median(timer.cull_ms() for _ in range(5))
                if "gpu_simulation_ms" in row:
                    row["gpu_sim_plus_cull_us"] = 1000.0 * (row["gpu_simulation_ms"] + row["gpu_cull_ms"])
            row["gpu_bytes_per_blade"] = scene.field.bytes_per_blade
            results.append(row)
            bar.update(1)
        del scene, renderer, timer
    bar.close()
    return dict(
        preset=preset,
        horizon=bool(horizon),
        frames=frames,
        steps_per_frame=steps_per_frame,
        adapter=info,
        machine=dict(host=socket.gethostname(), platform=platform.platform(), processor=platform.processor(),
                     python=platform.python_version()),
        date=time.strftime("%Y-%m-%d %H:%M:%S"),
        results=results,
    )


def format_table(report: dict) -> str:
    """A plain-text table of a run_benchmark report."""
    head = f"{'blades':>9} {'cull':>11} {'occl':>5} {'cr':>3} {'px':>4} {'frame ms':>9} {'p10':>7} {'p90':>7} {'cpu ms':>7} {'fps':>7} {'sim ms':>7} {'cull+draw':>9} {'gpu sim':>8} {'gpu cull':>8} {'gpu draw':>8} {'visible':>9} {'pipe fps':>8}"
    lines = [f"{report['adapter'].get('summary', '')} - preset {report['preset']}", head]

    def g(row, key):
        v = row.get(key)
        return f"{v:8.3f}" if isinstance(v, float) else f"{'-':>8}"

    def px_text(row):
        px = row.get("compute_raster_max_px")
        return f"{px:g}" if isinstance(px, (int, float)) else "-"

    for r in report["results"]:
        f = r["frame_ms"]
        lines.append(
            f"{r['blades']:>9} {r['cull']:>11} {'on' if r.get('occlusion') else 'off':>5} "
            f"{'on' if r.get('compute_raster') else 'off':>3} {px_text(r):>4} {f['median']:9.2f} {f['p10']:7.2f} {f['p90']:7.2f} "
            f"{r.get('frame_cpu_ms', float('nan')):7.1f} {r['fps']:7.1f} "
            f"{r['simulation_ms']:7.2f} {r['cull_draw_ms']:9.2f} {g(r, 'gpu_simulation_ms')} {g(r, 'gpu_cull_ms')} "
            f"{g(r, 'gpu_draw_ms')} {r['visible']:>9} {r['pipelined_fps']:8.1f}"
        )
    return "\n".join(lines)


def save_json(report, path):
    with open(path, "w") as f:
        json.dump(report, f, indent=2)
