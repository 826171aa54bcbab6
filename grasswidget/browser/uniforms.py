"""Uniform structs of the browser engine: layouts, WGSL text and packing (pure Python).

A layout is a tuple of ``(field, wgsl_type)``; ``SIM_LAYOUT`` and ``CULL_LAYOUT``
are the ones both engines use (:mod:`grasswidget.core.uniform_layouts`). Offsets follow WGSL's uniform
address-space rules (scalars 4 bytes, vec2 8, vec4 16, mat4x4 64 bytes aligned
to 16, ``array<vec4<f32>, N>`` 16 N). Python packs the parameter-driven
uniforms (simulation, culling, material) into bytes and sends them; the browser
only patches the per-dispatch fields (``steps``, ``time0``) and writes the
camera uniform (``StdInfo``) itself, at the offsets :func:`offsets` gives.

The field names are those the project's WGSL reads (``u_sim.wind_dir``,
``u_cull.n_blades``, ``u_stdinfo.cam_transform``, ``u_material.tip_color``...).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import GrassValueError
from ..core.collider_grid import GRID_WORDS, build_collider_grid, root_bounds
from ..core.colliders import MAX_COLLIDERS, collider_array
from ..core.enums import BladeShape, ColorBy, GravityMode, WindField
from ..core.params import GrassParams
from ..core.reference import wind_period
from ..core.uniform_layouts import CULL_LAYOUT, SIM_LAYOUT, wgsl_struct  # one source for both engines

__all__ = [
    "SIM_LAYOUT", "CULL_LAYOUT", "STDINFO_LAYOUT", "WOBJECT_LAYOUT", "MATERIAL_LAYOUT", "WIND_FIELD_IDS",
    "offsets", "struct_size", "wgsl_struct", "pack", "sim_uniform", "cull_uniform", "material_uniform",
    "layout_description", "srgb_color",
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
)

WOBJECT_LAYOUT = (("world_transform", "mat4x4<f32>"),)

MATERIAL_LAYOUT = (
    ("root_color", "vec4<f32>"),
    ("tip_color", "vec4<f32>"),
    ("light_direction", "vec4<f32>"),
    ("color_variation", "f32"),
    ("ambient", "f32"),
    ("tip_threshold", "f32"),
    ("blade_shape", "i32"),
    ("opacity", "f32"),
)

_SCALAR = {"f32": "<f4", "i32": "<i4", "u32": "<u4"}


def _size_align(wgsl_type):
    """(size, align, numpy dtype of one element, element count) of a WGSL type."""
    if wgsl_type in _SCALAR:
        return 4, 4, _SCALAR[wgsl_type], 1
    if wgsl_type == "vec2<f32>":
        return 8, 8, "<f4", 2
    if wgsl_type == "vec4<f32>":
        return 16, 16, "<f4", 4
    if wgsl_type == "mat4x4<f32>":
        return 64, 16, "<f4", 16
    if wgsl_type.startswith("array<vec4<f32>,"):
        n = int(wgsl_type.rsplit(",", 1)[1].rstrip(">").strip())
        return 16 * n, 16, "<f4", 4 * n
    raise GrassValueError(f"unsupported uniform type {wgsl_type!r}")


def offsets(layout) -> dict:
    """{field: (byte offset, numpy dtype, element count)}."""
    out, off = {}, 0
    for name, t in layout:
        size, align, dtype, count = _size_align(t)
        off = -(-off // align) * align
        out[name] = (off, dtype, count)
        off += size
    return out


def struct_size(layout) -> int:
    end = 0
    for name, (off, dtype, count) in offsets(layout).items():
        end = max(end, off + 4 * count)
    return -(-end // 16) * 16


def layout_description(layout) -> dict:
    """JSON-able {field: [offset, kind, count]} for the browser (kind "f32", "i32" or "u32")."""
    kinds = {"<f4": "f32", "<i4": "i32", "<u4": "u32"}
    return {k: [o, kinds[d], c] for k, (o, d, c) in offsets(layout).items()}


def pack(layout, values: dict) -> bytes:
    """Bytes of a uniform struct; fields missing from ``values`` are zero."""
    buf = bytearray(struct_size(layout))
    for name, (off, dtype, count) in offsets(layout).items():
        if name not in values:
            continue
        arr = np.zeros(count, dtype)
        v = np.asarray(values[name], dtype).reshape(-1)
        arr[: min(count, v.size)] = v[:count]
        buf[off: off + 4 * count] = arr.tobytes()
    return bytes(buf)


def sim_uniform(params: GrassParams, n_blades: int, colliders=()) -> bytes:
    """The simulation uniform for an untransformed field (the browser's field has no transform).

    ``steps`` and ``time0`` are left 0: the browser writes them for each dispatch.
    Same values as ``GrassField._write_sim_uniform`` for an identity world matrix.
    """
    p = params
    rad = math.radians(p.wind_direction)
    g = np.asarray(p.gravity_direction, np.float64)
    g = g / max(np.linalg.norm(g), 1e-12)
    spheres = collider_array(colliders)
    return pack(SIM_LAYOUT, dict(
        gravity_dir=(*g, 0.0),
        wind_dir=(math.cos(rad), math.sin(rad), 0.0, 0.0),
        gravity_center=(*p.gravity_center, 0.0),
        wind_center=(*p.wind_center, 0.0),
        gravity=p.gravity,
        front_gravity=p.front_gravity,
        stiffness_scale=p.stiffness_scale,
        dt=p.dt,
        wind_strength=p.wind_strength,
        wind_speed=p.wind_speed,
        wind_wavelength=p.wind_wavelength,
        wind_field=WIND_FIELD_IDS[p.wind_field],
        n_blades=n_blades,
        gravity_mode=int(GravityMode.from_label(p.gravity_mode)),
        wind_radius=p.wind_radius,
        wind_direction_rad=rad,
        collision_fade=p.collision_fade,
        collision_gain=p.collision_gain,
        n_colliders=len(spheres),
    ))


#: Bytes of the browser's collider buffers: the spheres (MAX_COLLIDERS vec4) and the grid words.
COLLIDER_BYTES = 16 * MAX_COLLIDERS
GRID_BYTES = 4 * GRID_WORDS


def collider_buffers(colliders, blades) -> tuple:
    """(spheres, grid) bytes for ``s_colliders`` and ``s_collider_grid``: the same arrays the
    kernel engine uploads (:func:`grasswidget.core.collider_grid.build_collider_grid` over the
    blades' roots, for their tallest blade)."""
    spheres = collider_array(colliders)
    height = float(np.max(blades.height)) if len(blades) else 0.0
    grid = build_collider_grid(spheres, root_bounds(blades.v0), height)
    return grid.spheres.tobytes(), grid.words().tobytes()


def cull_uniform(params: GrassParams, n_blades: int) -> bytes:
    p = params
    return pack(CULL_LAYOUT, dict(
        orientation_threshold=p.cull_orientation_threshold,
        frustum_tolerance=p.cull_frustum_tolerance,
        distance_max=p.cull_distance_max,
        buckets=p.cull_buckets,
        cull_orientation=int(p.cull_orientation),
        cull_frustum=int(p.cull_frustum),
        cull_distance=int(p.cull_distance),
        lod=int(p.lod),
        n_blades=n_blades,
        color_by=int(ColorBy.from_label(getattr(p, "color_by", "natural"))),
        frozen=0,  # the browser engine culls against its live camera
    ))


def srgb_color(hex_color: str) -> tuple:
    """(r, g, b, 1) in 0..1 from "#rrggbb"."""
    h = hex_color.lstrip("#")
    return tuple(int(h[i: i + 2], 16) / 255.0 for i in (0, 2, 4)) + (1.0,)


#: The kernel engine's GrassMaterial defaults (grasswidget.gpu.field.GrassMaterial).
MATERIAL_DEFAULTS = dict(root_color="#1d4a12", tip_color="#8fc246", color_variation=0.35, ambient=0.4,
                         light_direction=(0.4, 1.0, 0.3), tip_threshold=0.5)


def material_uniform(params: GrassParams, **overrides) -> bytes:
    m = dict(MATERIAL_DEFAULTS, **overrides)
    light = np.asarray(m["light_direction"], np.float64)
    light = light / np.linalg.norm(light)
    return pack(MATERIAL_LAYOUT, dict(
        root_color=srgb_color(m["root_color"]),
        tip_color=srgb_color(m["tip_color"]),
        light_direction=(*light, 0.0),
        color_variation=m["color_variation"],
        ambient=m["ambient"],
        tip_threshold=m["tip_threshold"],
        blade_shape=int(BladeShape.from_label(params.blade_shape)),
        opacity=1.0,
    ))


def clock(params: GrassParams) -> dict:
    """What the browser's clock needs: dt (s) and the wind period (s, 0 = none)."""
    return {"dt": float(params.dt), "wind_period": float(wind_period(params) or 0.0)}
