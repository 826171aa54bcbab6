"""The uniform structs the WGSL reads, written once for both engines (pure Python).

A layout is a tuple of ``(field, wgsl_type)`` in the order the struct declares
its fields. The kernel engine (pygfx) takes it as a shadertype dict through
:func:`shadertype` (and binds ``u_cull`` as a read-only storage buffer declared
with :func:`wgsl_struct`: see ``grasswidget.gpu.wgsl_templates`` for why); the browser engine packs bytes and writes the WGSL struct
from it (``grasswidget.browser.uniforms``). The order is the one pygfx lays a
struct out in (16-byte-aligned fields first, then the 4-byte ones, each group in
the order given), so both engines put every field at the same byte offset;
``tests/core/test_uniform_layouts.py`` checks that field for field.

The values are computed once too, for both engines, by
:mod:`grasswidget.core.engine_inputs` (``sim_uniform_values``, ``cull_uniform_values``):
the kernel copies them into its pygfx arrays, the browser gets them as bytes
from :func:`pack`. To add a uniform field: one line here, its value in
``engine_inputs``, and read it in the WGSL as ``u_sim.<field>`` or ``u_cull.<field>``.
"""

from __future__ import annotations

import numpy as np

from ..errors import GrassValueError
from .horizon import MAX_LEVELS
from .reference.shadows import MAX_SHADOW_BALLS

__all__ = ["SIM_LAYOUT", "CULL_LAYOUT", "SKY_GROUND_LAYOUT", "SUNLIGHT_VECTORS", "GRASS_MATERIAL_LAYOUT", "INSPECT_LAYOUT", "shadertype",
           "wgsl_shadertype", "offsets",
           "struct_size", "pack", "layout_description", "write_values", "wgsl_struct"]

#: ``u_sim``: the simulation's parameters (simulate.wgsl, inspect.wgsl). Vectors are
#: vec4 (xyz used) so that the struct has no vec3 padding rules to get wrong.
SIM_LAYOUT = (
    ("gravity_dir", "vec4<f32>"),         # GrassParams.gravity_direction, normalized
    ("wind_dir", "vec4<f32>"),            # from GrassParams.wind_direction
    ("gravity_center", "vec4<f32>"),      # GrassParams.gravity_center (m)
    ("wind_center", "vec4<f32>"),         # GrassParams.wind_center (m)
    ("gravity", "f32"),                   # m/s^2
    ("front_gravity", "f32"),             # GrassParams.front_gravity
    ("stiffness_scale", "f32"),           # GrassParams.stiffness_scale
    ("dt", "f32"),                        # fixed time step (s)
    ("time0", "f32"),                     # simulation time of the first step of this dispatch (s)
    ("wind_strength", "f32"),             # m/s^2
    ("wind_speed", "f32"),                # m/s
    ("wind_wavelength", "f32"),           # m
    ("wind_field", "i32"),                # enums.WindField
    ("steps", "i32"),                     # fixed steps in this dispatch
    ("n_blades", "u32"),
    ("gravity_mode", "i32"),              # enums.GravityMode
    ("wind_radius", "f32"),               # m
    ("wind_direction_rad", "f32"),        # GrassParams.wind_direction in radians
    ("collision_fade", "f32"),            # GrassParams.collision_fade
    ("collision_gain", "f32"),            # GrassParams.collision_gain
    ("n_colliders", "i32"),               # spheres in s_colliders (the grid: core.collider_grid)
)

