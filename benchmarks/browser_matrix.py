"""Issue 28's matrix in the browser engine, whatever runs it: the defaults (occlusion culling and
the compute rasterizer "auto", decided by the Python widget from the engine's own frame times)
against the four fixed combinations, per preset and blade count, windows interleaved in one run.

Shared by ``benchmarks/browser_engine.py --matrix`` (JupyterLab + Chromium on SwiftShader, the
widget in a kernel) and ``benchmarks/browser_engine_dawn.py --matrix`` (node + Dawn, the widget in
the benchmark's own process answering over stdin / stdout). Both hand :func:`run_matrix` a *page*:
an object with

* ``show(preset, blades, size)``: a playing ``GrassWidget(blades, preset=..., backend="browser",
  size=...)`` shown, its engine started (``gpu_status`` "ok");
* ``apply(occlusion, raster)``: ``w.params.cull_occlusion`` / ``w.params.compute_raster`` set
  (True, False or "auto");
* ``auto_state()``: ``(measuring, texts)`` of the widget's ``auto_switches`` (the trial running;
  the panel's words per switch);
* ``engine()``: the engine's counters: ``frames`` (frames completed), ``now`` (the page's clock, ms),
  ``visible`` (blades drawn per LOD class, read back), ``occluded``, ``rastered``,
  ``counts_switches`` (the switches of the frame those counts are of), ``counts_read_at`` (the page's clock when
  the newest read-back of the counts was issued), ``counts_pending`` (that read-back not done yet), ``adapter``;
* ``poll(check, what, timeout_s, interval_s)``: ``check()``'s first truthy value, or a timeout
  naming ``what``;
* ``hide()``: the widget closed.

Per row: every fixed setting drawn once (its pipelines compiled), "auto" left to decide (the
trial's seconds reported), then :data:`MATRIX_ROUNDS` rounds of the five settings, the order
rotated each round, each window at least 3 frames and ``window_s`` seconds after a warm-up frame:
frames/s of the engine's completed frames, and the counts read back in the window.
"""

from __future__ import annotations

import time

#: Rounds over the five settings; seconds a window lasts at least.
MATRIX_ROUNDS = 2
MATRIX_WINDOW_S = 2.0
#: (name, cull_occlusion, compute_raster): the defaults, then every fixed combination (bench --matrix's).
MATRIX_SETTINGS = (("defaults", "auto", "auto"), ("occl on, cr on", True, True), ("occl on, cr off", True, False),
                   ("occl off, cr on", False, True), ("occl off, cr off", False, False))
#: The "auto" trial's longest wait (s): SwiftShader's frames take seconds each.
DECISION_TIMEOUT_S = 600


def frames_per_s_after(page, warm_frames, min_frames, min_seconds):
    """Frames/s over at least ``min_frames`` frames and ``min_seconds``, after ``warm_frames`` frames
    (a setting's first frames: with occlusion culling the first one after it is switched on still
    draws every blade in its first phase)."""
    start = page.engine()["frames"]
    page.poll(lambda: page.engine()["frames"] >= start + warm_frames, "the warm-up frames", 300, 0.2)
    a = page.engine()

    def enough():
        e = page.engine()
        return e if e["frames"] >= a["frames"] + min_frames and e["now"] - a["now"] >= 1000 * min_seconds else None

    b = page.poll(enough, f"{min_frames} frames", 600, 0.2)
    return (b["frames"] - a["frames"]) * 1000.0 / (b["now"] - a["now"])


def counts_after(page, t_ms):
    """The engine's counters if its newest read-back of the counts was issued after ``t_ms`` (the page's clock) and
    is done, else None."""
    e = page.engine()
    return e if e["counts_read_at"] > t_ms and not e["counts_pending"] else None


def auto_decided(page):
    """Both "auto" switches decided (no trial running): their words, else None."""
    measuring, words = page.auto_state()
    done = not measuring and all(t.startswith(("auto (on:", "auto (off:")) for t in words.values())
    return words if done else None


