"""A student's functions in the browser engine, in real Chromium: ``ex.widget(code, backend="browser")``
runs them in the page's WebGPU, giving the kernel engine's physics with the same functions, and not the
stock physics."""

from __future__ import annotations

import os
import sys

import pytest

from .kernel_calls import kernel_execute, wait_for_kernel
from .notebook_actions import leave_notebook, open_notebook, run_all_cells, write_notebook

pytestmark = pytest.mark.browser

SIZE = (320, 240)



def test_the_browser_engine_runs_the_students_gravity(webgpu_browser, lab_server, browser_root):
    page = webgpu_browser.page
    write_notebook(browser_root / "exercise_browser.ipynb", [
        "import numpy as np\nimport grasswidget as gw\nfrom grasswidget.gpu.field import GrassField\n"
        "ex = gw.exercise('forces')\n"
        "wrong = ex.solution().replace('return d / max(length(d), 1e-12) * magnitude;', "
        "'return -3.0 * d / max(length(d), 1e-12) * magnitude;')\n"
        f"w = ex.widget(wrong, blades=512, size={SIZE}, backend='browser')\nw",
    ])
    try:
        open_notebook(page, lab_server, "exercise_browser.ipynb")
        run_all_cells(page, timeout=120)
        status = wait_for_kernel(page, "w.view.gpu_status", predicate=lambda s: s["state"] != "", timeout=60)
        assert status["state"] == "ok", status
        out = kernel_execute(page, """
w.pause()
w.params.wind_strength = 0.0
w.reset_blades()
w.step(120)
mine = w.read_state()
b = w.view.engine_widget.blades
def run(overrides):
    field = GrassField(b, params=w.params.copy())
    field.set_function_overrides(overrides)
    field.step(120)
    s = field.read_state()
    field.release()
    return s
same, stock = run(w.function_overrides), run(None)
err = float((np.abs(mine['v2'] - same['v2']).max(axis=1) / b.height).max())
off = float((np.abs(mine['v2'] - stock['v2']).max(axis=1) / b.height).max())
print('EXERCISE', err, off)
""", timeout=180)
        err, off = map(float, out.stdout.split("EXERCISE")[1].split())
        print(f"\n[exercise, browser engine] |v2 browser - v2 kernel| <= {err:.2e} h with the student's gravity; "
              f"{off:.2f} h from the stock physics")
        assert err < 1e-4 and off > 0.05
    except BaseException:
        from .chromium import save_debug_artifacts

        out_dir = save_debug_artifacts(page, os.environ.get("GW_ARTIFACTS_DIR") or browser_root / "artifacts",
                                       "exercise_browser", webgpu_browser, lab_server)
        print(f"\n[exercise, browser engine] debug artifacts in {out_dir}")
        raise
    finally:
        try:
            leave_notebook(page, lab_server, reload=sys.exc_info()[0] is not None)
        except Exception:
            pass
