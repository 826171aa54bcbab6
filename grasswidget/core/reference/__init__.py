"""NumPy reference of the blade physics, the culling tests, the looks and the compute
rasterizer: the spec.

Everything here is vectorised over N blades and imports no GPU code. The WGSL
include ``grasswidget/shaders/blade_math.wgsl`` implements the same functions under the same
names (``shaders/collisions.wgsl`` the loop over the colliders: ``collide_spheres``,
``collision_passes``), so the two can be read side by side: :func:`simulate_step` is
``simulate.wgsl``'s step (fade_collision, tip_step, collision_passes, gain_collision),
:func:`blade_forces` ``inspect.wgsl``'s. Equation numbers refer to Jahrmann &
Wimmer, "Responsive Real-Time Grass Rendering for General 3D Scenes", I3D 2017.

State dicts hold ``v0, v1, v2, up`` as (N, 3) and ``height, width, orientation,
stiffness`` as (N,) arrays (see :mod:`grasswidget.core.blades`). Computations run in
float64; the GPU runs float32 and agrees to ~1e-5 of the blade height.

Sign conventions chosen here (the sources differ): the width direction ``t1`` is
the tangent basis vector ``e1`` rotated by theta towards ``e2 = cross(e1, up)``, so
on a y-up plane ``t1 = (cos theta, 0, sin theta)``; the front direction is
``f = normalize(cross(up, t1))``.

The reference is a package of modules by subject, all re-exported here (read
``reference.simulate_step`` or ``from grasswidget.core.reference import cull``):
:mod:`~grasswidget.core.reference.physics` (geometry, forces, wind, validation,
collisions, one step, the inspector's forces), :mod:`~grasswidget.core.reference.culling`
(the culling tests, level of detail, occlusion and the depth pyramid),
:mod:`~grasswidget.core.reference.looks` (blade shapes, colours, fog, sky and ground,
shading), :mod:`~grasswidget.core.reference.raster` (the compute rasterizer) and
:mod:`~grasswidget.core.reference.sunlight` (the sun, the balls' and the grass' shadows), with
:mod:`~grasswidget.core.reference.vectors` (two vector helpers they share).
"""

from __future__ import annotations

from .physics import *  # noqa: F401,F403
from .culling import *  # noqa: F401,F403
from .looks import *  # noqa: F401,F403
from .raster import *  # noqa: F401,F403
from .sunlight import *  # noqa: F401,F403
from .vectors import safe_normalize  # noqa: F401
from . import culling, looks, physics, raster, sunlight, vectors  # noqa: F401

__all__ = [
    "safe_normalize",
    "tangent_basis",
    "width_direction",
    "front_direction",
    "environmental_gravity",
    "gravity_point",
    "front_gravity",
    "wind_wave",
    "wind_pulse",
    "wind_radial",
    "wind_vortex",
    "noise_hash",
    "simplex_corner",
    "simplex_noise2",
    "NOISE_SCALE",
    "wind_noise",
    "wind_field",
    "wind_force",
    "integrate_tip",
    "validate_ground",
    "validate_v1",
    "validate_length",
    "curve_length",
    "sphere_push",
    "collide_sphere",
    "collide_spheres",
    "sphere_in_reach",
    "grid_cell",
    "COLLIDER_REACH",
    "fade_collision",
    "gain_collision",
    "effective_stiffness",
    "validate_pushed",
    "collision_passes",
    "validate_state",
    "tip_step",
    "COLLISION_MAX",
    "RECOVERY_FLOOR",
    "COLLISION_PASSES",
    "simulate_step",
    "simulate",
    "wind_period",
    "LOD_SEGMENTS",
    "CULLED_SEGMENTS",
    "LOD_MIN_PIXELS",
    "orientation_cull",
    "clip_outside",
    "frustum_cull",
    "distance_cull",
    "projected_pixels",
    "lod_class",
    "CULL_REASONS",
    "cull_reason",
    "cull",
    "blade_forces",
    "FORCE_NAMES",
    "blade_shape_t",
    "hash01",
    "DRY_COLOR",
    "clump_noise",
    "blade_base_color",
    "backlight",
    "fog_amount",
    "sky_color",
    "field_inside",
    "ground_color",
    "ground_cover",
    "occlusion_bounds",
    "hzb_level",
    "hzb_layout",
    "build_hzb",
    "hzb_max",
    "occlusion_cull",
    "curve_pieces",
    "OCCLUSION_PIECES",
    "OCCLUSION_RADIUS_PER_WIDTH",
    "HZB_ROW_ALIGN",
    "HZB_MAX_LEVELS",
    "blade_shade",
    "FAR_ALONG",
    "far_grass_shade",
    "ground_albedo",
    "sun_direction", "sun_angles", "ball_shadow", "grass_transmittance", "grass_above", "sky_visibility", "light_share",
    "grass_optical_depths", "MAX_SHADOW_BALLS",
    "clip_to_pixel",
    "raster_step",
    "raster_section",
    "raster_cover",
    "raster_payload",
    "raster_walk",
    "raster_blades",
    "RASTER_MAX_SAMPLES",
    "RASTER_MAX_ACROSS",
    "RASTER_EMPTY",
]

