"""Sky and ground in one full-screen pass: the cheap backdrop of GrassScene.

``shaders/sky_ground.wgsl`` is drawn by both engines (the browser engine renders
it for its own bindings); GrassScene writes the values both engines use,
:func:`grasswidget.core.engine_inputs.sky_ground_values` (colours, ground square,
field rectangle, cover, far plane, fog), with :meth:`SkyGroundMaterial.set_values`.

On a CPU adapter every full-screen pass costs milliseconds (a gradient
Background and a lit ground plane were two of them: about 11 ms of a 640 x 480
lavapipe frame). :class:`SkyGround` draws both with one material, *after* the grass,
at the far depth with the "<" depth test, so the pixels the grass covers are
never shaded; in the kernel engine as two pieces of the screen (the sky's, the
ground's: :class:`GroundPart`), so that no sky pixel pays for the ground's maths. The ground is already lit (one normal, one sun): soil under the
field, darker the more the grass covers it, and beyond it the grass seen from afar in the
blades' colour patches (their noise a pixel; a noise texture there once cost a third of a
lavapipe frame, see SkyGroundMaterial.far_grass); it fades into the sky's horizon colour
towards the far plane and with the distance fog, so that the horizon is soft.
"""

from __future__ import annotations

import numpy as np
import pygfx as gfx
import wgpu
from pygfx.renderers.wgpu import BaseShader, Binding, register_wgpu_render_function

from ..errors import GrassValueError
from ..core.engine_inputs import BEYOND_COLOR, FIELD_EDGE, HORIZON_COLOR, SOIL_COLOR, ZENITH_COLOR, ground_sun
from ..core.shader_files import read_shader
from ..core.uniform_layouts import SKY_GROUND_LAYOUT, shadertype, write_values
from .wgsl_templates import shader_vars  # (also registers the 'grasswidget' WGSL loader)

__all__ = ["SkyGround", "GroundPart", "SkyGroundMaterial", "GroundSwitch"]


