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
  writes ``browser_occlusion_swiftshader.json``).

Usage (from the repository root)::

    .venv/bin/python benchmarks/browser_engine.py [--out benchmarks/browser_engine_swiftshader.json]
    .venv/bin/python benchmarks/browser_engine.py --occlusion-only [--out benchmarks/browser_occlusion_swiftshader.json]

Prints a table and writes the JSON (machine, browser, adapter and figures).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from tests.browser.harness import (  # noqa: E402
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

COUNTS = (4096, 1 << 14, 1 << 16)
STARTUP_BLADES = 1 << 18
WINDOW_S = 6.0
OCCLUSION_COUNTS = (1 << 13, 1 << 15)
OCCLUSION_ROUNDS = 2

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
    ``warm_frames`` frames (a setting's first frames: with occlusion culling the first one
    after it is switched on still draws every blade in its first phase)."""
    start = engine_info(page)["frames"]
    poll(lambda: engine_info(page)["frames"] >= start + warm_frames, "the warm-up frames", 300, 0.2, page=page)
    a = engine_info(page)
    b = poll(lambda: (lambda e: (e["frames"] >= a["frames"] + min_frames and e["now"] - a["now"] >= 1000 * min_seconds,
                                 e))(engine_info(page)), f"{min_frames} frames", 600, 0.2, page=page)
    return (b["frames"] - a["frames"]) * 1000.0 / (b["now"] - a["now"])


def occlusion_on_off(page, server, root):
    """Occlusion culling off vs on in the cis565 view, windows interleaved in one run."""
    write_notebook(root / "occlusion.ipynb", [
        "import grasswidget as gw\nfrom grasswidget.core.framing import preset_field\n"
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
        row = {"blades": n, "off": [], "on": []}
        for _ in range(OCCLUSION_ROUNDS):
            for mode in ("off", "on"):
                kernel_execute(page, f"w.params.cull_occlusion = {mode == 'on'}")
                fps = frames_per_s_after(page, 2, 4, WINDOW_S)
                since = engine_info(page)["now"]
                info = poll(lambda: (lambda e: (e["visibleAt"] > since, e))(engine_info(page)),
                            "a visible count read back after the window", 120, 0.5, page=page)
                row[mode].append({"frames_per_s": round(fps, 3), "drawn": sum(info["visible"]),
                                  "occluded": info["occluded"]})
                print(f"{n:>8} blades, occlusion {mode:>3}: {fps:6.2f} frames/s presented, "
                      f"{sum(info['visible'])} drawn, {info['occluded']} occluded")
        med = {m: sorted(r["frames_per_s"] for r in row[m])[len(row[m]) // 2] for m in ("off", "on")}
        row["on_over_off"] = round(med["on"] / med["off"], 2) if med["off"] else None
        print(f"{n:>8} blades: occlusion on / off = {row['on_over_off']}x frames/s")
        out["rows"].append(row)
    out["adapter"] = engine_info(page)["adapter"]
    kernel_execute(page, "w.close()")
    page.goto("about:blank")
    server.shutdown_kernels()
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default=None, help="JSON path (default benchmarks/browser_engine_swiftshader.json, "
                                                 "with --occlusion-only benchmarks/browser_occlusion_swiftshader.json)")
    ap.add_argument("--occlusion-only", action="store_true", help="only occlusion culling off vs on (cis565 view)")
    args = ap.parse_args(argv)
    if args.out is None:
        name = "browser_occlusion_swiftshader.json" if args.occlusion_only else "browser_engine_swiftshader.json"
        args.out = str(ROOT / "benchmarks" / name)
    root = Path(tempfile.mkdtemp(prefix="gw-bench-browser-"))
    if args.occlusion_only:
        env = {"PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
        result = {"machine": {"platform": platform.platform(), "processor": platform.processor() or platform.machine(),
                              "cpus": os.cpu_count()}}
        with JupyterLabServer(root, env=env) as server, Browser(webgpu=True) as browser:
            result["browser"] = browser.context.browser.version if browser.context.browser else "chromium"
            result["occlusion"] = occlusion_on_off(browser.page, server, root)
        Path(args.out).write_text(json.dumps(result, indent=2) + "\n")
        print(f"wrote {args.out}")
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
    result = {"machine": {"platform": platform.platform(), "processor": platform.processor() or platform.machine(),
                          "cpus": os.cpu_count()},
              "view": [640, 480], "window_s": WINDOW_S, "fps": {}}
    with JupyterLabServer(root, env=env) as server, Browser(webgpu=True) as browser:
        page = browser.page
        result["browser"] = browser.context.browser.version if browser.context.browser else "chromium"
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
            since = engine_info(page)["now"]
            info = poll(lambda: (lambda e: (e["visibleAt"] > since, e))(engine_info(page)),
                        "a visible count read back after the measurement", 120, 0.5, page=page)
            visible = sum(info["visible"])
            result["fps"][str(n)] = {"frames_per_s": round(fps, 2), "visible": visible}
            print(f"{n:>8} blades: {fps:6.2f} frames/s presented, {visible} visible")
        # The same 2^16 blades with a quarter of the pixels (GrassWidget(pixel_ratio=0.5)).
        kernel_execute(page, "w.view.browser_view.pixel_ratio = 0.5")
        poll(lambda: engine_info(page)["canvas"] == [320, 240], "the canvas to render 320 x 240", 30, 0.3, page=page)
        page.wait_for_timeout(1500)
        fps = presented_fps(page, WINDOW_S)
        result["fps"]["65536@pixel_ratio_0.5"] = {"frames_per_s": round(fps, 2)}
        print(f"   65536 blades at pixel_ratio 0.5: {fps:6.2f} frames/s presented")
        result["adapter"] = engine_info(page)["adapter"]
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
        Path(args.out).write_text(json.dumps(result, indent=2) + "\n")
        try:  # the page may still be busy drawing 2^18 blades on a CPU adapter
            page.goto("about:blank", timeout=120_000)
        finally:
            server.shutdown_kernels()
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
