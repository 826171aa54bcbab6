"""The project's WGSL, rendered for the browser engine's bindings (pure Python).

The browser runs the very files the kernel engine runs (the blade math include,
the simulation, the reset, the culling and the ribbon shaders). They are jinja2
templates in pygfx's dialect (``{$ include ... $}``, ``{{ var }}``, ``$$`` lines);
pygfx fills ``{{ bindings_code }}`` and ``pygfx.std.wgsl`` with its own uniform
structs. Here the same templates are rendered with this engine's own minimal
headers instead: uniform structs laid out by :mod:`grasswidget.browser.uniforms`
and one ``@group(0) @binding(k)`` line per resource the file uses and does not
declare itself.

Every rendered shader comes with its binding map (name, binding number, kind),
read back from the final text, so the browser binds resources by name and never
needs to know which file declares what. Nothing here imports pygfx or wgpu.
"""

from __future__ import annotations

import copy
import functools
import re
from collections import OrderedDict
from functools import lru_cache
from pathlib import Path

import jinja2

from ..core.reference import FORCE_NAMES, HZB_MAX_LEVELS, HZB_ROW_ALIGN, LOD_SEGMENTS
from ..core.shader_files import (BAND_RANGE, DISTANCE_BANDS, NO_WIND_BODY, RASTER_CLEAR_OFFSET, RASTER_DISPATCH_WORDS,
                                 RASTER_SHADE_OFFSET, WORKGROUP_SIZE,
                                 raster_shade_vars,
                                 ribbon_vars, shader_dir, template_vars, wgsl_environment, wgsl_float)
from ..core.teaching import (ARROW_ACCEL_PER_HEIGHT, COLLISION_ARROW_SCALE, FROZEN_FRUSTUM_COLOR, INSPECTOR_COLORS,
                             MAX_INSPECTED, SEGMENT_VERTICES, inspector_segment_colors)
from ..core.uniform_layouts import INSPECT_LAYOUT
from .uniforms import (BALL_LAYOUT, CULL_LAYOUT, GRASS_MATERIAL_LAYOUT, SIM_LAYOUT, SKY_GROUND_LAYOUT, STDINFO_LAYOUT,
                       WOBJECT_LAYOUT, offsets, wgsl_struct)

__all__ = ["BrowserShaders", "render_shader", "binding_map", "USER_WIND_SIGNATURE", "HERE"]

HERE = Path(__file__).resolve().parent
USER_WIND_SIGNATURE = "fn user_wind(p: vec3<f32>, t: f32) -> vec3<f32> {"
_MARK = "/*__GRASSWIDGET_BROWSER_BINDINGS__*/"
_VARYINGS_MARK = "/*__GRASSWIDGET_VARYINGS__*/"
_VARYING_RE = re.compile(r"\bvaryings\.(\w+)\s*=\s*((?:vec[234]|mat[234]x[234])<\w+>|f32|i32|u32)\s*\(")

#: Uniform structs: resource name -> (struct name, layout).
_UNIFORMS = {
    "u_sim": ("SimUniforms", SIM_LAYOUT),
    "u_cull": ("CullUniforms", CULL_LAYOUT),
    "u_stdinfo": ("StdInfo", STDINFO_LAYOUT),
    "u_wobject": ("WorldObject", WOBJECT_LAYOUT),
    "u_material": ("GrassMaterialUniforms", GRASS_MATERIAL_LAYOUT),
    "u_inspect": ("InspectUniforms", INSPECT_LAYOUT),
}

