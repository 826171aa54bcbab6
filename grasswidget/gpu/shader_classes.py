"""pygfx shader classes of the grass field, registered for (GrassField, GrassMaterial).

The Python classes that fill the WGSL templates of ``grasswidget/shaders/`` (the
folder of ``.wgsl`` files) for pygfx. As in pygfx, the shaders import the objects
they draw, never the other way round: importing this module registers
:func:`grass_render_function` with pygfx's ``register_wgpu_render_function``
decorator, and the occlusion culling's second-phase classes with
:func:`grasswidget.gpu.occlusion.register_second_phase_shaders`. The package
``grasswidget.gpu`` imports it, so any use of the GPU layer has them registered.
It composes the passes pygfx runs in every ``renderer.render()``:

1. ``ResetArgsShader`` (compute): zero the per-LOD-class instance counts and
   the distance-band counters.
2. ``CullShader("count")`` (compute): cull, bin into LOD classes and distance
   bands, count survivors per (class, band).
3. ``PrefixBandsShader`` (compute): each band's first slot, instance counts.
4. ``CullShader("scatter")`` (compute): the same tests again; survivors written
   to their class's list, nearest band first whatever the switches (front-to-back draws:
   the depth test rejects hidden fragments before they are written).
5. ``BladeRenderShader`` x LOD classes (render): one indirect draw per class,
   then one more for the culled blades (instances only with ``color_by = "cull"``).

The compute rasterizer (``params.compute_raster``, set up for the render size by
``GrassField.prepare_compute_raster``): ``RasterShader("clear_args")`` and
``RasterShader("clear")`` (indirect: the rows the last frame wrote) run before step 2,
the culling lists thin blades for it, ``RasterShader("args")`` sizes the walks and
``RasterShader("packed")`` (one walk, 64-bit atomics: ``GrassField.raster_packed``) or
``RasterShader("depth")`` and ``RasterShader("payload")`` walk them after step 4
(dispatched indirectly: a thread per listed blade), and ``RasterResolveShader``
(render, after the ribbons) writes their colour and depth.

Occlusion culling (``params.cull_occlusion``, with :func:`grasswidget.gpu.frame.render_frame`)
arms steps 2-4 as its first phase (only blades seen last frame), then runs the
pyramid (``HzbLevelShader``) and the second phase (``CullShader("scatter", occlusion=2)``,
one pass without distance bands)
outside render(), and draws with ``occlusion_render_function`` (the field's
:class:`~grasswidget.gpu.occlusion.OcclusionDraws` child: prepared by pygfx in the first
render, where their draws are deferred, and replayed in the second phase's submission).

The simulation's shader (``SimulateShader``) lives in :mod:`.simulation`: it is
dispatched by ``GrassField.step()``, never by ``render()``.
"""

from __future__ import annotations

import weakref

from pygfx.renderers.wgpu import BaseShader, Binding, register_wgpu_render_function

from ..core.reference import CULLED_SEGMENTS, LOD_SEGMENTS
from ..errors import GrassValueError
from ..core.shader_files import raster_shade_vars, read_shader, ribbon_vars
from ..core.uniform_layouts import CULL_LAYOUT
from ..core.shader_files import BAND_RANGE, DISTANCE_BANDS, RASTER_CLEAR_OFFSET, RASTER_SHADE_OFFSET
from .field import GrassField
from .material import GrassMaterial
from .occlusion import OcclusionDraws, register_second_phase_shaders
from .raster_walks import SHADE_STEPS, raster_walk_steps
from .wgsl_templates import (WORKGROUP_SIZE, GrassComputeShader, follows_camera, shader_vars, storage_struct_code,
                             workgroups)

__all__ = ["ResetArgsShader", "CullShader", "RasterShader", "RasterResolveShader", "PrefixBandsShader", "BladeRenderShader", "HzbLevelShader",
           "grass_render_function", "occlusion_render_function",
           "workgroups", "CULLED_SEGMENTS", "DISTANCE_BANDS", "BAND_RANGE", "U_CULL_SLOT",
           "U_CULL_CODE", "cull_binding"]

