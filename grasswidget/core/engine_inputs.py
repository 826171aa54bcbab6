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
  slow motion). :class:`grasswidget.views.clock.SimClock` executes them in the kernel;
  the browser's clock executes the same rules from this dict.
* :func:`orbit_rules`: the orbit limits (:class:`grasswidget.core.orbit_limits.OrbitLimits`)
  as a dict; pygfx's held controller and the browser's drag both clamp with them.
* :func:`dispatch_rules`, :func:`wind_time`, :func:`steps_per_dispatch`: how the simulation's
  steps are dispatched (workgroup size, blade steps per dispatch, the wind time of a step),
  the same in both engines.
* :data:`STATS_INTERVAL_MS`: how often both engines report their stats (by default);
  :func:`stats_freshness`: how old a view's stats are (``frame_age_s``, ``at_rest``, ``stale``)
  and whether it waits for frames, the same rule for both engines;
  :func:`counter_layout` and :func:`read_counters`: where the drawn, occluded and compute-drawn
  blade counts lie in the words both engines read back for their stats, and how they are read.
* :func:`sky_ground_values`: the values of ``u_material`` of
  ``shaders/sky_ground.wgsl`` (``uniform_layouts.SKY_GROUND_LAYOUT``: sky, soil,
  ground beyond the field, horizon, fog), which both engines draw.
* :func:`material_values` / :func:`look_values`: the blade material's values
  (``uniform_layouts.GRASS_MATERIAL_LAYOUT``): the browser packs all of them, the
  kernel's GrassField writes the params' looks into its GrassMaterial.
* :func:`scene_style`: :func:`sky_ground_values` plus the collider balls' colour.
* :func:`engine_rules`: the browser engine's own numbers (frames in flight, device-loss retries,
  the frame times kept for "auto", the ball mesh, the blade record's and an inspected blade's
  bytes, the uniform buffers and the traits that fill them), decided here and sent as data.
* :func:`frame_rules`: all of the above that a frame needs, with the camera's drag rules
  (:func:`grasswidget.core.camera_rules.drag_rules`) and the pointer, key and display rules
  (:func:`grasswidget.core.interaction.input_rules`), in one JSON-able dict (the browser's
  ``frame_rules`` trait; ``grasswidget/browser/js/rules.js`` executes it).
* :data:`EXPORT_SUPERSAMPLE` and :func:`export_filter`: how both engines anti-alias
  exported pictures (render that many times larger, filter down with pygfx's
  Mitchell filter in linear light; the browser engine runs the weights given here).

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
from .enums import BladeShape
from .camera_rules import drag_rules
from .interaction import input_rules
from .orbit_limits import OrbitLimits
from .params import DEFAULT_SUN_DIRECTION, LOOK_TRAITS, GrassParams
from .blades import BLADE_BYTES
from .auto_switches import FRAME_TIMES_KEPT, effective
from .reference import FAR_ALONG, FORCE_NAMES, LOD_SEGMENTS, far_grass_shade, ground_cover, wind_period
from .reference.shadows import MAX_SHADOW_BALLS, grass_optical_depths
from .reference.shadows import sun_direction as _sun_direction
from .teaching import INSPECTED_POINT_BYTES
from .shader_files import MAX_WORKGROUPS_X, WORKGROUP_SIZE
from .horizon import MAX_LEVELS
from .uniform_layouts import SKY_GROUND_LAYOUT

__all__ = [
    "sim_uniform_values", "collider_grid", "cull_uniform_values", "level_table_values", "compute_raster_on", "occlusion_on", "compute_raster_values",
    "MAX_RASTER_BLADES", "clock_rules", "orbit_rules", "scene_style", "ground_square",
    "field_rectangle", "field_cover", "far_ground_values", "sky_ground_values", "sun_direction", "sunlight_values", "grass_layer", "ground_sun", "look_values", "material_values", "frame_rules", "srgb",
    "SKY_GROUND_TRAITS", "HORIZON_COLOR", "ZENITH_COLOR", "SOIL_COLOR", "BEYOND_COLOR", "FIELD_EDGE", "MATERIAL_DEFAULTS",
    "BALL_COLOR", "BALL_OPACITY", "GROUND_DROP", "MAX_STEPS_PER_FRAME",
    "SLOW_MOTION_BELOW", "STATS_INTERVAL_MS", "BLADE_STEPS_PER_DISPATCH", "MAX_WORKGROUPS_X", "dispatch_rules",
    "wind_time", "steps_per_dispatch", "counter_layout", "read_counters",
    "EXPORT_SUPERSAMPLE", "export_filter", "mitchell",
    "stats_freshness", "WAITING_AFTER_S",
    "FRAMES_IN_FLIGHT", "DEVICE_LOSS_RETRIES", "BALL_RINGS", "BALL_SEGMENTS", "BALL_VERTICES", "UNIFORM_TRAITS",
    "engine_rules",
]

