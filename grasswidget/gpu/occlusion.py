"""Occlusion culling in the kernel engine: two phases around a max-depth pyramid.

The guarantee: a blade that would show is never culled, however the camera, the
wind or a ball move between frames. :func:`grasswidget.gpu.frame.render_frame` draws one frame as

1. ``renderer.render(scene)`` with every armed field's culling in its *first phase*
   (``u_cull.occlusion_phase = 1``): of the blades that pass the orientation,
   frustum and distance tests, only those seen last frame are drawn (with the sky,
   the ground and every other opaque object; translucent ``late`` objects wait).
2. Outside render(), in one command buffer per field
   (:meth:`OcclusionCulling.second_phase`): the depth buffer of step 1 is copied
   into a max-depth pyramid (``hzb_build.wgsl``), and the culling runs again
   (``cull.wgsl`` with ``occlusion = 2``): each blade that passes the other tests
   is hidden when its nearest depth is farther than the pyramid over its screen
   rect (``occlusion.wgsl``; the NumPy twin is ``reference.occlusion_cull``). The
   ones not hidden and not drawn in step 1 are listed for step 3; "seen" becomes
   "passes every test now" for the next frame.
3. ``renderer.render(field.occlusion.draws)`` (no clear): those blades, and with
   ``color_by = "cull"`` every culled blade in its test's colour (occlusion cyan).
4. The translucent ``late`` objects (GrassScene's collider balls), with the lights (no
   render call when none of them has anything to draw: on an H100's host a pygfx render
   call costs about 1.5 ms of CPU).

The pyramid holds only depths drawn in this frame with this camera; depth only
gets nearer as more is drawn, so whatever it hides is hidden in the final picture:
the picture is the one without occlusion culling (pixel for pixel, up to the order
of equal-depth fragments). Motion only costs time: blades that became visible are
found in step 2 and drawn in step 3.

A plain ``renderer.render(scene)`` never arms the first phase, so it draws every
blade that passes the other tests (occlusion culling off), as before.
"""

from __future__ import annotations

import weakref

import numpy as np
import pygfx as gfx
import wgpu

from .. import compat
from ..errors import GrassValueError
from ..core.reference import HZB_MAX_LEVELS, LOD_SEGMENTS, hzb_layout
from ..core.shader_files import RASTER_SHADE_OFFSET
from .adapter import ensure_device
from .compute import ComputeProgram, destroy_buffers, sync_buffer
from .draw_bundles import DrawBundle
from .raster_walks import SHADE_STEPS, raster_walk_steps
from .wgsl_templates import workgroups

__all__ = ["OcclusionDraws", "OcclusionCulling", "register_second_phase_shaders", "HZB_TAIL_TEXELS"]

#: Pyramid levels of at most this many texels are built together, in one workgroup of one dispatch.
HZB_TAIL_TEXELS = 2048

#: Blade draws per object and render: one per LOD class, one of the culled blades.
N_CLASSES = len(LOD_SEGMENTS)



#: The compute shader classes the second phase dispatches ("cull", "hzb_level", "raster"), registered
#: by :mod:`grasswidget.gpu.shader_classes` when the package is imported: objects never import their
#: shaders (the shader classes import the objects, as pygfx's do), so there is no import circle.
_SECOND_PHASE_SHADERS: dict = {}


def register_second_phase_shaders(*, cull, hzb_level, raster) -> None:
    """Register the shader classes :meth:`OcclusionCulling.second_phase` dispatches: ``cull`` (the
    culling pass, built as ``cull(field, "scatter", occlusion=2)``), ``hzb_level`` (one pyramid level,
    ``hzb_level(field, k)``) and ``raster`` (the compute rasterizer, ``raster(field, stage, second=True)``).
    Called once by :mod:`grasswidget.gpu.shader_classes`, as pygfx's decorator registers render functions."""
    _SECOND_PHASE_SHADERS.update(cull=cull, hzb_level=hzb_level, raster=raster)


