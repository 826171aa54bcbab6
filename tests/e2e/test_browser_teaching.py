"""The teaching views (frozen culling, colour by, the inspector) in the browser engine, in a real JupyterLab +
Chromium (WebGPU on SwiftShader), one notebook for both tests.

* Frozen culling: after freezing at one camera and flying above the field, the
  browser's visible count stays the frozen one, equals the NumPy reference
  (``reference.cull_reason``) and the kernel engine (a GrassField on lavapipe
  frozen with the same camera, from the browser's state), and the frozen frustum
  shows as white lines in the screenshot (gone after unfreezing).
* The blade inspector: ``w.read_inspected()`` of a browser widget equals
  ``GrassScene.read_inspected()`` for the same state, parameters, step count and
  ball (within 1e-5 + 5e-4 of each value's size), and its arrows show in their colours in the screenshot (gone after
  ``inspect([])``). Colour by LOD / cull test is checked in test_browser_engine.py.

Screenshots go to ``$GW_ARTIFACTS_DIR`` (else the Lab root's ``artifacts`` folder):
``browser_frozen_frustum.png`` and ``browser_inspector.png``.
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest

from .kernel_calls import kernel_eval, kernel_execute, wait_for_kernel
from .notebook_actions import leave_notebook, open_notebook, run_all_cells, write_notebook
from .polling import poll

pytestmark = pytest.mark.browser

N_BLADES = 2048
SIZE = (360, 270)
#: Where culling is frozen: inside the field, looking across it (it culls about half).
FROZEN_AT = {"position": (-5.0, 1.5, 5.0), "target": (3.0, 0.5, -2.0)}
#: High above the field, looking down: the whole field and the frozen camera in view.
ABOVE = {"position": (0.0, 28.0, 0.5), "target": (0.0, 0.0, 0.0)}


@pytest.fixture(scope="module")
def teaching_page(browser_root, lab_server, webgpu_chromium):
    write_notebook(browser_root / "browser_teaching.ipynb", [
        "import numpy as np\nimport grasswidget as gw\n"
        f"w = gw.GrassWidget({N_BLADES}, backend='browser', size={SIZE}, pixel_ratio=1)\nw",
    ])
    browser = webgpu_chromium
    page = browser.page
    try:
        open_notebook(page, lab_server, "browser_teaching.ipynb")
        run_all_cells(page, timeout=120)
        status = wait_for_kernel(page, "w.view.gpu_status", predicate=lambda s: s["state"] != "", timeout=60)
        assert status["state"] == "ok", status
        wait_for_kernel(page, "w.stats['visible'] is not None", True, timeout=60)
        yield page
    except BaseException:
        _save_failure(page, browser, lab_server, browser_root)
        raise
    finally:
        try:
            leave_notebook(page, lab_server, reload=sys.exc_info()[0] is not None)
        except Exception:
            pass


def _save_failure(page, browser, server, root):
    from .chromium import save_debug_artifacts

    out = save_debug_artifacts(page, _artifacts(root), "browser_teaching", browser, server)
    print(f"\n[browser teaching] debug artifacts in {out}\n" + "\n".join(browser.console[-30:]))


def _artifacts(root):
    out = os.environ.get("GW_ARTIFACTS_DIR") or str(root / "artifacts")
    os.makedirs(out, exist_ok=True)
    return out


def _canvas(page):
    import imageio.v3 as iio

    loc = page.locator("canvas.grasswidget-canvas").first
    loc.scroll_into_view_if_needed()
    return iio.imread(loc.screenshot(), extension=".png")[..., :3].astype(int)


def _pixels(points, camera, size):
    """(column, row, inside) of world points in a view of ``size`` from ``camera`` (a dict)."""
    from grasswidget.core.teaching import camera_view_proj

    vp = camera_view_proj(camera["position"], camera["target"], camera["fov_deg"], camera["near"], camera["far"],
                          size[0] / size[1])
    c = np.c_[points, np.ones(len(points))] @ vp.T
    ndc = c[:, :2] / c[:, 3:]
    col = np.floor((ndc[:, 0] + 1) / 2 * size[0]).astype(int)
    row = np.floor((1 - ndc[:, 1]) / 2 * size[1]).astype(int)
    inside = (col >= 2) & (col < size[0] - 2) & (row >= 2) & (row < size[1] - 2) & (c[:, 3] > 0)
    return col, row, inside


def _stats_after(page, n=3):
    """The visible counts of ``n`` stats messages from the browser (about 0.5 s apart), after
    two more (whose counts may have been read back before the last change reached the browser)."""
    kernel_execute(page, "if '_seen' not in globals():\n    _seen = []\n"
                         "    w.view.engine_widget.on('stats', lambda m: _seen.append(sum(m['visible'] or [-1])))")
    start = kernel_eval(page, "len(_seen)")
    wait_for_kernel(page, "len(_seen)", predicate=lambda k: k >= start + n + 2, timeout=30)
    return kernel_eval(page, "_seen[-%d:]" % n)


def test_frozen_culling_in_the_browser(teaching_page, browser_root):
    page = teaching_page
    out = kernel_execute(page, f"""
