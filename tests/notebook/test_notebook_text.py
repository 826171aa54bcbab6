"""The notebooks' words match the package: every name they mention exists, every control they
name is called that in the panel.

For every notebook in notebooks/ (a glob: notebooks added later are covered too), without a GPU:

* **controls** are named in the panel's words: the first column of a markdown table headed
  "control" (its **bold** items), and a "quoted" or **bold** name followed by slider, checkbox,
  button, dropdown, toggle or row, must be a label of the panel (``ControlPanel`` built
  headless from a ``GrassParams``, plus every ``description`` the notebook faces give a control,
  e.g. the ball's "sphere" and "Roll"), with or without its unit in brackets;
* **names** exist: ``VAR.attr`` where ``VAR`` is a widget, scene or params object made in the
  notebook's code (``w = gw.GrassWidget(...)``, ``scene = gw.GrassScene...``, ``p = scene.params``)
  or ``params``, in backticks in markdown and anywhere in code; ``VAR.params.name`` and
  ``GrassParams(name=...)``; ``w.panel.sliders["name"]``; and every snake_case name in backticks in
  markdown must be a ``GrassParams`` trait, a ``GrassWidget`` / ``GrassScene`` / ``GrassField``
  attribute, a public name of a grasswidget module, or a name the notebook's own code defines.
"""

from __future__ import annotations

import ast
import importlib
import pkgutil
import re
from functools import lru_cache
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")

ROOT = Path(__file__).resolve().parents[2]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))
NOTEBOOK_FACES = ROOT / "grasswidget" / "notebook"
CONTROL_WORDS = r"(?:slider|checkbox|button|dropdown|toggle|row)s?"


# ------------------------------------------------------------------ what the package offers

def _walk(widgets):
    todo = list(widgets)
    while todo:
        w = todo.pop(0)
        todo.extend(getattr(w, "children", ()))
        yield w


def _descriptions_in_source() -> set:
    """String constants given as a control's ``description`` (keyword or attribute) in the
    notebook faces' modules, e.g. the ball row's "sphere" and the play button's "Pause"/"Play"."""
    found = set()
    for path in NOTEBOOK_FACES.glob("*.py"):
        tree = ast.parse(path.read_text())
        values = []
        for node in ast.walk(tree):
            if isinstance(node, ast.keyword) and node.arg == "description":
                values.append(node.value)
            elif isinstance(node, ast.Assign) and any(isinstance(t, ast.Attribute) and t.attr == "description"
                                                      for t in node.targets):
                values.append(node.value)
        while values:  # a literal, or either branch of `"Pause" if playing else "Play"` (not a call's arguments)
            value = values.pop()
            if isinstance(value, ast.IfExp):
                values += [value.body, value.orelse]
            elif isinstance(value, ast.Constant) and isinstance(value.value, str):
                found.add(value.value)
        # row headings such as the looks row's "<b>looks</b>"
        found.update(re.findall(r"<b>([^<]+)</b>", path.read_text()))
    return {d for d in found if d.strip()}


@lru_cache(maxsize=1)
def panel_labels() -> frozenset:
    """Every label the panel shows (the control panel and the camera bar, built headless from a
    GrassParams and a stand-in owner with the widget's own traits), plus every literal
    ``description`` in the notebook faces' modules; each also without its unit in brackets."""
    import copy

    from traitlets import HasTraits

    from grasswidget.core.params import GrassParams
    from grasswidget.notebook.camera_bar import CameraBar
    from grasswidget.notebook.panel import ControlPanel
    from grasswidget.notebook.widget import GrassWidget

    # The widget's traits the panel and the camera bar edit (copies: the widget's own stay bound to it).
    owned = {n: copy.copy(t) for n, t in GrassWidget.class_traits().items()
             if n in ("time_scale", "culling_frozen", "playing", "camera_floor", "panel_folded")}
    Owner = type("Owner", (HasTraits,), {
        **owned,
        "target_fps": 24.0,
        # what the buttons would call: nothing is clicked here
        "__getattr__": lambda self, name: (lambda *args, **kwargs: None),
    })
    owner = Owner()
    panel = ControlPanel(GrassParams(), owner, owner, blade_count=16, max_blades=64, view_size=(640, 480))
    bar = CameraBar(owner, on_error=lambda err: None)
    try:
        labels = {w.description for w in _walk(panel.rows + [bar.row]) if getattr(w, "description", "")}
    finally:
        panel.close()
    labels |= _descriptions_in_source()
    labels |= {re.sub(r"\s*\([^)]*\)$", "", label) for label in labels}
    return frozenset(labels)


def _self_attributes(path: Path) -> set:
    """Names assigned as ``self.X = ...`` anywhere in a module."""
    tree = ast.parse(path.read_text())
    names = set()
    for node in ast.walk(tree):
        targets = node.targets if isinstance(node, ast.Assign) else [node.target] if isinstance(
            node, (ast.AnnAssign, ast.AugAssign)) else []
        for t in targets:
            for sub in ast.walk(t):
                if isinstance(sub, ast.Attribute) and isinstance(sub.value, ast.Name) and sub.value.id == "self":
                    names.add(sub.attr)
    return names


