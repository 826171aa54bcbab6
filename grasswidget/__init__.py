"""grasswidget: physically animated grass on the GPU, for notebooks and scripts.

The pure core (``Blades``, ``GrassParams``, ``grasswidget.reference``) imports no
GPU code. GPU classes (``GrassField``, ``GrassMaterial``, ``GrassScene``) load
pygfx/wgpu on first use.
"""

from .runtime_dir import ensure_runtime_dir

ensure_runtime_dir()  # before any Vulkan instance: keeps the loader from complaining (see runtime_dir)

from .blades import Blades  # noqa: E402
from .colliders import SphereCollider  # noqa: E402
from .errors import (  # noqa: E402
    BladeCountError, BladeLimitError, BrowserTimeoutError, GrassError, GrassTypeError, GrassValueError, MissingDependencyError,
    MissingFileError, MissingLimitError, NoGPUAdapterError, ParameterError, UnknownNameError, UpstreamChangedError,
    WidgetClosedError, WindShaderError,
)
from .params import GrassParams  # noqa: E402
from .teaching import CULL_COLORS, LOD_COLORS  # noqa: E402

__version__ = "0.1.0"

_LAZY = {
    "GrassField": ("grasswidget.gpu.field", "GrassField"),
    "GrassMaterial": ("grasswidget.gpu.material", "GrassMaterial"),
    "GrassScene": ("grasswidget.scene", "GrassScene"),
    "GrassWidget": ("grasswidget.widget", "GrassWidget"),
}

__all__ = [
    "Blades", "GrassParams", "SphereCollider", "CULL_COLORS", "LOD_COLORS",
    "GrassError", "GrassValueError", "GrassTypeError", "ParameterError", "UnknownNameError", "MissingLimitError",
    "BladeCountError", "BladeLimitError", "WindShaderError", "MissingFileError", "MissingDependencyError",
    "NoGPUAdapterError", "WidgetClosedError", "UpstreamChangedError", "BrowserTimeoutError",
    *_LAZY,
]


def __getattr__(name):
    if name in _LAZY:
        import importlib

        module, attr = _LAZY[name]
        return getattr(importlib.import_module(module), attr)
    raise UnknownNameError(f"module 'grasswidget' has no attribute {name!r}")
