"""The reference is the WGSL, enforced.

Every function of ``shaders/blade_math.wgsl`` has a NumPy twin of the same name in
``grasswidget/core/reference/``; each one runs here on random inputs on the GPU (a
small compute harness, lavapipe on CPU machines) and is compared with its twin.
The blade record of ``shaders/blade.wgsl`` is compared with ``blades.BLADE_LAYOUT``,
and the ids and constants the WGSL switches on come from one Python source.

Adding a function to blade_math.wgsl: add its NumPy twin to the module of its
subject in core/reference/ (named in that module's ``__all__`` and the package's)
and a line to TWINS below (how to draw inputs, how to call the twin); the name test
fails until both exist.
"""

import inspect
import math
import re

import numpy as np
import pytest
from conftest import HARNESS_BINDINGS

from grasswidget.core import reference as ref
from grasswidget.core.blades import BLADE_LAYOUT, pack_state
from grasswidget.core.collider_grid import GRID_HEADER_WORDS, build_collider_grid, collider_cell_range
from grasswidget.core.enums import BladeShape, ColorBy, GravityMode, WindField
from grasswidget.core.shader_files import read_shader, render_wgsl, template_vars

N = 256
WORDS = {"f32": 1, "i32": 1, "u32": 1, "bool": 1, "vec2<f32>": 2, "vec3<f32>": 3, "vec4<f32>": 4, "vec4<u32>": 4,
         "mat4x4<f32>": 16}


# ------------------------------------------------------------------ parsing the WGSL


def _functions(code):
    """{name: ([(param, type)], return type)} of the module-scope functions of ``code``."""
    out = {}
    for m in re.finditer(r"^fn (\w+)\(([^)]*)\)\s*(?:->\s*([\w<>]+))?\s*\{", code, re.M):
        params = [tuple(x.strip() for x in p.split(":")) for p in m.group(2).split(",") if p.strip()]
        out[m.group(1)] = (params, m.group(3))
    return out


def _structs(code):
    """{name: [(field, type)]} of the structs of ``code``."""
    out = {}
    for m in re.finditer(r"struct (\w+)\s*\{([^}]*)\}", code):
        fields = [tuple(x.strip() for x in f.split(":")) for f in m.group(2).split(",") if f.strip()]
        out[m.group(1)] = fields
    return out


BLADE_MATH = render_wgsl("blade_math.wgsl")
FUNCTIONS = _functions(BLADE_MATH)
STRUCTS = _structs(BLADE_MATH)


def test_every_wgsl_function_has_a_numpy_twin_of_the_same_name():
    assert len(FUNCTIONS) >= 30
    missing = sorted(n for n in FUNCTIONS if not callable(getattr(ref, n, None)))
    assert not missing, f"blade_math.wgsl functions without a NumPy twin in core/reference: {missing}"
    unexported = sorted(n for n in FUNCTIONS if n not in ref.__all__)
    assert not unexported, f"twins missing from reference.__all__: {unexported}"
    untested = sorted(set(FUNCTIONS) - set(TWINS))
    assert not untested, f"blade_math.wgsl functions with no GPU-vs-NumPy test (add them to TWINS): {untested}"


#: Twins whose NumPy signature differs from the WGSL one on purpose, and why.
DIFFERENT_SIGNATURE = {
    "wind_wave": "NumPy takes the direction in degrees, WGSL the unit vector (x, z) computed once per dispatch",
    "wind_noise": "NumPy takes the direction in degrees, WGSL the unit vector and its angle in radians",
    "sphere_push": "NumPy takes (center, radius), WGSL the packed vec4 of the collider uniform",
    "distance_cull": "NumPy takes the array of blade ids (ids), WGSL one id",
}


def test_parameter_names_match_except_documented():
    """Same parameter names, in the same order, e.g. environmental_gravity(v0, gravity_mode, direction, center, magnitude)."""
    wrong = {}
    for name, (params, _) in FUNCTIONS.items():
        if name in DIFFERENT_SIGNATURE:
            continue
        wgsl = [p for p, _ in params]
        numpy = list(inspect.signature(getattr(ref, name)).parameters)[: len(wgsl)]
        if wgsl != numpy:
            wrong[name] = (wgsl, numpy)
    assert not wrong, f"parameter names differ (WGSL, NumPy): {wrong}"
    assert [p for p, _ in FUNCTIONS["environmental_gravity"][0]] == ["v0", "gravity_mode", "direction", "center", "magnitude"]


# ------------------------------------------------------------------ the harness


def _words(ptype):
    """Words (u32) of one parameter or return value; structs count their fields."""
    if ptype in STRUCTS:
        return sum(_words(ftype) for _, ftype in STRUCTS[ptype])
    return WORDS[ptype]


def _decode(ptype, w):
    word = lambda k: f"harness_in[b + {w + k}u]"  # noqa: E731
    f = lambda k: f"bitcast<f32>({word(k)})"  # noqa: E731
    if ptype in STRUCTS:  # a struct parameter: its fields in order (e.g. validate_pushed's Collision)
        fields, offset = [], w
        for _, ftype in STRUCTS[ptype]:
            fields.append(_decode(ftype, offset))
            offset += _words(ftype)
        return f"{ptype}({', '.join(fields)})"
    if ptype == "f32":
        return f(0)
    if ptype == "i32":
        return f"bitcast<i32>({word(0)})"
    if ptype == "u32":
        return word(0)
    if ptype == "bool":
        return f"({word(0)} != 0u)"
    if ptype == "vec4<u32>":
        return f"vec4<u32>({', '.join(word(k) for k in range(4))})"
    if ptype.startswith("vec"):
        n = WORDS[ptype]
        return f"{ptype}({', '.join(f(k) for k in range(n))})"
    if ptype == "mat4x4<f32>":
        cols = [f"vec4<f32>({', '.join(f(4 * c + k) for k in range(4))})" for c in range(4)]
        return f"mat4x4<f32>({', '.join(cols)})"
    raise AssertionError(f"no decoder for {ptype}")


