"""Resident memory over many blade-count changes and many widgets made and closed (issue 37, item 6).

Three loops, each in this one process, each measured the same way: the process's resident
memory (RSS, /proc/self/statm) after the first ``--warmup`` calls (default 50) and after the
last, with ``gc.collect()`` every 10 calls (as a notebook's kernel collects now and then),
and the growth between them (MB, 2^20 bytes):

- ``widget_set_blades``: one GrassWidget (kernel engine, a 64 x 48 view), ``set_blades`` with
  counts cycling through 1,024 - 16,384; every ``--draw-every``-th call draws a frame (the
  widget's own draw function), so the new field's render pipelines are built too.
- ``scene_set_blades``: the same for a GrassScene (a new GrassScene and GrassField for each
  count, the previous one released), rendered every ``--draw-every``-th call.
- ``widget_create_close``: ``--widgets`` GrassWidgets (1,024 blades) made and closed; every
  ``--draw-every``-th one draws a frame before it closes.

Before the fixes of issue 37 on lavapipe: 1.2 MiB a set_blades (the shared params kept every
old scene alive), 2.6 MiB a drawn new scene (pygfx's render state died with each renderer, so
every scene compiled its render pipelines anew into pygfx's caches), 0.36 MiB a widget (about
130 ipywidgets Layouts and Styles per widget left open in ipywidgets' registry).
``tests/notebook/test_memory_flat.py`` runs this script and bounds the growth.

    python benchmarks/memory_flat.py [--calls 1000] [--widgets 500] [--draw-every 10]
                                     [--loops widget_set_blades,scene_set_blades,widget_create_close]
                                     [--out PATH]

Writes benchmarks/results/memory_flat-<machine>-<date>.json unless ``--out`` says otherwise.
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common  # noqa: E402  (benchmarks/common.py)

#: The blade counts the set_blades loops cycle through (1,024 - 16,384).
COUNTS = (1024, 4096, 16384, 2048, 8192, 1536, 12288)
#: The view size of every widget and scene (CSS px = pixels): small, the loops measure memory.
SIZE = (64, 48)
LOOPS = ("widget_set_blades", "scene_set_blades", "widget_create_close")


def resident_mb() -> float:
    """This process's resident memory (MB) from /proc/self/statm."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20


def _widget(gw, count):
    w = gw.GrassWidget(blades=count, size=SIZE)
    # What the page sends when the view is shown: the canvas gets its size, frames can be drawn.
    w.canvas.handle_event({"event_type": "resize", "width": SIZE[0], "height": SIZE[1], "pixel_ratio": 1.0})
    return w


def measure(name: str, calls: int, warmup: int, draw_every: int) -> dict:
    """Run loop ``name`` for ``calls`` calls; RSS after ``warmup`` calls and at the end."""
    import grasswidget as gw

    state = {}
    if name == "widget_set_blades":
        state["w"] = _widget(gw, COUNTS[-1])

        def call(i):
            state["w"].set_blades(COUNTS[i % len(COUNTS)])
            if i % draw_every == 0:
                state["w"].view.draw()

        def done():
            w = state["w"]
            w.view.draw()
            result = {"blade_count": w.blade_count, "visible": w.view.scene.visible_count()}
            w.close()
            return result
    elif name == "scene_set_blades":
        state["s"] = gw.GrassScene(COUNTS[-1], size=SIZE)

        def call(i):
            state["s"].release()
            state["s"] = gw.GrassScene(COUNTS[i % len(COUNTS)], size=SIZE)
            if i % draw_every == 0:
                state["s"].step(1)
                state["s"].render()

        def done():
            s = state["s"]
            s.render()
            result = {"blade_count": s.field.count, "visible": s.visible_count()}
            s.release()
            return result
    elif name == "widget_create_close":
        def call(i):
            w = _widget(gw, 1024)
            if i % draw_every == 0:
                w.view.draw()
            w.close()

        def done():
            from grasswidget import compat

            return {"open_ipywidgets": len(compat.widget_registry())}
    else:
        raise ValueError(f"loop must be one of {', '.join(LOOPS)}; got {name!r}")
    t0 = time.perf_counter()
    before = None
    for i in range(calls):
        call(i)
        if (i + 1) % 10 == 0:
            gc.collect()
        if i + 1 == warmup:
            gc.collect()
            before = resident_mb()
    gc.collect()
    after = resident_mb()
    seconds = time.perf_counter() - t0
    last = done()
    if before is None:
        raise ValueError(f"calls ({calls}) must exceed warmup ({warmup})")
    measured = calls - warmup
    return {"loop": name, "calls": calls, "warmup": warmup, "draw_every": draw_every,
            "rss_after_warmup_mb": round(before, 1), "rss_end_mb": round(after, 1),
            "growth_mb": round(after - before, 2), "mib_per_call": round((after - before) / measured, 4),
            "seconds": round(seconds, 1), **last}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--calls", type=int, default=1000, help="set_blades calls per set_blades loop (default 1000)")
    ap.add_argument("--widgets", type=int, default=500, help="widgets made and closed (default 500)")
    ap.add_argument("--warmup", type=int, default=50, help="calls before the first measurement (default 50)")
    ap.add_argument("--draw-every", type=int, default=10, help="draw a frame every N-th call (default 10)")
    ap.add_argument("--loops", default=",".join(LOOPS), help=f"comma-separated, of {', '.join(LOOPS)}")
    common.add_out_argument(ap, "memory_flat")
    args = ap.parse_args(argv)
    loops = [name for name in args.loops.split(",") if name]
    for name in loops:
        if name not in LOOPS:
            ap.error(f"--loops: {name!r} is not one of {', '.join(LOOPS)}")
    for flag, value in (("--calls", args.calls), ("--widgets", args.widgets)):
        if value <= args.warmup:
            ap.error(f"{flag} must exceed --warmup ({args.warmup}); got {value}")
    if args.draw_every < 1:
        ap.error(f"--draw-every must be >= 1; got {args.draw_every}")
    results = []
    for name in loops:
        calls = args.widgets if name == "widget_create_close" else args.calls
        results.append(measure(name, calls, args.warmup, args.draw_every))
        print(json.dumps(results[-1]), flush=True)
    from grasswidget.gpu.adapter import ensure_device

    summary = {"loops": results}
    common.save("memory_flat", summary, ensure_device().adapter.summary, args.out)
    return summary


if __name__ == "__main__":
    main()
