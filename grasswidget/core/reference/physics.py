"""The blade physics of the reference: geometry, forces, wind, validation, collisions
and one simulation step (Jahrmann & Wimmer 2017, sections 5.1-5.2), and the forces the
blade inspector draws. Twins of ``shaders/blade_math.wgsl``, ``collisions.wgsl``,
``simulate.wgsl`` and ``inspect.wgsl`` (see :mod:`grasswidget.core.reference`)."""

from __future__ import annotations

import math

import numpy as np

from ..enums import BladeShape, GravityMode
from ...errors import GrassValueError
from .vectors import U32_MASK, dot, safe_normalize

__all__ = [
    "tangent_basis",
    "width_direction",
    "front_direction",
    "environmental_gravity",
    "gravity_point",
    "front_gravity",
    "wind_wave",
    "wind_pulse",
    "wind_radial",
    "wind_vortex",
    "noise_hash",
    "simplex_corner",
    "simplex_noise2",
    "NOISE_SCALE",
    "wind_noise",
    "wind_field",
    "wind_force",
    "integrate_tip",
    "validate_ground",
    "validate_v1",
    "validate_length",
    "finite3",
    "validate_finite",
    "curve_length",
    "sphere_push",
    "collide_sphere",
    "collide_spheres",
    "sphere_in_reach",
    "grid_cell",
    "COLLIDER_REACH",
    "fade_collision",
    "gain_collision",
    "effective_stiffness",
    "validate_pushed",
    "collision_passes",
    "validate_state",
    "tip_step",
    "COLLISION_MAX",
    "RECOVERY_FLOOR",
    "COLLISION_PASSES",
    "simulate_step",
    "simulate",
    "wind_period",
    "blade_forces",
    "FORCE_NAMES",
]


# --------------------------------------------------------------------------- geometry


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
    e1 = safe_normalize(ref - up * dot(ref, up)[..., None])
    e2 = np.cross(e1, up)
    return e1, e2


def width_direction(up, theta):
    """Width direction t1 of each blade: e1 rotated by theta in the tangent plane."""
    e1, e2 = tangent_basis(up)
    theta = np.asarray(theta, np.float64)[..., None]
    return np.cos(theta) * e1 + np.sin(theta) * e2


def front_direction(up, t1):
    """Front direction f = normalize(cross(up, t1)), the way the blade faces."""
    return safe_normalize(np.cross(np.asarray(up, np.float64), t1))


# --------------------------------------------------------------------------- forces


def environmental_gravity(v0, gravity_mode, direction=None, center=None, magnitude=None):
    """Environmental gravity per blade (paper eq. 1), ``magnitude`` in m/s^2.

    ``gravity_mode`` (a :class:`~grasswidget.core.enums.GravityMode` id or label)
    "direction": gE = normalize(direction) * magnitude (``params.gravity_direction``,
    default (0, -1, 0)). "point": gE = :func:`gravity_point` (v0, center, magnitude),
    the paper's gravity point, so grass on a small planet leans towards its centre
    (a root exactly at the centre feels none). ``v0`` is the (N, 3) roots; the
    result has v0's shape. Same signature as the WGSL twin.

    The earlier form ``environmental_gravity(params, v0)`` (params with ``gravity``,
    ``gravity_mode``, ``gravity_direction``, ``gravity_center``; v0 may then be an
    int N in direction mode) is still accepted.
    """
    if hasattr(v0, "gravity") and not isinstance(v0, np.ndarray):  # the (params, v0) form
        params, v0 = v0, gravity_mode
        mode = params.gravity_mode
        if isinstance(v0, (int, np.integer)):
            if mode == "point":
                raise GrassValueError("environmental_gravity needs the roots v0 (N, 3) when gravity_mode is 'point'")
            v0 = np.zeros((int(v0), 3))
        # Only the direction counts: scaled by its largest component first, so that a
        # direction like (1e300, 0, 0) does not overflow its length (as engine_inputs does for the GPU).
        direction = np.asarray(params.gravity_direction, np.float64)
        direction = direction / max(float(np.abs(direction).max()), 1e-300)
        return environmental_gravity(v0, mode, direction, params.gravity_center, params.gravity)
    mode = GravityMode.from_label(gravity_mode) if isinstance(gravity_mode, str) else GravityMode(int(gravity_mode))
    v0 = np.asarray(v0, np.float64)
    if mode == GravityMode.POINT:
        return gravity_point(v0, center, magnitude)
    d = safe_normalize(np.asarray(direction, np.float64))
    return np.broadcast_to(d * magnitude, v0.shape).copy()


