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
from pygfx.renderers.wgpu import BaseShader, Binding, GfxTextureView, register_wgpu_render_function

from .. import compat
from ..errors import GrassValueError
from ..core.engine_inputs import BEYOND_COLOR, FIELD_EDGE, HORIZON_COLOR, SOIL_COLOR, ZENITH_COLOR, ground_sun
from ..core.shader_files import read_shader
from ..core.uniform_layouts import SKY_GROUND_LAYOUT, shadertype, write_values
from .wgsl_templates import shader_vars  # (also registers the 'grasswidget' WGSL loader)

__all__ = ["SkyGround", "GroundPart", "SkyGroundMaterial", "GroundSwitch", "SkyGroundCache", "SkyCopy",
           "SkyCopyMaterial"]


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
        self._store.copied = False  # drawn from SkyGroundCache's picture (SkyCopy), not shaded
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
    def copied(self) -> bool:
        """True while the sky and ground are drawn from :class:`SkyGroundCache`'s picture (the
        :class:`SkyCopy`) instead of shaded: the shaded draws have no instance (tracked by pygfx)."""
        return self._store.copied

    @copied.setter
    def copied(self, value):
        if bool(value) != self._store.copied:
            self._store.copied = bool(value)

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
        #: The picture of a still view, copied instead of shaded (:class:`SkyGroundCache`; render_frame
        #: prepares it before each frame).
        self.cache = SkyGroundCache(self)

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



class SkyCopyMaterial(gfx.Material):
    """What :class:`SkyCopy` draws: ``texture`` (a pygfx Texture of the view's size and the colour
    target's format, the sky and ground shaded once), ``drawn`` (False: no instance) and in its
    uniforms ``sky_id``, the pick id the copied pixels keep (the SkyGround's)."""

    uniform_type = dict(gfx.Material.uniform_type, sky_id="u4")

    def __init__(self, texture, sky_id: int):
        super().__init__(depth_test=True, depth_compare="<", depth_write=False)
        self._store.texture = texture
        self._store.drawn = False
        self.uniform_buffer.data["sky_id"] = int(sky_id)
        self.uniform_buffer.update_full()

    @property
    def texture(self):
        """The picture copied (tracked by pygfx: a new one binds anew)."""
        return self._store.texture

    @texture.setter
    def texture(self, value):
        self._store.texture = value

    @property
    def drawn(self) -> bool:
        """Whether the copy is drawn this frame (tracked by pygfx)."""
        return self._store.drawn

    @drawn.setter
    def drawn(self, value):
        if bool(value) != self._store.drawn:
            self._store.drawn = bool(value)


class SkyCopy(gfx.WorldObject):
    """The sky and ground drawn from :class:`SkyGroundCache`'s picture (``sky_copy.wgsl``): a child of
    the SkyGround it copies, drawn last like it, at the same depth."""

    def __init__(self, material: SkyCopyMaterial):
        _register()
        super().__init__(None, material, render_order=1e6)