#: ``u_cull``: the culling pass's parameters and the frozen camera (cull.wgsl).
CULL_LAYOUT = (
    ("frozen_cam_pos", "vec4<f32>"),      # frozen culling camera position (m)
    ("frozen_view_proj", "mat4x4<f32>"),  # frozen culling camera, world to clip space
    # A field to the horizon's camera-following levels (levels.wgsl; HorizonLayout.table, written with
    # the rest; zeros and n_levels 0 for any other field). The arrays come before the scalars, where
    # pygfx's array_from_shadertype puts them:
    ("level_bands", f"array<vec4<f32>, {MAX_LEVELS}>"),  # per level: fade-in start, end, fade-out start, end (m)
    ("level_periods", "array<vec4<f32>, 2>"),  # tile side P_k (m) at [k / 4][k % 4]
    ("level_ends", "array<vec4<u32>, 2>"),     # the first blade id after level k at [k / 4][k % 4]
    ("orientation_threshold", "f32"),     # GrassParams.cull_orientation_threshold
    ("frustum_tolerance", "f32"),         # GrassParams.cull_frustum_tolerance
    ("distance_max", "f32"),              # GrassParams.cull_distance_max (m)
    ("buckets", "i32"),                   # GrassParams.cull_buckets
    ("cull_orientation", "i32"),          # 0/1
    ("cull_frustum", "i32"),              # 0/1
    ("cull_distance", "i32"),             # 0/1
    ("lod", "i32"),                       # 0/1
    ("n_blades", "u32"),
    ("color_by", "i32"),                  # enums.ColorBy
    ("frozen", "i32"),                    # 0/1
    ("frozen_viewport_height", "f32"),    # frozen camera viewport height (pixels)
    ("occlusion_phase", "i32"),           # 1: this render is occlusion culling's first phase (cull.wgsl), else 0
    ("compute_raster", "i32"),            # 1: list thin blades for the compute rasterizer (raster.wgsl), else 0
    ("raster_max_px", "f32"),             # GrassParams.compute_raster_max_px (pixels)
    ("raster_width", "f32"),              # the compute rasterizer's buffers: width and height (pixels); it
    ("raster_height", "f32"),             #   runs only in renders of exactly that size
    ("raster_blade_shape", "i32"),        # GrassMaterial.blade_shape (enums.BladeShape id)
    ("raster_tip_threshold", "f32"),      # GrassMaterial.tip_threshold
    ("n_levels", "u32"),                  # camera-following levels K (0: not a field to the horizon)
)

#: The sunlight's vector fields of both ``u_material`` structs (the blades' and the sky/ground's),
#: read by ``shaders/shadows.wgsl`` with ``light_direction`` and ``shadows`` (values:
#: ``engine_inputs.sunlight_values``).
SUNLIGHT_VECTORS = (
    ("shadow_balls", f"array<vec4<f32>, {MAX_SHADOW_BALLS}>"),  # the first reference.MAX_SHADOW_BALLS colliders (x, y, z, r; r 0 unused)
    ("shadow_field", "vec4<f32>"),        # the field's rectangle for the grass' shadow: xy centre (x, z), zw half sizes (m)
    ("shadow_depths", "vec4<f32>"),       # sun's, sky's optical depth per m of grass, layer height (m), soft edge (m)
)

#: ``u_material`` of ``shaders/sky_ground.wgsl`` (both engines draw sky and ground with it;
#: values: ``engine_inputs.sky_ground_values``).
SKY_GROUND_LAYOUT = (
    ("horizon_color", "vec4<f32>"),       # sRGB 0..1: the sky at the horizon, also the fog's colour
    ("zenith_color", "vec4<f32>"),        # sRGB 0..1: the sky straight up
    ("soil_color", "vec4<f32>"),          # sRGB 0..1: bare soil under the field (lit), before the grass' cover
    ("beyond_color", "vec4<f32>"),        # sRGB 0..1: the ground beyond the field
    ("ground", "vec4<f32>"),              # xyz centre of the ground square (m), w half size (m)
    ("field", "vec4<f32>"),               # the field's rectangle: xy centre (x, z), zw half sizes (m)
    ("horizon", "vec4<f32>"),             # a field to the horizon: xy centre (x, z), z reach (m), w 1 (0: none)
    ("far_blend", "vec4<f32>"),           # x..y: camera distances (m) where the ground becomes far grass; z patch size (m); w along
    ("far_grass", "vec4<f32>"),           # rgb: the far grass's mean shade over its unlit colour at along far_blend.w
    ("grass_root", "vec4<f32>"),          # sRGB 0..1: the blades' root colour (their material's)
    ("grass_tip", "vec4<f32>"),           # sRGB 0..1: the blades' tip colour
    ("light_direction", "vec4<f32>"),     # unit vector towards the sun (xyz; GrassParams.sun_elevation, sun_azimuth)
    *SUNLIGHT_VECTORS,
    ("show_ground", "i32"),               # 0/1
    ("far_distance", "f32"),              # the camera's far plane (m): the ground fades into the horizon from 0.6 of it
    ("fog_density", "f32"),               # GrassParams.fog_density (1/m, 0 = no fog)
    ("cover", "f32"),                     # how much the grass shades its soil, 0..1 (reference.ground_cover)
    ("field_edge", "f32"),                # width of the soft edge between soil and ground beyond (m)
    ("color_variation", "f32"),           # GrassParams.color_variation (the far grass's patches)
    ("dryness", "f32"),                   # GrassParams.dryness
    ("shadows", "f32"),                   # GrassParams.shadows: 1 on, 0 off (shadows.wgsl)
    ("ground_sun", "f32"),                # the ground's sunlit share relative to the default sun (sun height ratio)
)

