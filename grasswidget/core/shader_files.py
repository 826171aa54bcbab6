"""The WGSL files of the package and the values their templates take (pure Python).

The files live in ``grasswidget/shaders/`` and ship inside the wheel and the
sdist; the same folder serves a source checkout and an installed copy. Nothing
here imports pygfx or wgpu.

Templates
---------
The WGSL files are jinja2 templates in pygfx's dialect: ``{{ name }}`` inserts a
value, ``$$ if ...`` / ``$$ for ...`` lines are statements, and
``{$ include 'grasswidget.<file>' $}`` includes another file of this folder. The
pygfx shader classes (:mod:`grasswidget.gpu.shader_classes`, :mod:`grasswidget.gpu.simulation`)
render them with :func:`template_vars` plus their own variables; any other engine
(e.g. a browser WebGPU engine) renders the same files with :func:`render_wgsl`.

The engine-neutral files and what they need:

``blade.wgsl``
    ``struct Blade`` and ``load_blade(i)`` / ``store_blade(i, b)`` /
    ``store_blade_guides(i, b)`` (the twin of ``blades.pack_state``). Reads and
    writes ``s_blades: array<vec4<f32>>``, which the engine declares; the store
    functions exist only when ``blades_writable`` is true.
``occlusion.wgsl``, ``hzb_build.wgsl``
    Occlusion culling: the test of the culling's second phase (
    ``blade_occluded(...)``, reads ``s_hzb`` and ``s_hzb_levels``) and one level of the max-depth pyramid
    (entry point ``main``, template variable ``level``); see ``cull.wgsl``.
``blade_math.wgsl``
    The blade math, one function per NumPy twin of ``core/reference/`` (same names).
    Pure functions: no bindings.
``wind_field.wgsl``
    ``wind_field(p, t)`` (switch on ``u_sim.wind_field``) and ``user_wind`` (body
    ``{{ user_wind_body }}``). Expects ``u_sim`` (a uniform whose fields are those
    of ``uniform_layouts.SIM_LAYOUT``). Included by the simulation and the inspector.
``collisions.wgsl``
    ``collider_cell_range(v0)`` (the list of the root's cell of the collider grid),
    ``collide_spheres(v0, v1, v2, height)`` (the one loop over the colliders: the
    spheres of that list in reach, calling blade_math's ``collide_sphere``) and
    ``collision_passes(v0, v1, v2, up, height)`` (``collision_passes`` times: push,
    then ``validate_pushed``); twins of the same names in ``core/reference/`` and
    ``collider_grid.py``. Expects ``u_sim`` (``n_colliders``), ``s_colliders:
    array<vec4<f32>>`` and ``s_collider_grid: array<u32>`` (read; the arrays of
    :mod:`grasswidget.core.collider_grid`); included after ``blade_math.wgsl`` by the
    simulation and the inspector.
``simulate_body.wgsl``
    The compute entry point ``main``. Expects, declared by the engine: ``u_sim``,
    ``s_blades`` (read_write), ``s_collision: array<f32>`` (read_write) and the
    collider arrays of ``collisions.wgsl``.
``cull_body.wgsl``
    The culling entry point ``main``. Expects ``u_stdinfo`` (fields
    ``projection_transform``, ``cam_transform``, ``cam_transform_inv``,
    ``physical_size``; pygfx's names), ``u_wobject.world_transform``, ``u_cull``
    (fields of ``uniform_layouts.CULL_LAYOUT``), ``s_blades`` (read), ``s_args:
    array<atomic<u32>>``, ``s_visible: array<u32>``, ``s_culled: array<u32>`` and
    ``s_culled_args: array<atomic<u32>>`` (read_write; the culled blades drawn
    with ``color_by = "cull"``).

``simulate.wgsl`` and ``cull.wgsl`` are the pygfx wrappers: ``{{ bindings_code }}``
(pygfx's generated declarations) and the few declarations pygfx cannot generate,
then the body. ``blade_render.wgsl``, ``reset_args.wgsl`` and ``inspect.wgsl``
(the blade inspector, :mod:`grasswidget.gpu.inspector`) are pygfx-only.

Template variables (:func:`template_vars`): ``wind_field_<name>``,
``blade_shape_<name>``, ``gravity_mode_<name>``, ``color_by_<name>`` (the ids of
:mod:`grasswidget.core.enums`; names in lowercase with underscores, e.g.
``blade_shape_triangle_tip``), ``recovery_floor``, ``collision_max``,
``collision_passes``, ``collider_reach``, ``noise_scale`` (from ``core/reference/``),
``grid_header_words`` (from ``collider_grid.py``),
``workgroup_size`` (threads per workgroup of the per-blade compute shaders),
``n_classes``, ``lod_segments``, ``lod_min_pixels`` (level-of-detail classes),
``blades_writable`` (False; True in the simulation), ``teaching_views`` (False;
True in the pygfx shader classes: the frozen culling camera, ``color_by`` and the
draw of culled blades, which need ``u_cull``'s ``color_by``/``frozen_*`` fields,
``s_culled`` and ``s_culled_args``; see :mod:`grasswidget.core.teaching`) and
``user_wind_body`` (the custom wind; default: no wind).
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from ..errors import MissingFileError

__all__ = ["shader_dir", "read_shader", "shader_names", "template_vars", "render_wgsl", "wgsl_float", "WORKGROUP_SIZE", "MAX_WORKGROUPS_X", "NO_WIND_BODY",
           "SHADE_PER_VERTEX_MIN_SEGMENTS",
           "DISTANCE_BANDS", "BAND_RANGE", "RASTER_CLEAR_OFFSET", "RASTER_SHADE_OFFSET", "RASTER_DISPATCH_WORDS"]

#: Threads per workgroup of the per-blade compute shaders (``@workgroup_size``).
WORKGROUP_SIZE = 256
#: Workgroups along x of one dispatch before it folds into y (WebGPU's guaranteed minimum limit;
#: raster.wgsl's args step folds the walks' indirect dispatch the same way).
MAX_WORKGROUPS_X = 65535
#: u32 words of the compute rasterizer's dispatch buffer (s_raster_dispatch): three (x, y, z, 0)
#: workgroup counts: the walks' at word 0, the clear's at 4, the shade's at 8.
RASTER_DISPATCH_WORDS = 12
#: Bytes into the compute rasterizer's dispatch words where its clear's workgroups are
#: (raster.wgsl's clear_args step writes words 4..6; the walks' are at 0).
RASTER_CLEAR_OFFSET = 16
#: Bytes into the compute rasterizer's dispatch words where its shade's workgroups are
#: (raster.wgsl's shade_args step writes words 8..10, after the walks).
RASTER_SHADE_OFFSET = 32

#: The "custom" wind when ``params.wind_wgsl`` is empty: no wind.
NO_WIND_BODY = "    return vec3<f32>(0.0);"

#: Distance bands per LOD class: the culling draws each class nearest band first (cull.wgsl with
#: ``bands``), so the depth test rejects hidden fragments before they are shaded.
DISTANCE_BANDS = 64
#: The bands are log-spaced over this range of distances to the camera (m).
BAND_RANGE = (0.5, 512.0)


def shader_dir() -> Path:
    """The folder holding the WGSL files (``grasswidget/shaders``)."""
    return Path(str(resources.files("grasswidget") / "shaders"))


def shader_names() -> list[str]:
    """File names of every WGSL file of the package, sorted."""
    return sorted(p.name for p in shader_dir().glob("*.wgsl"))


def read_shader(name: str) -> str:
    """Text of one WGSL file as stored (an unrendered template), e.g. ``read_shader("simulate.wgsl")``."""
    path = shader_dir() / name
    if not path.is_file():
        raise MissingFileError(f"grasswidget has no shader {name!r} in {shader_dir()}; the installation is incomplete")
    return path.read_text(encoding="utf-8")


def wgsl_float(x: float) -> str:
    """A WGSL f32 literal for x (always with a decimal point or exponent)."""
    text = repr(float(x))
    return text if any(c in text for c in ".eE") else text + ".0"


def template_vars() -> dict:
    """Every value the WGSL templates take from Python: the one source of shared ids and constants."""
    from .enums import BladeShape, ColorBy, GravityMode, WindField
    from .collider_grid import GRID_HEADER_WORDS
    from .reference import (COLLIDER_REACH, COLLISION_MAX, COLLISION_PASSES, CULLED_SEGMENTS, DRY_COLOR, LOD_MIN_PIXELS,
                            LOD_SEGMENTS, NOISE_SCALE, OCCLUSION_PIECES, HZB_SPAN_TEXELS, OCCLUSION_RADIUS_PER_WIDTH,
                            RASTER_MAX_ACROSS, RASTER_MAX_SAMPLES, RECOVERY_FLOOR)
    from .reference.shadows import BALL_PENUMBRA, GROUND_AMBIENT, MAX_SHADOW_BALLS, SKY_FLOOR, SUN_MIN_Y, TRANSMITTANCE_TAPS

    return {
        **WindField.template_vars("wind_field"),
        **BladeShape.template_vars("blade_shape"),
        **GravityMode.template_vars("gravity_mode"),
        **ColorBy.template_vars("color_by"),
        "recovery_floor": wgsl_float(RECOVERY_FLOOR),
        "collision_max": wgsl_float(COLLISION_MAX),
        "collision_passes": int(COLLISION_PASSES),
        "collider_reach": wgsl_float(COLLIDER_REACH),
        "grid_header_words": int(GRID_HEADER_WORDS),
        "noise_scale": wgsl_float(NOISE_SCALE),
        "dry_color": ", ".join(wgsl_float(c) for c in DRY_COLOR),
        "workgroup_size": WORKGROUP_SIZE,
        "max_groups_x": int(MAX_WORKGROUPS_X),
        "n_classes": len(LOD_SEGMENTS),
        "lod_segments": list(LOD_SEGMENTS),
        "culled_segments": int(CULLED_SEGMENTS),
        "lod_min_pixels": [f"{p:.1f}" for p in LOD_MIN_PIXELS[:-1]],
        "blades_writable": False,
        "teaching_views": False,
        "sunlight": False,  # shadows.wgsl: the shadows' maths compiled in (GrassParams.shadows on)
        "bands": 0,  # cull.wgsl: 0 = one pass, list order by blade id; > 0 = draw order by distance band
        "occlusion": 0,  # cull.wgsl: 0 = no occlusion culling, 1 = first phase, 2 = second phase
        "occlusion_radius_per_width": wgsl_float(OCCLUSION_RADIUS_PER_WIDTH),
        "occlusion_pieces": int(OCCLUSION_PIECES),
        "hzb_span_texels": int(HZB_SPAN_TEXELS),
        "raster_max_samples": wgsl_float(RASTER_MAX_SAMPLES),
        "raster_max_across": wgsl_float(RASTER_MAX_ACROSS),
        "sun_min_y": wgsl_float(SUN_MIN_Y),
        "sky_floor": wgsl_float(SKY_FLOOR),
        "ground_ambient": wgsl_float(GROUND_AMBIENT),
        "ball_penumbra": wgsl_float(BALL_PENUMBRA),
        "transmittance_taps": int(TRANSMITTANCE_TAPS),
        "max_shadow_balls": int(MAX_SHADOW_BALLS),
        "raster_packed": False,  # raster.wgsl / raster_resolve.wgsl: one walk with 64-bit atomics (gpu/raster_walks.py)
        "compute_raster": False,  # cull.wgsl: list thin blades for the compute rasterizer (raster.wgsl)
        # cull.wgsl, blade_render.wgsl, raster.wgsl: a field to the horizon's camera-following levels
        # (levels.wgsl): the culling pass wraps the blades around the camera, every pass that draws
        # blades scales their width by their level's weight
        "follow_camera": False,
        "from_end": False,  # blade_render.wgsl: the second occlusion phase's lists (from the end)
        "shade_per_vertex": False,  # blade_render.wgsl: shading per vertex (ribbon_vars), else per fragment
        "user_wind_body": NO_WIND_BODY,
    }


#: Ribbons of at least this many segments are shaded per vertex (``shade_per_vertex`` of
#: :func:`ribbon_vars`; blade_render.wgsl says why), coarser ones per fragment.
SHADE_PER_VERTEX_MIN_SEGMENTS = 4


def ribbon_vars(lod_class: int) -> dict:
    """The template variables of ``blade_render.wgsl`` for one draw: LOD classes
    ``0 .. len(LOD_SEGMENTS) - 1``, and ``len(LOD_SEGMENTS)`` for the culled blades
    drawn with ``color_by = "cull"`` (CULLED_SEGMENTS segments, flat in CULL_COLORS).
    ``shade_per_vertex``: the class's ribbons have at least SHADE_PER_VERTEX_MIN_SEGMENTS
    segments and are shaded per vertex."""
    from .reference import CULLED_SEGMENTS, LOD_SEGMENTS
    from .teaching import CULL_COLORS, LOD_COLORS, hex_to_rgb

    def rgb(color):
        return ", ".join(f"{c / 255:.6f}" for c in hex_to_rgb(color))

    culled = lod_class == len(LOD_SEGMENTS)
    segments = CULLED_SEGMENTS if culled else LOD_SEGMENTS[lod_class]
    return {
        "lod_class": int(lod_class),
        "culled": culled,
        "segments": segments,
        "shade_per_vertex": segments >= SHADE_PER_VERTEX_MIN_SEGMENTS,
        "lod_color": rgb(LOD_COLORS[0 if culled else lod_class]),
        "cull_colors": [rgb(c) for c in CULL_COLORS.values()],
    }


def raster_shade_vars() -> dict:
    """The template variables of ``raster.wgsl``'s step "shade": ``raster_color``, the
    "drawn in compute" teaching colour (teaching.COMPUTE_RASTER_COLOR) as WGSL floats."""
    from .teaching import COMPUTE_RASTER_COLOR, hex_to_rgb

    return {"raster_color": ", ".join(f"{c / 255:.6f}" for c in hex_to_rgb(COMPUTE_RASTER_COLOR))}


def wgsl_environment(includes=None, **options):
    """A jinja2 Environment with pygfx's WGSL template syntax (``{{ }}``, ``{$ $}``, ``$$``
    lines, undefined names are errors) that includes ``grasswidget.<file>`` from the
    package's shader folder, plus ``includes``: {prefix: jinja2 loader} of an engine's own."""
    import jinja2

    loaders = {"grasswidget": jinja2.FileSystemLoader(str(shader_dir())), **(includes or {})}
    return jinja2.Environment(
        block_start_string="{$",
        block_end_string="$}",
        variable_start_string="{{",
        variable_end_string="}}",
        line_statement_prefix="$$",
        undefined=jinja2.StrictUndefined,
        loader=jinja2.PrefixLoader(loaders, delimiter="."),
        **options,
    )


def _environment():
    return wgsl_environment(keep_trailing_newline=True)


def render_wgsl(source: str, **variables) -> str:
    """Render a WGSL template without pygfx, for any WebGPU engine.

    ``source`` is a file name of this folder (e.g. ``"blade_math.wgsl"``) or WGSL
    text (which may ``{$ include 'grasswidget.<file>' $}``). Variables default to
    :func:`template_vars`; keyword arguments override or add. pygfx's own
    includes (``pygfx.*``) do not resolve here.
    """
    env = _environment()
    text = read_shader(source) if source.endswith(".wgsl") and "\n" not in source else source
    return env.from_string(text).render(**{**template_vars(), **variables})
