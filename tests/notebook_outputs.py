"""What each notebook must print and write when it runs, checked on the outputs of a real run.

The Run All test (``tests/e2e/test_notebooks_run_all.py``) runs every notebook in
JupyterLab, saves it, and hands its outputs here: one run of each notebook serves both
"every widget is alive and drawing" and "the notebook computed what its text says".
"""

from __future__ import annotations

import re
from pathlib import Path

#: For 03: each culling checkbox of the live widget, flipped, changes the picture it renders and the
#: blades drawn (the widget's own scene and camera, rendered offscreen twice so that occlusion culling settles).
#: The widget is paused and its blades put back at rest first: the tables count the rest pose, and a view
#: that drew a frame or two before the probe (the page asks for frames as soon as it shows the view) has
#: wind-blown tips crossing the frozen view's edges (about 3,090 blades drawn instead of 2,972).
LIVE_CULLING_PROBE = """
import numpy as _np
w.pause()
w.reset_blades()
def _look():  # offscreen at the view's size, without the supersample (the live view's look)
    w.scene.render_at(antialias=False)
    return w.scene.render_at(antialias=False), w.scene.visible_count()
print(f"LIVE start {_look()[1]}")
def _control(_name):  # a checkbox, or occlusion culling's auto / on / off choice
    return w.panel.switch_choices[_name].dropdown if _name in w.panel.switch_choices else w.panel.checkboxes[_name]
def _is_on(_name):
    _v = _control(_name).value
    return _v == "on" if isinstance(_v, str) else _v
def _flipped(_name):  # on -> off, off (or auto) -> on
    _v = _control(_name).value
    return ("off" if _v == "on" else "on") if isinstance(_v, str) else not _v
for _name in ("cull_orientation", "cull_frustum", "cull_distance", "cull_occlusion"):
    _before, _n_before = _look()
    _was_on, _kept = _is_on(_name), _control(_name).value
    _control(_name).value = _flipped(_name)
    _after, _n_after = _look()
    _control(_name).value = _kept
    _px = int((_np.abs(_before.astype(int) - _after.astype(int)).max(axis=2) > 24).sum())
    print(f"LIVE {_name} {int(_was_on)} {_n_before} {_n_after} {_px}")
"""

#: Pictures each notebook writes into ``output/`` beside itself (each must be a real file).
WRITTEN = {
    "01_tour": ("tour.png", "tour.gif"),
    "02_blade_model": ("inspector.png",),
    "03_culling": ("culling_birdseye.png",),
    "05_colliders_and_wind": ("trampled.png", "vortex.png", "planet.png"),
}


def output_text(nb) -> str:
    """Every stream and plain-text result of a run notebook's code cells, in order."""
    parts = []
    for cell in nb.cells:
        if cell.cell_type != "code":
            continue
        for o in cell.outputs:
            if o.output_type == "stream":
                parts.append(o.get("text", ""))
            elif o.output_type in ("execute_result", "display_data"):
                parts.append(o.get("data", {}).get("text/plain", ""))
    return "".join(parts)


