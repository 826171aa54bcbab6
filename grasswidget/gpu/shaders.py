"""pygfx shader classes of the grass field, registered for (GrassField, GrassMaterial).

Importing this module registers :func:`grass_render_function` with pygfx's
``register_wgpu_render_function`` decorator (``grasswidget.gpu`` imports it, so
any use of the GPU layer has it registered). It composes the passes pygfx runs in
every ``renderer.render()``:

1. ``ResetArgsShader`` (compute): zero the per-LOD-class instance counts and
   the distance-band counters.
2. ``CullShader("count")`` (compute): cull, bin into LOD classes and distance
   bands, count survivors per (class, band).
3. ``PrefixBandsShader`` (compute): each band's first slot, instance counts.
4. ``CullShader("scatter")`` (compute): the same tests again; survivors written
   to their class's list, with LOD on nearest band first (front-to-back draws:
   the depth test rejects hidden fragments before they are written).
5. ``BladeRenderShader`` x LOD classes (render): one indirect draw per class,
   then one more for the culled blades (instances only with ``color_by = "cull"``).

The simulation's shader (``SimulateShader``) lives in :mod:`.simulation`: it is
dispatched by ``GrassField.step()``, never by ``render()``.
"""

from __future__ import annotations

import weakref

from pygfx.renderers.wgpu import BaseShader, Binding, register_wgpu_render_function

from ..core.reference import CULLED_SEGMENTS, LOD_SEGMENTS
from ..errors import GrassValueError
from ..core.shader_files import read_shader, ribbon_vars
from ..core.uniform_layouts import CULL_LAYOUT
from .field import BAND_RANGE, DISTANCE_BANDS, GrassField
from .material import GrassMaterial
from .wgsl import WORKGROUP, GrassComputeShader, shader_vars, storage_struct_code, workgroups

__all__ = ["ResetArgsShader", "CullShader", "PrefixBandsShader", "BladeRenderShader", "grass_render_function",
           "workgroups", "WORKGROUP", "CULLED_SEGMENTS", "DISTANCE_BANDS", "BAND_RANGE", "U_CULL_SLOT",
           "U_CULL_CODE", "cull_binding"]

#: Binding slot of ``u_cull`` in the culling and ribbon shaders. It is a read-only
#: storage buffer, not a uniform: the shaders branch on its switches, and lavapipe
#: leaks a recompiled shader per pass for branches on uniforms (see gpu/wgsl.py).
U_CULL_SLOT = 2
#: Its WGSL declaration (struct ``CullParams`` of ``uniform_layouts.CULL_LAYOUT``).
U_CULL_CODE = storage_struct_code(0, U_CULL_SLOT, "u_cull", "CullParams", CULL_LAYOUT)


def cull_binding(wobject, visibility):
    """The ``u_cull`` binding: GrassField.cull_uniform_buffer as read-only storage
    (declared by :data:`U_CULL_CODE`, not by pygfx)."""
    return Binding("u_cull", "buffer/read_only_storage", wobject.cull_uniform_buffer, visibility)


class ResetArgsShader(GrassComputeShader):
    """Reset the indirect draw arguments at the start of each frame (the LOD classes'
    and the culled blades')."""

    def __init__(self, wobject):
        super().__init__(wobject, teaching_views=True, bands=DISTANCE_BANDS)

    def get_bindings(self, wobject, shared, scene):
        return {0: {
            0: Binding("s_args", "buffer/storage", wobject.args_buffer, "COMPUTE"),
            1: Binding("s_culled_args", "buffer/storage", wobject.culled_args_buffer, "COMPUTE"),
            2: Binding("s_bands", "buffer/storage", wobject.band_buffer, "COMPUTE"),
        }}

    def get_code(self):
        return read_shader("reset_args.wgsl")

    def get_render_info(self, wobject, shared):
        return {"indices": (1, 1, 1)}


