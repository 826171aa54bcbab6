"""GrassMaterial: colours, lighting and ribbon shape of grass blades (a pygfx Material).

Its uniform buffer is read by the blade render shader (``blade_render.wgsl``,
``u_material``); every uniform is a validated, documented property.
"""

from __future__ import annotations

import math

import numpy as np
import pygfx as gfx

from ..core.enums import BladeShape
from ..errors import GrassValueError
from ..core.engine_inputs import MATERIAL_DEFAULTS
from ..core.params import LOOK_TRAITS, GrassParams
from ..core.uniform_layouts import GRASS_MATERIAL_LAYOUT, shadertype

__all__ = ["GrassMaterial"]

#: The looks' defaults, written once in ``GrassParams`` (a material made without params
#: looks like a field made with default params).
_LOOK_DEFAULTS = {name: GrassParams.class_traits()[name].default_value
                  for name in (*LOOK_TRAITS, "blade_shape")}

#: Ribbon shape labels, in id order (``enums.BladeShape``).
SHAPES = BladeShape.labels()


class GrassMaterial(gfx.Material):
    """Colours, lighting and ribbon shape of grass blades.

    Uniforms (all documented as properties): ``root_color``, ``tip_color`` (sRGB),
    ``color_variation`` (0..1, per-blade brightness/hue spread, in patches of
    ``patch_size`` metres), ``dryness`` (0..1), ``translucency`` (0..1, tips lit
    from behind), ``fog_density`` (1/m) and ``fog_color`` (sRGB), ``ambient``
    (0..1), ``light_direction`` (towards the light, world space),
    ``blade_shape`` (one of quad, triangle, quadratic, triangle-tip, fold) and
    ``tip_threshold`` (tau of the triangle-tip shape, 0..0.99). The sunlight's uniforms
    (``set_sunlight``) are written by the field it draws before every frame
    (``GrassField.prepare_sunlight``), ``light_direction`` with them: the params' sun.
    """

    #: pygfx's material uniforms plus ``uniform_layouts.GRASS_MATERIAL_LAYOUT`` (the browser
    #: engine's struct; ``opacity`` and ``alpha_test`` are pygfx's own, at the same places).
    uniform_type = dict(gfx.Material.uniform_type, **shadertype(GRASS_MATERIAL_LAYOUT))

    def __init__(
        self,
        *,
        root_color=MATERIAL_DEFAULTS["root_color"],
        tip_color=MATERIAL_DEFAULTS["tip_color"],
        color_variation=_LOOK_DEFAULTS["color_variation"],
        patch_size=_LOOK_DEFAULTS["patch_size"],
        dryness=_LOOK_DEFAULTS["dryness"],
        translucency=_LOOK_DEFAULTS["translucency"],
        fog_density=_LOOK_DEFAULTS["fog_density"],
        fog_color=MATERIAL_DEFAULTS["fog_color"],
        ambient=MATERIAL_DEFAULTS["ambient"],
        light_direction=MATERIAL_DEFAULTS["light_direction"],
        blade_shape=_LOOK_DEFAULTS["blade_shape"],
        tip_threshold=MATERIAL_DEFAULTS["tip_threshold"],
        **kwargs,
    ):
        super().__init__(**kwargs)
        self.root_color = root_color
        self.tip_color = tip_color
        self.color_variation = color_variation
        self.patch_size = patch_size
        self.dryness = dryness
        self.translucency = translucency
        self.fog_density = fog_density
        self.fog_color = fog_color
        self.ambient = ambient
        self.light_direction = light_direction
        self.blade_shape = blade_shape
        self.tip_threshold = tip_threshold
        self._store.sunlight = False

    @property
    def sunlight(self) -> bool:
        """True while the sunlight written last (:meth:`set_sunlight`) has ``shadows`` on: the
        ribbon and resolve shaders compile the shadows' maths in only then (tracked by pygfx:
        a change rebuilds their pipelines; ``shaders/shadows.wgsl``). False until then."""
        return self._store.sunlight

    def set_sunlight(self, values: dict):
        """Write the sunlight's values (``core.engine_inputs.sunlight_values``: ``light_direction``,
        ``shadow_balls``, ``shadow_field``, ``shadow_depths``, ``shadows``) as they are;
        ``GrassField.prepare_sunlight`` does it before every frame."""
        names = {"light_direction", "shadow_balls", "shadow_field", "shadow_depths", "shadows"}
        unknown = set(values) - names
        if unknown:
            raise GrassValueError(f"set_sunlight takes {', '.join(sorted(names))}; got {sorted(unknown)}")
        data = self.uniform_buffer.data
        for key, value in values.items():
            data[key] = value
        self.uniform_buffer.update_full()
        if "shadows" in values:
            self._store.sunlight = bool(float(values["shadows"]) > 0.0)

    def _set(self, key, value):
        self.uniform_buffer.data[key] = value
        self.uniform_buffer.update_full()

    def _wgpu_get_pick_info(self, pick_value) -> dict:
        """pygfx's hook for ``renderer.get_pick_info``: the blade shader packs the
        blade id in the 26 bits after the object id (with ``pick_write = True``)."""
        return {"blade_index": int((pick_value >> 20) & ((1 << 26) - 1))}

    @property
    def root_color(self):
        """Colour at the blade root (sRGB)."""
        return gfx.Color(self.uniform_buffer.data["root_color"])

    @root_color.setter
    def root_color(self, color):
        self._set("root_color", gfx.Color(color))

    @property
    def tip_color(self):
        """Colour at the blade tip (sRGB)."""
        return gfx.Color(self.uniform_buffer.data["tip_color"])

    @tip_color.setter
    def tip_color(self, color):
        self._set("tip_color", gfx.Color(color))

    @property
    def color_variation(self):
        """Per-blade colour spread, 0 (none) .. 1."""
        return float(self.uniform_buffer.data["color_variation"])

    @color_variation.setter
    def color_variation(self, value):
        self._set("color_variation", _check_unit("color_variation", value))

    @property
    def patch_size(self):
        """Size of the colour patches (clumps) in metres, 0.1..100."""
        return float(self.uniform_buffer.data["patch_size"])

    @patch_size.setter
    def patch_size(self, value):
        v = float(value)
        if not (math.isfinite(v) and 0.1 <= v <= 100.0):
            raise GrassValueError(f"patch_size must be in [0.1, 100] m; got {value!r}")
        self._set("patch_size", v)

    @property
    def dryness(self):
        """Share of dry, straw-coloured grass in patches, 0..1."""
        return float(self.uniform_buffer.data["dryness"])

    @dryness.setter
    def dryness(self, value):
        self._set("dryness", _check_unit("dryness", value))

    @property
    def translucency(self):
        """How much the tips glow with the sun behind them, 0..1."""
        return float(self.uniform_buffer.data["translucency"])

    @translucency.setter
    def translucency(self, value):
        self._set("translucency", _check_unit("translucency", value))

    @property
    def fog_density(self):
        """Distance fog density in 1/m (0 = no fog), 0..1."""
        return float(self.uniform_buffer.data["fog_density"])

    @fog_density.setter
    def fog_density(self, value):
        self._set("fog_density", _check_unit("fog_density", value))

    @property
    def fog_color(self):
        """Colour far blades fade to (sRGB): the sky's at the horizon."""
        return gfx.Color(self.uniform_buffer.data["fog_color"])

    @fog_color.setter
    def fog_color(self, color):
        self._set("fog_color", gfx.Color(color))

    @property
    def ambient(self):
        """Ambient light share, 0..1."""
        return float(self.uniform_buffer.data["ambient"])

    @ambient.setter
    def ambient(self, value):
        self._set("ambient", _check_unit("ambient", value))

    @property
    def light_direction(self):
        """Unit direction towards the light (world space)."""
        return tuple(float(x) for x in self.uniform_buffer.data["light_direction"][:3])

    @light_direction.setter
    def light_direction(self, value):
        v = np.asarray(value, np.float64).reshape(3)
        norm = np.linalg.norm(v)
        if not np.all(np.isfinite(v)) or norm == 0:
            raise GrassValueError(f"light_direction must be a finite non-zero 3-vector; got {value!r}")
        self._set("light_direction", (*(v / norm), 0.0))

    @property
    def blade_shape(self):
        """Ribbon shape: one of quad, triangle, quadratic, triangle-tip, fold."""
        return BladeShape(int(self.uniform_buffer.data["blade_shape"])).label

    @blade_shape.setter
    def blade_shape(self, value):
        if value not in SHAPES:
            raise GrassValueError(f"blade_shape must be one of {', '.join(SHAPES)}; got {value!r}")
        self._set("blade_shape", int(BladeShape.from_label(value)))

    @property
    def tip_threshold(self):
        """tau of the triangle-tip shape: the blade narrows to its tip above v = tau (0..0.99)."""
        return float(self.uniform_buffer.data["tip_threshold"])

    @tip_threshold.setter
    def tip_threshold(self, value):
        v = float(value)
        if not (math.isfinite(v) and 0.0 <= v <= 0.99):
            raise GrassValueError(f"tip_threshold must be in [0, 0.99]; got {value!r}")
        self._set("tip_threshold", v)


def _check_unit(name, value):
    v = float(value)
    if not (math.isfinite(v) and 0.0 <= v <= 1.0):
        raise GrassValueError(f"{name} must be in [0, 1]; got {value!r}")
    return v
