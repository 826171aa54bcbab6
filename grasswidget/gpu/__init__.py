"""The GPU layer (pygfx/wgpu; knows nothing of widgets).

Laid out like pygfx: :mod:`.field` (the GrassField WorldObject and its buffers),
:mod:`.material` (GrassMaterial and its uniforms), :mod:`.simulation` (the
compute program, uniform writer and fixed steps), :mod:`.shaders` (the shader
classes registered for (GrassField, GrassMaterial) when imported here),
:mod:`.wgsl` (templating helpers), :mod:`.compute`, :mod:`.indirect`,
:mod:`.stats`, :mod:`.adapter`, :mod:`.collider_view`, :mod:`.scene` (GrassScene),
:mod:`.occlusion` (occlusion culling and ``render_frame``, which draws a frame with it)
and :mod:`.runtime_dir`.

Importing this package loads no pygfx/wgpu (``import grasswidget`` uses
:mod:`.runtime_dir` before any Vulkan instance exists); ``GrassField``,
``GrassMaterial``, ``GrassScene`` and ``render_frame`` load on first use. Importing :mod:`.field`
registers the render function (its last line imports :mod:`.shaders`).
"""

from ..errors import UnknownNameError

_LAZY = {"GrassField": ".field", "GrassMaterial": ".material", "GrassScene": ".scene", "render_frame": ".occlusion"}

__all__ = list(_LAZY)


def __getattr__(name):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(_LAZY[name], __name__), name)
    raise UnknownNameError(f"module {__name__!r} has no attribute {name!r}")