def gravity_point(v0, center, magnitude):
    """Gravity towards a point: gE = safe_normalize(center - v0) * magnitude (gravity_mode "point")."""
    return safe_normalize(np.asarray(center, np.float64) - np.asarray(v0, np.float64)) * magnitude


def front_gravity(g_env, f, factor=0.25):
    """Front gravity gF = factor * |gE| * f (paper eq. 2; the paper uses 0.25)."""
    return factor * np.linalg.norm(g_env, axis=-1, keepdims=True) * f


def wind_period(params):
    """Period (s) after which the wind field repeats, or None if it is static or aperiodic.

    The wave, radial and vortex fields repeat every ``wind_wavelength / wind_speed``;
    the noise and custom fields do not repeat (None). Both sides pass time modulo
    this period, so float32 time on the GPU keeps its precision on long runs.
    """
    if params.wind_speed <= 0 or params.wind_field in ("noise", "custom"):
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


def wind_pulse(dist, t, speed, wavelength):
    """Rings travelling outwards at ``speed``: 0.7 + 0.3 sin(2 pi (dist - speed t) / wavelength)."""
    return 0.7 + 0.3 * np.sin(2.0 * math.pi * (dist - speed * t) / wavelength)


def wind_radial(p, t, strength, center, radius, speed, wavelength):
    """The "radial" wind field: away from ``center`` (helicopter downwash).

    With r = p - center (3D) and rho = |r| / radius::

        W = strength * 2 r / (radius (1 + rho^2)) * (0.7 + 0.3 sin(2 pi (|r| - speed t) / wavelength))

    |W| rises from 0 at the centre to ``strength`` * pulse at |r| = radius and falls
    as 1/|r| beyond (attenuated with distance); pulses travel outwards at ``speed``.
    A centre above the ground blows down and out, like a rotor's downwash.
    """
    p = np.asarray(p, np.float64)
    r = p - np.asarray(center, np.float64)
    dist = np.linalg.norm(r, axis=-1)
    rho = dist / radius
    k = strength * 2.0 / (radius * (1.0 + rho * rho)) * wind_pulse(dist, t, speed, wavelength)
    return r * k[..., None]


def wind_vortex(p, t, strength, center, radius, speed, wavelength):
    """The "vortex" wind field: tangential around the vertical (y) axis through ``center``.

    Same profile and pulse as :func:`wind_radial`, with r replaced by the tangent
    (-r.z, 0, r.x): the air turns from +x towards +z (clockwise seen from above,
    looking down -y).
    """
    p = np.asarray(p, np.float64)
    r = p - np.asarray(center, np.float64)
    dist = np.linalg.norm(r, axis=-1)
    rho = dist / radius
    k = strength * 2.0 / (radius * (1.0 + rho * rho)) * wind_pulse(dist, t, speed, wavelength)
    tangent = np.stack([-r[..., 2], np.zeros_like(dist), r[..., 0]], axis=-1)
    return tangent * k[..., None]


_F2 = 0.5 * (math.sqrt(3.0) - 1.0)
_G2 = (3.0 - math.sqrt(3.0)) / 6.0
#: Scales the sum of the three simplex corner terms to about [-1, 1].
NOISE_SCALE = 99.0