from grasswidget.core import reference as ref
from grasswidget.gpu.scene import GrassScene
w.pause()
w.params.cull_occlusion = False  # the paper's three tests, as the NumPy reference's cull_reason knows them
w.params.wind_field, w.params.wind_strength = 'wave', 8.0
w.step(90)
w.camera_state = {FROZEN_AT!r}
w.culling_frozen = True
frozen = w.view.frozen_camera
state = w.read_state()
reason = ref.cull_reason(state, w.params, frozen.view_proj, frozen.position)
scene = GrassScene(w.view.engine_widget.blades, size={SIZE}, params=w.params.copy())
scene.field.write_state(state)
scene.field.freeze_culling(frozen)
scene.look({ABOVE['position']!r}, {ABOVE['target']!r})
scene.render()
print('COUNTS', int((reason == 0).sum()), scene.visible_count(), frozen.viewport_size)
scene.release()
""", timeout=120)
    reference, kernel, viewport = out.stdout.split("COUNTS")[1].split(maxsplit=2)
    reference, kernel = int(reference), int(kernel)
    assert 200 < reference < N_BLADES - 200, reference  # the frozen view culls some and keeps some
    assert "360" in viewport and "270" in viewport, viewport
    at_frozen = _stats_after(page)
    kernel_execute(page, f"w.camera_state = {ABOVE!r}")
    above = _stats_after(page)
    print(f"\n[browser teaching] frozen culling: visible at the frozen camera {at_frozen}, from above {above}; "
          f"NumPy reference {reference}, kernel engine {kernel}")
    for count in at_frozen + above:
        assert abs(count - reference) <= 2 and abs(count - kernel) <= 2, (count, reference, kernel)

    # The frozen frustum: white lines from the frozen camera's position across the field.
    camera = kernel_eval(page, "dict(w.view.engine_widget.camera)")
    frozen_lines = poll(lambda: (lambda px: (bool((px >= 245).all(axis=-1).sum() > 150), px))(_canvas(page)),
                        "the frozen frustum to show as white lines", 20, 0.3, page=page)
    white = (frozen_lines >= 245).all(axis=-1)
    seg = np.asarray(kernel_eval(page, "frozen.segments().tolist()"), np.float64)
    t = np.linspace(0.002, 0.08, 16)[:, None]
    along = np.concatenate([seg[2 * k] + t * (seg[2 * k + 1] - seg[2 * k]) for k in range(8, 12)])  # the 4 side edges
    col, row, inside = _pixels(along, camera, SIZE)
    hits = [white[max(r - 2, 0): r + 3, max(c - 2, 0): c + 3].any() for c, r in zip(col[inside], row[inside])]
    print(f"[browser teaching] {white.sum()} white pixels; {np.sum(hits)} of {len(hits)} points on the frustum's "
          "side edges drawn white")
    assert len(hits) >= 12 and np.mean(hits) > 0.8
    kernel_execute(page, "w.culling_frozen = False")
    after = _stats_after(page)
    unfrozen = poll(lambda: (lambda px: (bool((px >= 245).all(axis=-1).sum() < white.sum() / 4), px))(_canvas(page)),
                    "the frustum lines to go after unfreezing", 20, 0.3, page=page)
    assert all(abs(c - reference) > 20 for c in after[-1:]), (after, reference)  # culls for the live camera again
    import imageio.v3 as iio

    out_dir = _artifacts(browser_root)
    iio.imwrite(os.path.join(out_dir, "browser_frozen_frustum.png"),
                np.concatenate([frozen_lines, unfrozen], axis=1).astype(np.uint8))
    assert "not available" not in kernel_eval(page, "w.panel.message_line.value")


def test_inspector_in_the_browser(teaching_page, browser_root):
    page = teaching_page
    out = kernel_execute(page, f"""