#: ``u_material`` of ``shaders/blade_render.wgsl``: the grass material (kernel:
#: ``grasswidget.gpu.material.GrassMaterial``, whose pygfx base adds ``opacity`` and
#: ``alpha_test`` at these places; values: ``engine_inputs.material_values``).
GRASS_MATERIAL_LAYOUT = (
    ("root_color", "vec4<f32>"),          # sRGB 0..1, blade root
    ("tip_color", "vec4<f32>"),           # sRGB 0..1, blade tip
    ("light_direction", "vec4<f32>"),     # unit vector towards the light (xyz)
    ("fog_color", "vec4<f32>"),           # sRGB 0..1: far blades fade to it (the sky's horizon colour)
    *SUNLIGHT_VECTORS,
    ("opacity", "f32"),                   # pygfx Material.opacity (1)
    ("alpha_test", "f32"),                # pygfx Material.alpha_test (0, unused)
    ("color_variation", "f32"),           # GrassParams.color_variation (0..1)
    ("patch_size", "f32"),                # GrassParams.patch_size (m)
    ("dryness", "f32"),                   # GrassParams.dryness (0..1)
    ("translucency", "f32"),              # GrassParams.translucency (0..1)
    ("fog_density", "f32"),               # GrassParams.fog_density (1/m)
    ("ambient", "f32"),                   # ambient light share (0..1)
    ("tip_threshold", "f32"),             # tau of the triangle-tip shape (0..0.99)
    ("blade_shape", "i32"),               # enums.BladeShape
    ("shadows", "f32"),                   # GrassParams.shadows: 1 on, 0 off (shadows.wgsl)
)

#: ``u_inspect``: the blade inspector's ids (inspect.wgsl): up to ``teaching.MAX_INSPECTED`` (64)
#: blade ids, four per vec4, and how many are used.
INSPECT_LAYOUT = (
    ("ids", "array<vec4<u32>, 16>"),      # blade ids, ids[k / 4][k % 4]
    ("n_ids", "u32"),                     # 0..64
)

_SCALARS = {"f32": "f4", "i32": "i4", "u32": "u4"}


def wgsl_shadertype(wgsl_type: str) -> str:
    """pygfx's shadertype format of one WGSL type: ``f32`` -> ``f4``, ``vec4<f32>`` ->
    ``4xf4``, ``mat4x4<f32>`` -> ``4x4xf4``, ``array<vec4<f32>, 16>`` -> ``16*4xf4``."""
    t = wgsl_type.replace(" ", "")
    if t in _SCALARS:
        return _SCALARS[t]
    if t.startswith("array<") and t.endswith(">"):
        element, _, count = t[len("array<"):-1].rpartition(",")
        return f"{int(count)}*{wgsl_shadertype(element)}"
    for prefix, dims in (("vec2<", "2x"), ("vec4<", "4x"), ("mat4x4<", "4x4x")):
        if t.startswith(prefix) and t.endswith(">") and t[len(prefix):-1] in _SCALARS:
            return dims + _SCALARS[t[len(prefix):-1]]
    raise GrassValueError(f"unsupported uniform type {wgsl_type!r}; supported: f32, i32, u32, vec2/vec4/mat4x4 "
                          "of them, array<vec4<f32|i32|u32>, N>")