def noise_hash(i, j):
    """32-bit hash of integer lattice coordinates (i, j), as uint64 arrays holding u32.

    Two's-complement u32 of i and j, combined and mixed with Wellons' lowbias32;
    every product wraps modulo 2^32 exactly like WGSL u32 arithmetic.
    """
    iu = np.asarray(i, np.int64).astype(np.uint64) & U32_MASK
    ju = np.asarray(j, np.int64).astype(np.uint64) & U32_MASK
    h = ((iu * np.uint64(0x8DA6B343)) & U32_MASK) ^ ((ju * np.uint64(0xD8163841)) & U32_MASK)
    h ^= h >> np.uint64(16)
    h = (h * np.uint64(0x7FEB352D)) & U32_MASK
    h ^= h >> np.uint64(15)
    h = (h * np.uint64(0x846CA68B)) & U32_MASK
    h ^= h >> np.uint64(16)
    return h


def simplex_corner(x, y, i, j):
    """One corner's term of :func:`simplex_noise2`: max(0.5 - x^2 - y^2, 0)^4 * dot(g, (x, y)),
    g the unit gradient at angle (noise_hash(i, j) & 7) * 45 degrees."""
    t = 0.5 - x * x - y * y
    angle = (noise_hash(i, j) & np.uint64(7)).astype(np.float64) * (0.25 * math.pi)
    t2 = np.maximum(t, 0.0) ** 2
    return t2 * t2 * (np.cos(angle) * x + np.sin(angle) * y)


def simplex_noise2(x, y):
    """2D simplex noise (Perlin 2001, Gustavson's formulation), about [-1, 1].

    Skew to the simplex grid (F2 = (sqrt 3 - 1) / 2, G2 = (3 - sqrt 3) / 6), sum the
    three corners' ``max(0.5 - |d|^2, 0)^4 * dot(g, d)`` with unit gradients g at one
    of 8 angles k * 45 degrees picked by :func:`noise_hash`, times NOISE_SCALE.
    Continuous (C1) everywhere, so float32 and float64 evaluations agree closely.
    """
    x = np.asarray(x, np.float64)
    y = np.asarray(y, np.float64)
    s = (x + y) * _F2
    i = np.floor(x + s)
    j = np.floor(y + s)
    t = (i + j) * _G2
    x0 = x - (i - t)
    y0 = y - (j - t)
    i1 = (x0 > y0).astype(np.float64)
    j1 = 1.0 - i1
    x1 = x0 - i1 + _G2
    y1 = y0 - j1 + _G2
    x2 = x0 - 1.0 + 2.0 * _G2
    y2 = y0 - 1.0 + 2.0 * _G2
    ii, jj = i.astype(np.int64), j.astype(np.int64)
    n = (
        simplex_corner(x0, y0, ii, jj)
        + simplex_corner(x1, y1, ii + i1.astype(np.int64), jj + j1.astype(np.int64))
        + simplex_corner(x2, y2, ii + 1, jj + 1)
    )
    return NOISE_SCALE * n


def wind_noise(p, t, strength, direction_deg, speed, scale):
    """The "noise" wind field: coherent gusts from 2D simplex noise.

    With d the unit wind direction (``direction_deg`` in the xz plane) and the noise
    coordinate ``q = (p.xz - d * speed * t) / scale`` (the pattern drifts with the
    wind at ``speed`` m/s; ``scale`` is the gust size in metres)::

        angle = direction + (pi / 2) * simplex(q)               (+-90 degrees around d)
        amp   = strength * clamp(0.6 + 0.5 * simplex(q + (31.7, 17.3)), 0, 1)
        W     = amp * (cos angle, 0, sin angle)
    """
    p = np.asarray(p, np.float64)
    rad = math.radians(direction_deg)
    dx, dz = math.cos(rad), math.sin(rad)
    qx = (p[..., 0] - dx * speed * t) / scale
    qz = (p[..., 2] - dz * speed * t) / scale
    angle = rad + 0.5 * math.pi * simplex_noise2(qx, qz)
    amp = strength * np.clip(0.6 + 0.5 * simplex_noise2(qx + 31.7, qz + 17.3), 0.0, 1.0)
    out = np.zeros(p.shape)
    out[..., 0] = amp * np.cos(angle)
    out[..., 2] = amp * np.sin(angle)
    return out