def _leaves(rtype, expr="r"):
    """[(expr, scalar or vector type)] of a return value, struct fields flattened in order."""
    if rtype in STRUCTS:
        return [leaf for field, ftype in STRUCTS[rtype] for leaf in _leaves(ftype, f"{expr}.{field}")]
    return [(expr, rtype)]


def _encode(expr, ltype):
    if ltype == "f32":
        return [f"bitcast<u32>({expr})"]
    if ltype == "u32":
        return [expr]
    if ltype == "i32":
        return [f"bitcast<u32>({expr})"]
    if ltype == "bool":
        return [f"select(0u, 1u, {expr})"]
    if ltype.startswith("vec"):
        return [f"bitcast<u32>({expr}.{c})" for c in "xyzw"[: WORDS[ltype]]]
    raise AssertionError(f"no encoder for {ltype}")


def _harness(name):
    params, rtype = FUNCTIONS[name]
    lines, w = [], 0
    for k, (_, ptype) in enumerate(params):
        lines.append(f"    let a{k} = {_decode(ptype, w)};")
        w += _words(ptype)
    lines.append(f"    let r = {name}({', '.join(f'a{k}' for k in range(len(params)))});")
    outs = [word for expr, ltype in _leaves(rtype) for word in _encode(expr, ltype)]
    lines += [f"    harness_out[o + {k}u] = {word};" for k, word in enumerate(outs)]
    code = BLADE_MATH + HARNESS_BINDINGS + f"""
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {{
    let i = gid.x;
    if (i >= {N}u) {{ return; }}
    let b = i * {w}u;
    let o = i * {len(outs)}u;
{chr(10).join(lines)}
}}
"""
    return code, w, len(outs)


def _pack_one(ptype, x):
    """(N, words) uint32 of one parameter; a struct parameter's input is a tuple of its fields."""
    if ptype in STRUCTS:
        return np.concatenate([_pack_one(ftype, xf) for (_, ftype), xf in zip(STRUCTS[ptype], x)], axis=1)
    x = np.asarray(x)
    if ptype in ("i32", "u32", "bool", "vec4<u32>"):
        words = x.astype(np.int64).astype(np.int32 if ptype == "i32" else np.uint32).view(np.uint32)
    else:
        words = np.ascontiguousarray(x, np.float32).view(np.uint32)
    return words.reshape(N, -1)


def _pack(params, inputs):
    return np.concatenate([_pack_one(ptype, x) for (_, ptype), x in zip(params, inputs)], axis=1)


def _as_gpu_sees(x):
    """Float inputs rounded to float32 (the GPU's view of them), tuples field by field."""
    if isinstance(x, tuple):
        return tuple(_as_gpu_sees(xf) for xf in x)
    return x if np.asarray(x).dtype.kind in "iub" else np.asarray(x, np.float32).astype(np.float64)


def _unpack(rtype, words):
    out, w = [], 0
    for _, ltype in _leaves(rtype):
        n = WORDS[ltype]
        block = words[:, w: w + n]
        w += n
        if ltype in ("f32",) or ltype.startswith("vec"):
            v = block.view(np.float32).astype(np.float64)
        elif ltype == "i32":
            v = block.view(np.int32).astype(np.int64)
        elif ltype == "bool":
            v = block.astype(bool)
        else:
            v = block.astype(np.uint64)
        out.append(v[:, 0] if n == 1 else v)
    return out


# ------------------------------------------------------------------ inputs and twins