#: The most fixed steps one drawn frame may take while playing, in both engines (a frame
#: owed more gets this many and the rest is dropped: slow motion).
MAX_STEPS_PER_FRAME = 64
#: Below this many simulated seconds per (time-scaled) wall second the status line says
#: "slow motion", in both engines.
SLOW_MOTION_BELOW = 0.97
#: Milliseconds between two stats reports of a view, both engines (the browser view's
#: ``stats_interval_ms`` default; the lab bench's charts ask for less while shown).
STATS_INTERVAL_MS = 500
#: The most blade steps (blades x fixed steps) one simulation dispatch takes, both engines: a
#: longer step(n) is split into dispatches of at most this many (no GPU watchdog trips on a long run).
BLADE_STEPS_PER_DISPATCH = 1 << 24
#: MAX_WORKGROUPS_X (from shader_files): workgroups along x of one dispatch before it folds into y.

#: The backdrop's colours (sRGB hex), both engines: the sky at the horizon (also the
#: distance fog's colour and the far ground's), the sky straight up, the bare soil
#: under the field (already lit; the grass' cover darkens it) and the ground beyond it
#: (a khaki that the grass detectors of the tests do not take for grass).
HORIZON_COLOR = "#e4edf5"
ZENITH_COLOR = "#8db8e3"
SOIL_COLOR = "#3b2a1a"
BEYOND_COLOR = "#787a4e"
#: The GrassParams traits the sky and ground's values depend on (both engines rewrite them when one
#: changes): the fog, and the looks of the far grass a field to the horizon shows on its ground.
SKY_GROUND_TRAITS = ("fog_density", "color_variation", "patch_size", "dryness", "translucency", "sun_elevation",
                     "sun_azimuth")
#: Width (m) of the soft edge between the soil under the field and the ground beyond.
FIELD_EDGE = 0.5
#: The blade material's defaults (both engines; ``GrassMaterial``'s): root and tip
#: colours (sRGB hex), ambient share (0..1), direction towards the light (world, not
#: normalized), tau of the triangle-tip shape (0..0.99), fog colour (sRGB hex).
MATERIAL_DEFAULTS = dict(root_color="#1d4a12", tip_color="#8fc246", ambient=0.4, light_direction=DEFAULT_SUN_DIRECTION,
                         tip_threshold=0.5, fog_color=HORIZON_COLOR)
_DEFAULT_SUN_Y = DEFAULT_SUN_DIRECTION[1] / math.sqrt(sum(x * x for x in DEFAULT_SUN_DIRECTION))
#: Collider balls: colour (sRGB hex) and opacity (0..1).
BALL_COLOR = "#dfe8ff"
BALL_OPACITY = 0.35
#: The ground plane lies this far (m) below the lowest blade root (no z-fight with the roots).
GROUND_DROP = 0.01


#: Supersampling of exported pictures, both engines (save_png, the CLI snapshot,
#: save_animation, the Save PNG button): each output pixel is rendered as
#: EXPORT_SUPERSAMPLE x EXPORT_SUPERSAMPLE pixels and filtered down (:func:`export_filter`).
#: On lavapipe at 640 x 360 this halves the mean difference to a 4 x 4 supersample
#: (benchmarks/looks_cost.py measures it and the time).
EXPORT_SUPERSAMPLE = 2


def mitchell(t):
    """The Mitchell-Netravali cubic (B = C = 1/3) at ``t`` (array; zero for |t| >= 2):
    pygfx's reconstruction filter (its ``ssaa.wgsl``), here for the browser's exports."""
    t = np.abs(np.asarray(t, np.float64))
    b = c = 1.0 / 3.0
    near = (12 - 9 * b - 6 * c) * t ** 3 + (-18 + 12 * b + 6 * c) * t ** 2 + (6 - 2 * b)
    far = (-b - 6 * c) * t ** 3 + (6 * b + 30 * c) * t ** 2 + (-12 * b - 48 * c) * t + (8 * b + 24 * c)
    return np.where(t < 1, near, np.where(t < 2, far, 0.0)) / 6.0