def wind_field(p, t, params, user_wind=None):
    """W(p, t) for ``params.wind_field`` at positions p (N, 3) and time t (s).

    For "custom" the GPU runs the WGSL of ``params.wind_wgsl``; the reference
    cannot, so it takes ``user_wind``, a Python callable ``(p (N, 3), t) -> (N, 3)``
    equivalent to the snippet (an empty snippet, i.e. no callable, means no wind).
    """
    kind = params.wind_field
    if kind == "wave":
        return wind_wave(p, t, params.wind_strength, params.wind_direction, params.wind_speed, params.wind_wavelength)
    if kind in ("radial", "vortex"):
        fn = wind_radial if kind == "radial" else wind_vortex
        return fn(p, t, params.wind_strength, params.wind_center, params.wind_radius, params.wind_speed, params.wind_wavelength)
    if kind == "noise":
        return wind_noise(p, t, params.wind_strength, params.wind_direction, params.wind_speed, params.wind_wavelength)
    if kind == "custom":
        p = np.asarray(p, np.float64)
        if user_wind is None:
            if params.wind_wgsl.strip():
                raise GrassValueError(
                    "wind_field 'custom' runs WGSL on the GPU; the NumPy reference needs user_wind, "
                    "a Python callable (p, t) -> W equivalent to params.wind_wgsl"
                )
            return np.zeros(p.shape)
        return np.broadcast_to(np.asarray(user_wind(p, t), np.float64), p.shape).copy()
    raise GrassValueError(f"unknown wind_field {kind!r}")


def wind_force(W, v0, v2, up, height):
    """Wind on the tip: w = W * fd * fr (paper eq. 3-5).

    fd = 1 - |dot(normalize(W), normalize(v2 - v0))| (a blade already aligned with
    the wind feels less of it), fr = dot(v2 - v0, up) / h (an upright blade feels
    more than a flattened one). A zero wind gives zero force.
    """
    W = np.asarray(W, np.float64)
    wlen = np.linalg.norm(W, axis=-1)
    wdir = W / np.maximum(wlen, 1e-12)[..., None]
    blade = safe_normalize(v2 - v0)
    fd = 1.0 - np.abs(dot(wdir, blade))
    fr = dot(v2 - v0, up) / height
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
    return v2 - up * np.minimum(dot(up, v2 - v0), 0.0)[..., None]


def validate_v1(v0, v2, up, height):
    """Place v1 from how far the tip leans (paper eq. 6-7)::

        l_proj = |v2 - v0 - up dot(v2 - v0, up)|
        v1 = v0 + h up max(1 - l_proj / h, 0.05 max(l_proj / h, 1))
    """
    d = v2 - v0
    l_proj = np.linalg.norm(d - up * dot(d, up)[..., None], axis=-1)
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


# --------------------------------------------------------------------------- collisions

#: The collision strength eta is clamped to [0, COLLISION_MAX] after each push.
COLLISION_MAX = 1.0
#: Recovery is scaled by max(1 - eta, RECOVERY_FLOOR) (paper: 0.1).
RECOVERY_FLOOR = 0.1
#: Collision passes per step (push out of all spheres, then validate the pushed blades).
COLLISION_PASSES = 2


def sphere_push(p, center, radius):
    """Push that moves points p out of a sphere (paper section 5.1, "Collision")::

        d = (c - p) / |c - p| * (|c - p| - R)   if |c - p| < R, else 0

    (|c - p| - R < 0, so d points from the centre towards p). A point exactly at
    the centre is not pushed (no direction).
    """
    diff = np.asarray(center, np.float64) - np.asarray(p, np.float64)
    dist = np.linalg.norm(diff, axis=-1)
    k = np.where(dist < radius, (dist - radius) / np.maximum(dist, 1e-12), 0.0)
    return diff * k[..., None]


