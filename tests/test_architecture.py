"""The package's architecture: the layers and what each may import, the public names.

Structural contracts: the pure core loads no GPU code; each subpackage imports
only the layers below it (core < gpu, browser < notebook, tools); no module of
the package imports itself back through others (no import circle, lazy imports
included); the render function is registered at package level (grasswidget.gpu)
whenever a GPU module is imported;
the top level keeps the public entry points and the import paths of before the
subpackages; every error raised on purpose derives from GrassError.
"""

import ast
import importlib
import json
import subprocess
import sys
from pathlib import Path

import pytest


def _run(code):
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)


ENTRY_POINTS = ["grasswidget.gpu.field", "grasswidget.gpu.material", "grasswidget.gpu.simulation",
                "grasswidget.gpu.shader_classes", "grasswidget.gpu.scene", "grasswidget.gpu.frame",
                "grasswidget.gpu", "grasswidget"]

#: Run each case's code in its own child of one fresh interpreter: the parent imports only what
#: every GPU entry point imports first anyway (numpy, wgpu, pygfx; no module of grasswidget), then
#: forks one child per case (as many at a time as there are CPU cores), so each case starts with no
#: grasswidget module loaded (as a fresh ``python -c`` would) without paying an interpreter start
#: and pygfx's import per case. Reads ``{case: code}`` (JSON) on stdin; prints
#: ``RESULTS {case: {"status": exit status, "stderr": what the child wrote to stderr}}``.
FORKED_CASES = """
import json, os, sys, tempfile, traceback
import numpy, wgpu, pygfx
cases = json.loads(sys.stdin.read())
assert not [m for m in sys.modules if m.split('.')[0] == 'grasswidget'], 'grasswidget loaded before the cases'
sys.stdout.flush(); sys.stderr.flush()
running, results = {}, {}

def wait_one():
    pid, status = os.wait()
    name, err = running.pop(pid)
    err.seek(0)
    results[name] = {'status': os.waitstatus_to_exitcode(status), 'stderr': err.read().decode(errors='replace')}
    err.close()

for name, code in cases.items():
    if len(running) >= (os.cpu_count() or 1):
        wait_one()
    err = tempfile.TemporaryFile()
    pid = os.fork()
    if pid == 0:
        os.dup2(err.fileno(), 2)
        status = 0
        try:
            exec(compile(code, name, 'exec'), {'__name__': '__main__'})
        except BaseException:
            traceback.print_exc()
            status = 1
        sys.stderr.flush()
        os._exit(status)
    running[pid] = (name, err)
while running:
    wait_one()
print('RESULTS', json.dumps(results))
"""


def _entry_point_code(module):
    return (f"import importlib; importlib.import_module({module!r})\n"
            "import grasswidget as gw\n"
            "field = gw.GrassField(gw.Blades.on_plane(64))\n"
            "from pygfx.renderers.wgpu.engine.utils import registry\n"
            "from grasswidget.gpu.shader_classes import grass_render_function\n"
            "assert registry.get_render_function(field) is grass_render_function\n")