def export_filter(factor: int = EXPORT_SUPERSAMPLE) -> dict:
    """The separable filter that takes a picture rendered ``factor`` times larger (an
    integer 1..4) down to its size, as pygfx's renderer does with ``pixel_ratio =
    factor``: output pixel i (each axis) is ``sum_k weights[k] * src[factor i + first + k]``
    (indices clamped to the picture), in linear light (sRGB decoded before, encoded
    after). The weights are :func:`mitchell` at the source pixels' distance from the
    output pixel's centre over ``factor``, normalized to sum 1. Returns
    ``{"factor", "first", "weights"}`` (JSON-able; factor 1: one tap of weight 1)."""
    if isinstance(factor, bool) or not isinstance(factor, (int, np.integer)) or not 1 <= factor <= 4:
        raise GrassValueError(f"factor (supersampling) must be an integer in [1, 4]; got {factor!r}")
    f = int(factor)
    if f == 1:
        return {"factor": 1, "first": 0, "weights": [1.0]}
    k = np.arange(-3 * f, 3 * f)
    w = mitchell((k + 0.5 - 0.5 * f) / f)
    keep = np.flatnonzero(w != 0)
    k, w = k[keep[0]: keep[-1] + 1], w[keep[0]: keep[-1] + 1]
    return {"factor": f, "first": int(k[0]), "weights": [float(x) for x in w / w.sum()]}


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
        params: a :class:`~grasswidget.core.params.GrassParams`.
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
    g = g / max(float(np.abs(g).max()), 1e-300)  # only the direction counts: no overflow in its length
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


def level_table_values(horizon=None) -> dict:
    """``u_cull``'s level table (``level_bands``, ``level_periods``, ``level_ends``, ``n_levels``):
    :meth:`~grasswidget.core.horizon.HorizonLayout.table` of a field to the horizon's layout
    (``Blades.horizon``), or for None (any other field) zeros and ``n_levels`` 0 (its shaders
    compile no level code: the template variable ``follow_camera`` is off)."""
    if horizon is not None:
        return horizon.table()
    return {"level_bands": np.zeros((MAX_LEVELS, 4)), "level_periods": np.zeros((2, 4)),
            "level_ends": np.zeros((2, 4)), "n_levels": 0}