class SkyGroundMaterial(gfx.Material):
    """Colours, ground square, field rectangle and fog of a :class:`SkyGround`.

    Args:
        horizon_color, zenith_color: sRGB colours of the sky at the horizon (also the
            fog's colour) and straight up; between them by the ray's elevation.
        soil_color: sRGB colour of the bare soil under the field (already lit; the
            grass' cover darkens it down to 0.4 of this).
        beyond_color: sRGB colour of the ground beyond the field.
        ground_center: (x, y, z) metres: the ground plane is y = ground_center[1].
        ground_half_size: half the side of the ground square (m, > 0).
        far_distance: the camera's far plane (m, > 0): the ground fades into the
            horizon colour from 0.6 of it.

    The field rectangle and the grass' cover come from
    :meth:`set_field`; the fog density from ``fog_density`` (1/m, 0 = none).
    """

    #: pygfx's material uniforms plus ``uniform_layouts.SKY_GROUND_LAYOUT`` (the browser engine's struct).
    uniform_type = dict(gfx.Material.uniform_type, **shadertype(SKY_GROUND_LAYOUT))

    def __init__(self, horizon_color=HORIZON_COLOR, zenith_color=ZENITH_COLOR, soil_color=SOIL_COLOR,
                 beyond_color=BEYOND_COLOR, ground_center=(0.0, 0.0, 0.0), ground_half_size=10.0,
                 far_distance=100.0, **kwargs):
        super().__init__(depth_test=True, depth_compare="<", depth_write=False, **kwargs)
        self._sunlight_seen = None  # (values, uniform bytes) of the last set_sunlight
        self._store.sunlight = False
        self._store.far_grass = False
        data = self.uniform_buffer.data
        for name, color in (("horizon_color", horizon_color), ("zenith_color", zenith_color),
                            ("soil_color", soil_color), ("beyond_color", beyond_color)):
            data[name] = gfx.Color(color).rgba
        data["fog_density"] = 0.0
        self.set_field((ground_center[0], ground_center[2]), (ground_half_size, ground_half_size), 0.0, FIELD_EDGE)
        self.set_ground(ground_center, ground_half_size, far_distance)
        self.show_ground = True

    def set_ground(self, center, half_size, far_distance=None):
        """Move the ground square: ``center`` (x, y, z) metres, ``half_size`` metres (> 0);
        ``far_distance`` (m, > 0): the camera's far plane (None keeps it)."""
        half_size = float(half_size)
        if not half_size > 0:
            raise GrassValueError(f"ground_half_size must be > 0 (metres); got {half_size!r}")
        if far_distance is not None:
            far_distance = float(far_distance)
            if not (np.isfinite(far_distance) and far_distance > 0):
                raise GrassValueError(f"far_distance must be > 0 (metres); got {far_distance!r}")
            self.uniform_buffer.data["far_distance"] = far_distance
        c = np.asarray(center, np.float32).reshape(3)
        self.uniform_buffer.data["ground"] = (c[0], c[1], c[2], half_size)
        self.uniform_buffer.update_full()

    def set_values(self, values: dict):
        """Write values of ``uniform_layouts.SKY_GROUND_LAYOUT`` fields as they are, e.g.
        :func:`grasswidget.core.engine_inputs.sky_ground_values` (what the browser engine
        is sent too)."""
        unknown = set(values) - {name for name, _ in SKY_GROUND_LAYOUT}
        if unknown:
            raise GrassValueError(f"values name fields the sky/ground lacks: {sorted(unknown)}")
        write_values(self.uniform_buffer.data, values)
        self.uniform_buffer.update_full()
        if "shadows" in values:  # the shader follows (sunlight)
            self._store.sunlight = bool(float(values["shadows"]) > 0.0)
        if "horizon" in values or "far_grass" in values:  # the shader follows (far_grass)
            data = self.uniform_buffer.data
            self._store.far_grass = bool(float(data["horizon"][3]) != 0.0 or float(data["far_grass"][3]) != 0.0)

    def set_field(self, center_xz, half_xz, cover, edge=FIELD_EDGE):
        """The field's rectangle on the ground: ``center_xz`` and ``half_xz`` (metres), the
        soil under it darkened by ``cover`` (0..1, see ``reference.ground_cover``), its
        edge soft over ``edge`` metres (> 0, default 0.5)."""
        cover, edge = float(cover), float(edge)
        if not 0.0 <= cover <= 1.0:
            raise GrassValueError(f"cover must be in [0, 1]; got {cover!r}")
        if not edge > 0:
            raise GrassValueError(f"edge must be > 0 metres; got {edge!r}")
        d = self.uniform_buffer.data
        d["field"] = (float(center_xz[0]), float(center_xz[1]), float(half_xz[0]), float(half_xz[1]))
        d["cover"], d["field_edge"] = cover, edge
        self.uniform_buffer.update_full()

    def set_sunlight(self, values: dict):
        """The sunlight of the field it is drawn with (``GrassField.sunlight_values``: the sun, the
        shadows' switch, the balls, the grass layer), with the ground's sunlit share for that sun;
        written only when it changed. Called every frame: the same values onto the same uniforms
        as last time return at once (a comparison of their bytes; 0.1 ms a frame otherwise)."""
        seen = (tuple(np.asarray(v, np.float64).tobytes() for v in values.values()), self.uniform_buffer.data.tobytes())
        if seen == self._sunlight_seen:
            return
        values = dict(values, ground_sun=ground_sun(values["light_direction"][1]))
        data = self.uniform_buffer.data
        if not all(np.array_equal(np.asarray(data[k], np.float32), np.asarray(v, np.float32))
                   for k, v in values.items()):
            self.set_values(values)
        self._sunlight_seen = (seen[0], self.uniform_buffer.data.tobytes())

    @property
    def sunlight(self) -> bool:
        """True while the ``shadows`` written last (:meth:`set_sunlight`, :meth:`set_values`) is on: the
        shader compiles the ground's shadows in only then (tracked by pygfx: a change rebuilds
        its pipeline; ``shaders/shadows.wgsl``). False until then."""
        return self._store.sunlight

    @property
    def far_grass(self) -> bool:
        """True while the values written last (:meth:`set_values`) show grass seen from afar on the
        ground: beyond the field (``far_grass.w`` non-zero, every field of
        :func:`~grasswidget.core.engine_inputs.sky_ground_values`) or over a field to the horizon
        (``horizon.w`` non-zero). The shader compiles the far grass in only then (tracked by pygfx: a
        change rebuilds its pipeline; on lavapipe its noise costs every ground pixel, the soil's too).
        False until then (both start at 0: the bare plain ``beyond_color``)."""
        return self._store.far_grass

    @property
    def fog_density(self) -> float:
        """Distance fog density in 1/m (0 = no fog), towards ``horizon_color``."""
        return float(self.uniform_buffer.data["fog_density"])

    @fog_density.setter
    def fog_density(self, value):
        v = float(value)
        if not (np.isfinite(v) and 0.0 <= v <= 1.0):
            raise GrassValueError(f"fog_density must be in [0, 1] 1/m; got {value!r}")
        self.uniform_buffer.data["fog_density"] = v
        self.uniform_buffer.update_full()

    @property
    def horizon_color(self):
        """The sky's colour at the horizon (sRGB), also the fog's."""
        return gfx.Color(self.uniform_buffer.data["horizon_color"])

    @property
    def show_ground(self) -> bool:
        """Draw the ground square (else sky everywhere)."""
        return bool(self.uniform_buffer.data["show_ground"])

    @show_ground.setter
    def show_ground(self, value):
        self.uniform_buffer.data["show_ground"] = int(bool(value))
        self.uniform_buffer.update_full()