def collide_sphere(v0, v1, v2, sphere):
    """Push blades out of one sphere ``(cx, cy, cz, R)``; returns (v2, eta_add, hit).

    Push v2 by d = sphere_push(v2); then with the curve midpoint
    m = v0/4 + v1/2 + v2/4 (updated v2), push v2 by 4 d_m (moving v2 by 4 d moves
    m by d). ``eta_add`` = |d|^2 + |d_m|^2, ``hit`` = eta_add > 0.
    """
    c = np.asarray(sphere, np.float64)
    center, radius = c[..., :3], c[..., 3]
    v0, v1 = np.asarray(v0, np.float64), np.asarray(v1, np.float64)
    v2 = np.asarray(v2, np.float64)
    d_tip = sphere_push(v2, center, radius)
    v2 = v2 + d_tip
    d_mid = sphere_push(0.25 * v0 + 0.5 * v1 + 0.25 * v2, center, radius)
    v2 = v2 + 4.0 * d_mid
    add = dot(d_tip, d_tip) + dot(d_mid, d_mid)
    return v2, add, add > 0


#: A sphere acts on a blade only when it comes within this many blade heights of the
#: root (:func:`sphere_in_reach`). A validated blade's tip and midpoint lie within one
#: height of the root, so only a tip already pushed in the same pass could reach farther.
#: The collider grid (:mod:`grasswidget.core.collider_grid`) lists, per cell, every
#: sphere in reach of a root in that cell, so the GPU's per-cell loop and the loop over
#: all spheres here give the same result.
COLLIDER_REACH = 1.0


def sphere_in_reach(v0, height, sphere):
    """True where a sphere (cx, cy, cz, R) comes near enough to act on a blade rooted at v0
    (N, 3) of ``height`` (N,) m: ``|c - v0| < R + COLLIDER_REACH * height``."""
    c = np.asarray(sphere, np.float64)
    dist = np.linalg.norm(c[..., :3] - np.asarray(v0, np.float64), axis=-1)
    return dist < c[..., 3] + COLLIDER_REACH * np.asarray(height, np.float64)


def grid_cell(p, origin, inv_cell_size, nx, nz):
    """Cell index ``cz * nx + cx`` of the collider grid holding the points p (N, 3) (their x, z):
    ``cx = clamp(floor((p.x - origin.x) * inv_cell_size), 0, nx - 1)``, likewise cz with z;
    the border cells reach to infinity. Computed in float32 like the GPU, so both pick the
    same cell (see :mod:`grasswidget.core.collider_grid`)."""
    p = np.asarray(p, np.float32)
    origin = np.asarray(origin, np.float32)
    inv = np.asarray(inv_cell_size, np.float32)
    nx = np.asarray(nx, np.int64)
    nz = np.asarray(nz, np.int64)
    qx = (p[..., 0] - origin[..., 0]) * inv
    qz = (p[..., 2] - origin[..., 1]) * inv
    cx = np.clip(np.floor(qx), 0, nx - 1).astype(np.int64)
    cz = np.clip(np.floor(qz), 0, nz - 1).astype(np.int64)
    return (cz * nx + cx).astype(np.uint32)


def collide_spheres(v0, v1, v2, height, spheres):
    """One push of each blade out of every sphere in reach (:func:`sphere_in_reach`), in
    the spheres' order (:func:`collide_sphere`); returns (v2, eta_add, hit) with
    ``eta_add`` summed over the spheres and ``hit`` True where any push happened (those
    blades are validated again). ``spheres`` is (K, 4), any K.

    The twin of ``collide_spheres(v0, v1, v2, height)`` of ``shaders/collisions.wgsl``,
    which loops over the spheres listed in the blade's cell of the collider grid (every
    sphere in reach, in the same order), not over all of them."""
    v0 = np.asarray(v0, np.float64)
    v1 = np.asarray(v1, np.float64)
    height = np.asarray(height, np.float64)
    v2 = np.array(v2, np.float64, copy=True)
    add = np.zeros(len(v2))
    hit = np.zeros(len(v2), bool)
    for c in np.asarray(spheres, np.float64).reshape(-1, 4):
        near = sphere_in_reach(v0, height, c)
        if not near.any():
            continue
        pushed, add_c, hit_c = collide_sphere(v0, v1, v2, c)
        v2 = np.where(near[:, None], pushed, v2)
        add += np.where(near, add_c, 0.0)
        hit |= near & hit_c
    return v2, add, hit


