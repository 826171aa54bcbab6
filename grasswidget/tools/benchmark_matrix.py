"""Benchmark of the "auto" switches: the defaults against every fixed choice, interleaved.

``python -m grasswidget bench --matrix --preset cis565 --blades 8192 32768 --size 640x480 --json m.json``

Per blade count, one scene and one offscreen renderer run five settings of occlusion
culling and the compute rasterizer: the defaults (both "auto", decided by measuring,
:mod:`grasswidget.core.auto_switches`) and the four fixed combinations (occlusion on/off x compute
raster on/off). After a warm-up of each setting and the auto decision's own trial (its
frames counted and reported, not timed), ``rounds`` rounds each run every setting for a
block of ``block`` timed frames (one dropped first: a switch flipped), in an order rotated
each round, so drift of a shared machine hits every setting alike. A frame is one
simulation step and one render, GPU-synchronised (its wall time, milliseconds; also the
process's CPU time over the same frame, ``frame_cpu_ms``: on a CPU adapter the rendering work
itself, far steadier than wall time on a loaded machine). Per setting:
median, p10, p90 over all its frames; the best fixed setting and ``defaults / best``
(best median / defaults median: 1.0 when the defaults are as fast as the best fixed choice,
0.8 when they take 25 % longer). The report records the machine and the load average
before and after the run.
"""

from __future__ import annotations

import os
import platform
import socket
import time

import numpy as np

from ..core.auto_switches import AUTO, TRIAL_MAX_FRAMES
from ..errors import GrassValueError

__all__ = ["SETTINGS", "run_matrix", "format_matrix"]

#: (name, cull_occlusion, compute_raster): the defaults, then every fixed combination.
SETTINGS = (
    ("defaults", AUTO, AUTO),
    ("occl on, cr on", True, True),
    ("occl on, cr off", True, False),
    ("occl off, cr on", False, True),
    ("occl off, cr off", False, False),
)


def _pct(values, q):
    return float(np.percentile(np.asarray(values, np.float64), q))


def _loadavg():
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except OSError:
        return None