@lru_cache(maxsize=1)
def known() -> dict:
    """Names by kind: params (GrassParams traits and methods), widget, scene, and every public name."""
    from grasswidget.core.params import GrassParams
    from grasswidget.gpu.field import GrassField
    from grasswidget.gpu.scene import GrassScene
    from grasswidget.notebook.widget import GrassWidget

    traits = set(GrassParams.class_trait_names())
    params = traits | {n for n in dir(GrassParams) if not n.startswith("_")}
    widget = set(dir(GrassWidget)) | _self_attributes(NOTEBOOK_FACES / "widget.py")
    scene = set(dir(GrassScene)) | _self_attributes(ROOT / "grasswidget" / "gpu" / "scene.py")
    field = set(dir(GrassField)) | _self_attributes(ROOT / "grasswidget" / "gpu" / "field.py")
    public = set()
    import grasswidget

    public |= set(dir(grasswidget))
    for info in pkgutil.walk_packages(grasswidget.__path__, "grasswidget."):
        if info.name.endswith("__main__"):
            continue
        try:
            module = importlib.import_module(info.name)
        except Exception:  # a module that needs what this machine lacks: its names are not needed here
            continue
        public |= {n for n in dir(module) if not n.startswith("_")}
        for obj in vars(module).values():
            if isinstance(obj, type) and obj.__module__ == module.__name__:
                public |= {n for n in dir(obj) if not n.startswith("_")}
    return dict(traits=traits, params=params, widget=widget, scene=scene,
                all=traits | widget | scene | field | public)


# ------------------------------------------------------------------ what a notebook says

def _sources(path: Path):
    nb = nbformat.read(str(path), as_version=4)
    markdown = [c.source for c in nb.cells if c.cell_type == "markdown"]
    code = [c.source for c in nb.cells if c.cell_type == "code"]
    return markdown, code


def _variables(code: list) -> dict:
    """The notebook's objects by kind, from its assignments."""
    text = "\n".join(code)
    kinds = {"widget": set(), "scene": set(), "params": {"params"}}
    for name in re.findall(r"^\s*(\w+)\s*=\s*(?:gw\.)?GrassWidget\(", text, re.M):
        kinds["widget"].add(name)
    for name in re.findall(r"^\s*(\w+)\s*=\s*(?:gw\.)?GrassScene(?:\.preset)?\(", text, re.M):
        kinds["scene"].add(name)
    for name in re.findall(r"^\s*(\w+)\s*=\s*(?:(?:gw\.)?GrassParams\(|[\w.]*\bparams(?:\.copy\(\))?\s*$)", text, re.M):
        kinds["params"].add(name)
    return kinds


def _defined_in_code(code: list) -> set:
    """Names the notebook's code defines or passes (assignment targets, functions, keywords, loop names)."""
    names = set()
    for src in code:
        try:
            tree = ast.parse(src)
        except SyntaxError:
            continue
        for node in ast.walk(tree):
            if isinstance(node, ast.Name):
                names.add(node.id)
            elif isinstance(node, (ast.FunctionDef, ast.ClassDef)):
                names.add(node.name)
            elif isinstance(node, ast.keyword) and node.arg:
                names.add(node.arg)
            elif isinstance(node, ast.arg):
                names.add(node.arg)
            elif isinstance(node, ast.Attribute):
                names.add(node.attr)
    return names


def _backticks(markdown: list) -> list:
    return [span for text in markdown for span in re.findall(r"`([^`\n]+)`", text)]


def control_problems(markdown: list) -> list:
    """Controls named otherwise than the panel names them."""
    labels = panel_labels()
    named = []
    for text in markdown:
        lines = text.splitlines()
        in_control_table = False
        for line in lines:
            cells = [c.strip() for c in line.strip().strip("|").split("|")] if line.lstrip().startswith("|") else None
            if cells is None:
                in_control_table = False
                continue
            if cells[0].lower() in ("control", "controls"):
                in_control_table = True
                continue
            if in_control_table:
                named += [(m, "control table") for m in re.findall(r"\*\*([^*]+)\*\*", cells[0])]
        for m in re.findall(r"\"([^\"\n]{1,40})\"\s+" + CONTROL_WORDS + r"\b", text):
            named.append((m, "quoted control"))
        for m in re.findall(r"\*\*([^*\n]{1,40})\*\*\s+" + CONTROL_WORDS + r"\b", text):
            named.append((m, "bold control"))
    return [f"{kind} {name!r} is not a label of the panel" for name, kind in named if name.strip() not in labels]


def _without_long_strings(src: str) -> str:
    """Code without its triple-quoted strings (WGSL snippets, docstrings: their ``p.x`` is not Python)."""
    return re.sub(r'(\"\"\"|\'\'\')(?:.|\n)*?\1', '""', src)