def fade_collision(eta, fade, dt):
    """Collision strength fades linearly: eta' = max(eta - fade * dt, 0).

    Chosen over the author's (1 - s') * 0.5 * dt so that the recovery time is one
    documented number: a fully trampled blade (eta = 1) regains full stiffness
    after 1 / fade seconds (``params.collision_fade``, default 0.15 /s: 6.7 s).
    """
    return np.maximum(np.asarray(eta, np.float64) - fade * dt, 0.0)


def gain_collision(eta, add, gain):
    """Collision strength after a step's pushes: eta' = min(eta + gain * add, COLLISION_MAX).

    ``add`` is the step's sum of |d|^2 (m^2, from :func:`collision_passes`), ``gain``
    ``params.collision_gain`` (1/m^2, default 200; the paper adds |d|^2, gain 1).
    """
    return np.minimum(np.asarray(eta, np.float64) + gain * np.asarray(add, np.float64), COLLISION_MAX)


def effective_stiffness(stiffness, eta):
    """Recovery stiffness (1/s) of blades with collision strength eta (0..1):
    s * max(1 - eta, RECOVERY_FLOOR), so a trampled blade recovers slowly (paper 5.1)."""
    return np.asarray(stiffness, np.float64) * np.maximum(1.0 - np.asarray(eta, np.float64), RECOVERY_FLOOR)


def validate_pushed(v0, v1, v2, up, height, pushed):
    """The blades after one collision pass: where a sphere pushed them, the pushed
    tip validated again (:func:`validate_state`); elsewhere (v1, v2) unchanged.

    ``pushed`` is the pass's (v2, eta_add, hit) of :func:`collide_spheres`. Returns (v1, v2).
    """
    pushed_v2, _, hit = pushed
    v1c, v2c = validate_state(v0, pushed_v2, up, height)
    hit = np.asarray(hit, bool)[..., None]
    return np.where(hit, v1c, v1), np.where(hit, v2c, v2)


def collision_passes(v0, v1, v2, up, height, spheres):
    """The collisions of one step: COLLISION_PASSES (2) times, push the blades out of
    every sphere (:func:`collide_spheres`) and validate the pushed ones
    (:func:`validate_pushed`); validation moves some tips back in, a second pass
    halves that. ``spheres`` is (K, 4) (centre, radius; m), K may be 0.

    Returns (v1, v2, eta_add), eta_add the sum of |d|^2 (m^2) over the passes and
    spheres (for :func:`gain_collision`). The twin of ``collision_passes`` of
    ``shaders/collisions.wgsl``.
    """
    v1 = np.asarray(v1, np.float64)
    v2 = np.asarray(v2, np.float64)
    add_total = np.zeros(len(v0))
    if len(np.asarray(spheres).reshape(-1, 4)) == 0:
        return v1, v2, add_total
    for _ in range(COLLISION_PASSES):
        pushed = collide_spheres(v0, v1, v2, height, spheres)
        add_total = add_total + pushed[1]
        v1, v2 = validate_pushed(v0, v1, v2, up, height, pushed)
    return v1, v2, add_total


# --------------------------------------------------------------------------- one step


def validate_state(v0, v2, up, height):
    """The paper's state validation (section 5.2) of moved tips v2: keep v2 above the
    ground (:func:`validate_ground`), place v1 from the lean (:func:`validate_v1`),
    then scale the curve to length ``height`` (:func:`validate_length`). Returns (v1, v2)."""
    v2 = validate_ground(v0, v2, up)
    return validate_length(v0, validate_v1(v0, v2, up, height), v2, height)


def finite3(v):
    """Whether every component of each 3-vector of ``v`` ((..., 3)) is finite (neither NaN
    nor +-inf): a bool array of v's shape without the last axis."""
    return np.isfinite(np.asarray(v, np.float64)).all(axis=-1)