class OcclusionDraws(gfx.WorldObject):
    """The second occlusion phase's draws of a GrassField: a child of the field (same
    transform, same material), hidden except during the first phase's render of
    :func:`~grasswidget.gpu.frame.render_frame`.

    There pygfx prepares them with the rest of the scene (transform uniforms, pipelines for
    that render's lights, pending uploads) but they draw nothing: each pipeline container's
    draw is handed to :meth:`defer` instead, and :meth:`OcclusionCulling.second_phase` replays
    them after the pyramid and the second culling pass, in the same command encoder and
    submission (no second ``renderer.render()`` call: it cost about 1 ms of host work a frame).
    """

    def __init__(self, field):
        super().__init__(field.geometry, field.material)
        self._field_ref = weakref.ref(field)
        self.visible = False
        self._deferred = None  # (pipeline container, renderstate) pairs while deferring, else None
        #: The blade draws of the second phase, replayed from a render bundle (gpu/draw_bundles.py).
        self.blade_draw_bundle = DrawBundle(N_CLASSES + 1)

    @property
    def field(self):
        """The GrassField whose blades these draws show."""
        return self._field_ref()

    def defer_draws(self):
        """Make the draws visible for the next render and collect their draw calls instead of drawing."""
        self._deferred = []
        self.visible = True

    def stop_deferring(self):
        """Hide the draws again (the collected calls stay for :meth:`take_deferred`)."""
        self.visible = False

    def defer(self, container, renderstate) -> bool:
        """Called by a pipeline container's draw (gpu/indirect.py): True (and the call kept)
        while deferring, False otherwise (then the container draws as usual)."""
        if self._deferred is None or not self.visible:
            return False
        self._deferred.append((container, renderstate))
        return True

    def take_deferred(self) -> list:
        """The collected (pipeline container, renderstate) pairs, and stop collecting."""
        deferred, self._deferred = self._deferred or [], None
        return deferred