#: Binding slot of ``u_cull`` in the culling and ribbon shaders. It is a read-only
#: storage buffer, not a uniform: the shaders branch on its switches, and lavapipe
#: leaks a recompiled shader per pass for branches on uniforms (see gpu/wgsl_templates.py).
U_CULL_SLOT = 2
#: Its WGSL declaration (struct ``CullParams`` of ``uniform_layouts.CULL_LAYOUT``).
U_CULL_CODE = storage_struct_code(0, U_CULL_SLOT, "u_cull", "CullParams", CULL_LAYOUT)


def _defer(draws_ref, container, renderstate) -> bool:
    draws = draws_ref() if draws_ref is not None else None
    return draws is not None and draws.defer(container, renderstate)


def cull_binding(wobject, visibility):
    """The ``u_cull`` binding: GrassField.cull_uniform_buffer as read-only storage
    (declared by :data:`U_CULL_CODE`, not by pygfx)."""
    return Binding("u_cull", "buffer/read_only_storage", wobject.cull_uniform_buffer, visibility)


class ResetArgsShader(GrassComputeShader):
    """Reset the indirect draw arguments at the start of each frame (the LOD classes',
    the culled blades' and the second occlusion phase's)."""

    def __init__(self, wobject):
        super().__init__(wobject, teaching_views=True, bands=DISTANCE_BANDS, occlusion=1)

    def get_bindings(self, wobject, shared, scene):
        return {0: {
            0: Binding("s_args", "buffer/storage", wobject.args_buffer, "COMPUTE"),
            1: Binding("s_culled_args", "buffer/storage", wobject.culled_args_buffer, "COMPUTE"),
            2: Binding("s_bands", "buffer/storage", wobject.band_buffer, "COMPUTE"),
            3: Binding("s_occlusion_args", "buffer/storage", wobject.occlusion_args_buffer, "COMPUTE"),
        }}

    def get_code(self):
        return read_shader("reset_args.wgsl")

    def get_render_info(self, wobject, shared):
        return {"indices": (1, 1, 1)}


class PrefixBandsShader(GrassComputeShader):
    """Between the culling passes: each distance band's first slot, the instance counts."""

    def __init__(self, wobject):
        super().__init__(wobject, bands=DISTANCE_BANDS)

    def get_bindings(self, wobject, shared, scene):
        return {0: {
            0: Binding("s_args", "buffer/storage", wobject.args_buffer, "COMPUTE"),
            1: Binding("s_bands", "buffer/storage", wobject.band_buffer, "COMPUTE"),
        }}

    def get_code(self):
        return read_shader("prefix_bands.wgsl")

    def get_render_info(self, wobject, shared):
        return {"indices": (1, 1, 1)}


