"""WGSL templating shared by every grasswidget shader class.

``{$ include 'grasswidget.<file>' $}`` resolves to ``grasswidget/shaders/<file>``
(registered with pygfx's WGSL loader when this module is imported). Every shader
class starts from :func:`grasswidget.core.shader_files.template_vars` (the ids of the
enums and the constants of the reference; documented there) and adds its own.
Compute shaders share :class:`GrassComputeShader` and :func:`workgroups`.

Parameter structs that WGSL branches on (``u_cull``, ...) are bound as read-only
*storage* buffers, declared with :func:`storage_struct_code`, not as uniforms:
Mesa's lavapipe (22.3, Debian 12) specialises a shader whose ``if``/loop
conditions read uniform-buffer values ("inline uniforms"): on every pipeline bind
it compiles a new variant with those values folded in and never frees it, about
0.3-0.4 MB a dispatch for the culling shader (issue 20: the live view grew
0.8 MB a frame). Values read from a storage buffer are never inlined. See
benchmarks/lavapipe_inline_uniform_leak.py for the smallest wgpu-py script that
shows it.
"""

from __future__ import annotations

import jinja2
from pygfx.renderers.wgpu import BaseShader, register_wgsl_loader

from ..core.shader_files import WORKGROUP_SIZE, shader_dir, template_vars
from ..core.uniform_layouts import wgsl_struct

__all__ = ["WORKGROUP", "workgroups", "GrassComputeShader", "shader_vars", "storage_struct_code"]

#: Threads per workgroup of the per-blade compute shaders (``@workgroup_size``).
WORKGROUP = WORKGROUP_SIZE

register_wgsl_loader("grasswidget", jinja2.FileSystemLoader(str(shader_dir())))


def workgroups(n_items, limit=65535):
    """Dispatch size for ``n_items`` threads in groups of WORKGROUP, folded into y past ``limit``."""
    groups = max(1, -(-int(n_items) // WORKGROUP))
    x = min(groups, limit)
    y = -(-groups // x)
    return x, y, 1


def shader_vars(**own):
    """The shared template variables plus a shader's own (``own`` wins)."""
    return {**template_vars(), **own}


class GrassComputeShader(BaseShader):
    """Base of the grass compute shaders (entry point ``main``, no pipeline info)."""

    type = "compute"

    def __init__(self, wobject, **own_vars):
        super().__init__(wobject, **shader_vars(**own_vars))

    def get_pipeline_info(self, wobject, shared):
        return {}


def storage_struct_code(group: int, slot: int, name: str, struct_name: str, layout) -> str:
    """WGSL that declares ``name`` (a struct of ``layout``, see
    :mod:`grasswidget.core.uniform_layouts`) as a read-only storage buffer at
    ``@group(group) @binding(slot)``; pair it with a pygfx
    ``Binding(name, "buffer/read_only_storage", buffer)`` that is *not* passed to
    ``define_binding``. Shaders read it as ``name.field``, as they would a uniform
    (the layout's offsets are the same in both address spaces). Why not a uniform:
    see the module docstring (lavapipe's inline-uniform leak).
    """
    return (f"{wgsl_struct(struct_name, layout)}\n"
            f"@group({group}) @binding({slot}) var<storage, read> {name}: {struct_name};\n")