class SkyGroundCache:
    """The sky and ground of a still view, shaded once and then copied (the kernel engine's live view).

    The sky and ground shade every pixel the grass leaves open, every frame; on a CPU adapter that
    is a sixth of the default widget's frame (0.4 of its render's CPU at 1280 x 720 beside the
    grass), and what they show depends only on the camera, the view's size and the sky/ground's
    values (:class:`SkyGroundMaterial`'s uniforms: colours, ground, field, fog, sunlight and the
    balls' shadows). :meth:`prepare`, before each frame (``render_frame``): while any of those
    changed since the frame before (a camera being dragged, a ball rolling), the sky and ground are
    shaded as ever; when a frame finds them as the last one left them, they are shaded once into a
    texture of the view's size (an own renderer, the same camera, nothing else in its scene) and
    drawn from it (:class:`SkyCopy`: one texel fetch per open pixel) until something changes. The
    picture is the same, pixel for pixel (tests/gpu/test_sky_ground.py). Only for renderers that draw
    at pixel ratio 1 (an export's supersampled renderer shades as ever).
    """

    def __init__(self, sky: "SkyGround"):
        self.sky = sky
        self._last_key = None    # what the last frame's sky and ground depended on
        self._cached_key = None  # what the picture in the texture was shaded for
        self._texture = None
        self._renderer = None
        self._scene = None
        self.copy = None  # the SkyCopy, added under the sky once a picture is cached
        #: Pictures shaded into the texture so far (for tests and benchmarks).
        self.builds = 0

    def _key(self, renderer, camera):
        material = self.sky.material
        return (tuple(renderer.physical_size), float(renderer.pixel_ratio),
                np.asarray(camera.world.matrix, np.float64).tobytes(),
                np.asarray(camera.projection_matrix, np.float64).tobytes(),
                material.uniform_buffer.data.tobytes(), material.sunlight, material.far_grass)

    def prepare(self, renderer, camera) -> bool:
        """Before a frame of ``renderer`` with ``camera``: draw the sky and ground from the cached
        picture this frame (True; shading it first when the picture is of something else) or shade
        them (False: they changed since the last frame, or the renderer does not draw at ratio 1)."""
        key = self._key(renderer, camera)
        still = key == self._last_key
        self._last_key = key
        depth = compat.renderer_depth_texture(renderer)  # the size pygfx draws at (None before its first render)
        usable = (float(renderer.pixel_ratio) == 1.0 and depth is not None
                  and tuple(int(s) for s in depth.size[:2]) == tuple(int(s) for s in renderer.physical_size)
                  and all(int(s) > 0 for s in renderer.physical_size))
        if not (still and usable):
            self._show(False)
            return False
        if self._cached_key != key:
            self._build(renderer, camera)
            self._cached_key = key
        self._show(True)
        return True

    def _show(self, copied: bool):
        self.sky.material.copied = copied
        if self.copy is not None:
            self.copy.material.drawn = copied

    def _build(self, renderer, camera):
        width, height = (int(s) for s in renderer.physical_size)
        if self._texture is None or tuple(self._texture.size[:2]) != (width, height):
            self._texture = gfx.Texture(dim=2, size=(width, height, 1), format="rgba8unorm-srgb", colorspace="physical")
            self._renderer = gfx.WgpuRenderer(self._texture, pixel_ratio=1, ppaa="none", enable_events=False)
            compat.copy_output_when_exact(self._renderer)  # the sky covers every pixel: a copy
            if self.copy is None:
                self.copy = SkyCopy(SkyCopyMaterial(self._texture, self.sky.id))
                self.sky.add(self.copy)
            else:
                self.copy.material.texture = self._texture
        if self._scene is None:
            self._scene = gfx.Scene()
            self._scene.add(SkyGround(self.sky.material))
        self._show(False)
        self._renderer.render(self._scene, camera)
        self.builds += 1

    def release(self):
        """Drop the texture and the renderer (the next still frame makes them again)."""
        self._show(False)
        if self.copy is not None:
            self.sky.remove(self.copy)
        self.copy = self._texture = self._renderer = self._scene = None
        self._last_key = self._cached_key = None

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
            # "all": the screen's strip of 4; a piece: up to 3 triangles of a fan (sky_ground.wgsl);
            # none while SkyGroundCache's copy draws the picture instead
            return {"indices": (4 if wobject.part == "all" else 9, 0 if wobject.material.copied else 1)}

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

    class SkyCopyShader(BaseShader):
        type = "render"

        def get_bindings(self, wobject, shared, scene):
            material = wobject.material
            bindings = {
                0: Binding("u_stdinfo", "buffer/uniform", shared.uniform_buffer),
                1: Binding("u_wobject", "buffer/uniform", wobject.uniform_buffer),
                2: Binding("u_material", "buffer/uniform", material.uniform_buffer),
                3: Binding("t_sky", "texture/auto", GfxTextureView(material.texture, view_dim="2d"), "FRAGMENT"),
            }
            self.define_bindings(0, bindings)
            return {0: bindings}

        def get_pipeline_info(self, wobject, shared):
            return {"primitive_topology": wgpu.PrimitiveTopology.triangle_strip, "cull_mode": wgpu.CullMode.none}

        def get_render_info(self, wobject, shared):
            return {"indices": (4, 1 if wobject.material.drawn else 0)}

        def get_code(self):
            return read_shader("sky_copy.wgsl")

    register_wgpu_render_function(SkyCopy, SkyCopyMaterial)(SkyCopyShader)