def median(values):
    v = sorted(values)
    return v[len(v) // 2] if len(v) % 2 else sum(v[len(v) // 2 - 1:len(v) // 2 + 1]) / 2


def matrix_row(page, preset, n, size, rounds=MATRIX_ROUNDS, window_s=MATRIX_WINDOW_S, label=""):
    """One row of the matrix (see the module docstring); the widget is shown and closed here."""
    w, h = size
    page.show(preset, n, (w, h))
    try:
        for _label, occlusion, raster in MATRIX_SETTINGS[1:]:  # every path compiled once
            page.apply(occlusion, raster)
            frames_per_s_after(page, 2, 2, 0.5)
        page.apply("auto", "auto")
        t0 = time.monotonic()
        decided = page.poll(lambda: auto_decided(page), "the defaults' decisions", DECISION_TIMEOUT_S, 0.5)
        trial_s = time.monotonic() - t0
        fps = {name: [] for name, _o, _r in MATRIX_SETTINGS}
        counts = {name: [] for name, _o, _r in MATRIX_SETTINGS}
        for r in range(rounds):
            k = r % len(MATRIX_SETTINGS)
            for name, occlusion, raster in MATRIX_SETTINGS[k:] + MATRIX_SETTINGS[:k]:
                page.apply(occlusion, raster)
                applied_at = page.engine()["now"]  # the engine has the setting: its next frames draw with it
                fps[name].append(round(frames_per_s_after(page, 1, 3, window_s), 3))
                # the counts of a frame drawn in this window: a read-back issued after the setting, done (the engine
                # reads the counters back every half stats interval; the window can end before one was issued)
                c = page.poll(lambda: counts_after(page, applied_at), "the counts of a frame of this setting", 120, 0.1)
                counts[name].append({"drawn": sum(c["visible"] or []) + (c["rastered"] or 0),
                                     "occluded": c["occluded"], "rastered": c["rastered"],
                                     "switches": c["counts_switches"]})
                print(f"{label}{preset:>7} {n:>7} blades, {name:>16}: {fps[name][-1]:7.2f} frames/s, "
                      f"counts {counts[name][-1]}", flush=True)
        page.apply("auto", "auto")  # the defaults again: the decisions kept (the same context, no new trial)
        still = auto_decided(page)
        adapter = page.engine().get("adapter")
    finally:
        page.hide()
    med = {name: median(v) for name, v in fps.items()}
    best = max((name for name, _o, _r in MATRIX_SETTINGS[1:]), key=lambda k: med[k])
    row = {"preset": preset, "blades": n, "size": f"{w}x{h}", "frames_per_s": fps, "median_frames_per_s": med,
           "counts": counts, "best_fixed": best, "defaults_over_best": round(med["defaults"] / med[best], 3),
           "decided": decided, "decided_after_run": still, "trial_s": round(trial_s, 1), "adapter": adapter}
    print(f"{label}{preset:>7} {n:>7} blades: defaults {med['defaults']:.2f} frames/s, best fixed {best} "
          f"{med[best]:.2f}: defaults / best {row['defaults_over_best']:.2f}; decided {decided}", flush=True)
    return row


def run_matrix(page, rows, rounds=MATRIX_ROUNDS, window_s=MATRIX_WINDOW_S, label="", on_row=None):
    """The matrix over ``rows`` ((preset, blades, (width, height)) each) on ``page``: the JSON's
    "matrix" part (rounds, window, rows, adapter); ``on_row(matrix so far)`` after each row (e.g. to
    save what was measured before a later row fails)."""
    out = {"rounds": rounds, "window": f"at least 3 frames and {window_s} s after 1 warm-up frame",
           "playing": True, "settings": [list(s) for s in MATRIX_SETTINGS], "rows": []}
    for preset, n, size in rows:
        row = matrix_row(page, preset, n, size, rounds, window_s, label)
        out["rows"].append(row)
        out["adapter"] = row["adapter"]
        if on_row is not None:
            on_row(out)
    return out


def markdown_table(matrix) -> str:
    """The rows as benchmarks/README.md's table (median frames/s; defaults / best fixed)."""
    names = [name for name, _o, _r in MATRIX_SETTINGS]
    lines = ["| preset, size | blades | auto decided (occl / cr) | " + " | ".join(names) +
             " | best fixed | defaults / best | trial s |",
             "|---|---|---|" + "---|" * len(names) + "---|---|---|"]
    for row in matrix["rows"]:
        decided = row["decided"] or {}
        words = " / ".join(("on" if t.startswith("auto (on:") else "off") for t in
                           (decided.get("cull_occlusion", ""), decided.get("compute_raster", "")))
        n = row["blades"]
        blades = f"2^{n.bit_length() - 1}" if n & (n - 1) == 0 else str(n)
        cells = " | ".join(f"{row['median_frames_per_s'][name]:.1f}" for name in names)
        lines.append(f"| {row['preset']} {row['size']} | {blades} | {words} | {cells} | {row['best_fixed']} | "
                     f"{row['defaults_over_best']:.2f} | {row['trial_s']} |")
    return "\n".join(lines)
