"""The package's architecture: the layers and what each may import, the public names.

Structural contracts: the pure core loads no GPU code; each subpackage imports
only the layers below it (core < gpu, browser < notebook, tools); the render
function is registered by pygfx's decorator whenever a GPU module is imported;
the top level keeps the public entry points and the import paths of before the
subpackages; every error raised on purpose derives from GrassError.
"""

import ast
import importlib
import subprocess
import sys
from pathlib import Path

import pytest


def _run(code):
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)


@pytest.mark.parametrize("module", ["grasswidget.gpu.field", "grasswidget.gpu.material", "grasswidget.gpu.simulation",
                                    "grasswidget.gpu.shaders", "grasswidget.gpu.scene"])
def test_importing_any_gpu_module_registers_the_render_function(module):
    """Whichever module a user imports first, pygfx knows how to render a GrassField (no lazy registration)."""
    code = (f"import importlib; importlib.import_module({module!r})\n"
            "from pygfx.renderers.wgpu.engine.utils import registry\n"
            "import grasswidget as gw\n"
            "from grasswidget.gpu.shaders import grass_render_function\n"
            "field = gw.GrassField(gw.Blades.on_plane(64))\n"
            "assert registry.get_render_function(field) is grass_render_function\n")
    r = _run(code)
    assert r.returncode == 0, r.stderr


def test_pure_core_imports_no_gpu_code():
    """Importing the package and every core module loads neither pygfx/wgpu nor a GPU module
    (``grasswidget.gpu`` itself is a lazy package; its runtime_dir helper is stdlib only)."""
    code = ("import sys, pkgutil, importlib, grasswidget, grasswidget.core as core, grasswidget.errors\n"
            "for m in pkgutil.iter_modules(core.__path__): importlib.import_module('grasswidget.core.' + m.name)\n"
            "allowed = {'grasswidget.gpu', 'grasswidget.gpu.runtime_dir'}\n"
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
#: pygfx/wgpu. The notebook front end and the tools are the faces on top and may use everything.
FORBIDDEN = {
    "core": ("grasswidget.gpu", "grasswidget.browser", "grasswidget.notebook", "grasswidget.tools", "grasswidget.compat",
             *GPU_LIBS, *NOTEBOOK_LIBS),
    "gpu": ("grasswidget.browser", "grasswidget.notebook", "grasswidget.tools", *NOTEBOOK_LIBS),
    "browser": ("grasswidget.gpu", "grasswidget.notebook", "grasswidget.tools", *GPU_LIBS),
}


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
    assert gw.bench is importlib.import_module("grasswidget.tools.bench")
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


def test_import_paths_of_before_the_layout_still_work():
    """``import grasswidget.reference`` / ``from grasswidget.scene import GrassScene`` (the paths of
    before the subpackages) give the very module under its new path; an unknown name still fails."""
    code = ("import grasswidget.reference as old, grasswidget.core.reference as new\n"
            "assert old is new and new.__name__ == 'grasswidget.core.reference'\n"
            "from grasswidget.scene import GrassScene\n"
            "import grasswidget as gw\n"
            "assert GrassScene is gw.GrassScene\n"
            "import grasswidget.widget_ball, grasswidget.notebook.ball\n"
            "assert grasswidget.widget_ball is grasswidget.notebook.ball\n"
            "from grasswidget.cli import main\n"
            "import grasswidget.tools.cli as cli\n"
            "assert main is cli.main\n"
            "try:\n"
            "    import grasswidget.nonsense\n"
            "except ModuleNotFoundError:\n"
            "    pass\n"
            "else:\n"
            "    raise AssertionError('grasswidget.nonsense imported')\n")
    r = _run(code)
    assert r.returncode == 0, r.stderr
