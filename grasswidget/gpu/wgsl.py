"""WGSL templating shared by every grasswidget shader class.

``{$ include 'grasswidget.<file>' $}`` resolves to ``grasswidget/shaders/<file>``
(registered with pygfx's WGSL loader when this module is imported). Every shader
class starts from :func:`grasswidget.core.shader_files.template_vars` (the ids of the
enums and the constants of the reference; documented there) and adds its own.
Compute shaders share :class:`GrassComputeShader` and :func:`workgroups`.
"""

from __future__ import annotations

import jinja2
from pygfx.renderers.wgpu import BaseShader, register_wgsl_loader

from ..core.shader_files import WORKGROUP_SIZE, shader_dir, template_vars

__all__ = ["WORKGROUP", "workgroups", "GrassComputeShader", "shader_vars"]

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