#: Storage resources each kind of pass may use: name -> WGSL declaration tail.
_STORAGE = {
    "compute": {
        "s_blades": "var<storage, read_write> s_blades: array<vec4<f32>>",
        "s_collision": "var<storage, read_write> s_collision: array<f32>",
        "s_args": "var<storage, read_write> s_args: array<atomic<u32>>",
        "s_visible": "var<storage, read_write> s_visible: array<u32>",
        "s_culled": "var<storage, read_write> s_culled: array<u32>",
        "s_culled_args": "var<storage, read_write> s_culled_args: array<atomic<u32>>",
        "s_bands": "var<storage, read_write> s_bands: array<atomic<u32>>",
        "s_colliders": "var<storage, read> s_colliders: array<vec4<f32>>",
        "s_collider_grid": "var<storage, read> s_collider_grid: array<u32>",
        # the blade inspector (inspect.wgsl): line vertices and points, 3 floats each; forces
        "s_segments": "var<storage, read_write> s_segments: array<f32>",
        "s_points": "var<storage, read_write> s_points: array<f32>",
        "s_forces": "var<storage, read_write> s_forces: array<vec4<f32>>",
        # Occlusion culling (cull.wgsl occlusion 1 and 2, hzb_build.wgsl): read_write only
        # where the file writes them (_WRITTEN_WHERE_STORED), else read.
        "s_occlusion_flags": "var<storage, read_write> s_occlusion_flags: array<u32>",
        "s_hzb": "var<storage, read_write> s_hzb: array<f32>",
        "s_hzb_levels": "var<storage, read> s_hzb_levels: array<vec4<u32>>",
        # The compute rasterizer (cull.wgsl with compute_raster, raster.wgsl): its list of blades
        # (read_write only where written), counters and per-pixel depth and payload words.
        "s_raster": "var<storage, read_write> s_raster: array<u32>",
        "s_raster_args": "var<storage, read_write> s_raster_args: array<atomic<u32>>",
        "s_raster_dispatch": "var<storage, read_write> s_raster_dispatch: array<u32>",
        "s_raster_depth": "var<storage, read_write> s_raster_depth: array<atomic<u32>>",
        "s_raster_payload": "var<storage, read_write> s_raster_payload: array<atomic<u32>>",
        "s_raster_color": "var<storage, read_write> s_raster_color: array<u32>",
    },
    "render": {
        "s_blades": "var<storage, read> s_blades: array<vec4<f32>>",
        "s_visible": "var<storage, read> s_visible: array<u32>",
        "s_culled": "var<storage, read> s_culled: array<u32>",
        # the compute rasterizer's resolve (raster_resolve.wgsl)
        "s_raster_depth": "var<storage, read> s_raster_depth: array<u32>",
        "s_raster_payload": "var<storage, read> s_raster_payload: array<u32>",
        "s_raster_args": "var<storage, read> s_raster_args: array<u32>",
        "s_raster_color": "var<storage, read> s_raster_color: array<u32>",
    },
}

#: Storage declared read_write only when the file stores into it (``name[...] = ...``).
_WRITTEN_WHERE_STORED = ("s_occlusion_flags", "s_hzb", "s_raster")
#: An index in brackets, one level of brackets inside allowed (``s_raster[wg_base[RASTER] + slot]``).
_INDEX = r"\[(?:[^\[\]]|\[[^\]]*\])*\]"

_DECL_RE = re.compile(r"@group\(\s*0\s*\)\s*@binding\(\s*(\d+)\s*\)\s*var\s*<\s*([a-z_, ]+?)\s*>\s*(\w+)")


def _std_include() -> str:
    """This engine's stand-in for ``pygfx.std.wgsl``: varyings, fragment output, helpers."""
    return (HERE / "std.wgsl").read_text(encoding="utf-8")


def varyings_struct(code: str) -> str:
    """The ``Varyings`` struct of a shader, as pygfx generates it: one field per
    ``varyings.<name> = <type>(...)`` assignment, in order of first assignment;
    ``position`` is the clip position builtin, integer fields are flat."""
    found = {}
    for name, wgsl_type in _VARYING_RE.findall(code):
        found.setdefault(name, wgsl_type)
    lines = ["    @builtin(position) position: vec4<f32>,"] if "position" in found else []
    others = [(name, t) for name, t in found.items() if name != "position"]
    for location, (name, wgsl_type) in enumerate(others):
        flat = " @interpolate(flat)" if wgsl_type in ("u32", "i32") or wgsl_type.endswith(("<u32>", "<i32>")) else ""
        lines.append(f"    @location({location}){flat} {name}: {wgsl_type},")
    return "struct Varyings {\n" + "\n".join(lines) + "\n};"


@lru_cache(maxsize=1)
def _environment() -> jinja2.Environment:
    std = jinja2.FunctionLoader(lambda name: _std_include() if name == "std.wgsl" else None)
    return wgsl_environment({"pygfx": std}, auto_reload=True)


def binding_map(code: str) -> list:
    """[{name, binding, kind}] of every ``@group(0)`` resource declared in ``code``.

    kind is "uniform", "read-only-storage" or "storage" (WebGPU's buffer binding types).
    """
    out = []
    for binding, space, name in _DECL_RE.findall(code):
        space = space.replace(" ", "")
        if space == "uniform":
            kind = "uniform"
        elif space in ("storage", "storage,read"):
            kind = "read-only-storage"
        else:
            kind = "storage"
        out.append({"name": name, "binding": int(binding), "kind": kind})
    return sorted(out, key=lambda b: b["binding"])


def _uses(code: str, name: str) -> bool:
    """``name`` occurs in the code outside ``//`` comments."""
    return re.search(rf"\b{name}\b", re.sub(r"//[^\n]*", "", code)) is not None


