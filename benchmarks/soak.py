"""Soak benchmark: a playing GrassWidget in JupyterLab + Chromium for minutes, with interaction.

Issue 20: the default ``GrassWidget(blades=8192)`` left playing grew the kernel
by about 16 MB a second on lavapipe. This runs the widget (``--engine kernel``:
pygfx renders in the kernel and streams frames; ``--engine browser``: WebGPU in
the page) in a real JupyterLab + Chromium (driven by benchmarks/lab.py) for
``--minutes``, interacting all the time, and samples every ``--interval`` seconds:

* the kernel's resident memory (``/proc/<kernel pid>/statm``, MB);
* frames delivered over the interval (kernel engine: new frames shown by the
  page's jupyter-rfb view; browser engine: frames the engine presented), per second;
* the browser: resident memory and PSS of every Chromium process by type (browser,
  renderer, gpu-process, utility...; PSS counts shared pages once), and the page's
  JavaScript heap (``Runtime.getHeapUsage`` through the DevTools protocol);
* the machine's load average (this machine is shared: figures are noisy).

Interaction, one action every ``--action-every`` seconds in turn: a mouse drag on
the view (orbit), a ``wind_strength`` slider move, a ``stiffness_scale`` slider
move, and every fourth action a blade-count change with the arrow keys on the
``blades`` slider (alternating ``--blades`` and twice that, the control's
power-of-two stops; its Apply clicked where the panel asks first). The sphere is switched on and set rolling at the start (the
``sphere`` checkbox and the ``Roll`` button) and rolls all the time.

Targets (issue 20): kernel memory flat after the first minute (growth under
50 MB over the run), frames/s steady. The summary reports both.

Usage (from the repository root)::

    .venv/bin/python benchmarks/soak.py --engine kernel --minutes 10
    .venv/bin/python benchmarks/soak.py --engine browser --minutes 10

Prints one line per sample and a summary, and writes benchmarks/results/soak_<engine>-<machine>-<date>.json
(or ``--out``).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402  (benchmarks/common.py)
from lab import (  # noqa: E402  (benchmarks/lab.py)
    ENGINE_CANVAS,
    Browser,
    JupyterLabServer,
    click_button,
    drag,
    engine_state,
    frame_count,
    kernel_eval,
    open_notebook,
    panel_label,
    poll,
    run_all_cells,
    set_checkbox,
    set_slider,
    step_slider,
    view_locator,
    wait_for_frames,
    wait_for_kernel,
    write_notebook,
)

common.use_this_checkout()
ROOT = common.ROOT

#: Kernel memory may grow at most this much (MB) from the sample at one minute to the end.
GROWTH_TARGET_MB = 50.0
#: Frames/s of the last third of the run over the second third (after the first minute)
#: within this band count as steady.
STEADY_BAND = (0.75, 1.33)




# ---------------------------------------------------------------- /proc readings


def _read(path):
    try:
        with open(path) as f:
            return f.read()
    except OSError:
        return None


def resident_mb(pid) -> float | None:
    """Resident memory of ``pid`` (MB), or None if it is gone."""
    text = _read(f"/proc/{pid}/statm")
    return None if text is None else int(text.split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def pss_mb(pid) -> float | None:
    """Proportional set size of ``pid`` (MB; shared pages split between their users), or None."""
    text = _read(f"/proc/{pid}/smaps_rollup")
    if text is None:
        return None
    for line in text.splitlines():
        if line.startswith("Pss:"):
            return int(line.split()[1]) / 1024
    return None


def descendants(pid) -> list:
    """Every descendant process id of ``pid``."""
    children = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            stat = _read(f"/proc/{entry}/stat")
            if stat:
                children.setdefault(int(stat.rsplit(")", 1)[1].split()[1]), []).append(int(entry))
    out, todo = [], [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            out.append(child)
            todo.append(child)
    return out


def chromium_memory() -> dict:
    """{process type: {"count", "rss_mb", "pss_mb"}} of the Chromium processes this script started."""
    out = {}
    for pid in descendants(os.getpid()):
        # Chromium rewrites its children's command lines into one space-separated string.
        cmd = (_read(f"/proc/{pid}/cmdline") or "").replace("\0", " ").split()
        if not cmd or "chrom" not in os.path.basename(cmd[0]):
            continue
        kind = next((a.split("=", 1)[1] for a in cmd if a.startswith("--type=")), "browser")
        rss, pss = resident_mb(pid), pss_mb(pid)
        if rss is None:
            continue
        row = out.setdefault(kind, {"count": 0, "rss_mb": 0.0, "pss_mb": 0.0})
        row["count"] += 1
        row["rss_mb"] = round(row["rss_mb"] + rss, 1)
        row["pss_mb"] = round(row["pss_mb"] + (pss or 0.0), 1)
    return out


# ---------------------------------------------------------------- the run


def frames_delivered(page, engine) -> int:
    if engine == "kernel":
        return frame_count(page)
    return int(engine_state(page, "e && e.frames") or 0)


def view_of(page, engine):
    if engine == "kernel":
        return view_locator(page, 0)
    return page.locator(ENGINE_CANVAS).first


def summarize(samples, minutes) -> dict:
    """Growth after the first minute and frames/s steadiness from the samples."""
    after = [s for s in samples if s["t_s"] >= 60.0] or samples[-1:]
    first, last = after[0], samples[-1]
    growth = last["kernel_rss_mb"] - first["kernel_rss_mb"]
    rates = [s["frames_per_s"] for s in after if s["frames_per_s"] is not None]
    third = max(1, len(rates) // 3)
    early = sum(rates[third:2 * third]) / max(1, len(rates[third:2 * third])) if len(rates) >= 3 else None
    late = sum(rates[-third:]) / third if rates else None
    ratio = (late / early) if early and late is not None else None
    browser_pss = [round(sum(r["pss_mb"] for r in s["chromium"].values()), 1) for s in after]
    return {
        "minutes": minutes,
        "kernel_rss_first_mb": samples[0]["kernel_rss_mb"],
        "kernel_rss_at_1_min_mb": first["kernel_rss_mb"],
        "kernel_rss_end_mb": last["kernel_rss_mb"],
        "kernel_growth_after_1_min_mb": round(growth, 1),
        "kernel_growth_target_mb": GROWTH_TARGET_MB,
        "kernel_flat": growth < GROWTH_TARGET_MB,
        "frames_per_s_mean": round(sum(rates) / len(rates), 2) if rates else None,
        "frames_per_s_min": min(rates) if rates else None,
        "frames_per_s_max": max(rates) if rates else None,
        "frames_per_s_last_over_middle_third": round(ratio, 2) if ratio is not None else None,
        "frames_steady": ratio is not None and STEADY_BAND[0] <= ratio <= STEADY_BAND[1],
        "browser_pss_after_1_min_mb": browser_pss[0] if browser_pss else None,
        "browser_pss_end_mb": browser_pss[-1] if browser_pss else None,
        "js_heap_after_1_min_mb": after[0]["js_heap_used_mb"],
        "js_heap_end_mb": last["js_heap_used_mb"],
        "frames_total": sum(s["frames"] for s in samples),
        "actions_total": last["actions"],
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--engine", choices=("kernel", "browser"), default="kernel")
    ap.add_argument("--minutes", type=float, default=10.0, help="length of the soak (default 10)")
    ap.add_argument("--interval", type=float, default=30.0, help="seconds between samples (default 30)")
    ap.add_argument("--action-every", type=float, default=5.0, help="seconds between interactions (default 5)")
    ap.add_argument("--blades", type=int, default=8192, help="blade count of the widget (default 8192)")
    ap.add_argument("--blade-changes", action=argparse.BooleanOptionalAction, default=True,
                    help="every fourth action changes the blade count (default on; --no-blade-changes: "
                         "that action moves the gravity slider instead)")
    common.add_out_argument(ap, "soak_<engine>")
    args = ap.parse_args(argv)
    for name in ("minutes", "interval", "action_every"):
        if not getattr(args, name) > 0:
            ap.error(f"--{name.replace('_', '-')} must be > 0; got {getattr(args, name)}")
    if args.blades < 1:
        ap.error(f"--blades must be >= 1; got {args.blades}")

    root = Path(tempfile.mkdtemp(prefix="gw-soak-"))
    backend = ", backend='browser'" if args.engine == "browser" else ""
    write_notebook(root / "soak.ipynb", [
        f"import os\nimport grasswidget as gw\nw = gw.GrassWidget(blades={args.blades}{backend})\nw",
    ])
    env = {"PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
    samples, actions, error = [], 0, None
    counts = [args.blades, args.blades * 2]  # neighbouring stops of the blade-count control
    with JupyterLabServer(root, env=env) as server, Browser(webgpu=args.engine == "browser") as browser:
        page = browser.page
        open_notebook(page, server, "soak.ipynb")
        run_all_cells(page, timeout=180)
        if args.engine == "kernel":
            wait_for_frames(page, 5, timeout=120)
        else:
            wait_for_kernel(page, "w.view.gpu_status['state']", "ok", timeout=120)
        kernel_pid = int(kernel_eval(page, "os.getpid()"))
        adapter = kernel_eval(page, "__import__('grasswidget.gpu.adapter', fromlist=['x']).ensure_device()"
                                    ".adapter.summary") if args.engine == "kernel" else engine_state(page, "e && e.adapterText")
        cdp = browser.context.new_cdp_session(page)
        set_checkbox(page, "sphere", True)
        click_button(page, "Roll")
        wait_for_kernel(page, "w.ball.rolling", True, timeout=30)

        def act(k):
            nonlocal actions
            which = k % 4
            if which == 0:
                drag(page, view_of(page, args.engine), 60 if k % 8 == 0 else -60, 10)
            elif which == 1:
                set_slider(page, panel_label("wind_strength"), [3.0, 8.0, 12.5][k % 3])
            elif which == 2:
                set_slider(page, panel_label("stiffness_scale"), [0.8, 1.0, 1.6][k % 3])
            elif not args.blade_changes:
                set_slider(page, panel_label("gravity"), [9.8, 6.0, 14.0][k % 3])
            else:  # a blade-count change, every fourth action
                now = kernel_eval(page, "w.blade_count")
                count = counts[1] if now == counts[0] else counts[0]  # the other of the two stops
                step_slider(page, panel_label("blades"), 1 if count > now else -1)
                # A count the view would draw under its target frame rate asks first (the panel's Apply):
                # answer it as a person would, then wait for the kernel to hold the new count.
                apply = page.locator("button.jupyter-button").filter(has_text=re.compile(r"^\s*Apply\s*$"))
                asked = poll(lambda: (lambda n, shown: (n == count or shown, shown))(
                    kernel_eval(page, "w.blade_count"), apply.count() > 0 and apply.first.is_visible()),
                    f"{count} blades or the question whether to apply them", 60, 0.25, page=page)
                if asked:
                    apply.first.click()
                wait_for_kernel(page, "w.blade_count", count, timeout=120)
            actions += 1

        def sample(t0, frames0, frames_before, t_before):
            now = time.monotonic()
            frames = frames_delivered(page, args.engine)
            heap = cdp.send("Runtime.getHeapUsage")
            row = {
                "t_s": round(now - t0, 1),
                "kernel_rss_mb": round(resident_mb(kernel_pid), 1),
                "frames": frames - frames_before,
                "frames_per_s": round((frames - frames_before) / (now - t_before), 2) if now - t_before > 1.0 else None,
                "frames_since_start": frames - frames0,
                "blades": kernel_eval(page, "w.blade_count"),
                "render_scale": kernel_eval(page, "w.stats.get('scale')"),
                "frame_size": kernel_eval(page, "w.stats.get('frame_size')"),
                "js_heap_used_mb": round(heap["usedSize"] / 2**20, 1),
                "js_heap_total_mb": round(heap["totalSize"] / 2**20, 1),
                "chromium": chromium_memory(),
                "load_avg_1min": round(os.getloadavg()[0], 2),
                "actions": actions,
            }
            total = sum(r["pss_mb"] for r in row["chromium"].values())
            gpu = row["chromium"].get("gpu-process", {}).get("pss_mb")
            print(f"t={row['t_s']:6.1f}s kernel {row['kernel_rss_mb']:7.1f} MB | {row['frames_per_s']} frames/s "
                  f"({row['blades']} blades) | chromium PSS {total:7.1f} MB (gpu {gpu}) | JS heap "
                  f"{row['js_heap_used_mb']} MB | load {row['load_avg_1min']}", flush=True)
            return row, frames, now

        t0 = time.monotonic()
        frames0 = frames_delivered(page, args.engine)
        row, frames_before, t_before = sample(t0, frames0, frames0, t0)
        samples.append(row)
        end = t0 + 60.0 * args.minutes
        next_sample, k = t0 + args.interval, 0
        try:
            while time.monotonic() < end - 1e-3:
                act(k)
                k += 1
                next_action = time.monotonic() + args.action_every
                # wait for the next action or sample, keeping the page's event loop running
                while time.monotonic() < min(next_action, end):
                    if time.monotonic() >= next_sample:
                        row, frames_before, t_before = sample(t0, frames0, frames_before, t_before)
                        samples.append(row)
                        next_sample += args.interval
                        if next_sample < time.monotonic():  # an action took longer than an interval
                            next_sample = time.monotonic() + args.interval
                    page.wait_for_timeout(200)
            if time.monotonic() - t_before > 0.5 * args.interval:
                row, frames_before, t_before = sample(t0, frames0, frames_before, t_before)
                samples.append(row)
        except Exception as exc:  # keep what was measured, and why it stopped
            error = {"at_s": round(time.monotonic() - t0, 1), "message": str(exc)[:3000],
                     "kernel_alive": resident_mb(kernel_pid) is not None,
                     "server_log_tail": server.log_text(8000)}
            print(f"stopped at {error['at_s']} s: kernel alive: {error['kernel_alive']}\n{error['message']}\n"
                  f"--- server log tail ---\n{error['server_log_tail']}", file=sys.stderr)
        browser_version = browser.version
        server.shutdown_kernels()

    result = {
        "engine": args.engine,
        "widget": f"GrassWidget(blades={args.blades}{backend})",
        "browser": browser_version,
        "load_note": "shared with other engineers' test runs: load_avg_1min in each sample",
        "interval_s": args.interval,
        "action_every_s": args.action_every,
        "interaction": "drag, wind_strength slider, stiffness_scale slider, "
                       + (f"blades slider ({counts[0]} <-> {counts[1]})" if args.blade_changes else "gravity slider")
                       + " in turn; sphere rolling throughout",
        "summary": summarize(samples, args.minutes),
        "error": error,
        "samples": samples,
    }
    print(json.dumps(result["summary"], indent=2))
    common.save(f"soak_{args.engine}", result, adapter, args.out)
    if error is not None:
        sys.exit(f"the soak stopped early ({error['at_s']} s): {error['message'][:300]}")
    return result


if __name__ == "__main__":
    main()