def _unit(rng):
    v = rng.normal(size=(N, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _pts(rng, r=10.0):
    return rng.uniform(-r, r, (N, 3))


def _u(rng, lo, hi):
    return rng.uniform(lo, hi, N)


def _dir2(rng):
    a = _u(rng, -math.pi, math.pi)
    return np.stack([np.cos(a), np.sin(a)], axis=1)


def _view_proj(rng):
    """Per-row world-to-clip matrices (N, 4, 4), row-major: a perspective camera looking at the origin."""
    out = np.empty((N, 4, 4))
    for k in range(N):
        eye = rng.uniform(-15, 15, 3) + np.array([0, 8, 0])
        fwd = -eye / np.linalg.norm(eye)
        right = np.cross(fwd, [0, 1, 0])
        right /= np.linalg.norm(right)
        up = np.cross(right, fwd)
        view = np.eye(4)
        view[0, :3], view[1, :3], view[2, :3] = right, up, -fwd
        view[:3, 3] = -view[:3, :3] @ eye
        f, aspect, near, far = 1 / math.tan(math.radians(30)), rng.uniform(0.7, 2.0), 0.1, 100.0
        proj = np.zeros((4, 4))
        proj[0, 0], proj[1, 1] = f / aspect, f
        proj[2, 2], proj[2, 3] = far / (near - far), near * far / (near - far)
        proj[3, 2] = -1.0
        out[k] = proj @ view
    return out


def _rows(fn, *args):
    """Call a NumPy twin row by row (for twins that take one scalar parameter set)."""
    results = [fn(*(a[k] for a in args)) for k in range(N)]
    if isinstance(results[0], tuple):
        return tuple(np.array(list(r)) for r in zip(*results))
    return np.array(results)


def _deg(d):
    return np.degrees(np.arctan2(d[:, 1], d[:, 0]))


def _blade_state(rng):
    """v0, v1, v2, up, height of plausible blades (v1, v2 from a lean of the tip)."""
    v0, up = _pts(rng, 5.0), _unit(rng)
    h = _u(rng, 0.3, 2.0)
    v2 = v0 + up * h[:, None] + rng.normal(scale=0.6, size=(N, 3)) * h[:, None]
    v1 = ref.validate_v1(v0, v2, up, h)
    return v0, v1, v2, up, h


def _lattice(rng):
    return rng.integers(-10**6, 10**6, N)


def _spheres(rng, v2):
    center = v2 + rng.normal(scale=0.5, size=(N, 3))
    return np.concatenate([center, _u(rng, 0.2, 1.5)[:, None]], axis=1)


def _valid_blade(rng):
    """v0, v1, v2, up, height of blades that passed validation (length = height)."""
    v0, _, v2, up, h = _blade_state(rng)
    v1, v2 = ref.validate_state(v0, v2, up, h)
    return v0, v1, v2, up, h


def _pushed(rng, v2, h):
    """A collision pass's (v2, add, hit): tips pushed by up to ~h / 3 where hit (about half)."""
    hit = rng.uniform(0, 1, N) < 0.5
    moved = v2 + rng.normal(scale=0.3, size=(N, 3)) * h[:, None]
    return np.where(hit[:, None], moved, v2), np.where(hit, _u(rng, 1e-4, 0.1), 0.0), hit


def _spoil(rng, x, share=0.3):
    """x with NaN, +inf or -inf in about ``share`` of the rows (one component of a vector row)."""
    x = np.array(x, np.float64)
    rows = np.flatnonzero(rng.uniform(0, 1, N) < share)
    bad = rng.choice([np.nan, np.inf, -np.inf], len(rows))
    if x.ndim == 1:
        x[rows] = bad
    else:
        x[rows, rng.integers(0, x.shape[1], len(rows))] = bad
    return x


def _unsettled_blade(rng):
    """v0, v1, v2, up, height of validated blades and eta in [0, 1], about a third of the rows
    with a NaN or inf in v1, v2 or eta (what a NaN wind leaves after a step)."""
    v0, v1, v2, up, h = _valid_blade(rng)
    eta = _u(rng, 0.0, 1.0)
    which = rng.integers(0, 3, N)
    spoilt = [_spoil(rng, x, 0.3) for x in (v1, v2, eta)]
    v1 = np.where((which == 0)[:, None], spoilt[0], v1)
    v2 = np.where((which == 1)[:, None], spoilt[1], v2)
    eta = np.where(which == 2, spoilt[2], eta)
    return [v0, v1, v2, up, h, eta]


#: name -> (inputs(rng) in WGSL order, twin(*inputs) -> output or tuple, tolerance scale)
TWINS = {
    "finite3": (lambda r: [_spoil(r, _pts(r, 1e30), 0.5)], ref.finite3, 0),
    "validate_finite": (_unsettled_blade, ref.validate_finite, 5),
    "safe_normalize": (lambda r: [np.where(_u(r, 0, 1)[:, None] < 0.1, 0.0, _pts(r))], ref.safe_normalize, 1),
    "tangent_basis": (lambda r: [_unit(r)], ref.tangent_basis, 1),
    "width_direction": (lambda r: [_unit(r), _u(r, -4, 4)], ref.width_direction, 1),
    "front_direction": (lambda r: (lambda up: [up, ref.width_direction(up, _u(r, -4, 4))])(_unit(r)),
                        ref.front_direction, 1),
    "environmental_gravity": (
        lambda r: [_pts(r), r.integers(0, 2, N), _pts(r), _pts(r), _u(r, 0, 50)],
        lambda v0, mode, d, c, m: _rows(lambda *a: ref.environmental_gravity(a[0][None], int(a[1]), *a[2:])[0],
                                        v0, mode, d, c, m), 50),
    "gravity_point": (lambda r: [_pts(r), _pts(r), _u(r, 0, 50)],
                      lambda v0, c, m: ref.gravity_point(v0, c, m[:, None]), 50),
    "front_gravity": (lambda r: [_pts(r), _unit(r), _u(r, 0, 1)],
                      lambda g, f, k: ref.front_gravity(g, f, k[:, None]), 10),
    "wind_wave": (lambda r: [_pts(r), _u(r, 0, 20), _u(r, 0, 30), _dir2(r), _u(r, 0, 10), _u(r, 1, 20)],
                  lambda p, t, s, d, v, wl: _rows(ref.wind_wave, p, t, s, _deg(d), v, wl), 30),
    "wind_force": (lambda r: (lambda b: [_pts(r, 20.0), b[0], b[2], b[3], b[4]])(_blade_state(r)), ref.wind_force, 20),
    "integrate_tip": (lambda r: [_pts(r), _pts(r), _u(r, 0, 40), _pts(r, 50.0), _u(r, 1e-3, 0.05)],
                      lambda v2, iv2, s, a, dt: ref.integrate_tip(v2, iv2, s, a, dt[:, None]), 10),
    "validate_ground": (lambda r: [_pts(r), _pts(r), _unit(r)], ref.validate_ground, 10),
    "validate_v1": (lambda r: (lambda b: [b[0], b[2], b[3], b[4]])(_blade_state(r)), ref.validate_v1, 5),
    "curve_length": (lambda r: (lambda b: list(b[:3]))(_blade_state(r)), ref.curve_length, 5),
    "validate_length": (lambda r: (lambda b: [b[0], b[1], b[2], b[4]])(_blade_state(r)), ref.validate_length, 5),
    "wind_pulse": (lambda r: [_u(r, 0, 30), _u(r, 0, 20), _u(r, 0, 10), _u(r, 1, 20)], ref.wind_pulse, 1),
    "wind_radial": (lambda r: [_pts(r), _u(r, 0, 20), _u(r, 0, 30), _pts(r), _u(r, 0.5, 10), _u(r, 0, 10), _u(r, 1, 20)],
                    ref.wind_radial, 30),
    "wind_vortex": (lambda r: [_pts(r), _u(r, 0, 20), _u(r, 0, 30), _pts(r), _u(r, 0.5, 10), _u(r, 0, 10), _u(r, 1, 20)],
                    ref.wind_vortex, 30),
    "noise_hash": (lambda r: [_lattice(r), _lattice(r)], ref.noise_hash, 0),
    "simplex_corner": (lambda r: [_u(r, -0.8, 0.8), _u(r, -0.8, 0.8), _lattice(r), _lattice(r)], ref.simplex_corner, 1),
    "simplex_noise2": (lambda r: [_u(r, -10, 10), _u(r, -10, 10)], ref.simplex_noise2, 1),
    "wind_noise": (lambda r: (lambda d: [_pts(r), _u(r, 0, 20), _u(r, 0, 30), d, np.arctan2(d[:, 1], d[:, 0]),
                                         _u(r, 0, 5), _u(r, 2, 20)])(_dir2(r)),
                   lambda p, t, s, d, rad, v, sc: _rows(ref.wind_noise, p, t, s, np.degrees(rad), v, sc), 30),
    "sphere_push": (lambda r: (lambda p: [p, _spheres(r, p)])(_pts(r, 3.0)),
                    lambda p, c: ref.sphere_push(p, c[:, :3], c[:, 3]), 2),
    "collide_sphere": (lambda r: (lambda b: [b[0], b[1], b[2], _spheres(r, b[2])])(_blade_state(r)),
                       ref.collide_sphere, 5),
    "sphere_in_reach": (lambda r: (lambda v0: [v0, _u(r, 0.3, 2.0), np.concatenate(
                            [v0 + r.normal(scale=1.5, size=(N, 3)), _u(r, 0.2, 1.5)[:, None]], axis=1)])(_pts(r)),
                        ref.sphere_in_reach, 0),
    "grid_cell": (lambda r: [_pts(r, 12.0), r.uniform(-10, -2, (N, 2)), _u(r, 0.2, 3.0), r.integers(1, 40, N),
                             r.integers(1, 40, N)], ref.grid_cell, 0),
    "fade_collision": (lambda r: [_u(r, 0, 1), _u(r, 0, 2), _u(r, 1e-3, 0.1)], ref.fade_collision, 1),
    "gain_collision": (lambda r: [_u(r, 0, 1), _u(r, 0, 0.005), _u(r, 0, 400)], ref.gain_collision, 1),
    "effective_stiffness": (lambda r: [_u(r, 0, 40), _u(r, 0, 1)], ref.effective_stiffness, 1),
    "validate_pushed": (lambda r: (lambda b: [*b, _pushed(r, b[2], b[4])])(_valid_blade(r)), ref.validate_pushed, 5),
    "validate_state": (lambda r: (lambda b: [b[0], b[2], b[3], b[4]])(_blade_state(r)), ref.validate_state, 5),
    "tip_step": (lambda r: (lambda b: [b[0], b[2], b[3], b[4], _u(r, 0, 40), _pts(r, 15.0), _pts(r, 20.0),
                                       _u(r, 1e-3, 0.05)])(_valid_blade(r)),
                 lambda v0, v2, up, h, s, g, wind, dt: ref.tip_step(v0, v2, up, h, s, g, wind, dt[:, None]), 10),
    "orientation_cull": (lambda r: [_pts(r), _unit(r), _pts(r), _u(r, 0.5, 1.0)], ref.orientation_cull, 0),
    "clip_outside": (lambda r: [np.concatenate([_pts(r, 2.0), _u(r, 0.2, 2.0)[:, None]], axis=1), _u(r, 0, 0.5)],
                     ref.clip_outside, 0),
    "frustum_cull": (lambda r: (lambda b: [b[0], b[1], b[2], _view_proj(r), _u(r, 0, 0.5)])(_blade_state(r)),
                     lambda v0, v1, v2, vp, tol: _rows(lambda *a: ref.frustum_cull(*(x[None] for x in a[:3]), a[3], a[4])[0],
                                                       v0, v1, v2, vp, tol), 0),
    "distance_cull": (lambda r: [_pts(r, 50.0), _unit(r), _pts(r, 50.0), r.integers(0, 10**6, N), r.integers(1, 200, N),
                                 _u(r, 10, 100)], ref.distance_cull, 0),
    "projected_pixels": (lambda r: (lambda b: [b[0], b[2], b[4], _view_proj(r), _u(r, 100, 2000)])(_blade_state(r)),
                         lambda v0, v2, h, vp, vh: _rows(lambda *a: ref.projected_pixels(a[0], a[1], a[2], a[3], a[4]),
                                                         v0, v2, h, vp, vh), 100),
    "blade_shape_t": (lambda r: [_u(r, 0, 1), _u(r, 0, 1), r.integers(0, len(BladeShape), N), _u(r, 0, 0.99)],
                      lambda u, v, shape, tau: _rows(ref.blade_shape_t, u, v, shape, tau), 1),
    "hash01": (lambda r: [r.integers(0, 2**32, N)], ref.hash01, 1),
    "clump_noise": (lambda r: [_u(r, -50, 50), _u(r, -50, 50), _u(r, 0.5, 20)], ref.clump_noise, 1),
    "blade_base_color": (lambda r: [r.uniform(0, 0.6, (N, 3)), r.uniform(0.2, 1, (N, 3)), _u(r, -0.1, 1.1), _u(r, 0, 1),
                                    r.uniform(-1, 1, (N, 2)), _u(r, 0, 1), _u(r, 0, 1)], ref.blade_base_color, 1),
    "backlight": (lambda r: [_unit(r), _unit(r), _u(r, -0.1, 1.1), _u(r, 0, 1)], ref.backlight, 1),
    "fog_amount": (lambda r: [_u(r, -1, 400), _u(r, -0.01, 0.2)], ref.fog_amount, 1),
    "sky_color": (lambda r: [_u(r, -1, 1), r.uniform(0, 1, (N, 3)), r.uniform(0, 1, (N, 3))], ref.sky_color, 1),
    "field_inside": (lambda r: [_u(r, -20, 20), _u(r, -20, 20), r.uniform(-5, 5, (N, 2)), r.uniform(1, 15, (N, 2)),
                                _u(r, 0.1, 2)], ref.field_inside, 10),
    "ground_color": (lambda r: [r.uniform(0, 1, (N, 3)), r.uniform(0, 1, (N, 3)), _u(r, -0.2, 1.2), _u(r, 0, 1)],
                     ref.ground_color, 1),
    "occlusion_bounds": (
        lambda r: (lambda b: [b[0], b[1], b[2], _u(r, 0.0, 0.3), _view_proj(r),
                              np.stack([_u(r, 100, 2000), _u(r, 100, 1200)], axis=1)])(_blade_state(r)),
        lambda v0, v1, v2, rad, vp, size: _rows(lambda *a: ref.occlusion_bounds(*a), v0, v1, v2, rad, vp, size), 100),
    "hzb_level": (lambda r: (lambda x, y: [np.stack([x, y, x + r.exponential(40.0, N), y + r.exponential(20.0, N)],
                                                    axis=1)])(_u(r, 0, 800), _u(r, 0, 600)),
                  ref.hzb_level, 0),
    "ball_shadow": (lambda r: (lambda p, sun: [p, sun, np.concatenate(
        [p + sun * _u(r, -1.0, 4.0)[:, None] + r.normal(scale=0.6, size=(N, 3)),
         np.where(_u(r, 0, 1) < 0.15, 0.0, _u(r, 0.1, 1.0))[:, None]], axis=1)])(_pts(r, 3.0), _unit(r)),
        ref.ball_shadow, 1),
    "grass_transmittance": (lambda r: [_u(r, -9, 9), _u(r, -9, 9), _u(r, -0.2, 1.5), _unit(r) * [1, 0, 1] + [0, 1, 0]
                                       * _u(r, 0.02, 1.0)[:, None], r.uniform(-2, 2, (N, 2)), r.uniform(1, 6, (N, 2)),
                                       _u(r, 0.1, 1.0), _u(r, 0.0, 6.0)], ref.grass_transmittance, 1),
    "sky_visibility": (lambda r: [_u(r, -9, 9), _u(r, -9, 9), _u(r, -0.2, 1.5), r.uniform(-2, 2, (N, 2)),
                                  r.uniform(1, 6, (N, 2)), _u(r, 0.1, 1.0), _u(r, 0.0, 6.0)], ref.sky_visibility, 1),
    "grass_above": (lambda r: [_u(r, -0.2, 1.2), _u(r, 0.1, 2.0)], ref.grass_above, 1),
    "light_share": (lambda r: [_u(r, 0, 1), _u(r, 0, 1), _u(r, -0.1, 1.1), _u(r, 0.3, 1.2), _u(r, 0, 1)],
                    ref.light_share, 1),
    "blade_shade": (lambda r: [_unit(r), _unit(r), _u(r, 0, 1), r.uniform(0, 1, (N, 3)), _u(r, 0, 1.5), _u(r, 0, 1),
                               r.uniform(0, 1, (N, 3)), _unit(r), _u(r, 0, 1)], ref.blade_shade, 1),
    "clip_to_pixel": (lambda r: [_clip_points(r), _viewports(r)], ref.clip_to_pixel, 2000),
    "raster_step": (lambda r: [r.uniform(0, 300, (N, 2)), r.uniform(0, 300, (N, 2)), r.uniform(0, 300, (N, 2)),
                               _u(r, 0, 1)], ref.raster_step, 1),
    "raster_section": (lambda r: [_clip_points(r), _clip_points(r), _clip_points(r), r.uniform(-20, 20, (N, 2)),
                                  _u(r, 0, 1), r.integers(0, len(BladeShape), N), _u(r, 0, 0.99), _viewports(r)],
                       ref.raster_section, 2000),
    "raster_cover": (lambda r: [r.integers(0, 2**24, N), r.integers(0, 256, N), _u(r, 0, 20)], ref.raster_cover, 0),
    "raster_payload": (lambda r: [r.integers(0, 2**24, N), _u(r, 0, 1)], ref.raster_payload, 0),
    "level_index": (lambda r: (lambda ends: [r.integers(0, 2**20, N), ends[:, :4], ends[:, 4:], r.integers(0, 9, N)])(
                        _level_ends(r)), ref.level_index, 0),
    "wrap_shift": (lambda r: [r.uniform(-500, 500, (N, 2)), r.uniform(-500, 500, (N, 2)), _u(r, 1.0, 400.0)],
                   ref.wrap_shift, 400),
    "level_weight": (lambda r: [_u(r, -1.0, 120.0), _level_bands(r)], ref.level_weight, 1),
}


def _level_ends(rng):
    """(N, 8) ascending level ends (ids, u32) below 2^20, the unused tail 0xffffffff."""
    ends = np.sort(rng.integers(1, 2**20, (N, 8)), axis=1)
    return np.where(np.arange(8)[None, :] >= rng.integers(1, 9, N)[:, None], 0xFFFFFFFF, ends)


def _level_bands(rng):
    """(N, 4) bands in metres: in_start < in_end <= out_start < out_end; a fifth are level 0's (rise -2..-1)."""
    b = np.sort(rng.uniform(0.0, 100.0, (N, 4)), axis=1) + np.array([0.0, 0.5, 0.5, 1.0])
    first = rng.uniform(0, 1, N) < 0.2
    b[first, 0], b[first, 1] = -2.0, -1.0
    return b


def _clip_points(rng):
    """Clip-space points in front of the camera (w in [0.5, 5])."""
    w = rng.uniform(0.5, 5.0, N)
    return np.stack([rng.uniform(-1, 1, N) * w, rng.uniform(-1, 1, N) * w, rng.uniform(0, 1, N) * w, w], axis=1)


def _viewports(rng):
    return np.stack([rng.uniform(100, 2000, N), rng.uniform(100, 1200, N)], axis=1)


def _to_wgsl_inputs(params, inputs):
    """Matrices go to the GPU column by column (WGSL mat4x4 is column-major)."""
    out = []
    for (_, ptype), x in zip(params, inputs):
        out.append(np.transpose(x, (0, 2, 1)).reshape(N, 16) if ptype == "mat4x4<f32>" else x)
    return out


@pytest.mark.parametrize("name", sorted(TWINS))
def test_wgsl_function_equals_numpy_twin(name, run_compute):
    assert name in FUNCTIONS, f"{name} is not a function of blade_math.wgsl"
    make_inputs, twin, scale = TWINS[name]
    rng = np.random.default_rng(sum(map(ord, name)))
    params, rtype = FUNCTIONS[name]
    inputs = make_inputs(rng)
    # The GPU sees float32 inputs: give the twin the same (rounded) values.
    inputs = [_as_gpu_sees(x) for x in inputs]
    code, w_in, w_out = _harness(name)
    words = run_compute(code, _pack(params, _to_wgsl_inputs(params, inputs)), w_out, N)
    gpu = _unpack(rtype, words)
    cpu = twin(*inputs)
    cpu = list(cpu) if isinstance(cpu, tuple) else [cpu]
    assert len(gpu) == len(cpu), f"{name}: WGSL returns {len(gpu)} values, NumPy {len(cpu)}"
    for k, (g, c) in enumerate(zip(gpu, cpu)):
        c = np.asarray(c)
        if g.dtype == bool or c.dtype == bool or scale == 0:
            mismatch = np.flatnonzero(np.asarray(g).reshape(N, -1).astype(np.int64) != c.reshape(N, -1).astype(np.int64))
            assert mismatch.size == 0, f"{name} value {k}: {mismatch.size} of {N} differ, e.g. row {mismatch[:1]}"
        else:
            c = c.astype(np.float64).reshape(g.shape)
            err = np.abs(g - c)
            tol = 2e-5 * max(scale, 1.0) + 2e-5 * np.abs(c)
            worst = int(np.argmax((err - tol).reshape(N, -1).max(axis=1)))
            assert np.all(err <= tol), (f"{name} value {k}: max |wgsl - numpy| {err.max():.3g} "
                                        f"(row {worst}: wgsl {g[worst]}, numpy {c[worst]})")
    # The test must be able to fail: the values vary across the random inputs.
    assert any(np.ptp(np.asarray(g, np.float64)) > 0 for g in gpu), f"{name}: constant output, weak inputs"


# ------------------------------------------------------------------ the collision include

#: Colliders per row in the collision include's test (the row's own collider grid).
K_SPHERES = 6
#: Cells of each row's grid (small, so that spheres straddle cells and lists differ).
GRID_CELLS = 4
#: Words of the stand-in s_collider_grid of a row: header, cell table, lists.
GRID_ROW_WORDS = GRID_HEADER_WORDS + 2 * GRID_CELLS + GRID_CELLS * K_SPHERES


def test_collision_include_equals_numpy_twins(run_compute):
    """collisions.wgsl (the loop over the spheres listed in the blade's grid cell) against
    reference.collide_spheres / collision_passes (every sphere) and collider_grid.collider_cell_range:
    per row a blade, 0..K_SPHERES spheres around it (some out of reach) and their grid, built by
    build_collider_grid over a few cells around the blade, as the stand-in s_colliders /
    s_collider_grid the include reads."""
    rng = np.random.default_rng(16)
    v0, v1, v2, up, h = _valid_blade(rng)
    mid = 0.25 * v0 + 0.5 * v1 + 0.25 * v2
    spheres = np.empty((N, K_SPHERES, 4))
    spheres[..., :3] = np.where(rng.uniform(0, 1, (N, K_SPHERES, 1)) < 0.5, v2[:, None], mid[:, None])
    far = rng.uniform(0, 1, (N, K_SPHERES, 1)) < 0.25  # out of reach, or nearly
    spread = np.where(far, 3.0, 0.4)
    spheres[..., :3] += rng.normal(size=(N, K_SPHERES, 3)) * spread * h[:, None, None]
    spheres[..., 3] = rng.uniform(0.1, 0.6, (N, K_SPHERES)) * h[:, None]
    n_colliders = rng.integers(0, K_SPHERES + 1, N)
    inputs = [_as_gpu_sees(x) for x in (v0, v1, v2, up, h, spheres)]
    v0, v1, v2, up, h, spheres = inputs
    grids = np.zeros((N, GRID_ROW_WORDS), np.uint32)
    for k in range(N):
        lo = v0[k] - rng.uniform(0.5, 3.0, 3) * h[k]
        hi = v0[k] + rng.uniform(0.5, 3.0, 3) * h[k]
        words = build_collider_grid(spheres[k, : n_colliders[k]], (lo[0], lo[2], hi[0], hi[2]), h[k],
                                    max_cells=GRID_CELLS, one_cell_max=0).words()
        grids[k, : len(words)] = words
    words = np.concatenate([_pack_one("i32", n_colliders), _pack_one("vec4<f32>", spheres.reshape(N, -1)), grids]
                           + [_pack_one(t, x) for t, x in zip(("vec3<f32>",) * 4 + ("f32",), (v0, v1, v2, up, h))],
                           axis=1)
    w_in = words.shape[1]
    g = 1 + 4 * K_SPHERES  # where the grid starts in a row
    s = g + GRID_ROW_WORDS  # where the blade starts
    code = BLADE_MATH + HARNESS_BINDINGS + f"""
struct HarnessSim {{ n_colliders: i32 }};
var<private> u_sim: HarnessSim;
var<private> s_colliders: array<vec4<f32>, {K_SPHERES}>;
var<private> s_collider_grid: array<u32, {GRID_ROW_WORDS}>;
""" + render_wgsl("collisions.wgsl") + f"""
fn vec3_at(k: u32) -> vec3<f32> {{
    return vec3<f32>(bitcast<f32>(harness_in[k]), bitcast<f32>(harness_in[k + 1u]), bitcast<f32>(harness_in[k + 2u]));
}}
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {{
    let i = gid.x;
    if (i >= {N}u) {{ return; }}
    let b = i * {w_in}u;
    u_sim.n_colliders = bitcast<i32>(harness_in[b]);
    for (var c = 0u; c < {K_SPHERES}u; c = c + 1u) {{
        s_colliders[c] = vec4<f32>(vec3_at(b + 1u + 4u * c), bitcast<f32>(harness_in[b + 4u + 4u * c]));
    }}
    for (var w = 0u; w < {GRID_ROW_WORDS}u; w = w + 1u) {{ s_collider_grid[w] = harness_in[b + {g}u + w]; }}
    let v0 = vec3_at(b + {s}u);
    let v1 = vec3_at(b + {s + 3}u);
    let v2 = vec3_at(b + {s + 6}u);
    let up = vec3_at(b + {s + 9}u);
    let h = bitcast<f32>(harness_in[b + {s + 12}u]);
    let pushed = collide_spheres(v0, v1, v2, h);
    let collided = collision_passes(v0, v1, v2, up, h);
    let list = collider_cell_range(v0);
    let o = i * 14u;
    let outs = array<f32, 12>(pushed.v2.x, pushed.v2.y, pushed.v2.z, pushed.add, select(0.0, 1.0, pushed.hit),
                              collided.v1.x, collided.v1.y, collided.v1.z, collided.v2.x, collided.v2.y, collided.v2.z,
                              collided.add);
    for (var k = 0u; k < 12u; k = k + 1u) {{ harness_out[o + k] = bitcast<u32>(outs[k]); }}
    harness_out[o + 12u] = list.x;
    harness_out[o + 13u] = list.y;
}}
"""
    out = run_compute(code, words, 14, N)
    gpu = out[:, :12].view(np.float32).astype(np.float64)
    ranges = np.array([[int(x[0]) for x in collider_cell_range(v0[k: k + 1], grids[k])] for k in range(N)])
    assert np.array_equal(out[:, 12:14].astype(np.int64), ranges), "collider_cell_range differs from its twin"
    cpu = np.zeros((N, 12))
    for k in range(N):
        row = spheres[k, : n_colliders[k]]
        pv2, padd, phit = ref.collide_spheres(v0[k: k + 1], v1[k: k + 1], v2[k: k + 1], h[k: k + 1], row)
        cv1, cv2, cadd = ref.collision_passes(v0[k: k + 1], v1[k: k + 1], v2[k: k + 1], up[k: k + 1], h[k: k + 1], row)
        cpu[k] = np.concatenate([pv2[0], padd, phit.astype(float), cv1[0], cv2[0], cadd])
    hit = cpu[:, 4] > 0
    assert 0.2 < hit.mean() < 0.9, f"weak inputs: {hit.mean():.0%} of the rows collide"
    assert not hit[n_colliders == 0].any()
    # the grids have several cells and leave spheres out of some lists (the test can tell a grid from a loop)
    assert (grids[:, 0] * grids[:, 1] > 1).mean() > 0.5 and (ranges[:, 1] < n_colliders).any()
    assert np.array_equal(gpu[:, 4], cpu[:, 4]), "hit differs"
    err = np.abs(gpu - cpu)
    tol = 1e-4 * np.maximum(h, 1.0)[:, None] + 2e-5 * np.abs(cpu)
    worst = int(np.argmax((err - tol).max(axis=1)))
    assert np.all(err <= tol), f"max |wgsl - numpy| {err.max():.3g} (row {worst}: wgsl {gpu[worst]}, numpy {cpu[worst]})"
    moved = np.linalg.norm(cpu[:, 8:11] - v2, axis=1)
    assert np.median(moved[hit]) > 1e-3, "the passes must move the blades they hit"


# ------------------------------------------------------------------ blade record and shared ids


def test_blade_struct_is_the_twin_of_the_python_packing():
    code = read_shader("blade.wgsl")
    fields = [f for f, _ in _structs(code)["Blade"]]
    assert fields == [name for row in BLADE_LAYOUT for name in row]
    # load_blade reads row k into (vec3 field, scalar field) of BLADE_LAYOUT[k], store_blade writes it back
    for k, (vec, scalar) in enumerate(BLADE_LAYOUT):
        assert f"let r{k} = s_blades[4u * i + {k}u];" in code
        assert f"s_blades[4u * i + {k}u] = vec4<f32>(b.{vec}, b.{scalar});" in code


def test_blade_load_store_round_trip_on_the_gpu(run_compute):
    """load_blade(i) of a packed state gives each field; store_blade writes the same bytes back."""
    rng = np.random.default_rng(4)
    state = {"v0": _pts(rng), "v1": _pts(rng), "v2": _pts(rng), "up": _unit(rng),
             "orientation": _u(rng, -3, 3), "height": _u(rng, 0.3, 2), "width": _u(rng, 0.01, 0.1),
             "stiffness": _u(rng, 1, 20)}
    packed = pack_state(state).reshape(N, 16)
    fields = [name for row in BLADE_LAYOUT for name in row]
    body = "\n".join(f"    harness_out[16u * i + {k}u] = bitcast<u32>(b.{f}{'.' + c if n == 3 else ''});"
                     for k, (f, c, n) in enumerate(_field_words(fields)))
    code = render_wgsl("{$ include 'grasswidget.blade.wgsl' $}", blades_writable=True).replace(
        "s_blades", "s_blades") + """
@group(0) @binding(0) var<storage, read> harness_in: array<u32>;
@group(0) @binding(1) var<storage, read_write> harness_out: array<u32>;
var<private> s_blades: array<vec4<f32>, 4>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if (i >= %du) { return; }
    for (var r = 0u; r < 4u; r = r + 1u) {
        s_blades[r] = bitcast<vec4<f32>>(vec4<u32>(harness_in[16u * i + 4u * r], harness_in[16u * i + 4u * r + 1u],
                                                   harness_in[16u * i + 4u * r + 2u], harness_in[16u * i + 4u * r + 3u]));
    }
    let b = load_blade(0u);
    store_blade(0u, b);
%s
}
""" % (N, body)
    words = run_compute(code, packed.view(np.uint32), 16, N)
    got = words.view(np.float32)
    offset = 0
    for f in fields:
        n = np.asarray(state[f]).reshape(N, -1).shape[1]
        assert np.array_equal(got[:, offset: offset + n].reshape(np.asarray(state[f], np.float32).shape),
                              np.asarray(state[f], np.float32)), f
        offset += n


def _field_words(fields):
    """(field, component, width) per output word: vec3 fields give 3 words, scalars 1."""
    vec3 = {vec for vec, _ in BLADE_LAYOUT}
    out = []
    for f in fields:
        out += [(f, c, 3) for c in "xyz"] if f in vec3 else [(f, "", 1)]
    return out


def test_ids_and_constants_come_from_python():
    """No hand-written copies: the WGSL switches on the enums' ids and uses the reference's constants."""
    v = template_vars()
    for enum, prefix in ((WindField, "wind_field"), (BladeShape, "blade_shape"), (GravityMode, "gravity_mode"),
                         (ColorBy, "color_by")):
        for m in enum:
            assert v[f"{prefix}_{m.name.lower()}"] == int(m)
    assert v["collision_passes"] == ref.COLLISION_PASSES
    assert float(v["recovery_floor"]) == ref.RECOVERY_FLOOR and float(v["collision_max"]) == ref.COLLISION_MAX
    assert float(v["noise_scale"]) == ref.NOISE_SCALE
    # wind_field() and the collision passes live in includes
    simulate = read_shader("simulate.wgsl") + read_shader("wind_field.wgsl") + read_shader("collisions.wgsl")
    for m in WindField:
        if m != WindField.WAVE:
            assert f"case {{{{ wind_field_{m.name.lower()} }}}}" in simulate
    assert re.search(r"case \d", simulate + read_shader("blade_math.wgsl")) is None, "a literal id in a switch"
    for literal in ("99.0", "0.1)", "const COLLISION_PASSES: i32 = 2"):
        assert literal not in simulate + read_shader("blade_math.wgsl"), literal
    # and the rendered shader has the values
    rendered = render_wgsl("simulate.wgsl")
    assert f"case {int(WindField.NOISE)}:" in rendered
    assert f"max(1.0 - eta, {v['recovery_floor']})" in rendered


def test_shared_includes_are_engine_neutral():
    """The includes another engine reuses declare no bindings of pygfx's (it prepends its own)."""
    for name in ("blade.wgsl", "blade_math.wgsl", "wind_field.wgsl", "collisions.wgsl", "simulate.wgsl", "cull.wgsl"):
        code = read_shader(name)
        assert "@group(" not in code and "bindings_code" not in code and "pygfx" not in code, name
        render_wgsl(name)  # renders without pygfx
