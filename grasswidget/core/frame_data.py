"""What a frame needs besides GPU execution, decided once for both engines (pure Python).

The kernel engine (pygfx, :mod:`grasswidget.gpu`) and the browser engine
(``grasswidget/browser/engine.js``) run the same WGSL. Everything else a frame
depends on is computed here, from the parameters, colliders, blades and camera,
and each engine only writes it into its own buffers:

* :func:`collider_grid`: the colliders' spheres and their grid
  (:mod:`grasswidget.core.collider_grid`), the two arrays both engines upload
  when the colliders change.
* :func:`sim_uniform_values` / :func:`cull_uniform_values`: the *values* of the
  ``u_sim`` and ``u_cull`` structs (field name -> number or array; the layouts
  are :mod:`grasswidget.core.uniform_layouts`). The kernel copies them into its
  pygfx uniform arrays; the browser receives them packed as bytes
  (:func:`grasswidget.core.uniform_layouts.pack`) and writes the bytes as they are.
* :func:`clock_rules`: the simulation clock's rules (``dt``, the wind period, at
  most ``max_steps_per_frame`` fixed steps per drawn frame, the rest dropped:
  slow motion). :class:`grasswidget.notebook.clock.SimClock` executes them in the kernel;
  the browser's clock executes the same rules from this dict.
* :func:`orbit_rules`: the orbit limits (:class:`grasswidget.core.orbit_limits.OrbitLimits`)
  as a dict; pygfx's held controller and the browser's drag both clamp with them.
* :func:`scene_style`: sky and ground colours and the ground square (one
  ``shaders/sky_ground.wgsl`` draws them in both engines), collider-ball colour.
* :func:`frame_rules`: the three above in one JSON-able dict (the browser's
  ``frame_rules`` trait).

Nothing here imports a GPU module.
"""

from __future__ import annotations

import math
from dataclasses import asdict

import numpy as np

from ..errors import GrassValueError
from .collider_grid import MAX_GRID_CELLS, build_collider_grid, root_bounds
from .colliders import collider_array
from .enums import ColorBy, GravityMode, WindField
from .orbit_limits import OrbitLimits
from .reference import wind_period

__all__ = [
    "sim_uniform_values", "collider_grid", "cull_uniform_values", "clock_rules", "orbit_rules", "scene_style", "ground_square",
    "frame_rules", "srgb", "SKY_BOTTOM", "SKY_TOP", "GROUND_COLOR", "BALL_COLOR", "BALL_OPACITY",
    "LIGHT_DIRECTION", "GROUND_DROP", "MAX_STEPS_PER_FRAME",
]

#: The most fixed steps one drawn frame may take while playing, in both engines (a frame
#: owed more gets this many and the rest is dropped: slow motion).
MAX_STEPS_PER_FRAME = 64

#: Sky gradient, bottom and top of the view (sRGB hex).
SKY_BOTTOM = "#9cc3e6"
SKY_TOP = "#e8f1f8"
#: The ground's flat colour (sRGB hex): a lit Phong plane facing up measured (51, 36, 22).
GROUND_COLOR = "#332416"
#: Collider balls: colour (sRGB hex) and opacity (0..1).
BALL_COLOR = "#dfe8ff"
BALL_OPACITY = 0.35
#: Direction towards the sun (world space, not normalized): the kernel scene's light position.
LIGHT_DIRECTION = (4.0, 10.0, 3.0)
#: The ground plane lies this far (m) below the lowest blade root (no z-fight with the roots).
GROUND_DROP = 0.01


def srgb(hex_color: str, alpha: float = 1.0) -> tuple:
    """``(r, g, b, alpha)`` in 0..1 from ``"#rrggbb"`` (sRGB, as written)."""
    h = str(hex_color).lstrip("#")
    if len(h) != 6:
        raise GrassValueError(f"colour must be '#rrggbb'; got {hex_color!r}")
    return tuple(int(h[i: i + 2], 16) / 255.0 for i in (0, 2, 4)) + (float(alpha),)


# ---------------------------------------------------------------------- uniform values


def _local(world_matrix):
    m = np.eye(4) if world_matrix is None else np.asarray(world_matrix, np.float64).reshape(4, 4)
    return m


