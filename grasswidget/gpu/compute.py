"""Run a pygfx compute shader on demand, outside ``renderer.render()``.

pygfx dispatches compute shaders only inside a render. The simulation must run
when ``step()`` is called and never because of a render, so it gets its own
pipeline here, built from the same BaseShader machinery (templating, includes,
Binding objects), and is recorded into our own command encoder.
"""

from __future__ import annotations

from collections import OrderedDict

from pygfx.renderers.wgpu import get_shared

from .. import compat

__all__ = ["ComputeProgram", "sync_buffer", "destroy_buffers"]


def sync_buffer(buffer):
    """Create the GPU buffer if needed and upload pending CPU data; return the wgpu buffer."""
    return compat.sync_buffer(buffer)


def destroy_buffers(buffers):
    """Free the GPU memory of pygfx Buffers now (not at garbage collection).

    A buffer with a pending upload sits in pygfx's global resource-update
    registry, and the next render by *any* renderer would write to it: take it
    out of the registry first. Without that registry (another pygfx version)
    the buffers are left to the garbage collector.
    """
    for buf in buffers:
        obj = compat.gpu_buffer(buf)
        if obj is None:
            continue
        if not compat.forget_pending_upload(buf):
            return
        obj.destroy()


#: Compute pipelines kept for reuse, most recently used last: (device id, WGSL, bind group
#: layout) -> (bind group layout, pipeline). A new field (a blade-count change) builds the
#: same shaders again; compiling them anew cost lavapipe about 100 KB of memory a pipeline
#: that was never given back (2.5 MB per blade-count change in all).
_PIPELINES: "OrderedDict[tuple, tuple]" = OrderedDict()
#: How many pipelines _PIPELINES keeps (custom wind shaders add new ones).
PIPELINE_CACHE_SIZE = 64


def _pipeline(device, wgsl, layout_entries):
    """(bind group layout, compute pipeline) of this WGSL and layout on ``device``, built
    once and then reused."""
    key = (id(device), wgsl, repr(layout_entries))
    found = _PIPELINES.get(key)
    if found is not None:
        _PIPELINES.move_to_end(key)
        return found
    module = device.create_shader_module(code=wgsl)
    layout = device.create_bind_group_layout(entries=layout_entries)
    pipeline = device.create_compute_pipeline(
        layout=device.create_pipeline_layout(bind_group_layouts=[layout]),
        compute={"module": module, "entry_point": "main"},
    )
    _PIPELINES[key] = (layout, pipeline)
    while len(_PIPELINES) > PIPELINE_CACHE_SIZE:
        _PIPELINES.popitem(last=False)
    return layout, pipeline


class ComputeProgram:
    """One compute shader + its bind group, ready to be dispatched into a pass."""

    def __init__(self, shader, wobject):
        shared = get_shared()
        device = shared.device
        bindings = shader.get_bindings_info(wobject, shared, None)[0]
        self.wgsl = shader.generate_wgsl()
        group_entries, layout_entries = [], []
        for slot in sorted(bindings):
            binding = bindings[slot]
            # Sets the usage flags, then creates the GPU object ...
            entry, layout_entry = binding.get_bind_group_descriptors(slot)
            if binding.type.startswith("buffer/"):
                sync_buffer(binding.resource)  # ... and uploads pending data.
            group_entries.append(entry)
            layout_entries.append(layout_entry)
        layout, self.pipeline = _pipeline(device, self.wgsl, layout_entries)
        self.bind_group = device.create_bind_group(layout=layout, entries=group_entries)
        self.bindings = bindings

    def dispatch(self, compute_pass, workgroups):
        compute_pass.set_pipeline(self.pipeline)
        compute_pass.set_bind_group(0, self.bind_group)
        compute_pass.dispatch_workgroups(*workgroups)

    def dispatch_indirect(self, compute_pass, buffer, offset=0):
        """Dispatch the workgroups (x, y, z u32) the GPU wrote at ``offset`` bytes of the pygfx
        Buffer ``buffer`` (usage INDIRECT)."""
        compute_pass.set_pipeline(self.pipeline)
        compute_pass.set_bind_group(0, self.bind_group)
        compute_pass.dispatch_workgroups_indirect(sync_buffer(buffer), offset)
