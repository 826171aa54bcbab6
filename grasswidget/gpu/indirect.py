"""Indirect draws and dispatches for pygfx 0.17 (the one patch on pygfx internals).

pygfx's ``RenderPipelineContainer.draw()`` always ends in ``render_pass.draw()``.
This module subclasses it: when the shader carries ``indirect_args`` (a pygfx
Buffer with usage INDIRECT) and ``indirect_offset`` (bytes), the draw becomes
``render_pass.draw_indirect(buffer, offset)``; other shaders draw as before. The
same for ``ComputePipelineContainer.dispatch()``: with ``indirect_args`` it becomes
``compute_pass.dispatch_workgroups_indirect(buffer, offset)`` (the compute
rasterizer's walks, sized on the GPU); a compute shader with a ``skip_dispatch()`` method that
returns True dispatches nothing this frame (the compute rasterizer's steps while it is off: on a
CPU adapter a dispatch of nothing still cost 0.01-0.07 ms). The subclasses are installed as the module
globals that pygfx's pipeline module instantiates. A shader with a ``defer_draw(container, renderstate)`` method that returns
True draws nothing now (the occlusion culling's second-phase draws, replayed by
:meth:`grasswidget.gpu.occlusion.OcclusionCulling.second_phase`); one with a ``draw_bundle()``
method that returns a :class:`~grasswidget.gpu.draw_bundles.DrawBundle` hands its draw to it
(the blade draws of an object, replayed from a render bundle). tests/test_compat.py (the
engine internals) and tests/gpu/test_culling.py (the live patch) fail loudly if an upgrade breaks it.
"""

from __future__ import annotations

import pygfx

from .. import compat
from ..errors import UpstreamChangedError

__all__ = ["IndirectRenderPipelineContainer", "IndirectComputePipelineContainer", "install", "is_installed",
           "SUPPORTED_PYGFX"]

#: pygfx versions this patch was written and tested against.
SUPPORTED_PYGFX = ("0.17",)

_Original = compat.render_pipeline_container_class()
_OriginalCompute = compat.compute_pipeline_container_class()


class IndirectRenderPipelineContainer(_Original):
    """A RenderPipelineContainer that can issue ``draw_indirect``."""

    def draw(self, render_pass, renderstate):
        defer = getattr(self.shader, "defer_draw", None)  # the occlusion draws: replayed after the second phase
        if defer is not None and defer(self, renderstate):
            return
        args = getattr(self.shader, "indirect_args", None)
        if args is None:
            return super().draw(render_pass, renderstate)
        bundle = getattr(self.shader, "draw_bundle", None)  # the blade draws: one render bundle per object
        bundle = bundle() if bundle is not None else None
        if bundle is not None:
            bundle.add(self, render_pass, renderstate)
            return
        if self.broken:
            return
        render_pass.set_pipeline(self.wgpu_pipeline)
        bind_groups = self.wgpu_bind_groups
        for index, bind_group in enumerate(bind_groups):
            render_pass.set_bind_group(index, bind_group, [], 0, 99)
        render_pass.set_bind_group(len(bind_groups), renderstate.wgpu_bind_group, [], 0, 99)
        hook = getattr(self.shader, "draw_hook", None)  # optional: timestamps around draws
        if hook is not None:
            hook(render_pass, "before")
        render_pass.draw_indirect(compat.sync_buffer(args), self.shader.indirect_offset)
        if hook is not None:
            hook(render_pass, "after")


class IndirectComputePipelineContainer(_OriginalCompute):
    """A ComputePipelineContainer that can issue ``dispatch_workgroups_indirect``."""

    def dispatch(self, compute_pass):
        skip = getattr(self.shader, "skip_dispatch", None)  # e.g. the compute rasterizer's steps while it is off
        if skip is not None and skip():
            return
        args = getattr(self.shader, "indirect_args", None)
        if args is None:
            return super().dispatch(compute_pass)
        if self.broken:
            return
        compute_pass.set_pipeline(self.wgpu_pipeline)
        for index, bind_group in enumerate(self.wgpu_bind_groups):
            compute_pass.set_bind_group(index, bind_group, [], 0, 999999)
        compute_pass.dispatch_workgroups_indirect(compat.sync_buffer(args), self.shader.indirect_offset)


def install():
    """Install the subclass (idempotent). Raises if pygfx is not a supported version."""
    if not pygfx.__version__.startswith(SUPPORTED_PYGFX):
        raise UpstreamChangedError(
            f"grasswidget's indirect-draw patch supports pygfx {SUPPORTED_PYGFX}, not {pygfx.__version__}"
        )
    if not hasattr(_Original, "draw"):
        raise UpstreamChangedError("pygfx internals changed: RenderPipelineContainer.draw not found")
    if not hasattr(_OriginalCompute, "dispatch"):
        raise UpstreamChangedError("pygfx internals changed: ComputePipelineContainer.dispatch not found")
    compat.set_render_pipeline_container_class(IndirectRenderPipelineContainer)
    compat.set_compute_pipeline_container_class(IndirectComputePipelineContainer)


def is_installed() -> bool:
    return (compat.render_pipeline_container_class() is IndirectRenderPipelineContainer
            and compat.compute_pipeline_container_class() is IndirectComputePipelineContainer)