@pytest.fixture(scope="module")
def forked_cases():
    """Each entry point's case (and the old import paths' cases), run once for the module in
    children of one interpreter (FORKED_CASES): ``{case: {"status", "stderr"}}``."""
    cases = {module: _entry_point_code(module) for module in ENTRY_POINTS}
    cases["old paths"] = OLD_PATHS_CODE
    cases["a failing case"] = "import grasswidget\nassert 'grasswidget' == 'elsewhere', 'the case failed'\n"
    r = subprocess.run([sys.executable, "-c", FORKED_CASES], input=json.dumps(cases), capture_output=True,
                       text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    line = next(x for x in r.stdout.splitlines() if x.startswith("RESULTS "))
    results = json.loads(line[len("RESULTS "):])
    assert set(results) == set(cases)
    return results


@pytest.mark.parametrize("module", ENTRY_POINTS)
def test_a_grass_field_renders_whichever_entry_point_is_imported(module, forked_cases):
    """Whichever module a user imports first (then ``gw.GrassField``), pygfx knows how to render a
    GrassField: the package ``grasswidget.gpu`` registers the render function (pygfx's pattern),
    and any GPU module's import runs it first. Each module is imported first in a process of its
    own (a child forked before any grasswidget module is loaded: FORKED_CASES)."""
    result = forked_cases[module]
    assert result["status"] == 0, result["stderr"]


def test_the_forked_cases_can_fail(forked_cases):
    """The check above sees a case that fails, with what it wrote to stderr (the fixture runs one
    that fails on purpose); a case that passes writes nothing there."""
    failing = forked_cases["a failing case"]
    assert failing["status"] == 1 and "AssertionError: the case failed" in failing["stderr"]
    assert forked_cases["old paths"] == {"status": 0, "stderr": ""}


def test_the_frame_entry_point_lives_in_its_own_module():
    """``render_frame`` is defined in gpu/frame.py; the package gives it too (occlusion.py does not:
    one path)."""
    from grasswidget.gpu import frame, occlusion
    import grasswidget.gpu as gpu

    assert frame.render_frame.__module__ == "grasswidget.gpu.frame"
    assert frame.render_frame is gpu.render_frame and not hasattr(occlusion, "render_frame")


def test_pure_core_imports_no_gpu_code():
    """Importing the package and every core module loads neither pygfx/wgpu nor a GPU module
    (the Vulkan loader's directory is set by core/runtime_dir.py, stdlib only)."""
    code = ("import sys, pkgutil, importlib, grasswidget, grasswidget.core as core, grasswidget.errors\n"
            "for m in pkgutil.iter_modules(core.__path__): importlib.import_module('grasswidget.core.' + m.name)\n"
            "allowed = set()\n"
            "bad = [m for m in sys.modules if m.split('.')[0] in ('pygfx', 'wgpu', 'ipywidgets', 'anywidget')\n"
            "       or m.startswith(('grasswidget.gpu', 'grasswidget.browser', 'grasswidget.notebook', 'grasswidget.tools'))\n"
            "       and m not in allowed]\n"
            "assert not bad, bad\n")
    r = _run(code)
    assert r.returncode == 0, r.stderr


PACKAGE = Path(__file__).resolve().parents[1] / "grasswidget"
NOTEBOOK_LIBS = ("ipywidgets", "anywidget", "jupyter_rfb", "jupyter_ui_poll", "IPython", "marimo")
GPU_LIBS = ("pygfx", "wgpu", "rendercanvas", "pylinalg")
#: What each layer may not import (anywhere in its source, lazy imports included). The core is pure;
#: the GPU layer knows no widgets and no browser; the browser engine runs in the page and needs no
#: pygfx/wgpu; the views (grasswidget/views: the interface and both engines' views) sit on both
#: engines and know no widget; the notebook front end talks to the engines through the views only
#: (never gpu/ or browser/; the lab bench's chart, an engine-neutral anywidget that lives beside
#: the browser engine's JS, is the one module of browser/ it may use). The tools are the faces on
#: top and may use everything.
FORBIDDEN = {
    "core": ("grasswidget.gpu", "grasswidget.browser", "grasswidget.notebook", "grasswidget.tools", "grasswidget.compat",
             "grasswidget.views", *GPU_LIBS, *NOTEBOOK_LIBS),
    "gpu": ("grasswidget.browser", "grasswidget.notebook", "grasswidget.tools", "grasswidget.views", *NOTEBOOK_LIBS),
    "browser": ("grasswidget.gpu", "grasswidget.notebook", "grasswidget.tools", "grasswidget.views", *GPU_LIBS),
    "views": ("grasswidget.notebook", "grasswidget.tools"),
    "notebook": ("grasswidget.gpu", "grasswidget.browser", *GPU_LIBS),
}
#: Modules a layer may import although FORBIDDEN names their package (each with its reason above).
ALLOWED = {"notebook": ("grasswidget.browser.trace_chart",)}


def imported_modules(path: Path) -> set[str]:
    """Absolute names of every module ``path`` imports (relative imports resolved;
    ``from . import x`` counts as ``package.x``)."""
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    package = parts[:-1]
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            if node.level == 0:
                found.add(node.module)
                continue
            base = ".".join(package[: len(package) - node.level + 1] + ([node.module] if node.module else []))
            found |= {base} if node.module else {f"{base}.{a.name}" for a in node.names}
    return found


def _layer_violations(layer: str) -> list[str]:
    bad = []
    for path in sorted((PACKAGE / layer).rglob("*.py")):
        for name in sorted(imported_modules(path)):
            if name in ALLOWED.get(layer, ()):
                continue
            if any(name == f or name.startswith(f + ".") for f in FORBIDDEN[layer]):
                bad.append(f"{path.relative_to(PACKAGE.parent)} imports {name}")
    return bad


@pytest.mark.parametrize("layer", sorted(FORBIDDEN))
def test_each_layer_imports_only_what_is_below_it(layer):
    assert (PACKAGE / layer / "__init__.py").is_file()
    bad = _layer_violations(layer)
    assert not bad, "\n".join(bad)


def test_the_layer_check_sees_lazy_and_relative_imports(tmp_path, monkeypatch):
    """A function-level ``from ..gpu.field import GrassField`` in a core module is caught (the check can fail)."""
    fake = tmp_path / "grasswidget"
    (fake / "core").mkdir(parents=True)
    (fake / "core" / "__init__.py").write_text("")
    (fake / "core" / "x.py").write_text("def f():\n    from ..gpu.field import GrassField\n    import pygfx\n")
    monkeypatch.setattr(sys.modules[__name__], "PACKAGE", fake)
    assert _layer_violations("core") == ["grasswidget/core/x.py imports grasswidget.gpu.field",
                                         "grasswidget/core/x.py imports pygfx"]


def test_top_level_keeps_the_public_names_and_modules():
    """The public entry points and the modules the notebooks use stay reachable from the package."""
    import grasswidget as gw

    for name in ("GrassWidget", "GrassScene", "GrassField", "GrassMaterial", "Blades", "GrassParams",
                 "SphereCollider", "GrassError"):
        assert getattr(gw, name).__name__ == name
    assert gw.reference is importlib.import_module("grasswidget.core.reference")
    assert gw.benchmark is importlib.import_module("grasswidget.tools.benchmark")
    assert gw.ball is importlib.import_module("grasswidget.notebook.ball")
    with pytest.raises(AttributeError, match="no attribute 'nonsense'"):
        gw.nonsense
    top = sorted(p.name for p in PACKAGE.glob("*.py"))
    assert top == ["__init__.py", "__main__.py", "compat.py", "errors.py"]


def test_errors_have_one_root():
    import grasswidget as gw

    assert issubclass(gw.BladeLimitError, gw.GrassError) and issubclass(gw.BladeLimitError, ValueError)
    assert issubclass(gw.WindShaderError, gw.GrassError) and issubclass(gw.WindShaderError, ValueError)
    assert issubclass(gw.NoGPUAdapterError, gw.GrassError) and issubclass(gw.NoGPUAdapterError, RuntimeError)


# names-rename: off (the old names below are the point: names_rename.py leaves them alone)
#: Import paths the package no longer keeps (issue 39: internal modules have one path, no aliases):
#: the flat paths of before the subpackages, the modules renamed for one meaning, the names of
#: before of the view interface's classes. Each must fail to import (run in a fresh process).
OLD_MODULES = ["grasswidget.reference", "grasswidget.scene", "grasswidget.widget_ball", "grasswidget.cli",
               "grasswidget.bench", "grasswidget.gpu.shaders", "grasswidget.gpu.wgsl", "grasswidget.gpu.runtime_dir",
               "grasswidget.browser.wgsl", "grasswidget.core.framing", "grasswidget.core.frame_data",
               "grasswidget.core.pays", "grasswidget.gpu.auto_switches", "grasswidget.browser.auto_switches",
               "grasswidget.tools.bench", "grasswidget.tools.bench_matrix", "grasswidget.notebook.blade_control",
               "grasswidget.notebook.sunlight_default", "grasswidget.core.reference.sunlight",
               "grasswidget.core.view_api", "grasswidget.notebook.kernel_view", "grasswidget.browser.view",
               "grasswidget.browser.engine_view", "grasswidget.notebook.clock", "grasswidget.nonsense"]
OLD_NAMES = [("grasswidget.views.api", "GrassView"), ("grasswidget.views.api", "ViewClock"),
             ("grasswidget.browser.engine_widget", "BrowserView"), ("grasswidget.gpu.occlusion", "render_frame")]
OLD_PATHS_CODE = ("import importlib, sys\n"
                  "import grasswidget as gw\n"
                  f"for old in {OLD_MODULES!r}:\n"
                  "    try:\n"
                  "        importlib.import_module(old)\n"
                  "    except ModuleNotFoundError:\n"
                  "        assert old not in sys.modules, old\n"
                  "    else:\n"
                  "        raise AssertionError(old + ' imported')\n"
                  f"for module, name in {OLD_NAMES!r}:\n"
                  "    assert not hasattr(importlib.import_module(module), name), (module, name)\n"
                  "assert not any(type(f).__name__ == '_OldPathFinder' or getattr(f, '__name__', '') == '_OldPathFinder'\n"
                  "               for f in sys.meta_path), 'an import hook of grasswidget is installed'\n"
                  "assert gw.GrassScene.__module__ == 'grasswidget.gpu.scene'\n")
# names-rename: on


def test_old_import_paths_and_names_are_gone(forked_cases):
    """Each module has one import path: the flat paths of before the subpackages, the modules
    renamed for one meaning and the names of before of three objects no longer import (no import
    hook, no alias), while the public entry points (``gw.GrassScene``) still load."""
    result = forked_cases["old paths"]
    assert result["status"] == 0, result["stderr"]


def package_modules(package: Path = None) -> dict:
    """Every module of the package: dotted name -> file (a package is its ``__init__.py``)."""
    package = package or PACKAGE
    out = {}
    for path in sorted(package.rglob("*.py")):
        parts = list(path.relative_to(package.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def import_graph(package: Path = None) -> dict:
    """The package's module import graph: module -> the package modules it imports, at the top or
    inside a function (lazy), by an import statement or by full dotted name in a string (the lazy
    tables of ``grasswidget/__init__.py``, ``importlib.import_module("grasswidget.x.y")``; the bare
    package name in ``importlib.resources.files("grasswidget")`` reads files, it is no import). ``from a.b import c``
    counts as an edge to ``a.b.c`` when that is a module, else to ``a.b``. Importing a submodule also
    runs its parents' ``__init__``; that implicit edge is not counted (it would make every package a circle)."""
    modules = package_modules(package)
    graph = {}
    for name, path in modules.items():
        targets = set(imported_modules(path))
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and "." in node.value \
                    and node.value in modules:
                targets.add(node.value)
        edges = set()
        for target in targets:
            while target and target not in modules:
                target = target.rpartition(".")[0]
            if target and target != name:
                edges.add(target)
        graph[name] = edges
    return graph


def import_cycles(graph: dict) -> list[list[str]]:
    """One circle (as a path a -> b -> ... -> a) per strongly connected group of modules, found with
    Tarjan's algorithm (iterative); [] when the graph has none."""
    index, low, on_stack, stack, groups, counter = {}, {}, set(), [], [], [0]
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter[0]; counter[0] += 1
        stack.append(root); on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = counter[0]; counter[0] += 1
                    stack.append(child); on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                group = []
                while True:
                    member = stack.pop(); on_stack.discard(member); group.append(member)
                    if member == node:
                        break
                if len(group) > 1:
                    groups.append(sorted(group))
    cycles = []
    for group in groups:  # a path through the group back to its first module, to name the circle
        members, start = set(group), group[0]
        path, seen = [start], {start}
        node = start
        while True:
            nxt = sorted(n for n in graph[node] if n in members)
            if start in nxt and len(path) > 1:
                break
            node = next((n for n in nxt if n not in seen), start)
            if node == start:
                break
            path.append(node); seen.add(node)
        cycles.append(path + [start])
    return cycles


def test_no_import_circle_in_the_package():
    """No module imports itself back through others, top-level or lazy imports alike (pygfx's pattern:
    objects never import their shaders; the shader classes register themselves, and the package
    ``grasswidget.gpu`` imports them). A failure names each circle."""
    graph = import_graph()
    assert "grasswidget.gpu.shader_classes" in graph["grasswidget.gpu"]  # the graph sees package-level imports
    assert "grasswidget.notebook.widget" in graph["grasswidget"]  # ... and the lazy tables' names
    cycles = import_cycles(graph)
    assert not cycles, "import circles:\n" + "\n".join(" -> ".join(c) for c in cycles)


def test_the_cycle_check_finds_a_lazy_circle(tmp_path, monkeypatch):
    """A circle closed by a function-level import (a.py imports b at the top, b imports a inside a
    function) is found and named; the check can fail."""
    fake = tmp_path / "grasswidget"
    (fake / "gpu").mkdir(parents=True)
    (fake / "__init__.py").write_text("")
    (fake / "gpu" / "__init__.py").write_text("")
    (fake / "gpu" / "a.py").write_text("from .b import thing\n")
    (fake / "gpu" / "b.py").write_text("thing = 1\ndef f():\n    from . import a\n")
    (fake / "gpu" / "c.py").write_text("from .a import thing\n")
    monkeypatch.setattr(sys.modules[__name__], "PACKAGE", fake)
    cycles = import_cycles(import_graph(fake))
    assert cycles == [["grasswidget.gpu.a", "grasswidget.gpu.b", "grasswidget.gpu.a"]]


TESTS = Path(__file__).resolve().parent
#: What the tests of a layer may not use: tests are grouped like the layers they test, so a test of
#: the pure core runs no GPU, browser or widget code (a test of both engines lives with the browser's
#: tests, which may compare against the kernel's GPU layer).
TEST_FORBIDDEN = {"core": FORBIDDEN["core"]}
#: The package's lazy entry points and the layer each loads (``gw.GrassWidget`` is an import too).
ENTRY_POINT_LAYERS = {"GrassField": "gpu", "GrassMaterial": "gpu", "GrassScene": "gpu", "GrassWidget": "notebook",
                      "compare": "notebook", "exercise": "notebook", "sweep": "tools"}


def _test_layer_violations(layer: str, tests: Path = TESTS) -> list[str]:
    bad = []
    for path in sorted((tests / layer).rglob("*.py")):
        tree = ast.parse(path.read_text(), filename=str(path))
        names = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                names |= {a.name for a in node.names}
            elif isinstance(node, ast.ImportFrom) and node.module:
                names |= {node.module} | {f"{node.module}.{a.name}" for a in node.names}
            elif isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) \
                    and node.value.id in ("gw", "grasswidget") and node.attr in ENTRY_POINT_LAYERS:
                names.add(f"grasswidget.{ENTRY_POINT_LAYERS[node.attr]}")
        for name in sorted(names):
            if any(name == f or name.startswith(f + ".") for f in TEST_FORBIDDEN[layer]):
                bad.append(f"{path.relative_to(tests).as_posix()} uses {name}")
    return sorted(set(bad))


def test_the_core_tests_use_only_the_core():
    """tests/core imports nothing of the GPU, browser, notebook or tools layers (nor their GPU and
    widget libraries), directly or through ``gw.GrassWidget`` / ``gw.GrassScene``-style entry points."""
    bad = _test_layer_violations("core")
    assert not bad, "\n".join(bad)


def test_the_test_layer_check_can_fail(tmp_path):
    (tmp_path / "core").mkdir()
    (tmp_path / "core" / "test_x.py").write_text("import grasswidget as gw\nfrom grasswidget.browser import engine_widget\n"
                                                 "def test():\n    gw.GrassWidget(64)\n")
    assert _test_layer_violations("core", tmp_path) == ["core/test_x.py uses grasswidget.browser",
                                                        "core/test_x.py uses grasswidget.browser.engine_widget",
                                                        "core/test_x.py uses grasswidget.notebook"]