def sim_uniform_values(params, n_blades: int, colliders=(), *, world_matrix=None, steps: int = 0,
                       time0: float = 0.0) -> dict:
    """The ``u_sim`` values (``uniform_layouts.SIM_LAYOUT``) for a dispatch.

    Args:
        params: a :class:`~grasswidget.params.GrassParams`.
        n_blades: blade count N.
        colliders: sphere colliders (a ColliderList, SphereColliders or a (K, 4) array; at most
            ``MAX_COLLIDERS`` = 1024), in the field's local space. Only their count goes into
            ``u_sim``; the spheres and their grid are :func:`collider_grid` (storage buffers).
        world_matrix: the field's 4x4 world matrix (default identity): gravity's
            direction and centre are given in world space and turned into local space.
        steps: fixed steps in this dispatch (the browser writes its own per dispatch).
        time0: simulation time of the dispatch's first step (s; same).

    Returns {field: value}; vectors are 4 floats.
    """
    p = params
    m = _local(world_matrix)
    g = np.asarray(p.gravity_direction, np.float64)
    try:
        g = np.linalg.solve(m[:3, :3], g)
    except np.linalg.LinAlgError:
        pass
    g = g / max(float(np.linalg.norm(g)), 1e-12)
    centre = np.array([*p.gravity_center, 1.0])
    try:
        centre = np.linalg.solve(m, centre)
    except np.linalg.LinAlgError:
        pass
    rad = math.radians(p.wind_direction)
    spheres = collider_array(colliders)
    return dict(
        gravity_dir=(*g, 0.0),
        wind_dir=(math.cos(rad), math.sin(rad), 0.0, 0.0),
        gravity_center=(*centre[:3], 0.0),
        wind_center=(*p.wind_center, 0.0),
        gravity=p.gravity,
        front_gravity=p.front_gravity,
        stiffness_scale=p.stiffness_scale,
        dt=p.dt,
        time0=float(time0),
        wind_strength=p.wind_strength,
        wind_speed=p.wind_speed,
        wind_wavelength=p.wind_wavelength,
        wind_field=int(WindField.from_label(p.wind_field)),
        steps=int(steps),
        n_blades=int(n_blades),
        gravity_mode=int(GravityMode.from_label(p.gravity_mode)),
        wind_radius=p.wind_radius,
        wind_direction_rad=rad,
        collision_fade=p.collision_fade,
        collision_gain=p.collision_gain,
        n_colliders=len(spheres),
    )


def collider_grid(colliders, blades, max_cells=MAX_GRID_CELLS):
    """The spheres of ``colliders`` and their grid over ``blades`` (a :class:`~grasswidget.core.blades.Blades`:
    the roots' xz bounds, the tallest blade), as both engines upload them into ``s_colliders`` and
    ``s_collider_grid``: a :class:`~grasswidget.core.collider_grid.ColliderGrid` (``.sphere_data()``,
    ``.words()``). ``max_cells`` (default MAX_GRID_CELLS; 1 = every blade tests every sphere)."""
    spheres = collider_array(colliders)
    height = float(np.max(blades.height)) if len(blades) else 0.0
    return build_collider_grid(spheres, root_bounds(blades.v0), height, max_cells=max_cells)