class CullShader(GrassComputeShader):
    """Per-frame culling + LOD binning into compacted lists (feeds draw_indirect).

    The pygfx bindings are generated here (``s_args`` and ``s_culled_args`` by
    hand: pygfx does not declare atomics); ``cull.wgsl`` is the engine-neutral body,
    rendered with ``teaching_views`` (frozen culling camera, colour by cull test).
    """

    def __init__(self, wobject, phase="scatter", occlusion=1):
        if phase not in ("count", "scatter"):
            raise GrassValueError(f"phase must be 'count' or 'scatter'; got {phase!r}")
        if occlusion not in (1, 2):
            raise GrassValueError(f"occlusion must be 1 (first phase) or 2 (second phase); got {occlusion!r}")
        # The second occlusion phase runs once, without distance bands: it lists the few
        # blades that became visible (the occlusion test is its cost, not the draw order).
        bands = DISTANCE_BANDS if occlusion == 1 else 0
        super().__init__(wobject, teaching_views=True, bands=bands, phase=phase, occlusion=occlusion,
                         compute_raster=True, band_near=f"{BAND_RANGE[0]:.3f}", band_far=f"{BAND_RANGE[1]:.3f}")

    def get_bindings(self, wobject, shared, scene):
        second = self["occlusion"] == 2
        bindings = {
            0: Binding("u_stdinfo", "buffer/uniform", shared.uniform_buffer, "COMPUTE"),
            1: Binding("u_wobject", "buffer/uniform", wobject.uniform_buffer, "COMPUTE"),
            U_CULL_SLOT: cull_binding(wobject, "COMPUTE"),
            # read_write for a field to the horizon: the pass moves its blades around the camera first
            10: Binding("s_blades", "buffer/storage" if self["follow_camera"] else "buffer/read_only_storage",
                        wobject.blade_buffer, "COMPUTE"),
            11: Binding("s_args", "buffer/storage", wobject.occlusion_args_buffer if second else wobject.args_buffer,
                        "COMPUTE"),
            12: Binding("s_visible", "buffer/storage", wobject.visible_buffer, "COMPUTE"),
            13: Binding("s_culled", "buffer/storage", wobject.culled_buffer, "COMPUTE"),
            14: Binding("s_culled_args", "buffer/storage", wobject.culled_args_buffer, "COMPUTE"),
            15: Binding("s_bands", "buffer/storage", wobject.band_buffer, "COMPUTE"),
            16: Binding("s_occlusion_flags", "buffer/storage" if second else "buffer/read_only_storage",
                        wobject.occlusion_flags_buffer, "COMPUTE"),
            19: Binding("s_raster", "buffer/storage", wobject.raster_list_buffer, "COMPUTE"),
            20: Binding("s_raster_args", "buffer/storage", wobject.raster_args_buffer, "COMPUTE"),
        }
        if second:
            occlusion = wobject.occlusion
            bindings[17] = Binding("s_hzb", "buffer/read_only_storage", occlusion.hzb_buffer, "COMPUTE")
            bindings[18] = Binding("s_hzb_levels", "buffer/read_only_storage", occlusion.levels_buffer, "COMPUTE")
        for slot in (0, 1, 10, 12, 13, 16, 17, 18, 19):
            if slot in bindings:
                self.define_binding(0, slot, bindings[slot])
        return {0: bindings}

    def get_code(self):
        return (
            "{{ bindings_code }}\n"
            + U_CULL_CODE +
            "@group(0) @binding(11) var<storage, read_write> s_args: array<atomic<u32>>;\n"
            "@group(0) @binding(14) var<storage, read_write> s_culled_args: array<atomic<u32>>;\n"
            "@group(0) @binding(15) var<storage, read_write> s_bands: array<atomic<u32>>;\n"
            "@group(0) @binding(20) var<storage, read_write> s_raster_args: array<atomic<u32>>;\n"
            "{$ include 'grasswidget.cull.wgsl' $}\n"
        )

    def get_render_info(self, wobject, shared):
        return {"indices": workgroups(wobject.count)}