#: Shaders already rendered (see :func:`_memoized`), oldest first; at most ``_RENDERED_MAX`` kept.
_RENDERED: OrderedDict = OrderedDict()
_RENDERED_MAX = 512


def _shader_files_stamp() -> tuple:
    """Name, modification time and size of every WGSL file of the shader folder."""
    return tuple((p.name, p.stat().st_mtime_ns, p.stat().st_size) for p in sorted(shader_dir().glob("*.wgsl")))


def _memoized(render):
    """Remember what ``render`` (:func:`render_shader`) returned for the same arguments, the same
    template values and the same shader files (name, time, size), and hand out copies: every
    browser-engine widget asks for the same few dozen shaders, and compiling their templates
    took most of the time to make one (about 0.3 s each on 2 busy cores)."""

    @functools.wraps(render)
    def cached(filename, stage, *, uniforms=None, resources=None, **variables):
        key = (filename, stage, repr(uniforms), repr(resources), repr(sorted(variables.items())),
               repr(sorted(template_vars().items())), _shader_files_stamp())
        if key in _RENDERED:
            _RENDERED.move_to_end(key)
        else:
            _RENDERED[key] = render(filename, stage, uniforms=uniforms, resources=resources, **variables)
            while len(_RENDERED) > _RENDERED_MAX:
                _RENDERED.popitem(last=False)
        return copy.deepcopy(_RENDERED[key])

    return cached


@_memoized
def render_shader(filename: str, stage: str, *, uniforms=None, resources=None, **variables) -> dict:
    """Render one of the project's WGSL files for the browser.

    Args:
        filename: a file of the shader folder, e.g. "simulate.wgsl".
        stage: "compute" or "render" (which storage access the header declares).
        uniforms: {resource name: (struct name, layout)} replacing the default struct
            of a uniform (e.g. ``u_material`` of sky_ground.wgsl is not the grass material).
        resources: {name in the WGSL: the engine's buffer name} where they differ;
            each binding then carries ``"resource"`` (the engine binds that buffer).
        variables: the template's variables (as the pygfx shader class passes them).

    Returns ``{"code": str, "bindings": [...]}`` (see :func:`binding_map`).
    """
    env = _environment()
    source = (shader_dir() / filename).read_text(encoding="utf-8")
    # teaching_views: the colour-by views (the culled blades' list and draw, flat colours).
    values = {**template_vars(), "teaching_views": True, "bindings_code": _MARK, "write_pick": False,
              "frag_depth": False, **variables}
    body = env.from_string(source).render(**values)
    if _VARYINGS_MARK in body:
        body = body.replace(_VARYINGS_MARK, varyings_struct(body), 1)
    declared = {b["name"] for b in binding_map(body)}
    used_numbers = {b["binding"] for b in binding_map(body)}

    structs, lines = [], []
    next_free = 0

    def take():
        nonlocal next_free
        while next_free in used_numbers:
            next_free += 1
        used_numbers.add(next_free)
        return next_free

    for name, (struct, layout) in {**_UNIFORMS, **(uniforms or {})}.items():
        if name in declared or not _uses(body.replace(_MARK, ""), name):
            continue
        structs.append(wgsl_struct(struct, layout))
        lines.append(f"@group(0) @binding({take()}) var<uniform> {name}: {struct};")
    for name, decl in _STORAGE[stage].items():
        if name in declared or not _uses(body.replace(_MARK, ""), name):
            continue
        if "atomic" in decl and not re.search(rf"\batomic\w+\(\s*&\s*{name}\b", body):
            decl = decl.replace("array<atomic<u32>>", "array<u32>")
        if name in _WRITTEN_WHERE_STORED and not re.search(rf"\b{name}{_INDEX}\s*=(?!=)", body):
            decl = decl.replace("read_write", "read")
        lines.append(f"@group(0) @binding({take()}) {decl};")
    header = "// ---- browser engine bindings (grasswidget.browser.browser_wgsl)\n" + "\n".join(structs + lines) + "\n"
    if _MARK in body:
        code = body.replace(_MARK, header, 1)
    else:
        code = header + body
    bindings = binding_map(code)
    for b in bindings:
        if resources and b["name"] in resources:
            b["resource"] = resources[b["name"]]
    return {"code": code, "bindings": bindings}


def wind_body(wind_wgsl: str) -> str:
    """The body of ``user_wind``: the user's snippet, or no wind when empty."""
    return wind_wgsl if wind_wgsl.strip() else NO_WIND_BODY


def _body_file(name: str) -> str:
    """``<name>_body.wgsl`` when the shader folder has an engine-neutral body of that name, else ``<name>.wgsl``."""
    return f"{name}_body.wgsl" if (shader_dir() / f"{name}_body.wgsl").is_file() else f"{name}.wgsl"