def cull_uniform_values(params, n_blades: int, frozen=None, *, every_frame_two_phases: bool = False) -> dict:
    """The ``u_cull`` values (``uniform_layouts.CULL_LAYOUT``).

    ``every_frame_two_phases``: the engine draws every frame in occlusion culling's two
    phases while ``params.cull_occlusion`` is on (the browser engine: its culling
    passes are always the first phase's, then it builds the pyramid and runs the
    second), so ``occlusion_phase`` is written: 1 while ``cull_occlusion`` is on, else
    0 (the browser engine then draws in one phase). False (the kernel engine, default):
    ``occlusion_phase`` is left out, the engine arms it per render
    (:func:`grasswidget.gpu.occlusion.render_frame`).

    ``frozen`` is the frozen culling camera or None (cull against each render's
    camera): anything with ``view_proj`` (4x4, world to WebGPU clip space, row-major
    as NumPy writes it), ``position`` (3 floats, m) and ``viewport_size`` ((w, h) pixels),
    e.g. a :class:`grasswidget.gpu.frozen_camera.FrozenCamera`.
    """
    p = params
    values = dict(
        orientation_threshold=p.cull_orientation_threshold,
        frustum_tolerance=p.cull_frustum_tolerance,
        distance_max=p.cull_distance_max,
        buckets=p.cull_buckets,
        cull_orientation=int(p.cull_orientation),
        cull_frustum=int(p.cull_frustum),
        cull_distance=int(p.cull_distance),
        lod=int(p.lod),
        n_blades=int(n_blades),
        color_by=int(ColorBy.from_label(p.color_by)),
        frozen=int(frozen is not None),
        frozen_view_proj=np.zeros((4, 4), np.float32),
        frozen_cam_pos=(0.0, 0.0, 0.0, 0.0),
        frozen_viewport_height=0.0,
        raster_max_px=p.compute_raster_max_px,
    )
    if every_frame_two_phases:
        values["occlusion_phase"] = int(bool(p.cull_occlusion))
    if frozen is not None:
        values.update(
            frozen_view_proj=np.asarray(frozen.view_proj, np.float64).T,  # WGSL matrices are column-major
            frozen_cam_pos=(*map(float, frozen.position), 1.0),
            frozen_viewport_height=float(frozen.viewport_size[1]),
        )
    return values


# ---------------------------------------------------------------------- frame rules


def clock_rules(params) -> dict:
    """The clock's rules for playing by the wall clock (see :class:`grasswidget.notebook.clock.SimClock`):
    ``dt`` (s, the fixed step), ``wind_period`` (s, 0 = none: the wind time of step k
    is ``(k dt) mod wind_period``), ``max_steps_per_frame`` (a frame owed more steps
    gets this many and the rest is dropped: slow motion)."""
    return {"dt": float(params.dt), "wind_period": float(wind_period(params) or 0.0),
            "max_steps_per_frame": int(MAX_STEPS_PER_FRAME)}


def orbit_rules(blades, far) -> dict:
    """:meth:`grasswidget.core.orbit_limits.OrbitLimits.for_field` of these blades and a far plane
    of ``far`` metres, as a JSON-able dict (tuples as lists; ``ground_y`` None = no ground)."""
    limits = OrbitLimits.for_field(blades.v0, blades.up, blades.height, far)
    return {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(limits).items()}


def ground_square(blades, far) -> tuple:
    """``((x, y, z), half_size)``: the ground square under the field, reaching the far
    plane (``far`` m) from anywhere over the field, so a low camera sees ground, not
    sky, below the horizon. y is :data:`GROUND_DROP` below the lowest root."""
    v0 = np.asarray(blades.v0, np.float64)
    lo, hi = v0.min(axis=0), v0.max(axis=0)
    extent = float(max(hi[0] - lo[0], hi[2] - lo[2], 1.0))
    far = 100.0 if far is None else float(far)
    centre = (float(0.5 * (lo[0] + hi[0])), float(lo[1]) - GROUND_DROP, float(0.5 * (lo[2] + hi[2])))
    return centre, 0.5 * (1.2 * extent + 2.0 * far)


def scene_style(blades, far) -> dict:
    """Sky, ground and collider-ball style: ``sky_bottom``, ``sky_top``, ``ground_color``
    (r, g, b, a sRGB 0..1), ``ground`` (x, y, z, half size in m: :func:`ground_square`),
    ``show_ground`` (1), ``ball_color`` (r, g, b, opacity), ``light_direction`` (x, y, z)."""
    centre, half = ground_square(blades, far)
    return {
        "sky_bottom": list(srgb(SKY_BOTTOM)),
        "sky_top": list(srgb(SKY_TOP)),
        "ground_color": list(srgb(GROUND_COLOR)),
        "ground": [*centre, float(half)],
        "show_ground": 1,
        "ball_color": list(srgb(BALL_COLOR, BALL_OPACITY)),
        "light_direction": list(LIGHT_DIRECTION),
    }


def frame_rules(params, blades, far) -> dict:
    """``{"clock": clock_rules, "orbit": orbit_rules, "style": scene_style}`` for a field
    of ``blades`` seen by a camera whose far plane is ``far`` metres."""
    return {"clock": clock_rules(params), "orbit": orbit_rules(blades, far), "style": scene_style(blades, far)}