def check_notebook_outputs(stem: str, nb, out_dir: Path, live_probe_text: str = "") -> None:
    """Assert what notebook ``stem`` must have printed (``nb``: the run notebook) and written
    (``out_dir``: its ``output/`` folder); ``live_probe_text``: what :data:`LIVE_CULLING_PROBE`
    printed in 03's kernel after the run."""
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs if o.output_type == "error"]
    assert not errors, f"{stem}: {errors[0].get('ename')}: {errors[0].get('evalue')}"
    for name in WRITTEN.get(stem, ()):
        assert (out_dir / name).stat().st_size > 1000, f"{stem} did not write output/{name}"
    text = output_text(nb)
    if stem == "02_blade_model":  # the inspector in calm air, in wind, under a ball
        assert "against a ball" in text and "collision push" in text
    if stem == "03_culling":  # each test seen from above through a frozen camera, with counts
        assert "drawn per LOD class, GPU" in text and "orientation" in text
        check_culling_counts(text)
        # the live view starts with the count of the tables' "all three" (same camera, same tests)
        assert int(re.search(r"LIVE start (\d+)", live_probe_text).group(1)) == culling_tables(text)[0]["all three"]
        live = re.findall(r"LIVE (\w+) ([01]) (\d+) (\d+) (\d+)", live_probe_text)
        assert len(live) == 4, live_probe_text[-500:]
        for name, was_on, n_before, n_after, changed_px in live:
            # unticking a test draws more blades (ticking one, fewer), and the picture changes
            more = int(n_after) > int(n_before)
            assert more == (was_on == "1") and int(changed_px) > 500, (name, was_on, n_before, n_after, changed_px)
    if stem == "05_colliders_and_wind":
        assert "refused: wind_wgsl line 2" in text  # the bad snippet's error names its line
    if stem in ("07_exercise_forces", "08_exercise_validation", "09_exercise_culling"):
        # nbgrader source notebooks: the code cell holds the teacher's answer (its solution region), so the
        # report passes and every points cell prints PASS for its function (the student copies: the
        # nbgrader workflow test, tests/tools/test_nbgrader_workflow.py)
        results = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs if o.output_type == "execute_result"]
        reports = [o["data"]["text/plain"] for o in results if "GradeReport" in o["data"].get("text/plain", "")]
        assert len(reports) == 1 and reports[0].endswith("passed>"), reports
        html = [o["data"]["text/html"] for o in results if "text/html" in o["data"]]
        assert "all passed" in html[0]
        points = [c for c in nb.cells if c.get("metadata", {}).get("nbgrader", {}).get("grade")]
        assert len(points) >= 3 and text.count("PASS  ") == len(points), text[-2000:]


def culling_tables(text):
    """The culling notebook's two count tables: {tests on: drawn} from the course camera, and from
    the frozen copy of it (the rows after the header naming "(culled by)")."""
    home, frozen, table = {}, {}, None
    for line in text.splitlines():
        if line.strip().startswith("tests on"):
            table = frozen if "culled by" in line else home
            continue
        m = re.match(r"\s*(none|orientation|frustum|distance|all three)\s+(\d+)\b", line)
        if m and table is not None:
            table[m.group(1)] = int(m.group(2))
        elif not m:
            table = None if not line.startswith(" ") else table
    return home, frozen


def check_culling_counts(text):
    """Both tables of 03 give the same counts for the same camera and tests, and they are the counts
    the NumPy reference gives for the preset's field and camera, computed here on its own."""
    import numpy as np

    import grasswidget as gw
    from grasswidget.core import reference as ref

    home, frozen = culling_tables(text)
    assert set(home) == {"none", "orientation", "frustum", "distance", "all three"}, home
    assert set(frozen) == {"orientation", "frustum", "distance", "all three"}, frozen
    assert all(frozen[k] == home[k] for k in frozen), (home, frozen)
    scene = gw.GrassScene.preset("cis565", blades=8192, size=(320, 240))
    try:
        assert scene.params.cull_distance_max == 40.0  # the preset's, which the notebook keeps
        state = scene.field.blades.rest_state()         # render() never advances time: the rest pose
        scene.freeze_culling()
        cam = scene.field.frozen_camera
        tests = {"orientation": ["cull_orientation"], "frustum": ["cull_frustum"], "distance": ["cull_distance"],
                 "all three": ["cull_orientation", "cull_frustum", "cull_distance"]}
        for label, names in tests.items():
            p = scene.params.copy()
            p.cull_occlusion = False
            for t in ("cull_orientation", "cull_frustum", "cull_distance"):
                setattr(p, t, t in names)
            kept = int(np.sum(ref.cull_reason(state, p, cam.view_proj, cam.position) == 0))
            assert home[label] == kept, (label, home[label], kept)
        assert home["none"] == scene.field.count
    finally:
        scene.release()