def run_matrix(preset="cis565", blades=(8192, 32768), size=None, rounds=3, block=3, seed=0, progress=True) -> dict:
    """Run the matrix; returns a JSON-ready dict (see the module docstring). ``rounds`` and
    ``block``: integers >= 1 (timed frames per setting: rounds x block)."""
    import pygfx as gfx
    import tqdm

    from ..gpu.adapter import adapter_info, ensure_device
    from ..gpu.trial_timing import switches_of, wait_for_queue
    from ..gpu.scene import GrassScene, make_renderer

    for name, value in (("rounds", rounds), ("block", block)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise GrassValueError(f"{name} must be an integer >= 1; got {value!r}")
    counts = [int(n) for n in blades]
    if not counts or min(counts) < 1:
        raise GrassValueError(f"blades must be one or more counts >= 1; got {blades!r}")
    ensure_device()
    info = adapter_info()
    load_before = _loadavg()
    rows = []
    bar = tqdm.tqdm(total=len(counts) * rounds * len(SETTINGS), desc="bench --matrix", disable=not progress)
    for n in counts:
        scene = GrassScene.preset(preset, blades=n, size=size, seed=seed)
        w, h = scene.size
        target = gfx.Texture(dim=2, size=(w, h, 1), format="rgba8unorm-srgb", colorspace="tex-srgb")  # the canvas format
        renderer = make_renderer(target)  # the live view's renderer (pygfx's DDAA in a compute pass on a GPU)
        params, field = scene.params, scene.field

        def frame():
            t0, c0 = time.perf_counter(), time.process_time()
            field.step(1)
            scene.draw_into(renderer)
            wait_for_queue()
            return (time.perf_counter() - t0) * 1e3, (time.process_time() - c0) * 1e3

        def apply(occlusion, raster):
            params.cull_occlusion = occlusion
            params.compute_raster = raster

        for _, occlusion, raster in SETTINGS[1:]:  # warm-up: compile and allocate every path
            apply(occlusion, raster)
            frame()
        apply(AUTO, AUTO)
        state = switches_of(field)
        trial_frames = 0
        # Until both are decided (at most 4 trials of 2 x (settle + TRIAL_MAX_FRAMES) frames).
        while (state.measuring or len(state.decisions) < 2) and trial_frames < 4 * 2 * (1 + TRIAL_MAX_FRAMES):
            frame()
            trial_frames += 1
        times = {name: [] for name, _, _ in SETTINGS}
        cpu_times = {name: [] for name, _, _ in SETTINGS}
        for r in range(rounds):
            order = SETTINGS[r % len(SETTINGS):] + SETTINGS[:r % len(SETTINGS)]
            for name, occlusion, raster in order:
                apply(occlusion, raster)
                frame()  # dropped: the switch flipped
                for _ in range(block):
                    wall, cpu = frame()
                    times[name].append(wall)
                    cpu_times[name].append(cpu)
                bar.update(1)
        settings = {name: dict(median=_pct(t, 50), p10=_pct(t, 10), p90=_pct(t, 90), frames=len(t))
                    for name, t in times.items()}
        cpu = {name: dict(median=_pct(t, 50), p10=_pct(t, 10), p90=_pct(t, 90)) for name, t in cpu_times.items()}
        best = min((name for name, _, _ in SETTINGS[1:]), key=lambda k: settings[k]["median"])
        best_cpu = min((name for name, _, _ in SETTINGS[1:]), key=lambda k: cpu[k]["median"])
        rows.append(dict(
            blades=n, size=f"{w}x{h}", frame_ms=settings, best_fixed=best,
            defaults_over_best=settings[best]["median"] / settings["defaults"]["median"],
            frame_cpu_ms=cpu, best_fixed_cpu=best_cpu,
            defaults_over_best_cpu=cpu[best_cpu]["median"] / cpu["defaults"]["median"],
            decisions={k: dict(on=d.on, reason=d.reason) for k, d in state.decisions.items()},
            trial_frames=trial_frames,
        ))
        scene.release()
        del scene, renderer
    bar.close()
    return dict(
        kind="matrix", preset=preset, rounds=rounds, block=block, adapter=info,
        machine=dict(host=socket.gethostname(), platform=platform.platform(), processor=platform.processor(),
                     cpus=os.cpu_count(), python=platform.python_version()),
        load_average=dict(before=load_before, after=_loadavg()),
        date=time.strftime("%Y-%m-%d %H:%M:%S"), results=rows,
    )


def _on_off(decision):
    return "-" if decision is None else ("on" if decision["on"] else "off")


def format_matrix(report: dict) -> str:
    """A plain-text table of a run_matrix report: median frame ms per setting."""
    names = [name for name, _, _ in SETTINGS]
    load = report.get("load_average") or {}
    lines = [f"{report['adapter'].get('summary', '')} - preset {report['preset']} - host {report['machine']['host']} "
             f"- load average before {load.get('before')} after {load.get('after')}",
             "median frame ms (step + render, GPU-synchronised); auto = what the defaults decided",
             f"{'blades':>9} {'size':>9} {'auto occl/cr':>12} " + " ".join(f"{n:>16}" for n in names)
             + f" {'best fixed':>16} {'defaults/best':>13}"]
    for key, best, ratio, title in (("frame_ms", "best_fixed", "defaults_over_best", None),
                                    ("frame_cpu_ms", "best_fixed_cpu", "defaults_over_best_cpu",
                                     "median frame CPU ms (the process's CPU time over the same frames: "
                                     "on a CPU adapter the rendering work itself)")):
        if title:
            lines.append(title)
        for r in report["results"]:
            if key not in r:
                continue
            auto = f"{_on_off(r['decisions'].get('cull_occlusion'))}/{_on_off(r['decisions'].get('compute_raster'))}"
            lines.append(f"{r['blades']:>9} {r['size']:>9} {auto:>12} "
                         + " ".join(f"{r[key][n]['median']:16.1f}" for n in names)
                         + f" {r[best]:>16} {r[ratio]:13.2f}")
    return "\n".join(lines)