class PrefixBandsShader(GrassComputeShader):
    """Between the culling phases: each distance band's first slot, the instance counts."""

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

    def __init__(self, wobject, phase="scatter"):
        if phase not in ("count", "scatter"):
            raise GrassValueError(f"phase must be 'count' or 'scatter'; got {phase!r}")
        super().__init__(wobject, teaching_views=True, bands=DISTANCE_BANDS, phase=phase,
                         band_near=f"{BAND_RANGE[0]:.3f}", band_far=f"{BAND_RANGE[1]:.3f}")

    def get_bindings(self, wobject, shared, scene):
        bindings = {
            0: Binding("u_stdinfo", "buffer/uniform", shared.uniform_buffer, "COMPUTE"),
            1: Binding("u_wobject", "buffer/uniform", wobject.uniform_buffer, "COMPUTE"),
            U_CULL_SLOT: cull_binding(wobject, "COMPUTE"),
            10: Binding("s_blades", "buffer/read_only_storage", wobject.blade_buffer, "COMPUTE"),
            11: Binding("s_args", "buffer/storage", wobject.args_buffer, "COMPUTE"),
            12: Binding("s_visible", "buffer/storage", wobject.visible_buffer, "COMPUTE"),
            13: Binding("s_culled", "buffer/storage", wobject.culled_buffer, "COMPUTE"),
            14: Binding("s_culled_args", "buffer/storage", wobject.culled_args_buffer, "COMPUTE"),
            15: Binding("s_bands", "buffer/storage", wobject.band_buffer, "COMPUTE"),
        }
        for slot in (0, 1, 10, 12, 13):
            self.define_binding(0, slot, bindings[slot])
        return {0: bindings}

    def get_code(self):
        return (
            "{{ bindings_code }}\n"
            + U_CULL_CODE +
            "@group(0) @binding(11) var<storage, read_write> s_args: array<atomic<u32>>;\n"
            "@group(0) @binding(14) var<storage, read_write> s_culled_args: array<atomic<u32>>;\n"
            "@group(0) @binding(15) var<storage, read_write> s_bands: array<atomic<u32>>;\n"
            "{$ include 'grasswidget.cull.wgsl' $}\n"
        )

    def get_render_info(self, wobject, shared):
        return {"indices": workgroups(wobject.count)}


class BladeRenderShader(BaseShader):
    """Ribbons of one LOD class, drawn with ``draw_indirect`` from the class's args.

    ``lod_class = len(LOD_SEGMENTS)`` is the draw of the culled blades
    (``color_by = "cull"``): CULLED_SEGMENTS segments, flat in CULL_COLORS.
    """

    type = "render"

    def __init__(self, wobject, lod_class):
        culled = lod_class == len(LOD_SEGMENTS)
        # The flat teaching colours only while they are shown (GrassField.flat_colors is
        # tracked by pygfx: a change rebuilds these pipelines).
        super().__init__(wobject, **shader_vars(**ribbon_vars(lod_class), teaching_views=wobject.flat_colors))
        self.indirect_args = wobject.culled_args_buffer if culled else wobject.args_buffer
        self.indirect_offset = 0 if culled else 16 * lod_class
        self._field = weakref.ref(wobject)
        self._when = ("before",) if lod_class == 0 else ()
        self._when += ("after",) if culled else ()

    def draw_hook(self, render_pass, when):
        """GPU timestamps around the field's draws (first class: begin, last: end)."""
        field = self._field()
        stats = getattr(field, "stats", None)
        if stats is not None and when in self._when:
            stats.draw_timestamp(render_pass, when)

    def get_bindings(self, wobject, shared, scene):
        rbuffer = "buffer/read_only_storage"
        bindings = {
            0: Binding("u_stdinfo", "buffer/uniform", shared.uniform_buffer),
            1: Binding("u_wobject", "buffer/uniform", wobject.uniform_buffer),
            U_CULL_SLOT: cull_binding(wobject, "VERTEX"),  # declared in get_code
            3: Binding("u_material", "buffer/uniform", wobject.material.uniform_buffer),
            4: Binding("s_blades", rbuffer, wobject.blade_buffer, "VERTEX"),
            5: Binding("s_visible", rbuffer, wobject.visible_buffer, "VERTEX"),
        }
        if self["culled"]:
            bindings[6] = Binding("s_culled", rbuffer, wobject.culled_buffer, "VERTEX")
        self.define_bindings(0, {slot: b for slot, b in bindings.items() if slot != U_CULL_SLOT})
        return {0: bindings}

    def get_pipeline_info(self, wobject, shared):
        return {"primitive_topology": "triangle-strip", "cull_mode": "none"}

    def get_render_info(self, wobject, shared):
        # Ignored when drawing indirectly; kept valid for pygfx's checks.
        return {"indices": (2 * (self["segments"] + 1), 0)}

    def get_code(self):
        return U_CULL_CODE + read_shader("blade_render.wgsl")


@register_wgpu_render_function(GrassField, GrassMaterial)
def grass_render_function(wobject):
    """The passes of one GrassField: reset, cull (count, prefix, scatter), then one
    draw per LOD class and one of the culled blades (empty unless ``color_by = "cull"``)."""
    return [
        ResetArgsShader(wobject),
        CullShader(wobject, "count"),
        PrefixBandsShader(wobject),
        CullShader(wobject, "scatter"),
        *(BladeRenderShader(wobject, k) for k in range(len(LOD_SEGMENTS) + 1)),
    ]