from grasswidget.gpu.scene import GrassScene
w.pause()
w.culling_frozen = False
w.reset_blades()
w.camera_state = {{'position': (0.0, 2.6, 6.0), 'target': (0.0, 0.8, 0.0)}}
w.params.wind_field, w.params.wind_strength = 'wave', 8.0
b = w.view.engine_widget.blades
near = np.flatnonzero((np.abs(b.v0[:, 0]) < 1.5) & (np.abs(b.v0[:, 2] - 1.0) < 1.5))
ids = [int(i) for i in near[:6]]
w.step(41)
# A ball just put over the first blade's root: the next step pushes that blade (and a neighbour).
w.ball.enabled = True
w.ball.set_radius(0.8)
w.ball.move_to(float(b.v0[ids[0], 0]) + 0.2, float(b.v0[ids[0], 2]))
# A crowd (set_array) beside the ball, two of its spheres over inspected blades: more spheres than
# fit one cell, so the browser's inspector looks the collisions up in a grid of many cells.
rng = np.random.default_rng(7)
crowd = np.column_stack([rng.uniform(-9, 9, 30), np.full(30, 0.45), rng.uniform(-9, 9, 30), np.full(30, 0.5)])
crowd[:2, 0], crowd[:2, 2] = b.v0[ids[2:4], 0] + 0.1, b.v0[ids[2:4], 2]
view = w.view.engine_widget
view.colliders.set_array(crowd)
view.colliders_changed()
grid_cells = int(np.prod(np.frombuffer(view.collider_grid, np.uint32)[:2]))
w.inspect(ids)
mine = w.read_inspected()
raw = w.view.engine_widget.read_state()
scene = GrassScene(b, size={SIZE}, params=w.params.copy())
scene.field.write_state(raw)
scene.field.step_count = raw['step_count']
scene.colliders = list(w.view.engine_widget.colliders)
scene.colliders.set_array(crowd)
scene.inspect(ids)
scene.render()
theirs = scene.read_inspected()
scene.release()
worst, worst_key = 0.0, None
for m, t in zip(mine, theirs):
    assert m.keys() == t.keys() and m['id'] == t['id']
    for k in m:
        a, c = np.asarray(m[k], np.float64), np.asarray(t[k], np.float64)
        e = float((np.abs(a - c) / (1e-5 + 5e-4 * np.abs(c).max())).max())
        if e > worst:
            worst, worst_key = e, (m['id'], k, a.tolist(), c.tolist())
pushed = sum(float(np.linalg.norm(m['collision']) > 0) for m in mine)
view.colliders.set_array([])
view.colliders_changed()
print('INSPECT', len(mine), len(theirs), worst, pushed, raw['step_count'], grid_cells)
print('WORST', worst_key)
print('EXAMPLE', {{k: np.round(v, 4).tolist() if hasattr(v, 'tolist') else v for k, v in mine[0].items()}})
""", timeout=180)
    n_mine, n_theirs, worst, pushed, steps, grid_cells = out.stdout.split("INSPECT")[1].split("\n")[0].split()
    print(f"\n[browser teaching] inspector: {n_mine} blades after {steps} steps; worst |browser - kernel| = "
          f"{float(worst):.2f} x (1e-5 + 5e-4 |value|) at {out.stdout.split('WORST')[1].splitlines()[0].strip()}; "
          f"{pushed} pushed by the ball and a crowd of 30 (grid of {grid_cells} cells)\n"
          f"[browser teaching] {out.stdout.split('EXAMPLE')[1].strip()}")
    assert int(n_mine) == int(n_theirs) == 6
    # Within float32 (SwiftShader's sin/cos of the wave wind differ from lavapipe's by ~1e-4 relative).
    assert float(worst) <= 1.0
    assert float(pushed) >= 3  # the collision arrows are compared with real pushes (ball, crowd), not zeros
    assert int(grid_cells) > 1  # the crowd's grid, not the one cell of a few spheres

    # The arrows in the screenshot: gravity, recovery and wind in their colours, gone after inspect([]).
    from grasswidget.core.teaching import INSPECTOR_COLORS, hex_to_rgb

    def arrow_pixels(px):
        return {name: int((np.abs(px - np.array(hex_to_rgb(INSPECTOR_COLORS[name]))).max(axis=-1) <= 24).sum())
                for name in ("gravity", "recovery", "wind")}

    shot = poll(lambda: (lambda px: (bool(min(arrow_pixels(px).values()) >= 15), px))(_canvas(page)),
                "the inspector's arrows in their colours", 20, 0.3, page=page)
    seen = arrow_pixels(shot)
    kernel_execute(page, "w.inspect([])")
    assert kernel_eval(page, "w.read_inspected()") == []
    cleared = poll(lambda: (lambda px: (bool(max(arrow_pixels(px).values()) <= 5), px))(_canvas(page)),
                   "the arrows to go after inspect([])", 20, 0.3, page=page)
    print(f"[browser teaching] arrow pixels inspecting {seen}, after inspect([]) {arrow_pixels(cleared)}")
    import imageio.v3 as iio

    iio.imwrite(os.path.join(_artifacts(browser_root), "browser_inspector.png"),
                np.concatenate([shot, cleared], axis=1).astype(np.uint8))
    assert "not available" not in kernel_eval(page, "w.panel.message_line.value")