def name_problems(markdown: list, code: list) -> list:
    k = known()
    kinds = _variables(code)
    problems = []
    spans = _backticks(markdown)
    places = [("markdown", s) for s in spans] + [("code", _without_long_strings(s)) for s in code]
    for where, text in places:
        for var in kinds["widget"]:
            for attr in re.findall(rf"(?<![\w.]){var}\.(\w+)", text):
                if attr not in k["widget"]:
                    problems.append(f"{where}: {var}.{attr}: GrassWidget has no {attr!r}")
        for var in kinds["scene"]:
            for attr in re.findall(rf"(?<![\w.]){var}\.(\w+)", text):
                if attr not in k["scene"]:
                    problems.append(f"{where}: {var}.{attr}: GrassScene has no {attr!r}")
        for var in kinds["params"]:
            for attr in re.findall(rf"(?<![\w.]){var}\.(\w+)", text):
                if attr not in k["params"]:
                    problems.append(f"{where}: {var}.{attr}: GrassParams has no {attr!r}")
        for attr in re.findall(r"\.params\.(\w+)", text):
            if attr not in k["params"]:
                problems.append(f"{where}: .params.{attr}: GrassParams has no {attr!r}")
        for key in re.findall(r"\.sliders\[[\"'](\w+)[\"']\]", text):
            if key not in k["traits"] | {"blades", "time_scale"}:
                problems.append(f"{where}: sliders[{key!r}]: the panel has no such slider")
    for src in code:
        for call in re.findall(r"GrassParams\(([^()]*(?:\([^()]*\)[^()]*)*)\)", src):
            for kw in re.findall(r"(\w+)\s*=(?!=)", call):
                if kw not in k["traits"]:
                    problems.append(f"code: GrassParams({kw}=...): no such trait")
    defined = _defined_in_code(code)
    for span in spans:
        if re.fullmatch(r"[a-z][a-z0-9]*(?:_[a-z0-9]+)+", span) and span not in k["all"] | defined:
            problems.append(f"markdown: `{span}` names nothing in grasswidget or in the notebook")
    return problems


# ------------------------------------------------------------------ the tests

@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_names_controls_as_the_panel_does(path):
    markdown, _code = _sources(path)
    problems = control_problems(markdown)
    assert not problems, f"{path.name}:\n" + "\n".join(problems)


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_names_in_notebook_exist(path):
    markdown, code = _sources(path)
    problems = name_problems(markdown, code)
    assert not problems, f"{path.name}:\n" + "\n".join(problems)


def test_panel_labels_are_read_from_the_panel():
    labels = panel_labels()
    # words with units, the words alone, checkboxes, buttons and the ball row's controls
    for label in ("gust speed (m/s)", "gust speed", "stiffness ×", "time (× real time)", "wind pattern",
                  "frustum culling", "freeze culling", "colour by", "Save PNG", "Reset camera", "Play", "Pause",
                  "sphere", "Roll", "looks", "details", "fog (1/m)", "home", "top", "low", "above the grass",
                  "more"):
        assert label in labels, label
    assert not {"wind_speed", "wind_field", "stiffness_scale", "stiffness x"} & labels


# What the tour said before its controls were named in words (verbatim lines): trait names where the panel has words.
OLD_TOUR = """| control | what it does |
| --- | --- |
| **blades** | number of blades; rebuilds the field when you let go of the slider |
| **wind_strength** | peak wind acceleration (m/s²) |
| **wind_speed** | how fast the gusts travel (m/s) |
| **wind_field** | which analytic wind field blows |
| **stiffness_scale** | multiplies every blade's stiffness: higher = springier grass |
| **time_scale** | simulated seconds per real second (0 freezes time) |
"""


def test_checks_catch_what_the_old_tour_said():
    problems = control_problems([OLD_TOUR])
    assert {"wind_strength", "wind_speed", "wind_field", "stiffness_scale", "time_scale"} == {
        re.search(r"'(.+)'", p).group(1) for p in problems}, problems
    assert control_problems(['tick the "stiffness x" slider']), "ASCII x for the panel's ×"
    assert not control_problems(['the "stiffness ×" slider and the **frustum culling** checkbox'])
    code = ["w = gw.GrassWidget()\np = w.params"]
    assert name_problems(["`w.params.wind_speeed`"], code)      # a misspelt trait
    assert name_problems(["`w.frame_time`"], code)              # not a widget attribute
    assert name_problems(["`p.stiffness`"], code)               # not a trait (stiffness_scale is)
    assert name_problems(["`cull_distance_maximum`"], code)     # names nothing
    assert name_problems([], ['q = gw.GrassParams(wind_strenght=3.0)'])
    assert not name_problems(["`w.params.wind_speed`, `p.dt`, `w.sim_time`, `cull_distance_max`"], code)