class BladeRenderShader(BaseShader):
    """Ribbons of one LOD class, drawn with ``draw_indirect`` from the class's args.

    ``lod_class = len(LOD_SEGMENTS)`` is the draw of the culled blades
    (``color_by = "cull"``): CULLED_SEGMENTS segments, flat in CULL_COLORS.
    ``wobject`` is the GrassField, or its :class:`~grasswidget.gpu.occlusion.OcclusionDraws`
    (the second occlusion phase: lists read from the end, its own args).
    """

    type = "render"

    def __init__(self, wobject, lod_class):
        culled = lod_class == len(LOD_SEGMENTS)
        field = wobject.field if isinstance(wobject, OcclusionDraws) else wobject
        second = field is not wobject
        # The flat teaching colours only while they are shown (GrassField.flat_colors is
        # tracked by pygfx: a change rebuilds these pipelines).
        # The sunlight's maths only while shadows are on (GrassMaterial.sunlight, tracked the same way).
        super().__init__(wobject, **shader_vars(**ribbon_vars(lod_class), teaching_views=field.flat_colors,
                                                sunlight=wobject.material.sunlight, from_end=second and not culled,
                                                follow_camera=follows_camera(field)))
        if culled:
            self.indirect_args = field.culled_args_buffer
        else:
            self.indirect_args = field.occlusion_args_buffer if second else field.args_buffer
        self.indirect_offset = 0 if culled else 16 * lod_class
        self._field = weakref.ref(field)
        self._draws = weakref.ref(wobject) if second else None
        self._when = ("before",) if lod_class == 0 and not second else ()
        self._when += ("after",) if culled else ()

    def defer_draw(self, container, renderstate) -> bool:
        """The second phase's draws are deferred during the first phase's render (OcclusionDraws.defer)."""
        return _defer(self._draws, container, renderstate)

    def draw_bundle(self):
        """The :class:`~grasswidget.gpu.draw_bundles.DrawBundle` this draw goes through (its object's)."""
        owner = self._draws() if self._draws is not None else self._field()
        return getattr(owner, "blade_draw_bundle", None)

    def draw_hook(self, render_pass, when):
        """GPU timestamps around the field's draws (first class: begin, last: end)."""
        field = self._field()
        stats = getattr(field, "stats", None)
        if stats is not None and when in self._when:
            stats.draw_timestamp(render_pass, when)

    def get_bindings(self, wobject, shared, scene):
        rbuffer = "buffer/read_only_storage"
        field = self._field()
        bindings = {
            0: Binding("u_stdinfo", "buffer/uniform", shared.uniform_buffer),
            1: Binding("u_wobject", "buffer/uniform", wobject.uniform_buffer),
            U_CULL_SLOT: cull_binding(field, "VERTEX"),  # declared in get_code
            3: Binding("u_material", "buffer/uniform", wobject.material.uniform_buffer),
            4: Binding("s_blades", rbuffer, field.blade_buffer, "VERTEX"),
            5: Binding("s_visible", rbuffer, field.visible_buffer, "VERTEX"),
        }
        if self["culled"]:
            bindings[6] = Binding("s_culled", rbuffer, field.culled_buffer, "VERTEX")
        self.define_bindings(0, {slot: b for slot, b in bindings.items() if slot != U_CULL_SLOT})
        return {0: bindings}

    def get_pipeline_info(self, wobject, shared):
        return {"primitive_topology": "triangle-strip", "cull_mode": "none"}

    def get_render_info(self, wobject, shared):
        # Ignored when drawing indirectly; kept valid for pygfx's checks.
        return {"indices": (2 * (self["segments"] + 1), 0)}

    def get_code(self):
        return U_CULL_CODE + read_shader("blade_render.wgsl")


