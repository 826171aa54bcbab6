"""Benchmark of the browser engine: frames/s presented by the browser, and start-up time.

Runs JupyterLab and Debian's headless Chromium with the WebGPU flags (SwiftShader:
WebGPU on the CPU), shows ``GrassWidget(backend="browser")`` at 640 x 480 and

* counts the frames the browser presents (GPU work completed) over 6 s at 4096,
  2^14 and 2^16 blades (the default view; culling and LOD on; playing);
* times the start-up of a 2^18-blade widget: from running the cell to the engine
  being ready (blades uploaded, pipelines compiled) and to the first presented
  frame, with the browser's own milestones (device, pipelines, buffers, first frame);
* occlusion culling off vs on in the cis565 view (640 x 480, the near grass fills it) at
  2^13 and 2^15 blades, playing: windows interleaved off, on, off, on in one run, frames/s
  presented, blades drawn and occluded (``--occlusion-only`` runs just this part and
  writes ``browser_occlusion_swiftshader.json``);
* the compute rasterizer of thin blades (``GrassParams.compute_raster``) off vs on in the
  default view (640 x 480) at 4096 and 2^14 blades, playing: windows interleaved off, on, off,
  on in one run, frames/s presented, blades drawn and drawn in compute; then, with the
  engine's own loop held, where a frame's time goes: the frame encoded by the engine into an
  offscreen target (no presentation), the same frame with one pass left out at a time (its
  draws or dispatches skipped: the pass's cost), the simulation's steps, and the presented
  rate of the live loop (the rest is presentation and the page) (``--compute-raster-only``
  runs just this part and writes ``browser_compute_raster_swiftshader.json``).

* ``--matrix``: issue 28's matrix in the browser engine: per preset and blade count
  (:data:`MATRIX_ROWS`), playing, the defaults (occlusion culling and compute rasterizer
  "auto", decided by Python from the browser's frame times) against the four fixed
  combinations, windows interleaved in one run (the order rotated each round), frames/s
  presented; the decision in the panel's words (writes ``browser_matrix_swiftshader.json``).

Usage (from the repository root)::

    .venv/bin/python benchmarks/browser_engine.py [--out PATH]
    .venv/bin/python benchmarks/browser_engine.py --occlusion-only [--out PATH]
    .venv/bin/python benchmarks/browser_engine.py --compute-raster-only [--out PATH]
    .venv/bin/python benchmarks/browser_engine.py --matrix [--out PATH]

Prints a table and writes benchmarks/results/<claim>-swiftshader-<date>.json (claim browser_engine,
browser_occlusion, browser_compute_raster or browser_matrix; or ``--out``): the browser and the figures.
JupyterLab and Chromium are driven by benchmarks/lab.py.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import browser_matrix  # noqa: E402  (benchmarks/browser_matrix.py)
import common  # noqa: E402  (benchmarks/common.py)
from lab import (  # noqa: E402  (benchmarks/lab.py)
    Browser,
    JupyterLabServer,
    kernel_eval,
    kernel_execute,
    open_notebook,
    poll,
    run_all_cells,
    wait_for_kernel,
    write_notebook,
)

common.use_this_checkout()
ROOT = common.ROOT
#: The adapter of these runs: Chromium's WebGPU on SwiftShader (lab.WEBGPU_FLAGS).
CHROMIUM_ADAPTER = "Chromium WebGPU, SwiftShader (CPU)"

COUNTS = (4096, 1 << 14, 1 << 16)
STARTUP_BLADES = 1 << 18
WINDOW_S = 6.0
OCCLUSION_COUNTS = (1 << 13, 1 << 15)
OCCLUSION_ROUNDS = 2
#: (preset, blades, profile): the default view has no blade under 2 px at 640 x 480; the meadow's far field has many.
RASTER_ROWS = ((None, 4096, True), (None, 1 << 14, True), ("meadow", 1 << 14, False))
RASTER_ROUNDS = 2
#: --matrix: (preset, blades, size) rows (the rounds, windows and settings: browser_matrix's).
MATRIX_ROWS = (("cis565", 1 << 13, (320, 240)), ("meadow", 1 << 14, (320, 240)))
PROFILE_FRAMES = 4
PROFILE_ROUNDS = 3

# The page's newest open engine (engine.js keeps them in a Map: engine_key -> engine).
_ENGINE = ("(() => { const es = [...(globalThis.__grasswidgetEngines || new Map()).values()].filter((e) => !e.closed); "
           "return es[es.length - 1]; })()")


def engine_info(page):
    return page.evaluate(f"""() => {{ const e = {_ENGINE}; if (!e) return null;
        return {{frames: e.frames, n: e.n, occluded: e.occluded === undefined ? null : e.occluded, timing: e.timing, adapter: e.adapterText, now: performance.now(),
                 canvas: (() => {{ const v = [...e.views][0]; return v ? [v.canvas.width, v.canvas.height] : null; }})(), visible: e.visible, visibleAt: e.visibleAt || 0}}; }}""")


def presented_fps(page, seconds):
    a = engine_info(page)
    page.wait_for_timeout(seconds * 1000)
    b = engine_info(page)
    return (b["frames"] - a["frames"]) * 1000.0 / (b["now"] - a["now"])


def frames_per_s_after(page, warm_frames, min_frames, min_seconds):
    """Frames/s presented over at least ``min_frames`` frames and ``min_seconds``, after
    ``warm_frames`` frames (:func:`browser_matrix.frames_per_s_after` on the page's newest engine)."""
    return browser_matrix.frames_per_s_after(ChromiumPage(page), warm_frames, min_frames, min_seconds)


def visible_read_back(page, what):
    """The engine's info once a visible count has been read back by a frame drawn after
    now (the readback is asynchronous)."""
    since = engine_info(page)["now"]
    return poll(lambda: (lambda e: (e["visibleAt"] > since, e))(engine_info(page)),
                f"a visible count read back after {what}", 120, 0.5, page=page)


def alternate_on_off(page, setting, rounds, report):
    """``rounds`` rounds of ``w.params.<setting>`` off then on, interleaved: {"off": [...],
    "on": [...]} of ``report(mode, frames/s presented after the switch, engine info read
    back after the window)``, called while that mode is still on."""
    out = {"off": [], "on": []}
    for _ in range(rounds):
        for mode in ("off", "on"):
            kernel_execute(page, f"w.params.{setting} = {mode == 'on'}")
            fps = frames_per_s_after(page, 2, 4, WINDOW_S)
            out[mode].append(report(mode, fps, visible_read_back(page, "the window")))
    return out


def median_ratio(row):
    """Median frames/s on over off of a row's "on" and "off" lists, or None."""
    med = {m: sorted(r["frames_per_s"] for r in row[m])[len(row[m]) // 2] for m in ("off", "on")}
    return (round(med["on"] / med["off"], 2) if med["off"] else None), med


def occlusion_on_off(page, server, root):
    """Occlusion culling off vs on in the cis565 view, windows interleaved in one run."""
    write_notebook(root / "occlusion.ipynb", [
        "import grasswidget as gw\nfrom grasswidget.core.presets import preset_field\n"
        f"w = gw.GrassWidget({OCCLUSION_COUNTS[0]}, preset='cis565', backend='browser', size=(640, 480))\nw",
    ])
    open_notebook(page, server, "occlusion.ipynb")
    run_all_cells(page, timeout=120)
    wait_for_kernel(page, "w.view.gpu_status['state']", "ok", timeout=60)
    kernel_execute(page, "w.pause()")  # the camera and the blades still: culling and drawing, not the simulation
    out = {"view": "cis565 preset, 640 x 480, paused (culling and drawing only)", "window": "at least 4 frames and "
           f"{WINDOW_S} s after 2 warm-up frames", "rounds": OCCLUSION_ROUNDS, "rows": []}
    for n in OCCLUSION_COUNTS:
        if (engine_info(page) or {}).get("n") != n:
            kernel_execute(page, f"w.set_blades(preset_field('cis565', {n})[0])")
            poll(lambda: (engine_info(page) or {}).get("n") == n, f"the browser to hold {n} blades", 120, 0.5,
                 page=page)
        def report(mode, fps, info):
            print(f"{n:>8} blades, occlusion {mode:>3}: {fps:6.2f} frames/s presented, "
                  f"{sum(info['visible'])} drawn, {info['occluded']} occluded")
            return {"frames_per_s": round(fps, 3), "drawn": sum(info["visible"]), "occluded": info["occluded"]}

        row = {"blades": n, **alternate_on_off(page, "cull_occlusion", OCCLUSION_ROUNDS, report)}
        row["on_over_off"], _ = median_ratio(row)
        print(f"{n:>8} blades: occlusion on / off = {row['on_over_off']}x frames/s")
        out["rows"].append(row)
    out["adapter"] = engine_info(page)["adapter"]
    kernel_execute(page, "w.close()")
    page.goto("about:blank")
    server.shutdown_kernels()
    return out


# Where a frame's time goes, measured in the page with the engine's own loop held: each variant
# encodes PROFILE_FRAMES frames with the engine's encodeFrame into an offscreen target the size of
# the canvas, submits them back to back and waits for the GPU (ms per frame). A variant leaves
# out the draws / dispatches of some pipelines (a pass whose work is skipped: its cost is the
# difference to the full frame). "simulate_ms": the simulation's dispatch of `steps` fixed steps.
_PROFILE_JS = """async ({frames, steps, rounds}) => {
  const es = [...(globalThis.__grasswidgetEngines || new Map()).values()].filter((e) => !e.closed);
  const e = es[es.length - 1];
  const device = e.device;
  const view = [...e.views][0];
  const W = view.canvas.width, H = view.canvas.height;
  const targets = new Map();
  const target = (w, h) => {
    const key = `${w}x${h}`;
    if (!targets.has(key)) {
      const color = device.createTexture({ size: [w, h], format: e.gpu.format, usage: GPUTextureUsage.RENDER_ATTACHMENT });
      targets.set(key, { color, view: color.createView(), depth: e.depthFor(w, h) });
    }
    return targets.get(key);
  };
  const wrapPass = (pass, skip) => {
    let current = null;
    return new Proxy(pass, { get(t, k) {
      if (k === "setPipeline") return (p) => { current = p; t.setPipeline(p); };
      if (typeof k === "string" && (k.startsWith("draw") || k.startsWith("dispatch"))) {
        return (...a) => { if (!(skip === "all" || skip.has(current))) t[k](...a); };
      }
      const v = t[k];
      return typeof v === "function" ? v.bind(t) : v;
    } });
  };
  const wrapEncoder = (enc, skip) => new Proxy(enc, { get(t, k) {
    if (k === "beginRenderPass" || k === "beginComputePass") return (d) => wrapPass(t[k](d), skip);
    const v = t[k];
    return typeof v === "function" ? v.bind(t) : v;
  } });
  const timeFrames = async (skip, w, h) => {
    const t = target(w, h);
    await device.queue.onSubmittedWorkDone();
    const t0 = performance.now();
    for (let i = 0; i < frames; i++) {
      const enc = device.createCommandEncoder();
      e.passes.encode(wrapEncoder(enc, skip), t.view, t.depth, w, h);
      device.queue.submit([enc.finish()]);
    }
    await device.queue.onSubmittedWorkDone();
    return (performance.now() - t0) / frames;
  };
  const pipes = (list) => new Set((list || []).filter(Boolean).map((p) => p.pipeline));
  const P = e.pipelines, o = P.occlusion, r = P.raster;
  const variants = {
    "full": () => timeFrames(new Set(), W, H),
    "half_size": () => timeFrames(new Set(), Math.round(W / 2), Math.round(H / 2)),
    "occlusion_off": async () => {
      const keep = e.passes.occlusionOn;
      e.passes.occlusionOn = () => false;
      try { return await timeFrames(new Set(), W, H); } finally { e.passes.occlusionOn = keep; }
    },
    "no_draws_or_dispatches": () => timeFrames("all", W, H),
  };
  const skips = {
    "sky_ground": pipes([P.skyGround]),
    "ribbons": pipes([...P.bladePipes, ...P.flatBladePipes, ...(o ? [...o.blades, ...o.flatBlades] : [])]),
    "culling": pipes([...P.computePasses.filter((p) => p.name.startsWith("cull") || p.name === "prefix_bands" || p.name === "reset_args"),
      ...(o ? [o.cull] : [])]),
    "occlusion_pyramid": pipes(o ? o.levels : []),
  };
  if (e.passes.rasterOn()) {
    skips["compute_raster_resolve"] = pipes(r ? [r.resolve, r.resolveFlat] : []);
    skips["compute_raster_walks"] = pipes([...P.computePasses.filter((p) => p.name === "raster_depth" || p.name === "raster_payload"),
      ...(r ? [r.second.second_depth, r.second.second_payload] : [])]);
    skips["compute_raster_clear"] = pipes(P.computePasses.filter((p) => p.name === "raster_clear"));
  }
  for (const [name, skip] of Object.entries(skips)) variants[`without_${name}`] = () => timeFrames(skip, W, H);
  const samples = {};
  for (let k = 0; k < rounds; k++) {
    for (const [name, run] of Object.entries(variants)) (samples[name] = samples[name] || []).push(await run());
  }
  const median = (a) => { const b = [...a].sort((x, y) => x - y); return b[Math.floor(b.length / 2)]; };
  const out = { size: [W, H], frames, rounds, ms: {}, samples };
  for (const [name, a] of Object.entries(samples)) out.ms[name] = median(a);
  await device.queue.onSubmittedWorkDone();
  const t0 = performance.now();
  e.simulate(steps);
  await device.queue.onSubmittedWorkDone();
  out.simulate_ms = performance.now() - t0;
  out.simulate_steps = steps;
  for (const t of targets.values()) { t.color.destroy(); t.depth.destroy(); }
  return out;
}"""


def profile_frame(page, steps):
    """Hold the engine's loop, time the frame offscreen with each pass left out (see _PROFILE_JS), resume."""
    page.evaluate(f"() => {{ const e = {_ENGINE}; e.ready = false; }}")
    try:
        page.wait_for_timeout(1500)  # frames in flight finish
        return page.evaluate(_PROFILE_JS, {"frames": PROFILE_FRAMES, "steps": steps, "rounds": PROFILE_ROUNDS})
    finally:
        page.evaluate(f"() => {{ const e = {_ENGINE}; e.ready = true; e.scheduleFrame(); }}")


def compute_raster_on_off(page, server, root):
    """The compute rasterizer off vs on in the default view, windows interleaved in one run, then
    where a frame's time goes (profile_frame) with it off and on."""
    write_notebook(root / "compute_raster.ipynb", [
        f"import grasswidget as gw\nfrom grasswidget.core.presets import preset_field\n"
        f"w = gw.GrassWidget({RASTER_ROWS[0][1]}, backend='browser', size=(640, 480))\nw",
    ])
    open_notebook(page, server, "compute_raster.ipynb")
    run_all_cells(page, timeout=120)
    wait_for_kernel(page, "w.view.gpu_status['state']", "ok", timeout=60)
    out = {"view": "default view, 640 x 480, playing (the widget's defaults: culling, LOD, occlusion culling on)",
           "window": f"at least 4 frames and {WINDOW_S} s after 2 warm-up frames", "rounds": RASTER_ROUNDS,
           "rows": []}
    for preset, n, profile in RASTER_ROWS:
        if preset is not None:  # the preset's blades and camera in the same widget
            kernel_execute(page, f"b, _, v = preset_field({preset!r}, {n})\nw.set_blades(b)\n"
                                 "w.camera_state = {k: v[k] for k in ('position', 'target', 'fov_deg')}")
        elif (engine_info(page) or {}).get("n") != n:
            kernel_execute(page, f"w.set_blades({n})")
        poll(lambda: (engine_info(page) or {}).get("n") == n, f"the browser to hold {n} blades", 120, 0.5, page=page)
        def report(mode, fps, info):
            rastered = page.evaluate(f"() => {_ENGINE}.rastered")
            print(f"{preset or 'default':>8} {n:>8} blades, compute raster {mode:>3}: {fps:6.2f} frames/s presented, "
                  f"{sum(info['visible'])} as ribbons, {rastered} in compute")
            return {"frames_per_s": round(fps, 3), "ribbons": sum(info["visible"]), "compute": rastered}

        row = {"view": preset or "default", "blades": n,
               **alternate_on_off(page, "compute_raster", RASTER_ROUNDS, report), "profile": {}}
        row["on_over_off"], med = median_ratio(row)
        print(f"{n:>8} blades: compute raster on / off = {row['on_over_off']}x frames/s")
        steps = max(1, round(60 / max(med["off"], 1e-3)))  # the steps one presented frame simulates while playing
        for mode in ("off", "on") if profile else ():
            kernel_execute(page, f"w.params.compute_raster = {mode == 'on'}")
            frames_per_s_after(page, 2, 2, 1.0)
            prof = profile_frame(page, steps)
            row["profile"][mode] = prof
            ms = prof["ms"]
            prof["pass_cost_ms"] = {k[len("without_"):]: round(ms["full"] - v, 1) for k, v in ms.items()
                                    if k.startswith("without_")}
            print(f"{n:>8} blades, {mode:>3}: offscreen frame {ms['full']:.1f} ms (median of {PROFILE_ROUNDS}), "
                  f"half size {ms['half_size']:.1f}, occlusion off {ms['occlusion_off']:.1f}, no draws or "
                  f"dispatches {ms['no_draws_or_dispatches']:.1f}; passes' cost (full - without) "
                  f"{prof['pass_cost_ms']}; simulate {steps} steps {prof['simulate_ms']:.1f} ms")
        out["rows"].append(row)
    out["adapter"] = engine_info(page)["adapter"]
    kernel_execute(page, "w.close()")
    page.goto("about:blank")
    server.shutdown_kernels()
    return out


class ChromiumPage:
    """The page :func:`browser_matrix.run_matrix` drives: a notebook in JupyterLab + Chromium whose
    kernel holds the widget ``w`` (``server`` and ``root``: the lab and its folder; only ``show`` needs them)."""

    def __init__(self, page, server=None, root=None):
        self.page, self.server, self.root = page, server, root

    def show(self, preset, n, size):
        name = f"matrix_{preset}_{n}.ipynb"
        write_notebook(self.root / name, [
            f"import grasswidget as gw\nw = gw.GrassWidget({n}, preset={preset!r}, backend='browser', size={tuple(size)})\nw",
        ])
        open_notebook(self.page, self.server, name)
        run_all_cells(self.page, timeout=120)
        wait_for_kernel(self.page, "w.view.gpu_status['state']", "ok", timeout=120)

    def apply(self, occlusion, raster):
        kernel_execute(self.page, f"w.params.cull_occlusion = {occlusion!r}\nw.params.compute_raster = {raster!r}")

    def auto_state(self):
        return kernel_eval(self.page, "[w.view.engine_widget.auto_switches.state.measuring, "
                                      "w.view.engine_widget.auto_switches.texts()]")

    def engine(self):
        return self.page.evaluate(f"""() => {{ const e = {_ENGINE}; if (!e) return null;
            return {{frames: e.frames, now: performance.now(), visible: e.visible, occluded: e.occluded === undefined ? null : e.occluded,
                     rastered: e.rastered === undefined ? null : e.rastered, counts_switches: e.countsSwitches || null,
                     counts_read_at: e.countsReadAt, counts_pending: e.countsPending,
                     adapter: e.adapterText}}; }}""")

    def poll(self, check, what, timeout, interval):
        return poll(check, what, timeout, interval, page=self.page)

    def hide(self):
        kernel_execute(self.page, "w.close()")
        self.page.goto("about:blank")
        self.server.shutdown_kernels()


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    common.add_out_argument(ap, "browser_<part>")
    ap.add_argument("--occlusion-only", action="store_true", help="only occlusion culling off vs on (cis565 view)")
    ap.add_argument("--compute-raster-only", action="store_true",
                    help="only the compute rasterizer off vs on, and where a frame's time goes (default view)")
    ap.add_argument("--matrix", action="store_true",
                    help="only the defaults ('auto') against every fixed combination of occlusion culling and the "
                         "compute rasterizer, per preset and blade count, interleaved")
    args = ap.parse_args(argv)
    root = Path(tempfile.mkdtemp(prefix="gw-bench-browser-"))
    if args.compute_raster_only:
        env = {"PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
        result = {}
        with JupyterLabServer(root, env=env) as server, Browser(webgpu=True) as browser:
            result["browser"] = browser.version
            result["compute_raster"] = compute_raster_on_off(browser.page, server, root)
        common.save("browser_compute_raster", result, CHROMIUM_ADAPTER, args.out)
        return
    if args.matrix:
        env = {"PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
        result = {}
        with JupyterLabServer(root, env=env) as server, Browser(webgpu=True) as browser:
            result["browser"] = browser.version
            result["matrix"] = browser_matrix.run_matrix(ChromiumPage(browser.page, server, root), MATRIX_ROWS)
        result["load_average_after"] = list(os.getloadavg())
        common.save("browser_matrix", result, CHROMIUM_ADAPTER, args.out)
        return
    if args.occlusion_only:
        env = {"PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
        result = {}
        with JupyterLabServer(root, env=env) as server, Browser(webgpu=True) as browser:
            result["browser"] = browser.version
            result["occlusion"] = occlusion_on_off(browser.page, server, root)
        common.save("browser_occlusion", result, CHROMIUM_ADAPTER, args.out)
        return
    write_notebook(root / "fps.ipynb", [
        "import grasswidget as gw\nw = gw.GrassWidget(4096, backend='browser', size=(640, 480))\nw",
    ])
    write_notebook(root / "startup.ipynb", [
        "import time\nt0 = time.perf_counter()\nimport grasswidget as gw\n"
        f"w = gw.GrassWidget({STARTUP_BLADES}, backend='browser', size=(640, 480))\n"
        "kernel_s = time.perf_counter() - t0\nw",
    ])
    env = {"PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    result = {"view": [640, 480], "window_s": WINDOW_S, "fps": {}}
    with JupyterLabServer(root, env=env) as server, Browser(webgpu=True) as browser:
        page = browser.page
        result["browser"] = browser.version
        open_notebook(page, server, "fps.ipynb")
        run_all_cells(page, timeout=120)
        wait_for_kernel(page, "w.view.gpu_status['state']", "ok", timeout=60)
        for n in COUNTS:
            kernel_execute(page, f"w.set_blades({n})")
            poll(lambda: (engine_info(page) or {}).get("n") == n, f"the browser to hold {n} blades", 120, 0.5,
                 page=page)
            wait_for_kernel(page, "w.stats['blades'] == w.blade_count and w.stats['visible'] is not None", True,
                            timeout=60)
            page.wait_for_timeout(1500)  # let the first frames after the rebuild pass
            fps = presented_fps(page, WINDOW_S)
            # The visible count read back by a frame drawn with these blades (the readback is asynchronous).
            info = visible_read_back(page, "the measurement")
            visible = sum(info["visible"])
            result["fps"][str(n)] = {"frames_per_s": round(fps, 2), "visible": visible}
            print(f"{n:>8} blades: {fps:6.2f} frames/s presented, {visible} visible")
        # The same 2^16 blades with a quarter of the pixels (GrassWidget(pixel_ratio=0.5)).
        kernel_execute(page, "w.view.engine_widget.pixel_ratio = 0.5")
        poll(lambda: engine_info(page)["canvas"] == [320, 240], "the canvas to render 320 x 240", 30, 0.3, page=page)
        page.wait_for_timeout(1500)
        fps = presented_fps(page, WINDOW_S)
        result["fps"]["65536@pixel_ratio_0.5"] = {"frames_per_s": round(fps, 2)}
        print(f"   65536 blades at pixel_ratio 0.5: {fps:6.2f} frames/s presented")
        adapter = engine_info(page)["adapter"] or CHROMIUM_ADAPTER
        kernel_execute(page, "w.close()")
        page.goto("about:blank")
        server.shutdown_kernels()
        result["occlusion"] = occlusion_on_off(page, server, root)

        open_notebook(page, server, "startup.ipynb")
        t0 = time.monotonic()
        page_t0 = page.evaluate("() => performance.now()")
        page.evaluate("() => window.jupyterapp.commands.execute('notebook:run-all-cells')")
        info = poll(lambda: (lambda e: (bool(e and e["n"] == STARTUP_BLADES and e["timing"].get("first_frame")), e))(
            engine_info(page)), "the first frame of the 2^18-blade widget", 300, 0.05, page=page)
        wall = time.monotonic() - t0
        t = info["timing"]
        kernel_s = kernel_eval(page, "kernel_s")
        result["startup"] = {
            "blades": STARTUP_BLADES,
            "run_cell_to_first_frame_s": round(wall, 2),
            "run_cell_to_engine_ready_s": round((t["buffers"] - page_t0) / 1000, 2),
            "kernel_widget_construction_s": round(kernel_s, 2),
            "browser_view_created_to_device_s": round((t["device"] - t["created"]) / 1000, 2),
            "browser_pipelines_s": round((t["pipelines"] - t["device"]) / 1000, 2),
            "browser_buffers_s": round((t["buffers"] - t["pipelines"]) / 1000, 2),
            "browser_first_frame_s": round((t["first_frame"] - t["buffers"]) / 1000, 2),
        }
        print("start-up at 2^18 blades:", json.dumps(result["startup"]))
        common.save("browser_engine", result, adapter, args.out)
        try:  # the page may still be busy drawing 2^18 blades on a CPU adapter
            page.goto("about:blank", timeout=120_000)
        finally:
            server.shutdown_kernels()


if __name__ == "__main__":
    main()
