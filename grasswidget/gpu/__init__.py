"""The GPU layer (pygfx/wgpu; knows nothing of widgets).

Laid out like pygfx: :mod:`.field` (the GrassField WorldObject and its buffers),
:mod:`.material` (GrassMaterial and its uniforms), :mod:`.simulation` (the
compute program, uniform writer and fixed steps), :mod:`.shader_classes` (the
pygfx shader classes that fill ``grasswidget/shaders/*.wgsl``, registered for
(GrassField, GrassMaterial)), :mod:`.wgsl_templates` (templating helpers),
:mod:`.compute`, :mod:`.indirect`, :mod:`.stats`, :mod:`.adapter`,
:mod:`.collider_view`, :mod:`.occlusion` (occlusion culling's state and passes),
:mod:`.frame` (``render_frame``: the kernel engine's frame entry point) and
:mod:`.scene` (GrassScene).

Registration at package level, as pygfx does it: this package imports the
objects, then :mod:`.shader_classes`, which registers the render functions with
pygfx's decorator (objects never import their shaders). Importing any module
of the layer (``grasswidget.gpu.field``, say) runs this first, so a GrassField
renders whichever entry point a user imports. ``import grasswidget`` does not
import this package (it loads no pygfx/wgpu; :mod:`grasswidget.core.runtime_dir`
sets the Vulkan loader's directory).
"""

from .field import GrassField
from .material import GrassMaterial
from . import shader_classes  # noqa: F401  (registers the render functions of (GrassField, GrassMaterial))
from .frame import render_frame
from .scene import GrassScene

__all__ = ["GrassField", "GrassMaterial", "GrassScene", "render_frame"]