class RasterShader(GrassComputeShader):
    """The compute rasterizer of thin blades (raster.wgsl): ``step`` "clear_args" (one thread
    before the culling: the counters to zero, the clear's workgroups for the rows the last
    frame wrote into ``GrassField.raster_dispatch_buffer`` at word 4), "clear" (those rows'
    per-pixel words, dispatched indirectly from there), "args" (one thread after the culling:
    the walks' workgroups into words 0..2, the rows written to none), "packed" (the one walk
    with 64-bit atomics, ``wobject.raster_packed``) or "depth" and "payload" (the two walks),
    dispatched indirectly from those workgroups, then "shade_args" (one thread: the shade's
    workgroups for the rows the walks wrote into words 8..10) and "shade" (a thread per pixel of
    those rows, dispatched indirectly from there: the winning blade's colour into
    ``GrassField.raster_color_buffer``, the ribbons' shading, so that the resolve's fragments only
    copy it); ``second``: the steps of occlusion culling's second phase (run by
    :class:`~grasswidget.gpu.occlusion.OcclusionCulling`, never by render()). The shade compiles
    the material's sunlight switch in, and no user function overrides (it shades, it does not
    simulate or cull)."""

    def __init__(self, wobject, step, second=False):
        walks = raster_walk_steps(wobject)
        if step not in ("clear_args", "clear", "args", *walks, *SHADE_STEPS):
            raise GrassValueError(f"step must be 'clear_args', 'clear', 'args', {', '.join(map(repr, walks))} "
                                  f"(this field's walks, GrassField.raster_packed), 'shade_args' or 'shade'; "
                                  f"got {step!r}")
        shade = {}
        if step == "shade":
            shade = dict(raster_shade_vars(), sunlight=bool(wobject.material.sunlight),
                         teaching_views=bool(wobject.flat_colors))
        super().__init__(wobject, step=step, second=bool(second), raster_packed=bool(wobject.raster_packed), **shade)
        if step == "shade":
            self.function_overrides = None  # the shading is the ribbons', whatever a user replaced
        if step in walks or step in ("clear", "shade"):  # gpu/indirect.py: dispatch_workgroups_indirect
            self.indirect_args = wobject.raster_dispatch_buffer
            # bytes: the clear's words, the shade's, or the walks' at 0
            self.indirect_offset = {"clear": RASTER_CLEAR_OFFSET, "shade": RASTER_SHADE_OFFSET}.get(step, 0)
        self._field = weakref.ref(wobject)

    def skip_dispatch(self) -> bool:
        """Nothing to do while the field's compute rasterizer is off (``GrassField.compute_raster_active``):
        no blade is listed for it, and switching it on again zeroes its counters (every row is cleared
        at the next frame). The second phase's steps are dispatched by the occlusion culling only while on."""
        field = self._field()
        return field is not None and not field.compute_raster_active

    def get_bindings(self, wobject, shared, scene):
        bindings = {
            0: Binding("u_stdinfo", "buffer/uniform", shared.uniform_buffer, "COMPUTE"),
            1: Binding("u_wobject", "buffer/uniform", wobject.uniform_buffer, "COMPUTE"),
            U_CULL_SLOT: cull_binding(wobject, "COMPUTE"),
            10: Binding("s_blades", "buffer/read_only_storage", wobject.blade_buffer, "COMPUTE"),
            11: Binding("s_raster", "buffer/read_only_storage", wobject.raster_list_buffer, "COMPUTE"),
            12: Binding("s_raster_args", "buffer/storage", wobject.raster_args_buffer, "COMPUTE"),
            13: Binding("s_raster_depth", "buffer/storage", wobject.raster_depth_buffer, "COMPUTE"),
            14: Binding("s_raster_payload", "buffer/storage", wobject.raster_payload_buffer, "COMPUTE"),
        }
        if self["step"] in ("args", "clear_args", "shade_args"):  # only there: the others read it as indirect arguments
            bindings[15] = Binding("s_raster_dispatch", "buffer/storage", wobject.raster_dispatch_buffer, "COMPUTE")
        declared = [0, 1, 10, 11]
        if self["step"] == "shade":
            bindings[3] = Binding("u_material", "buffer/uniform", wobject.material.uniform_buffer, "COMPUTE")
            bindings[16] = Binding("s_raster_color", "buffer/storage", wobject.raster_color_buffer, "COMPUTE")
            declared.append(3)
        for slot in declared:
            self.define_binding(0, slot, bindings[slot])
        return {0: bindings}

    def get_code(self):
        word = "u64" if self["step"] == "packed" else "u32"  # the one walk's pixels: a u64 each
        return (
            "{{ bindings_code }}\n"
            + U_CULL_CODE +
            "@group(0) @binding(12) var<storage, read_write> s_raster_args: array<atomic<u32>>;\n"
            f"@group(0) @binding(13) var<storage, read_write> s_raster_depth: array<atomic<{word}>>;\n"
            "@group(0) @binding(14) var<storage, read_write> s_raster_payload: array<atomic<u32>>;\n"
            + ("@group(0) @binding(15) var<storage, read_write> s_raster_dispatch: array<u32>;\n"
               if self["step"] in ("args", "clear_args", "shade_args") else "")
            + ("@group(0) @binding(16) var<storage, read_write> s_raster_color: array<u32>;\n"
               if self["step"] == "shade" else "")
            + "{$ include 'grasswidget.raster.wgsl' $}\n"
        )

    def get_render_info(self, wobject, shared):
        return {"indices": (1, 1, 1)}  # clear_args, args, shade_args: one thread; the others: indirect


