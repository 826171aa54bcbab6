"""The house rules: the layout of the GPU layer, the error root, the pure core.

These are structural contracts (issue 12): the render function is registered by
pygfx's decorator at import time, modules import without cycles, every error
raised on purpose derives from GrassError.
"""

import subprocess
import sys

import pytest


def _run(code):
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)


@pytest.mark.parametrize("module", ["grasswidget.gpu.field", "grasswidget.gpu.material", "grasswidget.gpu.simulation",
                                    "grasswidget.gpu.shaders", "grasswidget.scene"])
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
    code = ("import sys, grasswidget, grasswidget.reference, grasswidget.errors, grasswidget.shader_files\n"
            "import grasswidget.uniform_layouts, grasswidget.framing, grasswidget.memory, grasswidget.teaching\n"
            "bad = [m for m in ('pygfx', 'wgpu', 'grasswidget.gpu') if m in sys.modules]\n"
            "assert not bad, bad\n")
    r = _run(code)
    assert r.returncode == 0, r.stderr


def test_errors_have_one_root():
    import grasswidget as gw

    assert issubclass(gw.BladeLimitError, gw.GrassError) and issubclass(gw.BladeLimitError, ValueError)
    assert issubclass(gw.WindShaderError, gw.GrassError) and issubclass(gw.WindShaderError, ValueError)
    assert issubclass(gw.NoGPUAdapterError, gw.GrassError) and issubclass(gw.NoGPUAdapterError, RuntimeError)
