"""Run a pygfx compute shader on demand, outside ``renderer.render()``.

pygfx dispatches compute shaders only inside a render. The simulation must run
when ``step()`` is called and never because of a render, so it gets its own
pipeline here, built from the same BaseShader machinery (templating, includes,
Binding objects), and is recorded into our own command encoder.
"""

from __future__ import annotations

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
        module = device.create_shader_module(code=self.wgsl)
        layout = device.create_bind_group_layout(entries=layout_entries)
        self.bind_group = device.create_bind_group(layout=layout, entries=group_entries)
        self.pipeline = device.create_compute_pipeline(
            layout=device.create_pipeline_layout(bind_group_layouts=[layout]),
            compute={"module": module, "entry_point": "main"},
        )
        self.bindings = bindings

    def dispatch(self, compute_pass, workgroups):
        compute_pass.set_pipeline(self.pipeline)
        compute_pass.set_bind_group(0, self.bind_group)
        compute_pass.dispatch_workgroups(*workgroups)
