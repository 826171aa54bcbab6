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

import re

import jinja2
from pygfx.renderers.wgpu import BaseShader, register_wgsl_loader

from ..core.engine_inputs import MAX_WORKGROUPS_X
from ..core.shader_files import WORKGROUP_SIZE, shader_dir, template_vars
from ..core.uniform_layouts import wgsl_struct
from ..errors import ExerciseShaderError

__all__ = ["workgroups", "GrassComputeShader", "shader_vars", "storage_struct_code",
           "naga_error_parts", "overrides_error"]


register_wgsl_loader("grasswidget", jinja2.FileSystemLoader(str(shader_dir())))


def workgroups(n_items, limit=MAX_WORKGROUPS_X):
    """Dispatch size for ``n_items`` threads in groups of WORKGROUP_SIZE, folded into y past ``limit``."""
    groups = max(1, -(-int(n_items) // WORKGROUP_SIZE))
    x = min(groups, limit)
    y = -(-groups // x)
    return x, y, 1


def shader_vars(**own):
    """The shared template variables plus a shader's own (``own`` wins)."""
    return {**template_vars(), **own}


def follows_camera(field) -> bool:
    """Whether ``field`` (a GrassField, or anything without blades: False) is a field to the horizon
    whose blades follow the camera (``Blades.horizon``): its shaders are rendered with the
    template variable ``follow_camera``."""
    blades = getattr(field, "blades", None)
    return getattr(blades, "horizon", None) is not None


class GrassComputeShader(BaseShader):
    """Base of the grass compute shaders (entry point ``main``, no pipeline info).

    The field's ``function_overrides`` (a :class:`~grasswidget.core.wgsl_overrides.FunctionOverrides`
    or None; read from ``wobject``, or its ``field``) replace blade-math functions in the
    generated WGSL of every compute shader that defines them (simulation, culling,
    inspector); their key is a template variable, so a change builds new pipelines.
    """

    type = "compute"

    def __init__(self, wobject, **own_vars):
        field = getattr(wobject, "field", wobject)
        self.function_overrides = getattr(field, "function_overrides", None)
        key = self.function_overrides.key if self.function_overrides is not None else ""
        # A field to the horizon compiles its camera-following levels in (levels.wgsl; the culling
        # pass's wrap and the weights); any other field compiles none of it.
        own_vars.setdefault("follow_camera", follows_camera(field))
        super().__init__(wobject, **shader_vars(function_overrides=key, **own_vars))

    def generate_wgsl(self, **more_template_vars):
        code = super().generate_wgsl(**more_template_vars)
        if self.function_overrides is not None:
            code = self.function_overrides.apply(code)
        return code

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


def naga_error_parts(text: str, first_line: int, n_lines: int):
    """(line, column, reason) of a wgpu/naga compile error ``text`` on a shader whose
    lines ``first_line .. first_line + n_lines - 1`` hold a user's snippet: the line
    (1-based, within the snippet; None when the error points elsewhere), the column
    (None when naga gives none) and naga's one-line reason."""
    in_body = (lambda L: first_line is not None and first_line <= L < first_line + n_lines)
    line = column = None
    head = re.search(r"┌─ [^:\n]*:(\d+):(\d+)", text)
    if head and in_body(int(head.group(1))):
        line, column = int(head.group(1)), int(head.group(2))
    else:
        gutter = text.splitlines()
        marked = []
        for k, row in enumerate(gutter):
            m = re.match(r"\s*(\d+) │", row)
            if m and in_body(int(m.group(1))):
                nxt = gutter[k + 1] if k + 1 < len(gutter) else ""
                marked.append((("^" not in nxt), int(m.group(1))))
        if marked:
            line = sorted(marked)[0][1]
    reasons = [r.strip() for r in re.findall(r"(?:error|Error): (.+)", text) if "Validation Error" not in r]
    notes = [r.strip()[2:] for r in text.splitlines() if r.strip().startswith("= ")]
    reason = "; ".join(dict.fromkeys(reasons + notes)) or (text.strip().splitlines() or ["?"])[-1]
    return (line - first_line + 1 if line is not None else None), column, reason


def overrides_error(err, wgsl: str, overrides):
    """An :class:`~grasswidget.errors.ExerciseShaderError` for a compile error ``err`` of
    ``wgsl`` (a shader with ``overrides`` applied), naming the user's line and column."""
    text = str(err)
    code_lines = overrides.code.split("\n")
    line, column, reason = naga_error_parts(text, overrides.first_line(wgsl), len(code_lines))
    if line is not None:
        col = f", column {column}" if column is not None else ""
        message = f"{overrides.label} line {line}{col}: {reason}\n  {line} | {code_lines[line - 1]}"
    else:
        message = f"{overrides.label} does not compile with the stock shaders: {reason}"
    return ExerciseShaderError(message, line, column, reason, text)
