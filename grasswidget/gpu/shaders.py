"""pygfx shader classes for the grass field, and the registered render function.

One registered function per object kind (GrassField + GrassMaterial) composes the
passes pygfx runs in every ``renderer.render()``:

1. ``ResetArgsShader`` (compute): zero the per-LOD-class instance counts and
   the distance-band counters.
2. ``CullShader("count")`` (compute): cull, bin into LOD classes and distance
   bands, count survivors per (class, band).
3. ``PrefixBandsShader`` (compute): each band's first slot, instance counts.
4. ``CullShader("scatter")`` (compute): the same tests again, survivors written
   to their class's list, with LOD on nearest band first (front-to-back draws:
   the depth test rejects hidden fragments before they are written).
5. ``BladeRenderShader`` x LOD classes (render): one indirect draw per class.

``SimulateShader`` is a compute shader of the same kind, but it is dispatched by
``GrassField.step()`` (never by ``render()``), so time only advances in fixed steps.
"""

from __future__ import annotations

import weakref

import jinja2
from pygfx.renderers.wgpu import BaseShader, Binding, register_wgsl_loader, register_wgpu_render_function

from ..reference import LOD_MIN_PIXELS, LOD_SEGMENTS
from ..shader_files import read_shader, shader_dir

__all__ = ["SimulateShader", "ResetArgsShader", "CullShader", "PrefixBandsShader", "BladeRenderShader", "register",
           "DISTANCE_BANDS"]

WORKGROUP = 256
#: Distance bands per LOD class (draw order, nearest first), log-spaced over BAND_RANGE metres.
DISTANCE_BANDS = 64
BAND_RANGE = (0.5, 512.0)
_registered = {"loader": False, "render": False}


def register_loader():
    """Make ``{$ include 'grasswidget.<file>' $}`` resolve to our shaders/ folder."""
    if not _registered["loader"]:
        register_wgsl_loader("grasswidget", jinja2.FileSystemLoader(str(shader_dir())))
        _registered["loader"] = True


