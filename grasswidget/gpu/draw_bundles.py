"""The blade draws of a GrassField recorded once into a GPU render bundle and replayed.

Every render draws each LOD class of a field (and the culled blades) with its own indirect
draw: per draw a pipeline, three bind groups and ``draw_indirect``, about 25 wgpu calls per
field and phase, each crossing from Python into wgpu-native. The arguments live on the GPU
(the culling writes them), so the recorded commands do not change from frame to frame: a
:class:`DrawBundle` records them into a ``GPURenderBundle`` the first time and replays it with
one ``execute_bundles`` call, recording again only when pygfx rebuilt a pipeline or a bind
group (a changed shader, a new buffer), the lights changed or the render targets' formats did
(the last :data:`KEPT_BUNDLES` are kept: one per renderer drawing the field).

pygfx still drives everything (gpu/indirect.py): its render pass asks each pipeline container
of the field to draw, in order; the containers of one field hand themselves to the field's
``DrawBundle`` (:meth:`DrawBundle.add`), which executes the bundle when the last one arrived.
The GPU timestamps around the draws (``FrameStats``) are written into the pass before and
after the bundle (a bundle cannot hold them).
"""

from __future__ import annotations

from .. import compat
from .adapter import ensure_device

__all__ = ["DrawBundle", "KEPT_BUNDLES"]

#: Bundles kept per object (one per renderer that draws it: a live view and an export, two views).
KEPT_BUNDLES = 4


class DrawBundle:
    """The ``size`` indirect draws of one object (a GrassField or its OcclusionDraws), replayed
    from a render bundle.

    ``size``: how many pipeline containers of the object draw through it per render (its
    blade shaders: one per LOD class and one for the culled blades), in that order.
    Attributes: ``records`` (how many times a bundle was recorded: once, then again only
    after a change), ``replays`` (how many times it was executed).
    """

    def __init__(self, size: int):
        self.size = int(size)
        self.records = 0
        self.replays = 0
        self._pending = []
        self._pass = None
        self._bundles = {}  # key (pipelines, bind groups, buffers, formats) -> GPURenderBundle

    def add(self, container, render_pass, renderstate) -> None:
        """Take one container's draw (called by its ``draw`` in gpu/indirect.py); when the
        object's last one arrived, draw them all (the bundle, recorded again if needed)."""
        if render_pass is not self._pass:  # a new pass: whatever an interrupted one left is dropped
            self._pending, self._pass = [], render_pass
        self._pending.append((container, renderstate))
        if len(self._pending) < self.size:
            return
        pending, self._pending, self._pass = self._pending, [], None
        live = [(c, rs) for c, rs in pending if not c.broken]
        if not live:
            return
        formats = compat.render_target_formats(live[0][1])
        key = (formats, tuple((c.wgpu_pipeline, tuple(c.wgpu_bind_groups), rs.wgpu_bind_group,
                               compat.sync_buffer(c.shader.indirect_args), c.shader.indirect_offset)
                              for c, rs in live))
        bundle = self._bundles.pop(key, None)
        if bundle is None:
            bundle = self._record(live, formats)
        self._bundles[key] = bundle  # most recently used last
        while len(self._bundles) > KEPT_BUNDLES:
            del self._bundles[next(iter(self._bundles))]
        hooks = [getattr(c.shader, "draw_hook", None) for c, _ in live]
        for hook in hooks:
            if hook is not None:
                hook(render_pass, "before")
        render_pass.execute_bundles([bundle])
        self.replays += 1
        for hook in hooks:
            if hook is not None:
                hook(render_pass, "after")

    def _record(self, live, formats):
        color_formats, depth_format = formats
        encoder = ensure_device().create_render_bundle_encoder(color_formats=list(color_formats),
                                                               depth_stencil_format=depth_format, sample_count=1)
        for container, renderstate in live:
            encoder.set_pipeline(container.wgpu_pipeline)
            groups = container.wgpu_bind_groups
            for index, bind_group in enumerate(groups):
                encoder.set_bind_group(index, bind_group)
            encoder.set_bind_group(len(groups), renderstate.wgpu_bind_group)
            encoder.draw_indirect(compat.sync_buffer(container.shader.indirect_args), container.shader.indirect_offset)
        self.records += 1
        return encoder.finish()