class BrowserShaders:
    """All shader texts the browser engine compiles, rendered from the project's files.

    ``simulate(wind_wgsl)`` depends on the custom wind; the draws (ribbons, the compute
    rasterizer's resolve, sky and ground) on ``sunlight``: ``GrassParams.shadows``, whose maths
    (``shaders/shadows.wgsl``) they compile in only while it is on, as the kernel engine's do
    (a change of the switch sends the other set; the engine compiles what it is sent); the
    others are fixed.
    ``sky_ground()`` is the kernel engine's sky and ground file (its ``u_material``
    bound to the engine's ``u_sky_ground`` buffer); ``balls()`` the collider balls.
    """

    @staticmethod
    def simulate(wind_wgsl: str = "") -> dict:
        return render_shader(_body_file("simulate"), "compute", user_wind_body=wind_body(wind_wgsl),
                             blades_writable=True)

    @staticmethod
    def reset_args() -> dict:
        """Reset every draw's args, the second occlusion phase's included (``s_occlusion_args``)."""
        return render_shader("reset_args.wgsl", "compute", bands=DISTANCE_BANDS, occlusion=1)

    @staticmethod
    def cull(phase: str = "scatter", follow_camera: bool = False) -> dict:
        """The culling pass, drawing order by distance band as in the kernel: phase "count"
        counts survivors per (class, band), :meth:`prefix_bands` turns counts into slots,
        phase "scatter" writes the lists nearest band first; with the compute rasterizer on
        (``u_cull.compute_raster``) the thin blades go to its list instead. Rendered as occlusion
        culling's first phase (``occlusion = 1``): while ``u_cull.occlusion_phase`` is 1
        it keeps only the blades seen last frame (``s_occlusion_flags``), else all. ``follow_camera``: a
        field to the horizon (``Blades.horizon``): the pass first moves its blades around the camera
        (``s_blades`` read_write) and culls them by their level's weight."""
        return render_shader(_body_file("cull"), "compute", bands=DISTANCE_BANDS, phase=phase, occlusion=1,
                             compute_raster=True, band_near=f"{BAND_RANGE[0]:.3f}", band_far=f"{BAND_RANGE[1]:.3f}",
                             follow_camera=bool(follow_camera))

    @staticmethod
    def cull_occlusion(follow_camera: bool = False) -> dict:
        """Occlusion culling's second phase (``cull.wgsl``, ``occlusion = 2``, one pass without
        distance bands, as in the kernel engine): every blade that passes the other tests is
        tested against the max-depth pyramid; the newly visible ones are listed from the end
        of their class's list, counted in ``s_occlusion_args`` (bound as its ``s_args``)."""
        return render_shader(_body_file("cull"), "compute", bands=0, phase="scatter", occlusion=2,
                             compute_raster=True, resources={"s_args": "s_occlusion_args"},
                             follow_camera=bool(follow_camera))

    @staticmethod
    def raster(step: str, second: bool = False, follow_camera: bool = False, sunlight: bool = False) -> dict:
        """``raster.wgsl``, the compute rasterizer of thin blades: step "clear" (per-pixel words
        of the rows the last frame wrote, and counters), "args" (the walks' workgroups into
        ``s_raster_dispatch``, the rows written to none), "depth" or "payload" (the walks,
        dispatched indirectly from ``s_raster_dispatch``), "shade_args" (the shade's workgroups for
        the rows the walks wrote) and "shade" (each such pixel's colour into ``s_raster_color``,
        dispatched indirectly at ``RASTER_SHADE_OFFSET``); ``second``: the steps of occlusion
        culling's second phase (only the blades it listed). ``follow_camera``: a field to the
        horizon (its blades' widths scaled by their level's weight). ``sunlight``: the shade's
        shadows maths compiled in (``GrassParams.shadows`` on)."""
        shade = dict(raster_shade_vars(), sunlight=bool(sunlight)) if step == "shade" else {}
        return render_shader("raster.wgsl", "compute", step=step, second=bool(second),
                             follow_camera=bool(follow_camera), **shade)

    @staticmethod
    def raster_resolve() -> dict:
        """``raster_resolve.wgsl``: one draw (4 vertices, triangle strip) across the rows the walks
        wrote, writing the compute-rasterized pixels' colours (the shade step's: every view, the
        colour-by ones included) and their depth."""
        return render_shader("raster_resolve.wgsl", "render", frag_depth=True)

    @classmethod
    def compute_raster(cls, sunlight: bool = False, follow_camera: bool = False) -> dict:
        """The compute rasterizer of thin blades (``GrassParams.compute_raster``), as the kernel
        engine's ``grasswidget.gpu.render_frame`` runs it, executed by the browser engine while
        ``u_cull.compute_raster`` (Python's bytes at ``switch_offset``, i32) is 1:

        * per view size (w, h): ``s_raster_depth`` and ``s_raster_payload`` of w * h u32 each and
          ``s_raster_color`` of ``color_words_per_pixel`` * w * h u32 (the shade's colours);
          before each frame's passes the engine writes w and h (f32) at ``width_offset`` and
          ``height_offset`` of ``u_cull`` (cull.wgsl lists thin blades only in renders of that size);
        * the compute passes marked ``only_if: "compute_raster"`` in ``compute_passes`` (the
          clear's args step, one thread; the clear over the rows the last frame wrote and the walks
          with ``dispatch: "raster_listed"``: ``dispatchWorkgroupsIndirect(s_raster_dispatch,
          indirect_offset)``, offset 0 unless given; the args and shade_args steps, one thread each;
          the shade, after the walks, at ``RASTER_SHADE_OFFSET``), bound to that size's buffers;
        * ``resolve`` (every view's: the shade step made the colour-by views' colours) drawn after
          the ribbons in the same render pass, before sky and ground; with
          occlusion culling the second phase's args step, walks and shade (``second_args`` dispatched
          once, ``second_depth``, ``second_payload`` indirectly, ``second_shade_args`` once,
          ``second_shade`` indirectly at ``shade_offset``) run after the second culling pass and the
          resolve is drawn again after its ribbons;
        * ``s_raster_dispatch`` holds ``dispatch_words`` u32 (usage STORAGE | INDIRECT): the walks'
          workgroups at byte 0, the clear's at byte ``RASTER_CLEAR_OFFSET``, the shade's at
          ``shade_offset`` (``RASTER_SHADE_OFFSET``);
        * ``s_raster`` holds N u32, ``s_raster_args`` 4 u32 (listed blades, first phase's part, the
          first row written and the complement of the last); the stats read ``s_raster_args[0]``
          (blades drawn in compute). The clear clears only the rows the last frame wrote: when a
          frame is drawn at another size than the frame before, the engine first writes zeros to
          the ``rows_words`` words at word ``rows_at`` (zeros: every row, the whole view cleared).
        """
        at = offsets(CULL_LAYOUT)
        return {
            "switch_offset": int(at["compute_raster"][0]),
            "width_offset": int(at["raster_width"][0]),
            "height_offset": int(at["raster_height"][0]),
            "args_words": 4,
            "rows_at": 2,
            "rows_words": 2,
            "dispatch_words": RASTER_DISPATCH_WORDS,
            "shade_offset": RASTER_SHADE_OFFSET,
            "color_words_per_pixel": 2,
            "second_args": cls.raster("args", second=True, follow_camera=follow_camera),
            "second_depth": cls.raster("depth", second=True, follow_camera=follow_camera),
            "second_payload": cls.raster("payload", second=True, follow_camera=follow_camera),
            "second_shade_args": cls.raster("shade_args", second=True),
            "second_shade": cls.raster("shade", second=True, sunlight=sunlight),
            "resolve": cls.raster_resolve(),
        }

    @staticmethod
    def hzb_level(level: int) -> dict:
        """One level (1 .. HZB_MAX_LEVELS - 1) of the max-depth pyramid (``hzb_build.wgsl``)."""
        return render_shader("hzb_build.wgsl", "compute", level=int(level))

    @staticmethod
    def prefix_bands() -> dict:
        return render_shader("prefix_bands.wgsl", "compute", bands=DISTANCE_BANDS)

    @staticmethod
    def blades(flat_colors: bool = True, from_end: bool = False, sunlight: bool = False,
               follow_camera: bool = False) -> list:
        """One ribbon shader per level-of-detail class (segments along the blade); with
        ``flat_colors`` (the colour-by views) also one for the culled blades drawn flat
        when ``color_by`` is "cull" (``culled``: True). The natural view uses the set
        without the flat-colour path, as the kernel engine does (it costs GPU draw time).
        ``from_end``: the second occlusion phase's draws (lists read from the end; no
        culled draw: the first set's draws it). ``sunlight``: the shadows' maths compiled in
        (``GrassParams.shadows`` on). ``follow_camera``: a field to the horizon (widths scaled by
        the level weights, levels.wgsl)."""
        out = []
        for k in range(len(LOD_SEGMENTS) + (1 if flat_colors and not from_end else 0)):
            values = ribbon_vars(k)
            out.append(dict(render_shader("blade_render.wgsl", "render", **values, teaching_views=flat_colors,
                                          sunlight=bool(sunlight), from_end=from_end and not values["culled"],
                                          follow_camera=bool(follow_camera)),
                            culled=bool(values["culled"])))
        return out

    @classmethod
    def occlusion(cls, sunlight: bool = False, follow_camera: bool = False) -> dict:
        """Occlusion culling's second phase, as the browser engine runs it every frame while
        ``u_cull.occlusion_phase`` (its bytes at ``phase_offset``) is 1:

        1. the first render pass draws the first phase's lists (blades seen last frame),
           sky and ground, and stores the depth (``depth_format``, copyable);
        2. the depth is copied into ``s_hzb`` as the pyramid's level 0, rows every
           ``pitch`` texels (``bytesPerRow = 4 * pitch``), and ``hzb_levels[k - 1]``
           (``hzb_build.wgsl``, level k) runs once per further level at
           ceil(width / 8) x ceil(height / 8) workgroups of that level;
        3. ``cull`` (the second phase) runs over the blades;
        4. a second render pass (colour and depth loaded) draws ``blades`` /
           ``blades_flat`` (lists from the end, args from ``s_occlusion_args``), then the
           culled blades' draw (colour by cull) and the collider balls.

        The pyramid's layout follows :func:`grasswidget.core.reference.hzb_layout` (the
        engine's ``hzbLayout``, same rule, held to it by tests/core/test_engine_inputs.py):
        ``row_align`` is its HZB_ROW_ALIGN; ``s_hzb_levels`` holds (levels, width, height, 0),
        then (offset, width, height, pitch) per level, ``max_levels`` + 1 entries in all.
        ``flag_words_per_workgroup``: ``s_occlusion_flags`` holds that many u32 per culling
        workgroup, all ones at start (every blade seen). ``args_words``: ``s_occlusion_args``
        holds (vertex_count, instance_count, 0, 0) per class, then (occluded, 0, 0, 0).
        """
        return {
            "phase_offset": int(offsets(CULL_LAYOUT)["occlusion_phase"][0]),
            "depth_format": "depth32float",
            "row_align": int(HZB_ROW_ALIGN),
            "max_levels": int(HZB_MAX_LEVELS),
            "flag_words_per_workgroup": int(WORKGROUP_SIZE) // 32,
            "args_words": 4 * (len(LOD_SEGMENTS) + 1),
            "hzb_levels": [cls.hzb_level(k) for k in range(1, HZB_MAX_LEVELS)],
            "cull": cls.cull_occlusion(follow_camera),
            "blades": cls.blades(flat_colors=False, from_end=True, sunlight=sunlight, follow_camera=follow_camera),
            "blades_flat": cls.blades(flat_colors=True, from_end=True, sunlight=sunlight, follow_camera=follow_camera),
        }

    @staticmethod
    def sky_ground(sunlight: bool = False) -> dict:
        """``shaders/sky_ground.wgsl``: sky gradient and ground to the horizon, as in the kernel engine;
        ``sunlight``: the ground's shadows compiled in (``GrassParams.shadows`` on). The far grass is
        always compiled in (``far_grass``; the kernel's SkyGroundMaterial leaves it out while
        ``far_grass.w`` and ``horizon.w`` are 0: the same picture, the bare plain). One full-screen
        pass (``part`` "all"; the kernel draws the sky's and the ground's pieces of the screen apart)."""
        return render_shader("sky_ground.wgsl", "render", uniforms={"u_material": ("SkyGround", SKY_GROUND_LAYOUT)},
                             resources={"u_material": "u_sky_ground"}, sunlight=bool(sunlight), far_grass=True,
                             part="all")

    @staticmethod
    def balls() -> dict:
        """The translucent collider balls (``balls.wgsl``, the browser's stand-in for pygfx's Phong spheres)."""
        code = (wgsl_struct("StdInfo", STDINFO_LAYOUT) + "\n" + wgsl_struct("BallStyle", BALL_LAYOUT) + "\n"
                + (HERE / "balls.wgsl").read_text(encoding="utf-8"))
        return {"code": code, "bindings": binding_map(code)}

    @staticmethod
    def inspect(wind_wgsl: str = "") -> dict:
        """``shaders/inspect.wgsl``, the blade inspector's compute pass (one workgroup of 64),
        with the same template values as the kernel's ``gpu.inspector.InspectShader``."""
        return render_shader("inspect.wgsl", "compute", user_wind_body=wind_body(wind_wgsl),
                             segment_vertices=SEGMENT_VERTICES, n_forces=len(FORCE_NAMES),
                             arrow_accel_per_height=wgsl_float(ARROW_ACCEL_PER_HEIGHT),
                             collision_arrow_scale=wgsl_float(COLLISION_ARROW_SCALE))

    @staticmethod
    def overlay(primitive: str, size_px: float, colors, positions: str) -> dict:
        """``overlay.wgsl`` for one overlay: "segments" (vertex pairs) or "points", each
        ``size_px`` physical pixels across, vertex k coloured ``colors[k % len(colors)]``
        (sRGB hex), positions read from the engine's buffer ``positions``."""
        from .uniforms import srgb_color

        env = _environment()
        rgba = ", ".join("vec4<f32>({:.6f}, {:.6f}, {:.6f}, 1.0)".format(*srgb_color(c)[:3]) for c in colors)
        body = env.from_string((HERE / "overlay.wgsl").read_text(encoding="utf-8")).render(
            primitive=primitive, size_px=wgsl_float(size_px), period=len(colors), colors=rgba)
        code = wgsl_struct("StdInfo", STDINFO_LAYOUT) + "\n" + body
        bindings = binding_map(code)
        for b in bindings:
            if b["name"] == "s_overlay":
                b["resource"] = positions
        return {"code": code, "bindings": bindings}

    @classmethod
    def overlays(cls) -> list:
        """The overlays drawn after the meadow, each while its condition holds (``only_if``):
        the frozen camera's frustum (12 white segments from ``s_frustum``, depth-tested like
        the kernel's Line), the inspector's polygon and arrows (``s_segments``) and its control
        points (``s_points``), over everything (no depth test, as in the kernel)."""
        return [
            dict(cls.overlay("segments", 2.0, [FROZEN_FRUSTUM_COLOR], "s_frustum"), name="frustum",
                 instances=12, depth_test=True, only_if="frozen"),
            dict(cls.overlay("segments", 3.0, inspector_segment_colors(), "s_segments"), name="inspector lines",
                 instances=MAX_INSPECTED * SEGMENT_VERTICES // 2, depth_test=False, only_if="inspecting"),
            dict(cls.overlay("points", 9.0, [INSPECTOR_COLORS["points"]], "s_points"), name="inspector points",
                 instances=MAX_INSPECTED * 3, depth_test=False, only_if="inspecting"),
        ]

    @classmethod
    def shaders(cls, wind_wgsl: str = "", sunlight: bool = False, follow_camera: bool = False) -> dict:
        """Every shader of a frame for the wind ``wind_wgsl``, the sunlight's switch
        ``sunlight`` (``GrassParams.shadows``: the draws compile its maths in only while on) and
        ``follow_camera`` (a field to the horizon, ``Blades.horizon``: the culling passes move its
        blades around the camera and every pass that draws blades scales their widths by their
        level's weight, levels.wgsl; other fields compile none of it)."""
        return {
            # The compute passes of every frame, in order ("blades": one invocation per blade,
            # "one": one workgroup): reset the draw arguments, count survivors per distance band,
            # turn counts into slots, cull and scatter the lists nearest band first.
            "compute_passes": [
                {"shader": "reset_args", "dispatch": "one", "label": "reset_args.wgsl"},
                # the compute rasterizer's counters and per-pixel words (per view size: "sized"): one
                # thread writes the clear's workgroups for the rows the last frame wrote into
                # s_raster_dispatch at byte RASTER_CLEAR_OFFSET, the clear is dispatched from there
                {"shader": "raster_clear_args", "dispatch": "one", "label": "raster.wgsl (clear_args)",
                 "only_if": "compute_raster", "sized": True},
                {"shader": "raster_clear", "dispatch": "raster_listed", "indirect_offset": RASTER_CLEAR_OFFSET,
                 "label": "raster.wgsl (clear)", "only_if": "compute_raster", "sized": True},
                {"shader": "cull_count", "dispatch": "blades", "label": "cull.wgsl (count)"},
                {"shader": "prefix_bands", "dispatch": "one", "label": "prefix_bands.wgsl"},
                {"shader": "cull", "dispatch": "blades", "label": "cull.wgsl"},
                # the compute rasterizer's walks of the thin blades the culling listed: one thread
                # writes their workgroups into s_raster_dispatch, the walks are dispatched from it
                # ("raster_listed": dispatchWorkgroupsIndirect, a thread per listed blade)
                {"shader": "raster_args", "dispatch": "one", "label": "raster.wgsl (args)",
                 "only_if": "compute_raster", "sized": True},
                {"shader": "raster_depth", "dispatch": "raster_listed", "label": "raster.wgsl (depth)",
                 "only_if": "compute_raster", "sized": True},
                {"shader": "raster_payload", "dispatch": "raster_listed", "label": "raster.wgsl (payload)",
                 "only_if": "compute_raster", "sized": True},
                # the colours of the pixels the walks won: one thread writes the shade's workgroups for
                # the rows written at byte RASTER_SHADE_OFFSET, the shade is dispatched from there
                {"shader": "raster_shade_args", "dispatch": "one", "label": "raster.wgsl (shade_args)",
                 "only_if": "compute_raster", "sized": True},
                {"shader": "raster_shade", "dispatch": "raster_listed", "indirect_offset": RASTER_SHADE_OFFSET,
                 "label": "raster.wgsl (shade)", "only_if": "compute_raster", "sized": True},
                # the blade inspector's forces, polygon and points, while blades are inspected
                # (u_sim for "now": the current parameters and colliders at the time of the next step)
                {"shader": "inspect", "dispatch": "one", "label": "inspect.wgsl", "only_if": "inspecting",
                 "sim_uniform": "now"},
            ],
            "inspect": cls.inspect(wind_wgsl),
            "overlays": cls.overlays(),
            # bytes of the inspector's buffers (engine.js allocates them): vertices of 3 floats, forces vec4
            "inspector_sizes": {"segments": MAX_INSPECTED * SEGMENT_VERTICES * 12, "points": MAX_INSPECTED * 3 * 12,
                                "forces": MAX_INSPECTED * len(FORCE_NAMES) * 16, "frustum": 24 * 12},
            "simulate": cls.simulate(wind_wgsl),
            "reset_args": cls.reset_args(),
            "cull_count": cls.cull("count", follow_camera),
            "prefix_bands": cls.prefix_bands(),
            "cull": cls.cull("scatter", follow_camera),
            "raster_clear_args": cls.raster("clear_args"),
            "raster_clear": cls.raster("clear"),
            "raster_args": cls.raster("args"),
            "raster_depth": cls.raster("depth", follow_camera=follow_camera),
            "raster_payload": cls.raster("payload", follow_camera=follow_camera),
            "raster_shade_args": cls.raster("shade_args"),
            "raster_shade": cls.raster("shade", sunlight=sunlight),
            "compute_raster": cls.compute_raster(sunlight, follow_camera),
            "blades": cls.blades(flat_colors=False, sunlight=sunlight, follow_camera=follow_camera),
            "blades_flat": cls.blades(flat_colors=True, sunlight=sunlight, follow_camera=follow_camera),
            # byte offset of u_cull.color_by: the engine draws "blades_flat" while it is not natural (0)
            "color_by_offset": int(offsets(CULL_LAYOUT)["color_by"][0]),
            "sky_ground": cls.sky_ground(sunlight),
            "balls": cls.balls(),
            "lod_segments": list(LOD_SEGMENTS),
            "bands": DISTANCE_BANDS,
            "occlusion": cls.occlusion(sunlight, follow_camera),
        }

    @classmethod
    def all(cls, wind_wgsl: str = "", sunlight: bool = False, follow_camera: bool = False) -> dict:
        """Every shader of the engine (:meth:`shaders`), with ``max_storage_buffers``: the most
        storage buffers one of them binds (the engine asks its device for that many per
        shader stage; WebGPU's default is 8, occlusion culling's second pass with the
        compute rasterizer binds 10)."""
        out = cls.shaders(wind_wgsl, sunlight, follow_camera)
        out["max_storage_buffers"] = max(_storage_count(sh) for sh in _all_shader_dicts(out))
        return out


def with_function_overrides(tree, overrides):
    """A copy of a shader tree (:meth:`BrowserShaders.all`, or one shader dict) in which every
    shader that defines the replaced blade-math functions runs the user's instead
    (:meth:`~grasswidget.core.wgsl_overrides.FunctionOverrides.apply`: the simulation, the
    culling passes, the inspector); None gives the tree unchanged. Bindings stay as they were
    (the user's functions bind nothing)."""
    if overrides is None:
        return tree
    if isinstance(tree, dict):
        out = {k: with_function_overrides(v, overrides) for k, v in tree.items()}
        if isinstance(tree.get("code"), str):
            out["code"] = overrides.apply(tree["code"])
        return out
    if isinstance(tree, list):
        return [with_function_overrides(v, overrides) for v in tree]
    return tree


def _all_shader_dicts(tree):
    """Every rendered shader ({"code", "bindings"}) in a nested dict / list."""
    if isinstance(tree, dict):
        if "code" in tree and "bindings" in tree:
            yield tree
        else:
            for value in tree.values():
                yield from _all_shader_dicts(value)
    elif isinstance(tree, list):
        for value in tree:
            yield from _all_shader_dicts(value)


def _storage_count(shader) -> int:
    return sum(1 for b in shader["bindings"] if b["kind"] != "uniform")