def workgroups(n_items, limit=65535):
    """Dispatch size for ``n_items`` threads in groups of 256, folded into y past ``limit``."""
    groups = max(1, -(-int(n_items) // WORKGROUP))
    x = min(groups, limit)
    y = -(-groups // x)
    return x, y, 1


class _GrassCompute(BaseShader):
    type = "compute"

    def __init__(self, wobject, **kwargs):
        # BaseShader reads clipping/alpha settings of the material; not used here.
        super().__init__(wobject, **kwargs)

    def get_pipeline_info(self, wobject, shared):
        return {}


class SimulateShader(_GrassCompute):
    """Forces, state validation and collisions, ``u_sim.steps`` fixed steps per dispatch.

    ``user_wind_body`` is the body of ``fn user_wind(p, t) -> vec3<f32>`` (the
    "custom" wind field, ``params.wind_wgsl``); empty means no wind.
    """

    def __init__(self, wobject, user_wind_body=""):
        body = user_wind_body if user_wind_body.strip() else "    return vec3<f32>(0.0);"
        super().__init__(wobject, user_wind_body=body)

    def get_bindings(self, wobject, shared, scene):
        bindings = {
            0: Binding("u_sim", "buffer/uniform", wobject._sim_uniform, "COMPUTE"),
            1: Binding("s_blades", "buffer/storage", wobject.blade_buffer, "COMPUTE"),
            2: Binding("s_collision", "buffer/storage", wobject.collision_buffer, "COMPUTE"),
        }
        self.define_binding(0, 0, bindings[0])
        return {0: bindings}

    def get_code(self):
        return read_shader("simulate.wgsl")

    def get_render_info(self, wobject, shared):
        return {"indices": workgroups(wobject.count)}


class ResetArgsShader(_GrassCompute):
    """Reset the indirect draw arguments at the start of each frame."""

    def __init__(self, wobject):
        super().__init__(wobject, lod_segments=list(LOD_SEGMENTS))

    def get_bindings(self, wobject, shared, scene):
        return {0: {0: Binding("s_args", "buffer/storage", wobject.args_buffer, "COMPUTE"),
                    1: Binding("s_bands", "buffer/storage", wobject.band_buffer, "COMPUTE")}}

    def get_code(self):
        return read_shader("reset_args.wgsl")

    def get_render_info(self, wobject, shared):
        return {"indices": (1, 1, 1)}


class PrefixBandsShader(_GrassCompute):
    """Between the culling phases: first slot per distance band, instance counts."""

    def __init__(self, wobject):
        super().__init__(wobject, n_classes=len(LOD_SEGMENTS), bands=DISTANCE_BANDS)

    def get_bindings(self, wobject, shared, scene):
        return {0: {0: Binding("s_args", "buffer/storage", wobject.args_buffer, "COMPUTE"),
                    1: Binding("s_bands", "buffer/storage", wobject.band_buffer, "COMPUTE")}}

    def get_code(self):
        return read_shader("prefix_bands.wgsl")

    def get_render_info(self, wobject, shared):
        return {"indices": (1, 1, 1)}


class CullShader(_GrassCompute):
    """Per-frame culling + LOD binning into compacted lists (feeds draw_indirect).

    ``phase`` "count" counts survivors per (LOD class, distance band); "scatter"
    writes them, nearest band first (see cull.wgsl)."""

    def __init__(self, wobject, phase="scatter"):
        if phase not in ("count", "scatter"):
            raise ValueError(f"phase must be 'count' or 'scatter'; got {phase!r}")
        super().__init__(
            wobject,
            n_classes=len(LOD_SEGMENTS),
            lod_min_pixels=[f"{p:.1f}" for p in LOD_MIN_PIXELS[:-1]],
            bands=DISTANCE_BANDS,
            band_near=f"{BAND_RANGE[0]:.3f}",
            band_far=f"{BAND_RANGE[1]:.3f}",
            phase=phase,
        )

    def get_bindings(self, wobject, shared, scene):
        bindings = {
            0: Binding("u_stdinfo", "buffer/uniform", shared.uniform_buffer, "COMPUTE"),
            1: Binding("u_wobject", "buffer/uniform", wobject.uniform_buffer, "COMPUTE"),
            2: Binding("u_cull", "buffer/uniform", wobject._cull_uniform, "COMPUTE"),
            10: Binding("s_blades", "buffer/read_only_storage", wobject.blade_buffer, "COMPUTE"),
            11: Binding("s_args", "buffer/storage", wobject.args_buffer, "COMPUTE"),
            12: Binding("s_visible", "buffer/storage", wobject.visible_buffer, "COMPUTE"),
            13: Binding("s_bands", "buffer/storage", wobject.band_buffer, "COMPUTE"),
        }
        for slot in (0, 1, 2):
            self.define_binding(0, slot, bindings[slot])
        return {0: bindings}

    def get_code(self):
        return read_shader("cull.wgsl")

    def get_render_info(self, wobject, shared):
        return {"indices": workgroups(wobject.count)}


class BladeRenderShader(BaseShader):
    """Ribbons of one LOD class, drawn with ``draw_indirect`` from the class's args."""

    type = "render"

    def __init__(self, wobject, lod_class):
        super().__init__(wobject, lod_class=lod_class, segments=LOD_SEGMENTS[lod_class])
        self.indirect_args = wobject.args_buffer
        self.indirect_offset = 16 * lod_class
        self._field = weakref.ref(wobject)
        self._when = ("before",) if lod_class == 0 else ()
        self._when += ("after",) if lod_class == len(LOD_SEGMENTS) - 1 else ()

    def draw_hook(self, render_pass, when):
        """GPU timestamps around the field's draws (first class: begin, last: end)."""
        field = self._field()
        stats = getattr(field, "stats", None)
        if stats is not None and when in self._when:
            stats.draw_timestamp(render_pass, when)

    def get_bindings(self, wobject, shared, scene):
        rbuffer = "buffer/read_only_storage"
        bindings = [
            Binding("u_stdinfo", "buffer/uniform", shared.uniform_buffer),
            Binding("u_wobject", "buffer/uniform", wobject.uniform_buffer),
            Binding("u_material", "buffer/uniform", wobject.material.uniform_buffer),
            Binding("u_cull", "buffer/uniform", wobject._cull_uniform, "VERTEX"),
            Binding("s_blades", rbuffer, wobject.blade_buffer, "VERTEX"),
            Binding("s_visible", rbuffer, wobject.visible_buffer, "VERTEX"),
        ]
        bindings = dict(enumerate(bindings))
        self.define_bindings(0, bindings)
        return {0: bindings}

    def get_pipeline_info(self, wobject, shared):
        return {"primitive_topology": "triangle-strip", "cull_mode": "none"}

    def get_render_info(self, wobject, shared):
        # Ignored when drawing indirectly; kept valid for pygfx's checks.
        return {"indices": (2 * (LOD_SEGMENTS[self["lod_class"]] + 1), 0)}

    def get_code(self):
        return read_shader("blade_render.wgsl")


def grass_render_function(wobject):
    """The passes of one GrassField: reset, cull (count, prefix, scatter), then one draw per LOD class."""
    return [
        ResetArgsShader(wobject),
        CullShader(wobject, "count"),
        PrefixBandsShader(wobject),
        CullShader(wobject, "scatter"),
        *(BladeRenderShader(wobject, k) for k in range(len(LOD_SEGMENTS))),
    ]


def register(field_cls, material_cls):
    """Register the WGSL loader and the render function (once)."""
    register_loader()
    if not _registered["render"]:
        register_wgpu_render_function(field_cls, material_cls)(grass_render_function)
        _registered["render"] = True