class OcclusionCulling:
    """The occlusion culling state of one GrassField: the depth pyramid, its level
    table, the second phase's compute programs and draws (:attr:`draws`)."""

    def __init__(self, field):
        self._field_ref = weakref.ref(field)
        #: The field's second-phase draws (an :class:`OcclusionDraws` child of the field).
        self.draws = OcclusionDraws(field)
        field.add(self.draws)
        usage = wgpu.BufferUsage
        #: The max-depth pyramid, all levels in one float32 buffer (reference.hzb_layout).
        self.hzb_buffer = gfx.Buffer(nbytes=4, nitems=1, format="f4", usage=usage.STORAGE | usage.COPY_DST)
        #: [levels, width, height, 0], then (offset, width, height, pitch) per level (u32).
        self.levels_buffer = gfx.Buffer(np.zeros((HZB_MAX_LEVELS + 1, 4), np.uint32), usage=usage.STORAGE)
        #: Set by GrassField.freeze_culling: a copy of the frozen camera whose view the
        #: next render_frame renders once to find the blades it hides (then None).
        self.capture_camera = None
        self.size = None
        self.layout = None
        self._level_programs = None
        self._cull_programs = None
        self._cull_key = None

    @property
    def field(self):
        return self._field_ref()

    # ------------------------------------------------------------------ first phase

    def arm(self, phase: int):
        """Set ``u_cull.occlusion_phase`` for the next render (1: first phase, 0: off)."""
        self._set_uniform("occlusion_phase", phase)

    def _set_uniform(self, name, value):
        data = self.field.cull_uniform_buffer.data
        if int(data[name]) != value:
            data[name] = value
            self.field.cull_uniform_buffer.update_full()

    def capture(self, renderer, scene):
        """Render ``scene`` once with :attr:`capture_camera` (the frozen view), culling
        against that camera, so that the seen flags are the frozen view's (no flush:
        the frame that follows clears the target)."""
        camera, self.capture_camera = self.capture_camera, None
        if camera is None:
            return
        try:
            self._set_uniform("frozen", 0)  # cull against the render camera: the frozen view itself
            self.arm(1)
            renderer.render(scene, camera, flush=False)
            self.second_phase(renderer)
        finally:
            self.arm(0)
            self._set_uniform("frozen", 1)

    # ------------------------------------------------------------------ second phase

    def _ensure_size(self, width, height):
        if self.size == (width, height):
            return
        layout = hzb_layout(width, height)
        if len(layout) > HZB_MAX_LEVELS:
            raise GrassValueError(f"occlusion culling supports views up to {2 ** (HZB_MAX_LEVELS - 1)} pixels wide "
                                  f"and high; got {width} x {height}")
        last = layout[-1]
        total = last[0] + last[1] * last[2]
        old = self.hzb_buffer
        usage = wgpu.BufferUsage
        self.hzb_buffer = gfx.Buffer(nbytes=4 * total, nitems=total, format="f4",
                                     usage=usage.STORAGE | usage.COPY_DST | usage.COPY_SRC)
        destroy_buffers([old])
        table = np.zeros((HZB_MAX_LEVELS + 1, 4), np.uint32)
        table[0] = (len(layout), width, height, 0)
        table[1: len(layout) + 1] = layout
        self.levels_buffer.data[:] = table
        self.levels_buffer.update_full()
        self.size, self.layout = (width, height), layout
        self._level_programs = self._cull_programs = None

    def _programs(self):
        CullShader, HzbLevelShader, RasterShader = (_SECOND_PHASE_SHADERS[k] for k in ("cull", "hzb_level", "raster"))
        field = self.field
        if self._level_programs is None:
            # The big levels one dispatch each (8 x 8 texels a workgroup), the small ones (HZB_TAIL_TEXELS
            # texels or fewer) together in one workgroup: a dispatch cost a CPU adapter 0.05-0.08 ms however small.
            levels = range(1, len(self.layout))
            big = [k for k in levels if self.layout[k][1] * self.layout[k][2] > HZB_TAIL_TEXELS]
            programs = [(ComputeProgram(HzbLevelShader(field, k), field),
                         (-(-self.layout[k][1] // 8), -(-self.layout[k][2] // 8), 1)) for k in big]
            if len(big) < len(levels):
                first = len(big) + 1
                programs.append((ComputeProgram(HzbLevelShader(field, first, len(self.layout) - 1), field), (1, 1, 1)))
            self._level_programs = programs
        key = (id(self.hzb_buffer), id(field.culled_buffer), id(field.raster_list_buffer),
               id(field.raster_depth_buffer), id(field.raster_color_buffer), bool(field.material.sunlight))
        if self._cull_programs is None or key != self._cull_key:
            self._cull_programs = [ComputeProgram(CullShader(field, "scatter", occlusion=2), field),
                                   ComputeProgram(RasterShader(field, "args", second=True), field),
                                   *(ComputeProgram(RasterShader(field, step, second=True), field)
                                     for step in (*raster_walk_steps(field), *SHADE_STEPS))]
            self._cull_key = key
        return self._level_programs, self._cull_programs

    def second_phase(self, renderer) -> bool:
        """Build the pyramid from ``renderer``'s depth buffer, run the second culling phase
        and draw its blades (the draws :attr:`draws` deferred in the first phase's render,
        in a render pass on ``renderer``'s targets), all in one submission. False when the
        renderer has no depth yet (nothing done)."""
        deferred = self.draws.take_deferred()
        depth = compat.renderer_depth_texture(renderer)
        if depth is None:
            return False
        width, height = int(depth.size[0]), int(depth.size[1])
        self._ensure_size(width, height)
        levels, (cull, raster_args, *raster_walks, shade_args, shade) = self._programs()
        device = ensure_device()
        hzb = sync_buffer(self.hzb_buffer)
        sync_buffer(self.levels_buffer)
        enc = device.create_command_encoder()
        enc.copy_texture_to_buffer(
            {"texture": depth, "mip_level": 0, "origin": (0, 0, 0), "aspect": "depth-only"},
            {"buffer": hzb, "offset": 0, "bytes_per_row": 4 * self.layout[0][3], "rows_per_image": height},
            (width, height, 1),
        )
        cp = enc.begin_compute_pass()
        for program, groups in levels:
            program.dispatch(cp, groups)
        cull.dispatch(cp, workgroups(self.field.count))
        if self.field.compute_raster_active:  # the thin blades this phase found (cull.wgsl, raster.wgsl)
            raster_args.dispatch(cp, (1, 1, 1))  # a thread per blade this phase listed
            for walk in raster_walks:  # one walk (packed) or two (depth, payload): raster_walk_steps
                walk.dispatch_indirect(cp, self.field.raster_dispatch_buffer)
            # the written rows' colours again (both phases' blades), for the resolve drawn after
            shade_args.dispatch(cp, (1, 1, 1))
            shade.dispatch_indirect(cp, self.field.raster_dispatch_buffer, RASTER_SHADE_OFFSET)
        cp.end()
        if deferred:
            render_pass = compat.begin_target_render_pass(renderer, enc, self.draws.material.alpha_method)
            for container, renderstate in deferred:
                container.draw(render_pass, renderstate)
            render_pass.end()
        device.queue.submit([enc.finish()])
        return True

    def read_hzb(self) -> list:
        """The pyramid of the last frame as a list of (height, width) float32 arrays,
        level 0 (the depth buffer) first (synchronous; for tests and teaching)."""
        if self.layout is None:
            return []
        raw = np.frombuffer(ensure_device().queue.read_buffer(sync_buffer(self.hzb_buffer)), np.float32)
        out = []
        for offset, w, h, pitch in self.layout:
            out.append(raw[offset: offset + pitch * h].reshape(h, pitch)[:, :w].copy())
        return out

    def release(self):
        destroy_buffers([self.hzb_buffer, self.levels_buffer])
        self._level_programs = self._cull_programs = None