def shadertype(layout) -> dict:
    """The pygfx shadertype dict of ``layout`` (for ``pygfx.utils.array_from_shadertype``)."""
    return {name: wgsl_shadertype(t) for name, t in layout}


def wgsl_struct(name: str, layout) -> str:
    """The WGSL ``struct name { ... };`` of ``layout``, fields in layout order."""
    fields = "\n".join(f"    {f}: {t}," for f, t in layout)
    return f"struct {name} {{\n{fields}\n}};"


# ---------------------------------------------------------------------- byte layout (WGSL uniform rules)

_NUMPY = {"f32": "<f4", "i32": "<i4", "u32": "<u4"}


def _size_align(wgsl_type):
    """(size, align, numpy dtype of one element, element count) of a WGSL type."""
    t = wgsl_type.replace(" ", "")
    if t in _NUMPY:
        return 4, 4, _NUMPY[t], 1
    if t == "vec2<f32>":
        return 8, 8, "<f4", 2
    if t == "vec4<f32>":
        return 16, 16, "<f4", 4
    if t == "mat4x4<f32>":
        return 64, 16, "<f4", 16
    for scalar in ("f32", "i32", "u32"):
        if t.startswith(f"array<vec4<{scalar}>,"):
            n = int(t.rsplit(",", 1)[1].rstrip(">"))
            return 16 * n, 16, _NUMPY[scalar], 4 * n
    raise GrassValueError(f"unsupported uniform type {wgsl_type!r}")


def offsets(layout) -> dict:
    """{field: (byte offset, numpy dtype, element count)} under WGSL's uniform rules
    (scalars 4 bytes, vec2 8, vec4 16, mat4x4 64 aligned to 16, array<vec4<f32>, N> 16 N)."""
    out, off = {}, 0
    for name, t in layout:
        size, align, dtype, count = _size_align(t)
        off = -(-off // align) * align
        out[name] = (off, dtype, count)
        off += size
    return out


def struct_size(layout) -> int:
    """Bytes of the struct (rounded up to 16)."""
    end = max((off + 4 * count for off, _dtype, count in offsets(layout).values()), default=0)
    return -(-end // 16) * 16


def layout_description(layout) -> dict:
    """JSON-able {field: [offset, kind, count]} (kind "f32", "i32" or "u32")."""
    kinds = {"<f4": "f32", "<i4": "i32", "<u4": "u32"}
    return {k: [o, kinds[d], c] for k, (o, d, c) in offsets(layout).items()}


def pack(layout, values: dict) -> bytes:
    """The struct's bytes from ``values`` ({field: number or array}, e.g.
    ``engine_inputs.sim_uniform_values(...)``); fields missing from ``values`` are zero,
    names not in the layout raise GrassValueError."""
    unknown = set(values) - {name for name, _ in layout}
    if unknown:
        raise GrassValueError(f"values name fields the layout lacks: {sorted(unknown)}")
    buf = bytearray(struct_size(layout))
    for name, (off, dtype, count) in offsets(layout).items():
        if name not in values:
            continue
        arr = np.zeros(count, dtype)
        v = np.asarray(values[name], np.float64).reshape(-1).astype(dtype)
        arr[: min(count, v.size)] = v[:count]
        buf[off: off + 4 * count] = arr.tobytes()
    return bytes(buf)


def write_values(array, values: dict):
    """Copy ``values`` into a pygfx uniform array (``buffer.data``) field by field."""
    for name, value in values.items():
        array[name] = value
