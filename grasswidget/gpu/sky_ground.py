"""Sky and ground in one full-screen pass: the cheap backdrop of GrassScene.

``shaders/sky_ground.wgsl`` is drawn by both engines (the browser engine renders
it for its own bindings); the colours and the ground square come from
:func:`grasswidget.core.frame_data.scene_style`.

On a CPU adapter every full-screen pass costs milliseconds (a gradient
Background and a lit ground plane were two of them: about 11 ms of a 640 x 480
lavapipe frame). :class:`SkyGround` draws both in one pass, *after* the grass,
at the far depth with the "<" depth test, so the pixels the grass covers are
never shaded. The ground is a flat square of colour: the lit plane it replaces
had one normal and one directional light, so it was one colour too (checked:
sRGB (51, 36, 22) +- 1 over the whole plane), and that lit colour is the
default ``ground_color``.
"""

from __future__ import annotations

import numpy as np
import pygfx as gfx
import wgpu
from pygfx.renderers.wgpu import BaseShader, Binding, register_wgpu_render_function

from ..errors import GrassValueError
from ..core.frame_data import GROUND_COLOR, SKY_BOTTOM, SKY_TOP
from ..core.shader_files import read_shader
from ..core.uniform_layouts import SKY_GROUND_LAYOUT, shadertype
from . import wgsl as _wgsl  # noqa: F401  (registers the 'grasswidget' WGSL loader)

__all__ = ["SkyGround", "SkyGroundMaterial", "GroundSwitch"]


class SkyGroundMaterial(gfx.Material):
    """Colours and ground square of a :class:`SkyGround`.

    Args:
        sky_bottom, sky_top: sRGB colours of the sky gradient (bottom and top of the view).
        ground_color: sRGB colour of the ground (already lit).
        ground_center: (x, y, z) metres: the ground plane is y = ground_center[1].
        ground_half_size: half the side of the ground square (m, > 0).
    """

    #: pygfx's material uniforms plus ``uniform_layouts.SKY_GROUND_LAYOUT`` (the browser engine's struct).
    uniform_type = dict(gfx.Material.uniform_type, **shadertype(SKY_GROUND_LAYOUT))

    def __init__(self, sky_bottom=SKY_BOTTOM, sky_top=SKY_TOP, ground_color=GROUND_COLOR,
                 ground_center=(0.0, 0.0, 0.0), ground_half_size=10.0, **kwargs):
        super().__init__(depth_test=True, depth_compare="<", depth_write=False, **kwargs)
        self.uniform_buffer.data["sky_bottom"] = gfx.Color(sky_bottom).rgba
        self.uniform_buffer.data["sky_top"] = gfx.Color(sky_top).rgba
        self.uniform_buffer.data["ground_color"] = gfx.Color(ground_color).rgba
        self.set_ground(ground_center, ground_half_size)
        self.show_ground = True

    def set_ground(self, center, half_size):
        """Move the ground square: ``center`` (x, y, z) metres, ``half_size`` metres (> 0)."""
        half_size = float(half_size)
        if not half_size > 0:
            raise GrassValueError(f"ground_half_size must be > 0 (metres); got {half_size!r}")
        c = np.asarray(center, np.float32).reshape(3)
        self.uniform_buffer.data["ground"] = (c[0], c[1], c[2], half_size)
        self.uniform_buffer.update_full()

    @property
    def show_ground(self) -> bool:
        """Draw the ground square (else sky everywhere)."""
        return bool(self.uniform_buffer.data["show_ground"])

    @show_ground.setter
    def show_ground(self, value):
        self.uniform_buffer.data["show_ground"] = int(bool(value))
        self.uniform_buffer.update_full()


class SkyGround(gfx.WorldObject):
    """Sky gradient and a flat ground square, drawn last in one full-screen pass."""

    def __init__(self, material: SkyGroundMaterial | None = None):
        _register()
        super().__init__(None, material or SkyGroundMaterial(), render_order=1e6)


class GroundSwitch:
    """``GrassScene.ground``: ``visible`` switches the ground square of a SkyGround
    on and off (the sky stays), as ``visible`` did on the old ground mesh."""

    def __init__(self, material: SkyGroundMaterial):
        self.material = material

    @property
    def visible(self) -> bool:
        return self.material.show_ground

    @visible.setter
    def visible(self, value):
        self.material.show_ground = value


_done = []


def _register():
    if _done:
        return
    _done.append(True)

    @register_wgpu_render_function(SkyGround, SkyGroundMaterial)
    class SkyGroundShader(BaseShader):
        type = "render"

        def get_bindings(self, wobject, shared, scene):
            bindings = {
                0: Binding("u_stdinfo", "buffer/uniform", shared.uniform_buffer),
                1: Binding("u_wobject", "buffer/uniform", wobject.uniform_buffer),
                2: Binding("u_material", "buffer/uniform", wobject.material.uniform_buffer),
            }
            self.define_bindings(0, bindings)
            return {0: bindings}

        def get_pipeline_info(self, wobject, shared):
            return {"primitive_topology": wgpu.PrimitiveTopology.triangle_strip, "cull_mode": wgpu.CullMode.none}

        def get_render_info(self, wobject, shared):
            return {"indices": (4, 1)}

        def get_code(self):
            return read_shader("sky_ground.wgsl")