def validate_finite(v0, v1, v2, up, height, eta):
    """The last state validation of a step (after the paper's, section 5.2, and the
    collisions): a blade whose guides v1, v2 or collision strength ``eta`` are not all finite
    (a user's wind WGSL that returned NaN or inf) is put back at rest, v1 = v2 = v0 + up *
    height and eta = 0; any other blade is unchanged. Returns (v1, v2, eta, reset), reset
    the bool array of the blades put back."""
    v0, up = np.asarray(v0, np.float64), np.asarray(up, np.float64)
    v1, v2, eta = np.asarray(v1, np.float64), np.asarray(v2, np.float64), np.asarray(eta, np.float64)
    ok = finite3(v1) & finite3(v2) & np.isfinite(eta)
    rest = v0 + up * np.asarray(height, np.float64)[..., None]
    return (np.where(ok[..., None], v1, rest), np.where(ok[..., None], v2, rest), np.where(ok, eta, 0.0), ~ok)


def tip_step(v0, v2, up, height, stiffness, gravity, wind, dt):
    """One fixed step ``dt`` (s) of the tips, collisions aside (paper 5.1-5.2).

    ``wind`` is the wind field W at the roots (m/s^2, :func:`wind_field`), turned into
    the wind force by :func:`wind_force`; ``gravity`` is gE + gF (m/s^2); the recovery
    of ``stiffness`` (the effective stiffness, 1/s, :func:`effective_stiffness`)
    pulls towards v0 + up * height; :func:`integrate_tip` moves v2 and
    :func:`validate_state` validates it. Returns (v1, v2).
    """
    v0 = np.asarray(v0, np.float64)
    up = np.asarray(up, np.float64)
    height = np.asarray(height, np.float64)
    v2 = np.asarray(v2, np.float64)
    w = wind_force(wind, v0, v2, up, height)
    moved = integrate_tip(v2, v0 + up * height[..., None], stiffness, gravity + w, dt)
    return validate_state(v0, moved, up, height)


def _gravity(state, params):
    """g = gE + gF (m/s^2, (N, 3)) of each blade: environmental plus front gravity (eq. 1-2)."""
    v0 = np.asarray(state["v0"], np.float64)
    up = np.asarray(state["up"], np.float64)
    g_env = environmental_gravity(params, v0)
    return g_env + front_gravity(g_env, front_direction(up, width_direction(up, state["orientation"])),
                                 params.front_gravity)


def _step_collision_and_stiffness(state, params):
    """The step's faded collision strength eta ((N,), :func:`fade_collision`) and the
    effective stiffness ((N,), 1/s, :func:`effective_stiffness`)."""
    n = len(state["v0"])
    eta = fade_collision(state.get("collision", np.zeros(n)), params.collision_fade, params.dt)
    s = np.asarray(state["stiffness"], np.float64) * params.stiffness_scale
    return eta, effective_stiffness(s, eta)


def simulate_step(state, params, t, colliders=None, user_wind=None):
    """Advance a state dict by one fixed step ``params.dt`` at time t (s).

    1. Fade the collision strength (:func:`fade_collision`):
       eta = max(eta - collision_fade * dt, 0).
    2. Forces and validation (:func:`tip_step`, sections 5.1-5.2): gravity
       (direction or point), front gravity, wind, recovery with the effective
       stiffness s * max(1 - eta, 0.1) (:func:`effective_stiffness`); semi-implicit
       update of v2; validation: ground, v1, length.
    3. Collisions with ``colliders`` (SphereColliders, (center, radius) pairs or a
       (K, 4) array; :func:`collision_passes`): push v2 and the midpoint out of the
       spheres and validate the pushed blades again, COLLISION_PASSES (2) times
       (validation moves some tips back in; a second pass halves that); then
       eta += collision_gain * sum |d|^2 (clamped to COLLISION_MAX = 1;
       :func:`gain_collision`). The paper adds |d|^2 (gain 1); with small fixed
       steps the pushes are small, hence the gain (default 200).
    4. :func:`validate_finite`: a blade whose state is not finite any more (a user's
       wind that returned NaN or inf) goes back to rest, eta 0 (the GPU also sets one
       flag for Python's warning).

    The same functions in the same order as ``shaders/simulate.wgsl``.

    Limits of these local pushes (the paper's): a blade taller than the sphere's
    diameter can stay pierced through it (its midpoint inside), and a blade rooted
    where a sphere touches the ground cannot leave it. Spheres larger than the
    grass and resting on it (centre a little above radius) behave best.

    ``user_wind`` is the Python twin of ``params.wind_wgsl`` (wind_field "custom").
    The state's "collision" (eta, (N,)) is read (zeros when absent) and returned.
    Returns a new state dict (float64 copies of v1/v2/collision; other fields shared).
    """
    v0 = np.asarray(state["v0"], np.float64)
    up = np.asarray(state["up"], np.float64)
    h = np.asarray(state["height"], np.float64)
    v2 = np.asarray(state["v2"], np.float64)
    eta, s_eff = _step_collision_and_stiffness(state, params)
    v1, v2 = tip_step(v0, v2, up, h, s_eff, _gravity(state, params), wind_field(v0, t, params, user_wind), params.dt)
    with np.errstate(invalid="ignore", over="ignore"):  # a non-finite wind: validate_finite settles it
        v1, v2, add = collision_passes(v0, v1, v2, up, h, _spheres(colliders))
        eta = gain_collision(eta, add, params.collision_gain)
    v1, v2, eta, _reset = validate_finite(v0, v1, v2, up, h, eta)
    out = dict(state)
    out["v1"], out["v2"], out["collision"] = v1, v2, eta
    return out


