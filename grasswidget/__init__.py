"""grasswidget: physically animated grass on the GPU, for notebooks and scripts.

The pure core (``Blades``, ``GrassParams``, ``grasswidget.reference``) imports no
GPU code. GPU classes (``GrassField``, ``GrassMaterial``, ``GrassScene``) load
pygfx/wgpu on first use.
"""

from .blades import Blades
from .colliders import SphereCollider
from .errors import BladeLimitError, GrassError, NoGPUAdapterError, WindShaderError
from .params import GrassParams

__version__ = "0.1.0"

_LAZY = {
    "GrassField": ("grasswidget.gpu.field", "GrassField"),
    "GrassMaterial": ("grasswidget.gpu.material", "GrassMaterial"),
    "GrassScene": ("grasswidget.scene", "GrassScene"),
    "GrassWidget": ("grasswidget.widget", "GrassWidget"),
}

__all__ = [
    "Blades", "GrassParams", "SphereCollider",
    "GrassError", "BladeLimitError", "WindShaderError", "NoGPUAdapterError",
    *_LAZY,
]


def __getattr__(name):
    if name in _LAZY:
        import importlib

        module, attr = _LAZY[name]
        return getattr(importlib.import_module(module), attr)
    raise AttributeError(f"module 'grasswidget' has no attribute {name!r}")