def cull_uniform_values(params, n_blades: int, frozen=None, *, every_frame_two_phases: bool = False,
                        decided=None, thinned: bool = False, horizon=None) -> dict:
    """The ``u_cull`` values (``uniform_layouts.CULL_LAYOUT``).

    ``horizon``: a field to the horizon's :class:`~grasswidget.core.horizon.HorizonLayout`
    (``Blades.horizon``) or None: its level table (:func:`level_table_values`); a layout also
    means ``thinned``.

    ``thinned``: the field thins itself with distance (a field to the horizon,
    ``Blades.horizon``: fewer, wider blades far away), so distance culling is off
    (``cull_distance`` 0) whatever ``params.cull_distance`` says: culling those blades by
    distance too would thin them twice and undo their widening (bare ground far away).

    ``every_frame_two_phases``: the engine draws every frame in occlusion culling's two
    phases while ``params.cull_occlusion`` is on (the browser engine: its culling
    passes are always the first phase's, then it builds the pyramid and runs the
    second), so ``occlusion_phase`` is written: 1 while ``cull_occlusion`` is on, else
    0 (the browser engine then draws in one phase). False (the kernel engine, default):
    ``occlusion_phase`` is left out, the engine arms it per render
    (:func:`grasswidget.gpu.frame.render_frame`). ``decided``: the view's values of its
    "auto" switches for the next frames (``{"cull_occlusion": bool, ...}``, what
    :meth:`grasswidget.core.auto_switches.AutoSwitches.values` said; a forced switch wins), or None
    (the fixed defaults of :func:`occlusion_on`).

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
        cull_distance=int(p.cull_distance and not (thinned or horizon is not None)),
        lod=int(p.lod),
        n_blades=int(n_blades),
        color_by=int(ColorBy.from_label(p.color_by)),
        frozen=int(frozen is not None),
        frozen_view_proj=np.zeros((4, 4), np.float32),
        frozen_cam_pos=(0.0, 0.0, 0.0, 0.0),
        frozen_viewport_height=0.0,
        raster_max_px=p.compute_raster_max_px,
        **level_table_values(horizon),
    )
    if every_frame_two_phases:
        values["occlusion_phase"] = int(occlusion_on(p, (decided or {}).get("cull_occlusion")))
    if frozen is not None:
        values.update(
            frozen_view_proj=np.asarray(frozen.view_proj, np.float64).T,  # WGSL matrices are column-major
            frozen_cam_pos=(*map(float, frozen.position), 1.0),
            frozen_viewport_height=float(frozen.viewport_size[1]),
        )
    return values


#: Most blades a field may have for the compute rasterizer (its payload holds 24 bits of blade id);
#: a larger field draws every blade with the hardware rasterizer, in both engines.
MAX_RASTER_BLADES = 1 << 24


def occlusion_on(params, decided=None) -> bool:
    """Whether occlusion culling runs: ``params.cull_occlusion`` True, or "auto" and
    ``decided`` (the view's decision, :mod:`grasswidget.core.auto_switches`) True; "auto" without a
    decision runs it (a view that has not measured yet: a BrowserEngineWidget before its first values)."""
    return effective(params.cull_occlusion, True if decided is None else decided)


def compute_raster_on(params, n_blades: int, decided=None) -> bool:
    """Whether the compute rasterizer draws the thin blades of a field of ``n_blades`` (both
    engines): ``params.compute_raster`` True (or "auto" and ``decided`` True, the view's
    decision, :mod:`grasswidget.core.auto_switches`; "auto" without a decision: off),
    ``compute_raster_max_px`` > 0 and at most :data:`MAX_RASTER_BLADES` blades."""
    return (effective(params.compute_raster, decided) and params.compute_raster_max_px > 0
            and int(n_blades) <= MAX_RASTER_BLADES)


def compute_raster_values(params, n_blades: int, blade_shape: int, tip_threshold: float, decided=None) -> dict:
    """The compute rasterizer's ``u_cull`` values but the render size (``raster_width`` and
    ``raster_height``, which the engine writes for each render: 0 here): ``compute_raster``
    (1 when :func:`compute_raster_on`), ``raster_blade_shape`` (the material's
    ``enums.BladeShape`` id) and ``raster_tip_threshold`` (the material's, 0..1). ``decided``:
    as :func:`cull_uniform_values`'s (its ``"compute_raster"``)."""
    return dict(compute_raster=int(compute_raster_on(params, n_blades, (decided or {}).get("compute_raster"))), raster_width=0.0, raster_height=0.0,
                raster_blade_shape=int(blade_shape), raster_tip_threshold=float(tip_threshold))


# ---------------------------------------------------------------------- frame rules


def clock_rules(params) -> dict:
    """The clock's rules for playing by the wall clock (see :class:`grasswidget.views.clock.SimClock`):
    ``dt`` (s, the fixed step), ``wind_period`` (s, 0 = none: the wind time of step k
    is ``(k dt) mod wind_period``), ``max_steps_per_frame`` (a frame owed more steps
    gets this many and the rest is dropped: slow motion). While no view of a widget is on
    screen both engines stop the clock as ``pause()`` does (no rule of its own: the time out of
    sight is not simulated, nothing is owed on return)."""
    return {"dt": float(params.dt), "wind_period": float(wind_period(params) or 0.0),
            "max_steps_per_frame": int(MAX_STEPS_PER_FRAME)}


def dispatch_rules() -> dict:
    """How both engines size their compute dispatches: ``workgroup_size`` (threads per workgroup
    of the per-blade shaders, ``shader_files.WORKGROUP_SIZE``), ``max_groups_x`` (workgroups along
    x before folding into y) and ``blade_steps_per_dispatch`` (see :func:`steps_per_dispatch`)."""
    return {"workgroup_size": int(WORKGROUP_SIZE), "max_groups_x": MAX_WORKGROUPS_X,
            "blade_steps_per_dispatch": BLADE_STEPS_PER_DISPATCH}


def steps_per_dispatch(n_blades: int) -> int:
    """Fixed steps one simulation dispatch of ``n_blades`` blades takes at most (>= 1):
    :data:`BLADE_STEPS_PER_DISPATCH` // n_blades."""
    return max(1, BLADE_STEPS_PER_DISPATCH // max(int(n_blades), 1))


def wind_time(step: int, dt: float, period: float) -> float:
    """The wind time (s) of fixed step ``step`` (>= 0): ``step * dt`` modulo ``period``
    (s; 0 or None: no period), the ``time0`` both engines write for a dispatch starting there."""
    t = step * float(dt)
    return math.fmod(t, period) if period else t


def counter_layout(n_classes: int = len(LOD_SEGMENTS)) -> dict:
    """Where the stats' counts lie in the u32 words both engines read back after a frame (JSON-able):
    the first phase's draw args (4 words per LOD class) from word ``first_at`` (0), the second
    phase's (4 per class, then the occluded count and 3 zeros) from ``second_at``, the compute
    rasterizer's counters (4 words) from ``raster_at``; ``words`` in all. ``visible``: per class the
    two words (instance counts) whose sum is the blades drawn; ``occluded`` and ``rastered``: the word
    of each count. ``n_classes`` >= 1 (default: the LOD classes, ``reference.LOD_SEGMENTS``)."""
    c = int(n_classes)
    if c < 1:
        raise GrassValueError(f"n_classes must be at least 1; got {n_classes!r}")
    return {"words": 8 * c + 8, "first_at": 0, "second_at": 4 * c, "raster_at": 8 * c + 4,
            "visible": [[4 * k + 1, 4 * c + 4 * k + 1] for k in range(c)], "occluded": 8 * c, "rastered": 8 * c + 4}


def read_counters(words, layout: dict) -> dict:
    """The counts of one read-back (``words``: u32, at least ``layout["words"]``) as
    :func:`counter_layout` places them: ``visible_per_class`` (blades drawn per LOD class, both
    occlusion phases), ``occluded`` and ``rastered`` (ints; whether the pass ran is the caller's)."""
    w = np.asarray(words).astype(np.int64).ravel()
    if len(w) < layout["words"]:
        raise GrassValueError(f"words must hold at least {layout['words']} counters; got {len(w)}")
    return {"visible_per_class": [int(w[i] + w[j]) for i, j in layout["visible"]],
            "occluded": int(w[layout["occluded"]]), "rastered": int(w[layout["rastered"]])}


def orbit_rules(blades, far, floor="grass") -> dict:
    """:meth:`grasswidget.core.orbit_limits.OrbitLimits.for_field` of these blades, a far plane
    of ``far`` metres and a camera floor (``"grass"``: above the tallest tip, or ``"ground"``),
    as a JSON-able dict (tuples as lists; ``ground_y`` None = no ground). The browser clamps
    with these numbers (``browser/js/rules.js`` ``clampOrbit``); the floor only changes them."""
    limits = OrbitLimits.for_field(blades.v0, blades.up, blades.height, far, floor=floor, horizon=blades.horizon)
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


def field_rectangle(blades) -> tuple:
    """``((x, z), (half_x, half_z))``: the rectangle of the blades' roots on the ground (m); for a field
    to the horizon (``blades.horizon``), whose blades follow the camera anywhere within its reach, the
    square around its centre that they can reach (half side: the reach plus half the last level's
    tile), so that the ground under them is soil wherever the camera goes."""
    h = getattr(blades, "horizon", None)
    if h is not None:
        half = float(h.reach) + 0.5 * float(h.periods[-1])
        return (float(h.center[0]), float(h.center[1])), (half, half)
    v0 = np.asarray(blades.v0, np.float64)
    lo, hi = v0.min(axis=0), v0.max(axis=0)
    return (float(0.5 * (lo[0] + hi[0])), float(0.5 * (lo[2] + hi[2]))), \
        (float(0.5 * (hi[0] - lo[0])), float(0.5 * (hi[2] - lo[2])))


def field_cover(blades) -> float:
    """How much the blades shade the soil of their rectangle, 0..1
    (:func:`grasswidget.core.reference.ground_cover`; sides of at least 0.1 m); a field to
    the horizon: of its disc (the leaf area per square metre is the same all over it)."""
    if blades.horizon is not None:
        return ground_cover(blades.height, blades.width, math.pi * float(blades.horizon.reach) ** 2)
    _centre, (hx, hz) = field_rectangle(blades)
    return ground_cover(blades.height, blades.width, max(2 * hx, 0.1) * max(2 * hz, 0.1))


def far_ground_values(blades, params=None) -> dict:
    """The far ground's values of ``u_material`` (sky_ground.wgsl ``ground_albedo``): the grass seen
    from afar that covers the ground beyond every field, ``far_grass`` (its shade,
    :func:`~grasswidget.core.reference.far_grass_shade` of the default blade material, the params'
    looks and sun; ``w`` = 1: the ground beyond the field is that grass, 0 would leave the bare plain
    ``beyond_color``), the blades' root and tip colours, the params' colour variation and dryness, and
    ``far_blend`` (z: the params' patch size in m, the blades' patches; w:
    :data:`~grasswidget.core.reference.FAR_ALONG`); for a field to the horizon (``blades.horizon``)
    also ``horizon`` (x, z of its centre, its reach in m, 1) and ``far_blend``'s x, y (the camera
    distances in m over which the soil between the blades gives way to the far grass,
    :meth:`~grasswidget.core.horizon.HorizonLayout.ground_blend`); for any other field ``horizon`` is
    all 0 (the far grass only beyond the field's rectangle)."""
    p = params if params is not None else GrassParams()
    m = MATERIAL_DEFAULTS
    root, tip = srgb(m["root_color"]), srgb(m["tip_color"])
    shade = far_grass_shade(root[:3], tip[:3], p.color_variation, p.dryness, p.translucency, sun_direction(p),
                            m["ambient"])
    values = {"grass_root": root, "grass_tip": tip, "color_variation": float(p.color_variation),
              "dryness": float(p.dryness), "far_grass": (*(float(c) for c in shade), 1.0)}
    h = blades.horizon
    if h is None:
        return dict(values, horizon=(0.0, 0.0, 0.0, 0.0), far_blend=(0.0, 1.0, float(p.patch_size), FAR_ALONG))
    start, end = h.ground_blend()
    return dict(values, horizon=(float(h.center[0]), float(h.center[1]), float(h.reach), 1.0),
                far_blend=(float(start), float(end), float(p.patch_size), FAR_ALONG))


def sky_ground_values(blades, far, params=None, *, show_ground=True, colliders=()) -> dict:
    """The ``u_material`` values of ``shaders/sky_ground.wgsl``
    (``uniform_layouts.SKY_GROUND_LAYOUT``), the same for both engines.

    Args:
        blades: the field's :class:`~grasswidget.core.blades.Blades` (its rectangle
            and cover decide where the soil is and how dark).
        far: the camera's far plane in metres (None: 100): the ground square reaches
            it (:func:`ground_square`) and fades into the horizon colour from 0.6 of it.
        params: the :class:`~grasswidget.core.params.GrassParams` (its ``fog_density``,
            1/m); None: the defaults.
        show_ground: draw the ground (else sky everywhere).
        colliders: the sphere colliders whose shadows the ground shows (with ``params.shadows``;
            :func:`sunlight_values`).

    Colours are (r, g, b, 1) sRGB 0..1, ``ground`` (x, y, z, half size) and
    ``field`` (x, z, half_x, half_z) in metres.
    """
    centre, half = ground_square(blades, far)
    (cx, cz), (hx, hz) = field_rectangle(blades)
    params = params if params is not None else GrassParams()
    fog = params.fog_density
    sunlight = sunlight_values(params, blades, colliders)
    values = {
        "horizon_color": srgb(HORIZON_COLOR),
        "zenith_color": srgb(ZENITH_COLOR),
        "soil_color": srgb(SOIL_COLOR),
        "beyond_color": srgb(BEYOND_COLOR),
        "ground": (*centre, float(half)),
        "field": (cx, cz, hx, hz),
        "light_direction": sunlight["light_direction"],
        "shadow_balls": sunlight["shadow_balls"],
        "shadow_field": sunlight["shadow_field"],
        "shadow_depths": sunlight["shadow_depths"],
        "show_ground": int(bool(show_ground)),
        "far_distance": 100.0 if far is None else float(far),
        "fog_density": float(fog),
        "cover": field_cover(blades),
        "field_edge": FIELD_EDGE,
        **far_ground_values(blades, params),
        "shadows": sunlight["shadows"],
        "ground_sun": ground_sun(sunlight["light_direction"][1]),
    }
    return {name: values[name] for name, _ in SKY_GROUND_LAYOUT}  # in the layout's order


def sun_direction(params) -> tuple:
    """Unit direction towards the sun (x, y, z) of ``params`` (``sun_elevation``, ``sun_azimuth``;
    :func:`grasswidget.core.reference.sun_direction`), both engines' light."""
    return tuple(float(x) for x in _sun_direction(params.sun_elevation, params.sun_azimuth))


def grass_layer(blades) -> dict:
    """What the sunlight needs of a field's blades (O(N): engines keep it until the blades change):
    ``field`` (x, z, half_x, half_z: the roots' rectangle, m), ``leaf_area_index`` (one-sided blade
    area per m^2 of it, sides of at least 0.1 m) and ``height`` (the mean blade height, m)."""
    if blades is None or not len(blades):
        return {"field": (0.0, 0.0, 0.0, 0.0), "leaf_area_index": 0.0, "height": 0.0}
    (cx, cz), (hx, hz) = field_rectangle(blades)
    area = max(2 * hx, 0.1) * max(2 * hz, 0.1)
    leaf = float(np.sum(2.0 * np.asarray(blades.width, np.float64) * np.asarray(blades.height, np.float64))) / area
    return {"field": (cx, cz, hx, hz), "leaf_area_index": leaf, "height": float(np.mean(blades.height))}


def sunlight_values(params, blades, colliders=()) -> dict:
    """The sunlight's values of both ``u_material`` structs (``uniform_layouts.SUNLIGHT_VECTORS``
    with ``light_direction`` and ``shadows``; ``shaders/shadows.wgsl``), the same for both engines.

    Args:
        params: a :class:`~grasswidget.core.params.GrassParams`: ``shadows`` (1.0 / 0.0), the sun
            (:func:`sun_direction`).
        blades: the field's :class:`~grasswidget.core.blades.Blades`, or its :func:`grass_layer`
            (the rectangle, leaf area and height:
            :func:`grasswidget.core.reference.grass_optical_depths`), or None (no grass shadow).
        colliders: the sphere colliders (anything :func:`grasswidget.core.colliders.collider_array`
            takes); the first :data:`~grasswidget.core.reference.MAX_SHADOW_BALLS` cast shadows.
    """
    sun = sun_direction(params)
    layer = blades if isinstance(blades, dict) else grass_layer(blades)
    balls = np.zeros((MAX_SHADOW_BALLS, 4), np.float64)
    spheres = collider_array(colliders)[:MAX_SHADOW_BALLS]
    balls[: len(spheres)] = spheres
    sun_depth, sky_depth = grass_optical_depths(layer["leaf_area_index"], layer["height"], sun[1])
    return {"light_direction": (*sun, 0.0), "shadow_balls": balls, "shadow_field": tuple(layer["field"]),
            "shadow_depths": (sun_depth, sky_depth, layer["height"], FIELD_EDGE),
            "shadows": float(bool(params.shadows))}


def ground_sun(sun_y: float) -> float:
    """The ground's sunlit share for a sun whose unit direction has height ``sun_y``, relative to the
    default sun's (the ground's colours are lit by that one): 1 for the default sun."""
    ratio = float(sun_y) / _DEFAULT_SUN_Y
    return 1.0 if abs(ratio - 1.0) < 1e-6 else ratio


def look_values(params) -> dict:
    """The blade material's looks from the params (``params.LOOK_TRAITS``): colour
    variety (0..1), patch size (m), dryness (0..1), translucency (0..1), fog density (1/m)."""
    return {name: float(getattr(params, name)) for name in LOOK_TRAITS}


def material_values(params, blades=None, colliders=(), **material) -> dict:
    """The blade material's ``u_material`` values (``uniform_layouts.GRASS_MATERIAL_LAYOUT``):
    :data:`MATERIAL_DEFAULTS` with ``material``'s overrides (same keys; the light is the params'
    sun, :func:`sun_direction`, unless ``light_direction`` is given), the looks from
    :func:`look_values`, the ribbon shape from ``params.blade_shape``, opacity 1, and the
    sunlight of ``blades`` and ``colliders`` (:func:`sunlight_values`)."""
    unknown = set(material) - set(MATERIAL_DEFAULTS)
    if unknown:
        raise GrassValueError(f"material_values takes {', '.join(MATERIAL_DEFAULTS)}; got {sorted(unknown)}")
    m = {**MATERIAL_DEFAULTS, "light_direction": sun_direction(params), **material}
    sunlight = sunlight_values(params, blades, colliders)
    light = np.asarray(m["light_direction"], np.float64).reshape(3)
    norm = float(np.linalg.norm(light))
    if not (np.all(np.isfinite(light)) and norm > 0):
        raise GrassValueError(f"light_direction must be a finite non-zero 3-vector; got {m['light_direction']!r}")
    return {
        "root_color": srgb(m["root_color"]),
        "tip_color": srgb(m["tip_color"]),
        "light_direction": (*(light / norm), 0.0),
        "fog_color": srgb(m["fog_color"]),
        "opacity": 1.0,
        "alpha_test": 0.0,
        **look_values(params),
        "ambient": float(m["ambient"]),
        "tip_threshold": float(m["tip_threshold"]),
        "blade_shape": int(BladeShape.from_label(params.blade_shape)),
        **{k: v for k, v in sunlight.items() if k != "light_direction"},
    }


def scene_style(blades, far, params=None, colliders=()) -> dict:
    """Sky, ground and collider-ball style: :func:`sky_ground_values` (lists; the shadows of
    ``colliders``) plus ``ball_color`` (r, g, b, opacity); ``light_direction`` (x, y, z, 0: the
    unit direction towards the params' sun) lights the balls too."""
    values = sky_ground_values(blades, far, params, colliders=colliders)
    style = {k: (np.asarray(v).tolist() if isinstance(v, (tuple, np.ndarray)) else v) for k, v in values.items()}
    style["ball_color"] = list(srgb(BALL_COLOR, BALL_OPACITY))
    return style


#: Frames the browser engine lets the GPU queue at once; an animation frame that finds this many
#: not yet done draws nothing (it keeps the page responsive on a slow adapter).
FRAMES_IN_FLIGHT = 2
#: Times the browser engine starts again (from the rest pose) after losing its WebGPU device;
#: the next loss gives up and says so (``gpu_status`` "unavailable").
DEVICE_LOSS_RETRIES = 2
#: The collider balls' UV sphere (``browser/balls.wgsl``'s ``BALL_RINGS`` and ``BALL_SEGMENTS``):
#: rings from pole to pole, segments around; 6 vertices per quad.
BALL_RINGS = 16
BALL_SEGMENTS = 32
BALL_VERTICES = 6 * BALL_RINGS * BALL_SEGMENTS
#: The browser engine's uniform buffers (the WGSL's names) and the traits that carry their packed
#: bytes, all written by one route (``js/resources.js`` ``writeUniform``); ``u_sim`` gets its
#: per-dispatch fields (``time0``, ``steps``, at ``sim_layout``'s offsets) on the way.
UNIFORM_TRAITS = (("u_sim", "sim_uniform"), ("u_cull", "cull_uniform"), ("u_material", "material_uniform"),
                  ("u_sky_ground", "sky_ground_uniform"), ("u_balls", "ball_uniform"), ("u_inspect", "inspect_uniform"))


def engine_rules() -> dict:
    """The browser engine's own numbers, JSON-able (``frame_rules["engine"]``; ``engine.js`` and
    ``js/*.js`` write none of them): ``frames_in_flight`` (:data:`FRAMES_IN_FLIGHT`),
    ``device_loss_retries`` (:data:`DEVICE_LOSS_RETRIES`), ``frame_times_kept`` (the newest frame
    times a stats message carries, :data:`grasswidget.core.auto_switches.FRAME_TIMES_KEPT`), ``ball_vertices``
    (one ball's triangle list, :data:`BALL_VERTICES`), ``blade_bytes`` (one blade's record,
    :data:`grasswidget.core.blades.BLADE_BYTES`), ``inspected_point_bytes`` (one inspected blade's
    control points, :data:`grasswidget.core.teaching.INSPECTED_POINT_BYTES`), ``inspected_force_bytes``
    (its forces, a vec4 each of ``reference.FORCE_NAMES``), ``uniforms`` ([buffer,
    trait] pairs, :data:`UNIFORM_TRAITS`)."""
    return {"frames_in_flight": FRAMES_IN_FLIGHT, "device_loss_retries": DEVICE_LOSS_RETRIES,
            "frame_times_kept": FRAME_TIMES_KEPT, "ball_vertices": BALL_VERTICES, "blade_bytes": BLADE_BYTES,
            "inspected_point_bytes": INSPECTED_POINT_BYTES, "inspected_force_bytes": 16 * len(FORCE_NAMES), "uniforms": [list(pair) for pair in UNIFORM_TRAITS]}


def frame_rules(params, blades, far, floor="grass") -> dict:
    """``{"clock": clock_rules, "dispatch": dispatch_rules, "orbit": orbit_rules, "drag":
    camera_rules.drag_rules, "input": interaction.input_rules, "counters": counter_layout, "style":
    scene_style, "engine": engine_rules}`` for a field of ``blades`` seen by a camera whose far plane is
    ``far`` metres, orbiting above the ``floor`` ("grass" or "ground", see :func:`orbit_rules`)."""
    return {"clock": clock_rules(params), "dispatch": dispatch_rules(), "orbit": orbit_rules(blades, far, floor),
            "drag": drag_rules(), "input": input_rules(), "counters": counter_layout(),
            "style": scene_style(blades, far, params), "engine": engine_rules()}


#: A playing view whose newest frame arrived longer ago than this (wall seconds) is "waiting for
#: frames"; a frame that arrived more recently never is (two stats intervals and more: the
#: browser's acknowledgements come about 0.5 s after a frame on a loaded machine).
WAITING_AFTER_S = 2.0


def stats_freshness(now: float, frame_t: float | None, *, playing: bool, at_rest: bool = False,
                    changed_t: float | None = None, interval_s: float = STATS_INTERVAL_MS / 1000.0) -> dict:
    """How old a view's stats are, both engines alike (seconds on one monotonic clock, e.g.
    ``time.perf_counter()``).

    Args:
        now: the time now.
        frame_t: when the newest frame the stats describe arrived (the kernel engine: the browser
            acknowledged it, or, with no browser, it was drawn; the browser engine: the stats
            message reporting it came in); None before the first frame.
        playing: whether the view's clock runs (a paused view draws on demand only).
        at_rest: no view of it is on screen, so nothing is drawn (scrolled away, a collapsed
            output, a hidden tab).
        changed_t: when something the picture shows changed (parameters, camera, steps) with no
            frame drawn since; None when the newest frame shows it.
        interval_s: the stats interval (default :data:`STATS_INTERVAL_MS`, 0.5 s).

    Returns:
        ``{"frame_age_s": wall seconds since ``frame_t`` (None before a frame), "at_rest": bool,
        "stale": bool, "waiting": bool}``. ``stale``: the numbers may not describe what the view
        would draw now: it is at rest, or playing with its newest frame older than ``interval_s``,
        or a change older than ``interval_s`` has not been drawn; never before the first frame
        (the numbers are None then, not old). ``waiting``: playing, on screen and no frame arrived
        for :data:`WAITING_AFTER_S` (or none yet after that long a change); a frame that arrived
        more recently is never waited for.
    """
    age = None if frame_t is None else max(0.0, float(now) - float(frame_t))
    pending = changed_t is not None and float(now) - float(changed_t) > interval_s
    stale = age is not None and bool(at_rest or (playing and age > interval_s) or pending)
    waiting = bool(playing and not at_rest and age is not None and age > WAITING_AFTER_S)
    return {"frame_age_s": age, "at_rest": bool(at_rest), "stale": stale, "waiting": waiting}