def _spheres(colliders):
    if colliders is None:
        return np.zeros((0, 4))
    if isinstance(colliders, np.ndarray):
        return np.asarray(colliders, np.float64).reshape(-1, 4)
    from ..colliders import collider_array

    return collider_array(colliders)


def simulate(state, params, steps, first_step=0, colliders=None, user_wind=None):
    """Run ``steps`` fixed steps; step k (counting from ``first_step``) uses time
    ``(k * dt) mod wind_period`` exactly as the GPU does (``k * dt`` when the wind
    is aperiodic). ``colliders`` and ``user_wind`` as in :func:`simulate_step`."""
    period = wind_period(params)
    spheres = _spheres(colliders)
    for k in range(first_step, first_step + steps):
        t = k * params.dt
        if period:
            t = math.fmod(t, period)
        state = simulate_step(state, params, t, spheres, user_wind)
    return state



# --------------------------------------------------------------------------- forces, for the inspector

#: The arrows of the blade inspector, in drawing order (see :func:`blade_forces`).
FORCE_NAMES = ("gravity", "recovery", "wind", "collision")


def blade_forces(state, params, t, colliders=None, user_wind=None):
    """What moves each tip guide v2 in the next step from ``state``: three
    accelerations (m/s^2) and the collision push (m).

    Returns a dict of (N, 3) arrays, keyed by :data:`FORCE_NAMES`:

    - ``gravity``: g = gE + gF (environmental plus front gravity, eq. 1-2);
    - ``recovery``: r = (iv2 - v2) s_eff with s_eff = s * stiffness_scale *
      max(1 - eta, RECOVERY_FLOOR), eta the collision strength after this step's
      fade (the explicit form of the paper's eq. 4; the integrator takes it at the
      end of the step, see :func:`integrate_tip`);
    - ``wind``: w = W(v0, t) fd fr (eq. 3-5) at time ``t`` (s);
    - ``collision``: the displacement d (m, not an acceleration) by which the
      colliders push v2 in this step, after the forces and the validation, as
      :func:`simulate_step` does. Zero where no sphere touches the blade.

    The state is not changed. ``colliders`` and ``user_wind`` as in :func:`simulate_step`.
    """
    v0 = np.asarray(state["v0"], np.float64)
    up = np.asarray(state["up"], np.float64)
    h = np.asarray(state["height"], np.float64)
    v2 = np.asarray(state["v2"], np.float64)
    _, s_eff = _step_collision_and_stiffness(state, params)
    g = _gravity(state, params)
    wind = wind_field(v0, t, params, user_wind)
    w = wind_force(wind, v0, v2, up, h)
    r = (v0 + up * h[:, None] - v2) * s_eff[:, None]
    v1_step, v2_step = tip_step(v0, v2, up, h, s_eff, g, wind, params.dt)
    _, v2_pushed, _ = collision_passes(v0, v1_step, v2_step, up, h, _spheres(colliders))
    return {"gravity": g, "recovery": r, "wind": w, "collision": v2_pushed - v2_step}


