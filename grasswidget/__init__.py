"""grasswidget: physically animated grass on the GPU, for notebooks and scripts.

The package's top level holds the public entry points; the code lives in
subpackages: :mod:`.core` (pure: NumPy and traitlets, no GPU import),
:mod:`.gpu` (pygfx/wgpu, knows no widgets), :mod:`.browser` (the WebGPU engine
in the page), :mod:`.notebook` (the widget and its views) and :mod:`.tools`
(CLI, benchmarks, export). GPU classes (``GrassField``, ``GrassMaterial``,
``GrassScene``) and the widget load on first use. The public modules are
attributes too, loaded on first use: ``gw.reference``, ``gw.teaching``,
``gw.benchmark``, ...
"""

from .core.runtime_dir import ensure_runtime_dir

ensure_runtime_dir()  # before any Vulkan instance: keeps the loader from complaining (see runtime_dir)

from .core.blades import Blades  # noqa: E402
from .core.colliders import MAX_COLLIDERS, SphereCollider  # noqa: E402
from .core.limits import MAX_STEPS, NonFiniteStateWarning, StepsInterrupted  # noqa: E402
from .errors import (  # noqa: E402
    BladeCountError, BladeLimitError, BrowserTimeoutError, PageBuildError, TraceFileError, GrassError, GrassTypeError,
    GrassValueError, MissingDependencyError, MissingFileError, MissingLimitError, NoGPUAdapterError, ParameterError, ReadOnlyAttributeError, UnknownNameError, UpstreamChangedError,
    WidgetClosedError, WindShaderError, ExerciseShaderError, IsolatedRunError,
)
from .core.params import GrassParams  # noqa: E402
from .core.teaching import CULL_COLORS, LOD_COLORS  # noqa: E402
from .core.exercises import EXERCISES  # noqa: E402

__version__ = "0.1.0"

_LAZY = {
    "GrassField": ("grasswidget.gpu.field", "GrassField"),
    "GrassMaterial": ("grasswidget.gpu.material", "GrassMaterial"),
    "GrassScene": ("grasswidget.gpu.scene", "GrassScene"),
    "GrassWidget": ("grasswidget.notebook.widget", "GrassWidget"),
    "compare": ("grasswidget.notebook.compare", "compare"),
    "sweep": ("grasswidget.tools.sweep", "sweep"),
    "exercise": ("grasswidget.notebook.exercise", "exercise"),
    "TraceRecorder": ("grasswidget.core.traces", "TraceRecorder"),
    "load_traces": ("grasswidget.core.traces", "load_traces"),
}

#: Modules reachable as attributes of the package (``gw.reference``), loaded on first use (full names
#: written out, so tests/test_architecture.py's import graph sees these lazy imports). Each module
#: has one import path, its full name (``import grasswidget.core.reference``): no import hook, no alias.
_MODULES = {
    "blades": "grasswidget.core.blades", "params": "grasswidget.core.params", "enums": "grasswidget.core.enums",
    "colliders": "grasswidget.core.colliders", "reference": "grasswidget.core.reference",
    "memory": "grasswidget.core.memory", "uniform_layouts": "grasswidget.core.uniform_layouts",
    "shader_files": "grasswidget.core.shader_files", "teaching": "grasswidget.core.teaching",
    "presets": "grasswidget.core.presets", "traces": "grasswidget.core.traces",
    "exercises": "grasswidget.core.exercises", "scene": "grasswidget.gpu.scene",
    "widget": "grasswidget.notebook.widget", "kernel_view": "grasswidget.views.kernel",
    "panel": "grasswidget.notebook.panel", "control_link": "grasswidget.notebook.control_link",
    "clock": "grasswidget.views.clock", "adaptive": "grasswidget.views.adaptive",
    "orbit": "grasswidget.views.orbit", "ball": "grasswidget.notebook.ball",
    "cli": "grasswidget.tools.cli", "benchmark": "grasswidget.tools.benchmark",
    "export": "grasswidget.tools.export", "sweep": "grasswidget.tools.sweep",
    "grading": "grasswidget.tools.grading",
}

__all__ = [
    "Blades", "GrassParams", "SphereCollider", "MAX_COLLIDERS", "CULL_COLORS", "LOD_COLORS", "EXERCISES",
    "MAX_STEPS", "NonFiniteStateWarning", "StepsInterrupted",
    "GrassError", "GrassValueError", "GrassTypeError", "ParameterError", "UnknownNameError", "ReadOnlyAttributeError", "MissingLimitError",
    "BladeCountError", "BladeLimitError", "WindShaderError", "ExerciseShaderError", "IsolatedRunError", "MissingFileError", "MissingDependencyError",
    "NoGPUAdapterError", "WidgetClosedError", "UpstreamChangedError", "BrowserTimeoutError", "PageBuildError", "TraceFileError",
    *_LAZY,
]


def __getattr__(name):
    import importlib

    if name in _LAZY:
        module, attr = _LAZY[name]
        return getattr(importlib.import_module(module), attr)
    if name in _MODULES:
        return importlib.import_module(_MODULES[name])
    raise UnknownNameError(f"module 'grasswidget' has no attribute {name!r}")
