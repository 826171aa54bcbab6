"""Uniform structs of the browser engine: layouts, WGSL text and packed bytes (pure Python).

``SIM_LAYOUT``, ``CULL_LAYOUT`` and ``SKY_GROUND_LAYOUT`` are the layouts both
engines use (:mod:`grasswidget.core.uniform_layouts`), and their values come from
the one function each engine uses (:mod:`grasswidget.core.engine_inputs`); here they are
only packed into bytes for the browser, which writes them into its buffers as
they are. The browser patches only the per-dispatch fields of ``u_sim``
(``steps``, ``time0``) and writes the camera uniform (``StdInfo``) itself, at
the offsets :func:`offsets` gives. ``GRASS_MATERIAL_LAYOUT`` (the blade material) is
the layout of the kernel's ``GrassMaterial`` too, and its
values come from ``engine_inputs.material_values``.

The field names are those the project's WGSL reads (``u_sim.wind_dir``,
``u_cull.n_blades``, ``u_stdinfo.cam_transform``, ``u_material.tip_color``...).
"""

from __future__ import annotations

from ..core.collider_grid import GRID_WORDS
from ..core.colliders import MAX_COLLIDERS
from ..core.enums import WindField
from ..core.engine_inputs import (clock_rules, collider_grid, compute_raster_values, cull_uniform_values, material_values,
                                  sim_uniform_values, srgb)
from ..core.params import GrassParams
from ..core.uniform_layouts import (CULL_LAYOUT, GRASS_MATERIAL_LAYOUT, SIM_LAYOUT, SKY_GROUND_LAYOUT,
                                   layout_description, offsets, pack, struct_size, wgsl_struct)

__all__ = [
    "SIM_LAYOUT", "CULL_LAYOUT", "SKY_GROUND_LAYOUT", "STDINFO_LAYOUT", "WOBJECT_LAYOUT", "GRASS_MATERIAL_LAYOUT",
    "WIND_FIELD_IDS", "offsets", "struct_size", "wgsl_struct", "pack", "sim_uniform", "cull_uniform",
    "material_uniform", "sky_ground_uniform", "collider_buffers", "COLLIDER_BYTES", "GRID_BYTES", "ball_uniform", "BALL_LAYOUT", "layout_description", "srgb_color",
]

#: Wind field ids of simulate.wgsl's wind_field() (grasswidget.core.enums.WindField).
WIND_FIELD_IDS = {label: int(WindField.from_label(label)) for label in WindField.labels()}

STDINFO_LAYOUT = (
    ("cam_transform", "mat4x4<f32>"),
    ("cam_transform_inv", "mat4x4<f32>"),
    ("projection_transform", "mat4x4<f32>"),
    ("projection_transform_inv", "mat4x4<f32>"),
    ("physical_size", "vec2<f32>"),
    ("logical_size", "vec2<f32>"),
    ("ndc_offset", "vec4<f32>"),      # xy scale, zw offset of a sub-viewport (the browser: 1, 1, 0, 0)
)

#: pygfx's world-object uniform, the fields the project's WGSL reads (the browser's field is
#: untransformed: both are the identity).
WOBJECT_LAYOUT = (("world_transform", "mat4x4<f32>"), ("world_transform_inv", "mat4x4<f32>"))



#: The collider balls' style (balls.wgsl; from engine_inputs.scene_style).
BALL_LAYOUT = (
    ("ball_color", "vec4<f32>"),          # sRGB rgb, a opacity
    ("light_direction", "vec4<f32>"),     # towards the light (xyz)
)




def sim_uniform(params: GrassParams, n_blades: int, colliders=()) -> bytes:
    """``u_sim`` for an untransformed field (the browser's field has no transform), packed:
    :func:`grasswidget.core.engine_inputs.sim_uniform_values`, as the kernel engine writes it.
    ``steps`` and ``time0`` are 0: the browser writes them for each dispatch."""
    return pack(SIM_LAYOUT, sim_uniform_values(params, n_blades, colliders))


#: Bytes of the browser's collider buffers: the spheres (MAX_COLLIDERS vec4) and the grid words.
COLLIDER_BYTES = 16 * MAX_COLLIDERS
GRID_BYTES = 4 * GRID_WORDS


def collider_buffers(colliders, blades) -> tuple:
    """(spheres, grid) bytes for ``s_colliders`` and ``s_collider_grid``: the arrays the kernel
    engine uploads too (:func:`grasswidget.core.engine_inputs.collider_grid`)."""
    grid = collider_grid(colliders, blades)
    return grid.sphere_data().tobytes(), grid.words().tobytes()


def cull_uniform(params: GrassParams, n_blades: int, frozen=None, decided=None, *, thinned: bool = False,
                 horizon=None) -> bytes:
    """``u_cull`` packed: :func:`grasswidget.core.engine_inputs.cull_uniform_values` (the
    browser draws every frame in occlusion culling's two phases while
    ``params.cull_occlusion`` is on: ``occlusion_phase`` is 1 then), with the compute
    rasterizer's switch and material values (:func:`grasswidget.core.engine_inputs.compute_raster_values`;
    the browser writes the render size, ``raster_width`` and ``raster_height``, for each view).
    ``decided``: the values of the "auto" switches Python chose for the browser's next frames
    (:mod:`grasswidget.browser.trial_feed`), or None (the fixed defaults). ``thinned``: a
    field to the horizon (no distance culling; see ``cull_uniform_values``). ``horizon``: a field to
    the horizon's layout (``Blades.horizon``), its level table; it implies ``thinned``."""
    values = cull_uniform_values(params, n_blades, frozen, every_frame_two_phases=True, decided=decided,
                                 thinned=thinned, horizon=horizon)
    material = material_values(params)  # the material the ribbons get (material_uniform)
    values.update(compute_raster_values(params, n_blades, material["blade_shape"], material["tip_threshold"], decided))
    return pack(CULL_LAYOUT, values)


def sky_ground_uniform(style: dict) -> bytes:
    """``u_material`` of sky_ground.wgsl from a :func:`grasswidget.core.engine_inputs.scene_style` dict."""
    return pack(SKY_GROUND_LAYOUT, {k: style[k] for k, _ in SKY_GROUND_LAYOUT})


def ball_uniform(style: dict) -> bytes:
    """``u_balls`` of balls.wgsl from a :func:`grasswidget.core.engine_inputs.scene_style` dict."""
    return pack(BALL_LAYOUT, {"ball_color": style["ball_color"], "light_direction": (*style["light_direction"][:3], 0.0)})


def srgb_color(hex_color: str) -> tuple:
    """(r, g, b, 1) in 0..1 from "#rrggbb"."""
    return srgb(hex_color)


def material_uniform(params: GrassParams, blades=None, colliders=(), **material) -> bytes:
    """``u_material`` of blade_render.wgsl packed: :func:`grasswidget.core.engine_inputs.material_values`
    (the material's defaults, or ``material``'s overrides of them, the params' looks and sun, the
    sunlight of ``blades`` and ``colliders``), the values the kernel engine's GrassField writes
    into its GrassMaterial."""
    return pack(GRASS_MATERIAL_LAYOUT, material_values(params, blades, colliders, **material))


def clock(params: GrassParams) -> dict:
    """The clock's rules: :func:`grasswidget.core.engine_inputs.clock_rules`."""
    return clock_rules(params)
