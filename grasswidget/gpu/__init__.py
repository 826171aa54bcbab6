"""The GPU layer (pygfx/wgpu; knows nothing of widgets).

Laid out like pygfx: :mod:`.field` (the GrassField WorldObject and its buffers),
:mod:`.material` (GrassMaterial and its uniforms), :mod:`.simulation` (the
compute program, uniform writer and fixed steps), :mod:`.shaders` (the shader
classes registered for (GrassField, GrassMaterial) when imported here),
:mod:`.wgsl` (templating helpers), :mod:`.compute`, :mod:`.indirect`,
:mod:`.stats`, :mod:`.adapter`, :mod:`.collider_view`.
"""

from .field import GrassField
from .material import GrassMaterial
from . import shaders  # noqa: F401  (registers the render function)

__all__ = ["GrassField", "GrassMaterial"]