class RasterResolveShader(BaseShader):
    """The compute rasterizer's resolve (raster_resolve.wgsl): one draw across the rows the
    walks wrote that writes the compute-rasterized pixels' colours (shaded by RasterShader's step
    "shade") and depths; no instance while the compute rasterizer is off. ``wobject``: the
    GrassField or its OcclusionDraws."""

    type = "render"

    def __init__(self, wobject):
        field = wobject.field if isinstance(wobject, OcclusionDraws) else wobject
        super().__init__(wobject, **shader_vars(raster_packed=bool(field.raster_packed)))
        self._field = weakref.ref(field)
        self._draws = weakref.ref(wobject) if field is not wobject else None

    def defer_draw(self, container, renderstate) -> bool:
        """The second phase's resolve is deferred during the first phase's render (OcclusionDraws.defer)."""
        return _defer(self._draws, container, renderstate)

    def get_bindings(self, wobject, shared, scene):
        rbuffer = "buffer/read_only_storage"
        field = self._field()
        bindings = {
            0: Binding("u_stdinfo", "buffer/uniform", shared.uniform_buffer),
            1: Binding("u_wobject", "buffer/uniform", wobject.uniform_buffer),
            U_CULL_SLOT: cull_binding(field, "FRAGMENT"),
            3: Binding("u_material", "buffer/uniform", wobject.material.uniform_buffer),
            4: Binding("s_raster_color", rbuffer, field.raster_color_buffer, "FRAGMENT"),
            5: Binding("s_raster_depth", rbuffer, field.raster_depth_buffer, "FRAGMENT"),
            6: Binding("s_raster_payload", rbuffer, field.raster_payload_buffer, "FRAGMENT"),
            7: Binding("s_raster_args", rbuffer, field.raster_args_buffer, "VERTEX"),  # the rows written
        }
        self.define_bindings(0, {slot: b for slot, b in bindings.items() if slot != U_CULL_SLOT})
        return {0: bindings}

    def get_pipeline_info(self, wobject, shared):
        return {"primitive_topology": "triangle-strip", "cull_mode": "none"}

    def get_render_info(self, wobject, shared):
        return {"indices": (4, 1 if self._field().compute_raster_active else 0)}

    def get_code(self):
        return U_CULL_CODE + read_shader("raster_resolve.wgsl")


class HzbLevelShader(GrassComputeShader):
    """One level (1 ..) of the occlusion culling's max-depth pyramid (hzb_build.wgsl), or with
    ``last_level`` > ``level`` the levels ``level`` .. ``last_level`` in one workgroup (dispatched
    as (1, 1, 1)); run by :class:`~grasswidget.gpu.occlusion.OcclusionCulling`, never by render()."""

    def __init__(self, wobject, level, last_level=None):
        last = int(level) if last_level is None else int(last_level)
        super().__init__(wobject, level=int(level), last_level=last)

    def get_bindings(self, wobject, shared, scene):
        occlusion = wobject.occlusion
        bindings = {
            0: Binding("s_hzb", "buffer/storage", occlusion.hzb_buffer, "COMPUTE"),
            1: Binding("s_hzb_levels", "buffer/read_only_storage", occlusion.levels_buffer, "COMPUTE"),
        }
        self.define_bindings(0, bindings)
        return {0: bindings}

    def get_code(self):
        return "{{ bindings_code }}\n{$ include 'grasswidget.hzb_build.wgsl' $}\n"

    def get_render_info(self, wobject, shared):
        return {"indices": (1, 1, 1)}  # dispatched by OcclusionCulling at each level's size


@register_wgpu_render_function(OcclusionDraws, GrassMaterial)
def occlusion_render_function(wobject):
    """The second occlusion phase's draws (one per LOD class, lists from the end), then
    the culled blades (``color_by = "cull"``: every test's, occlusion included)."""
    return [*(BladeRenderShader(wobject, k) for k in range(len(LOD_SEGMENTS) + 1)), RasterResolveShader(wobject)]


@register_wgpu_render_function(GrassField, GrassMaterial)
def grass_render_function(wobject):
    """The passes of one GrassField: reset, cull (count, prefix, scatter), then one
    draw per LOD class and one of the culled blades (empty unless ``color_by = "cull"``)."""
    return [
        ResetArgsShader(wobject),
        RasterShader(wobject, "clear_args"),
        RasterShader(wobject, "clear"),
        CullShader(wobject, "count"),
        PrefixBandsShader(wobject),
        CullShader(wobject, "scatter"),
        RasterShader(wobject, "args"),
        *(RasterShader(wobject, step) for step in (*raster_walk_steps(wobject), *SHADE_STEPS)),
        *(BladeRenderShader(wobject, k) for k in range(len(LOD_SEGMENTS) + 1)),
        RasterResolveShader(wobject),
    ]


register_second_phase_shaders(cull=CullShader, hzb_level=HzbLevelShader, raster=RasterShader)