class SkyGround(gfx.WorldObject):
    """Sky gradient and a flat ground square, drawn last: two draws of one material, this object the
    sky's piece of the screen and its child :attr:`ground_part` the ground's (``sky_ground.wgsl``'s
    ``part``: the screen split where the view ray turns towards the ground), so that no sky pixel
    runs the ground's maths; both at the far depth behind the "<" depth test (nothing the grass
    covers is shaded). ``SkyGround(material, split=False)`` draws one full-screen pass instead
    (``part`` "all", what the browser engine draws; the same picture)."""

    def __init__(self, material: SkyGroundMaterial | None = None, split: bool = True):
        _register()
        super().__init__(None, material or SkyGroundMaterial(), render_order=1e6)
        #: The ground's piece (a :class:`GroundPart` sharing this material), None when not split.
        self.ground_part = GroundPart(self.material) if split else None
        if self.ground_part is not None:
            self.add(self.ground_part)

    @property
    def part(self) -> str:
        """What this object's draw covers: "sky" (split) or "all" (one full-screen pass)."""
        return "all" if self.ground_part is None else "sky"


class GroundPart(gfx.WorldObject):
    """The ground's piece of the screen of a split :class:`SkyGround` (its child; same material)."""

    part = "ground"

    def __init__(self, material: SkyGroundMaterial):
        _register()
        super().__init__(None, material, render_order=1e6)


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
            topology = wgpu.PrimitiveTopology.triangle_strip if wobject.part == "all" \
                else wgpu.PrimitiveTopology.triangle_list
            return {"primitive_topology": topology, "cull_mode": wgpu.CullMode.none}

        def get_render_info(self, wobject, shared):
            # "all": the screen's strip of 4; a piece: up to 3 triangles of a fan (sky_ground.wgsl)
            return {"indices": (4 if wobject.part == "all" else 9, 1)}

        def __init__(self, wobject, **kwargs):
            # blade_math.wgsl's ids and constants; the shadows' maths only while they are on
            super().__init__(wobject, **shader_vars(sunlight=wobject.material.sunlight,
                                                       far_grass=wobject.material.far_grass,
                                                       part=wobject.part,
                                                       **kwargs))

        def get_code(self):
            return read_shader("sky_ground.wgsl")

    register_wgpu_render_function(SkyGround, SkyGroundMaterial)(SkyGroundShader)
    register_wgpu_render_function(GroundPart, SkyGroundMaterial)(SkyGroundShader)
