"""Call one WGSL function on the GPU for a batch of inputs (a small compute harness).

:func:`call_function` wraps a function of a WGSL module (e.g. the blade math with a
student's functions in place, :class:`~grasswidget.core.wgsl_overrides.FunctionOverrides`)
in a compute shader that reads each call's arguments from a u32 buffer and writes the
result to another, one invocation per call. The exercise grader uses it to show a
student what their function returned for the blade where the pass went wrong, and to
catch a NaN the rest of the pass would hide (a max() or a clamp downstream may turn a
NaN into a number).

Parameter and result types: f32, i32, u32, bool, vec2/3/4<f32>, mat4x4<f32>, and
structs of those (results only), as declared in the module.
"""

from __future__ import annotations

import re

import numpy as np
import wgpu

from ..errors import GrassValueError
from .adapter import ensure_device

__all__ = ["call_function"]

_WORDS = {"f32": 1, "i32": 1, "u32": 1, "bool": 1, "vec2<f32>": 2, "vec3<f32>": 3, "vec4<f32>": 4, "mat4x4<f32>": 16}
_GROUP = 64


def _structs(code):
    return {m.group(1): [tuple(x.strip() for x in f.split(":")) for f in m.group(2).split(",") if f.strip()]
            for m in re.finditer(r"struct (\w+)\s*\{([^}]*)\}", code)}


def _decode(ptype, w):
    word = lambda k: f"probe_in[b + {w + k}u]"  # noqa: E731
    f = lambda k: f"bitcast<f32>({word(k)})"  # noqa: E731
    if ptype == "f32":
        return f(0)
    if ptype == "i32":
        return f"bitcast<i32>({word(0)})"
    if ptype == "u32":
        return word(0)
    if ptype == "bool":
        return f"({word(0)} != 0u)"
    if ptype.startswith("vec"):
        return f"{ptype}({', '.join(f(k) for k in range(_WORDS[ptype]))})"
    if ptype == "mat4x4<f32>":
        cols = [f"vec4<f32>({', '.join(f(4 * c + k) for k in range(4))})" for c in range(4)]
        return f"mat4x4<f32>({', '.join(cols)})"
    raise GrassValueError(f"call_function: no parameter of type {ptype}")


def _leaves(rtype, structs, expr="r"):
    if rtype in structs:
        return [leaf for name, ftype in structs[rtype] for leaf in _leaves(ftype, structs, f"{expr}.{name}")]
    return [(expr, rtype)]


def _encode(expr, ltype):
    if ltype in ("f32", "i32"):
        return [f"bitcast<u32>({expr})"]
    if ltype == "u32":
        return [expr]
    if ltype == "bool":
        return [f"select(0u, 1u, {expr})"]
    if ltype.startswith("vec"):
        return [f"bitcast<u32>({expr}.{c})" for c in "xyzw"[: _WORDS[ltype]]]
    raise GrassValueError(f"call_function: no result of type {ltype}")


def _pack(ptype, x, n):
    x = np.asarray(x)
    if ptype in ("i32", "u32", "bool"):
        return x.astype(np.int64).astype(np.int32 if ptype == "i32" else np.uint32).view(np.uint32).reshape(n, -1)
    if ptype == "mat4x4<f32>":  # row-major (n, 4, 4) world-to-clip matrices -> WGSL's columns
        x = np.swapaxes(x.reshape(n, 4, 4), 1, 2)
    return np.ascontiguousarray(x, np.float32).view(np.uint32).reshape(n, -1)


def call_function(module: str, name: str, params, returns: str, inputs, read_after=()) -> dict:
    """Call ``name`` (a function of WGSL ``module``, with parameter types ``params`` and
    result type ``returns``) once per row of ``inputs`` (a list of arrays, one per
    parameter, each with the calls along the first axis). Returns {leaf: array}: the
    result's fields (``"r"`` for a plain result, ``"r.v1"``... for a struct), float64
    for floats, bool for bool, int64 for integers. ``read_after``: names of ``u32``
    module-scope ``var<private>`` variables of ``module`` read after each call (e.g. the
    trap of :func:`grasswidget.core.student_wgsl.instrument`), returned under their names."""
    structs = _structs(module)
    n = len(np.asarray(inputs[0])) if inputs else 1
    lines, w = [], 0
    for k, ptype in enumerate(params):
        lines.append(f"    let a{k} = {_decode(ptype, w)};")
        w += _WORDS[ptype]
    leaves = _leaves(returns, structs) + [(var, "u32") for var in read_after]
    outs = [word for expr, ltype in leaves for word in _encode(expr, ltype)]
    lines.append(f"    let r = {name}({', '.join(f'a{k}' for k in range(len(params)))});")
    lines += [f"    probe_out[o + {k}u] = {word};" for k, word in enumerate(outs)]
    code = (module + "\n@group(0) @binding(0) var<storage, read> probe_in: array<u32>;\n"
            "@group(0) @binding(1) var<storage, read_write> probe_out: array<u32>;\n"
            f"@compute @workgroup_size({_GROUP})\nfn probe_main(@builtin(global_invocation_id) gid: vec3<u32>) {{\n"
            f"    let i = gid.x;\n    if (i >= {n}u) {{ return; }}\n    let b = i * {w}u;\n    let o = i * {len(outs)}u;\n"
            + "\n".join(lines) + "\n}\n")
    words = np.concatenate([_pack(t, x, n) for t, x in zip(params, inputs)], axis=1) if params else np.zeros((n, 1))
    device = ensure_device()
    usage = wgpu.BufferUsage
    b_in = device.create_buffer_with_data(data=np.ascontiguousarray(words, np.uint32).tobytes() or b"\0" * 4,
                                          usage=usage.STORAGE)
    b_out = device.create_buffer(size=max(4 * len(outs) * n, 4), usage=usage.STORAGE | usage.COPY_SRC)
    pipeline = device.create_compute_pipeline(
        layout="auto", compute={"module": device.create_shader_module(code=code), "entry_point": "probe_main"})
    group = device.create_bind_group(layout=pipeline.get_bind_group_layout(0), entries=[
        {"binding": 0, "resource": {"buffer": b_in}}, {"binding": 1, "resource": {"buffer": b_out}}])
    encoder = device.create_command_encoder()
    cpass = encoder.begin_compute_pass()
    cpass.set_pipeline(pipeline)
    cpass.set_bind_group(0, group)
    cpass.dispatch_workgroups(-(-n // _GROUP))
    cpass.end()
    device.queue.submit([encoder.finish()])
    raw = np.frombuffer(device.queue.read_buffer(b_out), np.uint32)[: len(outs) * n].reshape(n, len(outs))
    b_in.destroy()
    b_out.destroy()
    result, w = {}, 0
    for expr, ltype in leaves:
        k = _WORDS[ltype]
        block = raw[:, w: w + k]
        w += k
        if ltype == "bool":
            v = block.astype(bool)
        elif ltype in ("i32", "u32"):
            v = block.view(np.int32 if ltype == "i32" else np.uint32).astype(np.int64)
        else:
            v = block.view(np.float32).astype(np.float64)
        result[expr] = v[:, 0] if k == 1 else v
    return result
