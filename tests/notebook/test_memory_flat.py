"""Memory stays flat over blade-count changes and widgets made and closed (issue 37, item 6).

Three leaks, each found and fixed at its cause (docs/design.md, "Memory"):

- the shared params kept every released GrassScene alive through its sun observer
  (1.2 MiB a ``set_blades``, more with larger counts);
- pygfx's render state died with each renderer, so every new scene compiled its render
  pipelines again into pygfx's caches (2.6 MiB a drawn scene on lavapipe);
- ipywidgets' close leaves a widget's own Layout and Style open, and jupyter-rfb never closed
  its canvas's Layout and output widget: about 130 widgets and their comms stayed in
  ipywidgets' registry for every GrassWidget closed (0.36 MiB a widget).

The soak test runs ``benchmarks/memory_flat.py`` (one process per loop, so one loop's freed
memory cannot hide another's growth) with fewer calls than the benchmark's 1,000 / 500 (120, 120
and 90: 17 s on a quiet machine, about 60 s at load 8; the full counts take 78 s quiet), enough that
the code of before grew by 239, 132 and 89 MB, and bounds the growth after the first 50 calls at 20 MB.
"""

from __future__ import annotations

import gc
import json
import os
import runpy
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "benchmarks" / "memory_flat.py"
#: The bound on resident memory growth after the first 50 calls of each loop (MB).
GROWTH_BOUND_MB = 20.0
#: (loop, calls): set_blades calls over 1,024 - 16,384 blades, or widgets made and closed.
SOAK = (("widget_set_blades", 120), ("scene_set_blades", 120), ("widget_create_close", 90))

pytestmark = pytest.mark.skipif(not os.path.exists("/proc/self/statm"), reason="needs /proc/self/statm (Linux)")


def _make(kind):
    import grasswidget as gw

    if kind == "compare":
        return gw.compare({"calm": {}, "windy": {"wind_strength": 4.0}}, blades=1024, size=(64, 48))
    return gw.GrassWidget(blades=1024, size=(64, 48), backend=kind)


@pytest.mark.parametrize("kind", ["kernel", "browser", "compare"])
def test_a_closed_widget_leaves_no_ipywidget_open(kind):
    """Every ipywidget a GrassWidget (either engine) or a comparison made is closed with it:
    its controls, their Layouts and Styles, the canvas's and jupyter-rfb's output widget."""
    from grasswidget import compat

    registry = compat.widget_registry()
    _make(kind).close()  # the first one may make module-level widgets once
    gc.collect()
    before = set(registry)
    w = _make(kind)
    made = set(registry) - before
    assert len(made) > 100  # the panel's controls and their layouts: what closing must undo
    w.close()
    gc.collect()
    left = [type(registry[k]).__name__ for k in set(registry) - before]
    assert left == [], f"{len(left)} widgets left open: {sorted(set(left))}"


@pytest.mark.slow
@pytest.mark.parametrize("loop,calls", SOAK, ids=[name for name, _ in SOAK])
def test_resident_memory_stays_flat(loop, calls, tmp_path):
    out = tmp_path / "memory.json"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    proc = subprocess.run([sys.executable, str(SCRIPT), "--loops", loop, "--calls", str(calls),
                           "--widgets", str(calls), "--warmup", "50", "--draw-every", "10", "--out", str(out)],
                          capture_output=True, text=True, cwd=ROOT, env=env, timeout=600, check=False)
    tail = (proc.stdout + proc.stderr)[-3000:]
    assert proc.returncode == 0, f"the process died (exit {proc.returncode}):\n{tail}"
    (result,) = json.loads(out.read_text())["loops"]
    assert result["loop"] == loop and result["calls"] == calls
    if loop == "widget_create_close":
        assert result["open_ipywidgets"] == 0, result
    else:  # the last field is the last count asked for, and it draws
        counts = runpy.run_path(str(SCRIPT))["COUNTS"]
        assert result["blade_count"] == counts[(calls - 1) % len(counts)]
        assert result["visible"] > 0, result
    assert result["growth_mb"] < GROWTH_BOUND_MB, (
        f"{loop}: resident memory grew {result['growth_mb']} MB over {calls - 50} calls "
        f"({result['mib_per_call']} MiB a call)")
