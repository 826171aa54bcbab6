"""Start-up benchmark: import time, the widget's first frame, the live page's first frame.

* import: wall time of ``python -c "import grasswidget"`` (the pure core; GPU code
  loads on first use) and of ``import grasswidget.notebook.widget`` (ipywidgets, anywidget,
  pygfx, jupyter-rfb), against ``python -c pass``; the median of --repeat runs;
* the widget's first frame, in JupyterLab + headless Chromium: from "run all cells"
  to the first frame in the page, for the kernel engine (the first jupyter-rfb
  image) and the browser engine (WebGPU on SwiftShader; the engine's first
  presented frame), 4096 blades at 640 x 480;
* the live page: seconds to write it (``save_html``, with and without the still
  picture), its size, and from navigation to the first presented frame (the
  engine's own milestone, ms since navigation start) at 4096 and 65536 blades.

Usage (from the repository root)::

    .venv/bin/python benchmarks/startup.py [--repeat 5] [--out PATH]

Prints a table and writes benchmarks/results/startup-lavapipe+swiftshader-<date>.json (the kernel's adapter,
then the browser's; or ``--out``). JupyterLab and Chromium are driven by benchmarks/lab.py. On this machine (CPU Vulkan, SwiftShader) the
absolute times say little about a GPU; compare ratios within one run.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402  (benchmarks/common.py)
from lab import (  # noqa: E402  (benchmarks/lab.py)
    Browser,
    JupyterLabServer,
    StaticServer,
    engine_state,
    open_notebook,
    poll,
    run_all_cells,
    wait_for_frames,
    write_notebook,
)

common.use_this_checkout()
ROOT = common.ROOT
SIZE = (640, 480)
WIDGET_BLADES = 4096
PAGE_BLADES = (4096, 1 << 16)


def import_times(repeat):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}

    def wall(code):
        runs = common.time_frames(lambda: subprocess.run([sys.executable, "-c", code], check=True, env=env, cwd=ROOT,
                                                         capture_output=True), repeat, warmup=0)
        return round(common.median(runs["wall_ms"]) / 1e3, 3)

    base = wall("pass")
    return {"python_pass_s": base, "import_grasswidget_s": wall("import grasswidget"),
            "import_grasswidget_widget_s": wall("import grasswidget.notebook.widget")}


def widget_first_frames(root):
    out = {}
    write_notebook(root / "kernel.ipynb", [f"import grasswidget as gw\nw = gw.GrassWidget({WIDGET_BLADES}, size={SIZE})\nw"])
    write_notebook(root / "browser.ipynb", [
        f"import grasswidget as gw\nw = gw.GrassWidget({WIDGET_BLADES}, backend='browser', size={SIZE})\nw"])
    env = {"PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    with JupyterLabServer(root, env=env) as server:
        with Browser() as b:
            page = b.page
            open_notebook(page, server, "kernel.ipynb")  # counts the kernel engine's frames from here
            t0 = time.perf_counter()
            run_all_cells(page, timeout=180)
            wait_for_frames(page, 1, timeout=120, index=0)
            out["kernel_engine_run_to_first_frame_s"] = round(time.perf_counter() - t0, 2)
            page.goto("about:blank")
            server.shutdown_kernels()
        with Browser(webgpu=True) as b:
            page = b.page
            open_notebook(page, server, "browser.ipynb")
            t0 = time.perf_counter()
            run_all_cells(page, timeout=180)
            info = poll(lambda: (lambda e: (bool(e and e["timing"].get("first_frame")), e))(engine_state(page)),
                        "the browser engine's first frame", 180, 0.05)
            out["browser_engine_run_to_first_frame_s"] = round(time.perf_counter() - t0, 2)
            t = info["timing"]
            out["browser_engine_created_to_first_frame_s"] = round((t["first_frame"] - t["created"]) / 1000, 2)
            page.goto("about:blank")
            server.shutdown_kernels()
    return out


def live_pages(root):
    from grasswidget.tools.html_export import save_html

    rows = []
    with StaticServer(root) as static, Browser(webgpu=True) as b:
        for n in PAGE_BLADES:
            path = root / f"meadow_{n}.html"
            t0 = time.perf_counter()
            save_html(path, n, size=SIZE, still=False)
            t_plain = time.perf_counter() - t0
            t0 = time.perf_counter()
            save_html(path, n, size=SIZE, still=True)
            t_still = time.perf_counter() - t0
            page = b.page
            page.goto(static.url_for(path.name))
            info = poll(lambda: (lambda e: (bool(e and e["timing"].get("first_frame")), e))(engine_state(page)),
                        f"the live page's first frame at {n} blades", 180, 0.05)
            t = info["timing"]
            rows.append({"blades": n, "adapter": engine_state(page, "e && e.adapterText"),
                         "page_mib": round(path.stat().st_size / 2 ** 20, 2),
                         "save_s": round(t_plain, 2), "save_with_still_s": round(t_still, 2),
                         "navigation_to_first_frame_s": round(t["first_frame"] / 1000, 2),
                         "engine_created_s": round(t["created"] / 1000, 2),
                         "pipelines_compiled_s": round((t["pipelines"] - t["device"]) / 1000, 2)})
            page.goto("about:blank")
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    common.add_out_argument(ap, "startup")
    ap.add_argument("--repeat", type=int, default=5, help="runs of each import timed (median; default 5)")
    args = ap.parse_args(argv)
    if args.repeat < 1:
        ap.error(f"--repeat must be >= 1; got {args.repeat}")
    report = {}
    report["import"] = import_times(args.repeat)
    with tempfile.TemporaryDirectory(prefix="gw-startup-") as tmp:
        report["widget_first_frame"] = widget_first_frames(Path(tmp))
        report["live_page"] = live_pages(Path(tmp))
    for section in ("import", "widget_first_frame"):
        for k, v in report[section].items():
            print(f"{section:20s} {k:45s} {v}")
    for row in report["live_page"]:
        print("live_page           ", row)
    kernel = common.kernel_adapter()
    common.save("startup", report, {"kernel": kernel, "browser": report["live_page"][0].get("adapter")}, args.out,
                machine=f"{common.machine_tag(kernel)}+swiftshader")


if __name__ == "__main__":
    main()
