"""NumPy reference of the blade physics and the culling tests: the spec.

Everything here is vectorised over N blades and imports no GPU code. The WGSL
include ``shaders/blade_math.wgsl`` implements the same functions under the same
names, so the two can be read side by side. Equation numbers refer to Jahrmann &
Wimmer, "Responsive Real-Time Grass Rendering for General 3D Scenes", I3D 2017.

State dicts hold ``v0, v1, v2, up`` as (N, 3) and ``height, width, orientation,
stiffness`` as (N,) arrays (see :mod:`grasswidget.blades`). Computations run in
float64; the GPU runs float32 and agrees to ~1e-5 of the blade height.

Sign conventions chosen here (the sources differ): the width direction ``t1`` is
the tangent basis vector ``e1`` rotated by theta towards ``e2 = cross(e1, up)``, so
on a y-up plane ``t1 = (cos theta, 0, sin theta)``; the front direction is
``f = normalize(cross(up, t1))``.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "tangent_basis",
    "width_direction",
    "front_direction",
    "environmental_gravity",
    "front_gravity",
    "wind_wave",
    "wind_field",
    "wind_force",
    "integrate_tip",
    "validate_ground",
    "validate_v1",
    "validate_length",
    "curve_length",
    "simulate_step",
    "simulate",
    "wind_period",
    "LOD_SEGMENTS",
    "LOD_MIN_PIXELS",
    "orientation_cull",
    "frustum_cull",
    "distance_cull",
    "lod_class",
    "cull",
]

# --------------------------------------------------------------------------- geometry


def _normalize(v, eps=1e-12):
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.maximum(n, eps)


def _dot(a, b):
    return np.sum(a * b, axis=-1)


def tangent_basis(up):
    """Two unit vectors (e1, e2) spanning the plane orthogonal to ``up``.

    e1 is the x axis made orthogonal to up (the z axis when up is within ~25
    degrees of x); e2 = cross(e1, up). For up = +y this gives e1 = +x, e2 = +z.
    """
    up = np.asarray(up, np.float64)
    ref = np.zeros_like(up)
    near_x = np.abs(up[..., 0]) > 0.9
    ref[..., 0] = np.where(near_x, 0.0, 1.0)
    ref[..., 2] = np.where(near_x, 1.0, 0.0)
    e1 = _normalize(ref - up * _dot(ref, up)[..., None])
    e2 = np.cross(e1, up)
    return e1, e2


def width_direction(up, theta):
    """Width direction t1 of each blade: e1 rotated by theta in the tangent plane."""
    e1, e2 = tangent_basis(up)
    theta = np.asarray(theta, np.float64)[..., None]
    return np.cos(theta) * e1 + np.sin(theta) * e2


def front_direction(up, t1):
    """Front direction f = normalize(cross(up, t1)), the way the blade faces."""
    return _normalize(np.cross(np.asarray(up, np.float64), t1))


# --------------------------------------------------------------------------- forces


def environmental_gravity(params, n):
    """Environmental gravity gE = normalize(D.xyz) * D.w (paper eq. 1), per blade.

    D points down (-y) with magnitude ``params.gravity`` (m/s^2).
    """
    g = np.zeros((n, 3))
    g[:, 1] = -params.gravity
    return g


def front_gravity(g_env, f, factor=0.25):
    """Front gravity gF = factor * |gE| * f (paper eq. 2; the paper uses 0.25)."""
    return factor * np.linalg.norm(g_env, axis=-1, keepdims=True) * f


def wind_period(params):
    """Period (s) after which the wave field repeats, or None if it is static.

    Both sides pass time modulo this period, so float32 time on the GPU keeps
    its precision on long runs.
    """
    if params.wind_speed <= 0:
        return None
    return params.wind_wavelength / params.wind_speed


def wind_wave(p, t, strength, direction_deg, speed, wavelength):
    """The "wave" wind field W(p, t): a gust front travelling along a direction.

    With d the unit direction in the xz plane (``direction_deg``: 0 = +x, 90 = +z),
    d_perp = (-d.z, d.x) and the phase ``a = 2 pi (d . p.xz - speed t) / wavelength``::

        W = strength * d * (0.65 + 0.35 sin(a)) * (0.85 + 0.15 sin(2 pi (d_perp . p.xz) / (1.7 wavelength) + 0.5 a))

    So the wind never reverses, and crests (strong gusts) move with ``speed`` m/s.
    """
    p = np.asarray(p, np.float64)
    rad = math.radians(direction_deg)
    dx, dz = math.cos(rad), math.sin(rad)
    along = p[..., 0] * dx + p[..., 2] * dz
    across = -p[..., 0] * dz + p[..., 2] * dx
    a = 2.0 * math.pi * (along - speed * t) / wavelength
    b = 2.0 * math.pi * across / (1.7 * wavelength) + 0.5 * a
    amp = strength * (0.65 + 0.35 * np.sin(a)) * (0.85 + 0.15 * np.sin(b))
    out = np.zeros(p.shape)
    out[..., 0] = amp * dx
    out[..., 2] = amp * dz
    return out


def wind_field(p, t, params):
    """W(p, t) for ``params.wind_field`` at positions p (N, 3) and time t (s)."""
    if params.wind_field == "wave":
        return wind_wave(p, t, params.wind_strength, params.wind_direction, params.wind_speed, params.wind_wavelength)
    raise ValueError(f"unknown wind_field {params.wind_field!r}")


def wind_force(W, v0, v2, up, height):
    """Wind on the tip: w = W * fd * fr (paper eq. 3-5).

    fd = 1 - |dot(normalize(W), normalize(v2 - v0))| (a blade already aligned with
    the wind feels less of it), fr = dot(v2 - v0, up) / h (an upright blade feels
    more than a flattened one). A zero wind gives zero force.
    """
    W = np.asarray(W, np.float64)
    wlen = np.linalg.norm(W, axis=-1)
    wdir = W / np.maximum(wlen, 1e-12)[..., None]
    blade = _normalize(v2 - v0)
    fd = 1.0 - np.abs(_dot(wdir, blade))
    fr = _dot(v2 - v0, up) / height
    return W * (fd * fr)[..., None] * (wlen > 1e-12)[..., None]


def integrate_tip(v2, iv2, stiffness, accel, dt):
    """One step of v2 += (g + r + w) dt with the recovery r = (iv2 - v2) s taken
    at the end of the step (semi-implicit Euler)::

        v2' = (v2 + dt * (accel + s * iv2)) / (1 + s * dt),   accel = g + w

    This equals the paper's explicit update to first order in dt and stays
    stable for any stiffness (explicit Euler oscillates once s * dt > 2, which
    stiffness_scale up to 20 can reach).
    """
    s = np.asarray(stiffness, np.float64)[..., None]
    return v2 + dt * (accel + s * (iv2 - v2)) / (1.0 + s * dt)


# --------------------------------------------------------------------------- validation (5.2)


def validate_ground(v0, v2, up):
    """Keep v2 above the ground plane of the blade: v2 -= up * min(dot(up, v2 - v0), 0)."""
    return v2 - up * np.minimum(_dot(up, v2 - v0), 0.0)[..., None]


def validate_v1(v0, v2, up, height):
    """Place v1 from how far the tip leans (paper eq. 6-7)::

        l_proj = |v2 - v0 - up dot(v2 - v0, up)|
        v1 = v0 + h up max(1 - l_proj / h, 0.05 max(l_proj / h, 1))
    """
    d = v2 - v0
    l_proj = np.linalg.norm(d - up * _dot(d, up)[..., None], axis=-1)
    ratio = l_proj / height
    k = np.maximum(1.0 - ratio, 0.05 * np.maximum(ratio, 1.0))
    return v0 + up * (height * k)[..., None]


def curve_length(v0, v1, v2):
    """Approximate length of the quadratic Bezier: L = (2 L0 + L1) / 3 (paper eq. 8, n = 2)."""
    l0 = np.linalg.norm(v2 - v0, axis=-1)
    l1 = np.linalg.norm(v2 - v1, axis=-1) + np.linalg.norm(v1 - v0, axis=-1)
    return (2.0 * l0 + l1) / 3.0


def validate_length(v0, v1, v2, height):
    """Scale the curve so that its length equals h (paper eq. 9-10)::

        k = h / L,  v1' = v0 + k (v1 - v0),  v2' = v1' + k (v2 - v1)
    """
    k = (height / np.maximum(curve_length(v0, v1, v2), 1e-12))[..., None]
    v1n = v0 + k * (v1 - v0)
    v2n = v1n + k * (v2 - v1)
    return v1n, v2n


# --------------------------------------------------------------------------- one step


def simulate_step(state, params, t):
    """Advance a state dict by one fixed step ``params.dt`` at time t (s).

    Forces (section 5.1), then validation (section 5.2): ground, v1, length.
    Returns a new state dict (float64 copies of v1/v2; other fields shared).
    """
    v0 = np.asarray(state["v0"], np.float64)
    up = np.asarray(state["up"], np.float64)
    h = np.asarray(state["height"], np.float64)
    v2 = np.asarray(state["v2"], np.float64)
    s = np.asarray(state["stiffness"], np.float64) * params.stiffness_scale
    n = len(v0)
    t1 = width_direction(up, state["orientation"])
    f = front_direction(up, t1)
    g_env = environmental_gravity(params, n)
    g = g_env + front_gravity(g_env, f, params.front_gravity)
    w = wind_force(wind_field(v0, t, params), v0, v2, up, h)
    iv2 = v0 + up * h[:, None]
    v2 = integrate_tip(v2, iv2, s, g + w, params.dt)
    v2 = validate_ground(v0, v2, up)
    v1 = validate_v1(v0, v2, up, h)
    v1, v2 = validate_length(v0, v1, v2, h)
    out = dict(state)
    out["v1"], out["v2"] = v1, v2
    return out


def simulate(state, params, steps, first_step=0):
    """Run ``steps`` fixed steps; step k (counting from ``first_step``) uses time
    ``(k * dt) mod wind_period`` exactly as the GPU does."""
    period = wind_period(params)
    for k in range(first_step, first_step + steps):
        t = k * params.dt
        if period:
            t = math.fmod(t, period)
        state = simulate_step(state, params, t)
    return state


# --------------------------------------------------------------------------- culling

#: Segments along a blade for each level-of-detail class (class 0 = nearest).
LOD_SEGMENTS = (15, 8, 4, 2)
#: A blade goes to class k when its projected height in pixels is >= LOD_MIN_PIXELS[k].
LOD_MIN_PIXELS = (48.0, 20.0, 8.0, 0.0)


def orientation_cull(v0, t1, cam_pos, threshold=0.9):
    """True where a blade is seen edge-on: |dot(normalize(v0 - cam), t1)| > threshold."""
    dir_c = _normalize(np.asarray(v0, np.float64) - np.asarray(cam_pos, np.float64))
    return np.abs(_dot(dir_c, t1)) > threshold


def _clip(points, view_proj):
    p = np.concatenate([points, np.ones(points.shape[:-1] + (1,))], axis=-1)
    return p @ np.asarray(view_proj, np.float64).T


def _outside(clip, tol):
    x, y, z, w = clip[..., 0], clip[..., 1], clip[..., 2], clip[..., 3]
    lim = w + tol
    inside = (np.abs(x) <= lim) & (np.abs(y) <= lim) & (z >= 0) & (z <= w)
    return ~inside


def frustum_cull(v0, v1, v2, view_proj, tol=0.5):
    """True where v0, the curve midpoint m = v0/4 + v1/2 + v2/4 and v2 are all
    outside the view: a clip-space point is inside when |x|, |y| <= w + tol and
    0 <= z <= w (WebGPU depth range). ``view_proj`` maps world to clip (4x4)."""
    m = 0.25 * v0 + 0.5 * v1 + 0.25 * v2
    return _outside(_clip(v0, view_proj), tol) & _outside(_clip(m, view_proj), tol) & _outside(_clip(v2, view_proj), tol)


def distance_cull(v0, up, cam_pos, ids, buckets=100, d_max=100.0):
    """Bucketed thinning with ground distance (author's scheme)::

        d_proj = |v0 - c - up dot(v0 - c, up)|
        cull if id mod n >= ceil(n * max(1 - d_proj / d_max, 0))
    """
    d = np.asarray(v0, np.float64) - np.asarray(cam_pos, np.float64)
    d_proj = np.linalg.norm(d - up * _dot(d, up)[..., None], axis=-1)
    keep = np.ceil(buckets * np.maximum(1.0 - d_proj / d_max, 0.0))
    return (np.asarray(ids) % buckets) >= keep


def lod_class(v0, v2, height, view_proj, viewport_height):
    """Level-of-detail class per blade from its projected height in pixels.

    pixels = h * P11 * viewport_height / (2 w), with w the clip w of the curve's
    middle (v0 + v2) / 2 and P11 the vertical focal factor of ``view_proj``
    (the length of its second row's xyz part). Class k is the first with
    pixels >= LOD_MIN_PIXELS[k].
    """
    vp = np.asarray(view_proj, np.float64)
    mid = 0.5 * (np.asarray(v0, np.float64) + np.asarray(v2, np.float64))
    w = np.maximum(_clip(mid, vp)[..., 3], 1e-6)
    focal = np.linalg.norm(vp[1, :3])
    pixels = np.asarray(height, np.float64) * focal * viewport_height * 0.5 / w
    cls = np.full(len(mid), len(LOD_MIN_PIXELS) - 1)
    for k in reversed(range(len(LOD_MIN_PIXELS))):
        cls = np.where(pixels >= LOD_MIN_PIXELS[k], k, cls)
    return cls


def cull(state, params, view_proj, cam_pos, ids=None):
    """Which blades survive all enabled culling tests (bool (N,), True = drawn)."""
    v0, v1, v2, up = (np.asarray(state[k], np.float64) for k in ("v0", "v1", "v2", "up"))
    n = len(v0)
    ids = np.arange(n) if ids is None else ids
    culled = np.zeros(n, bool)
    if params.cull_orientation:
        t1 = width_direction(up, state["orientation"])
        culled |= orientation_cull(v0, t1, cam_pos, params.cull_orientation_threshold)
    if params.cull_frustum:
        culled |= frustum_cull(v0, v1, v2, view_proj, params.cull_frustum_tolerance)
    if params.cull_distance:
        culled |= distance_cull(v0, up, cam_pos, ids, params.cull_buckets, params.cull_distance_max)
    return ~culled
