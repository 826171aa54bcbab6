"""NumPy reference of the blade physics and the culling tests: the spec.

Everything here is vectorised over N blades and imports no GPU code. The WGSL
include ``grasswidget/shaders/blade_math.wgsl`` implements the same functions under the same
names (``shaders/collisions.wgsl`` the loop over the colliders: ``collide_spheres``,
``collision_passes``), so the two can be read side by side: :func:`simulate_step` is
``simulate.wgsl``'s step (fade_collision, tip_step, collision_passes, gain_collision),
:func:`blade_forces` ``inspect.wgsl``'s. Equation numbers refer to Jahrmann &
Wimmer, "Responsive Real-Time Grass Rendering for General 3D Scenes", I3D 2017.

State dicts hold ``v0, v1, v2, up`` as (N, 3) and ``height, width, orientation,
stiffness`` as (N,) arrays (see :mod:`grasswidget.core.blades`). Computations run in
float64; the GPU runs float32 and agrees to ~1e-5 of the blade height.

Sign conventions chosen here (the sources differ): the width direction ``t1`` is
the tangent basis vector ``e1`` rotated by theta towards ``e2 = cross(e1, up)``, so
on a y-up plane ``t1 = (cos theta, 0, sin theta)``; the front direction is
``f = normalize(cross(up, t1))``.
"""

from __future__ import annotations

import math

import numpy as np

from .enums import BladeShape, GravityMode
from ..errors import GrassValueError

__all__ = [
    "safe_normalize",
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
    "LOD_SEGMENTS",
    "CULLED_SEGMENTS",
    "LOD_MIN_PIXELS",
    "orientation_cull",
    "clip_outside",
    "frustum_cull",
    "distance_cull",
    "projected_pixels",
    "lod_class",
    "CULL_REASONS",
    "cull_reason",
    "cull",
    "blade_forces",
    "FORCE_NAMES",
    "blade_shape_t",
    "hash01",
    "DRY_COLOR",
    "clump_noise",
    "blade_base_color",
    "backlight",
    "fog_amount",
    "sky_color",
    "field_inside",
    "ground_color",
    "ground_cover",
    "occlusion_bounds",
    "hzb_level",
    "hzb_layout",
    "build_hzb",
    "hzb_max",
    "occlusion_cull",
    "curve_pieces",
    "OCCLUSION_PIECES",
    "OCCLUSION_RADIUS_PER_WIDTH",
    "HZB_ROW_ALIGN",
    "blade_shade",
    "clip_to_pixel",
    "raster_step",
    "raster_span",
    "raster_cover",
    "raster_payload",
    "raster_walk",
    "raster_blades",
    "RASTER_MAX_SAMPLES",
    "RASTER_MAX_ACROSS",
    "RASTER_EMPTY",
]

# --------------------------------------------------------------------------- geometry


def safe_normalize(v, eps=1e-12):
    """v / |v| along the last axis; a zero vector stays zero (no NaN)."""
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.maximum(n, eps)


_normalize = safe_normalize


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
        return environmental_gravity(v0, mode, params.gravity_direction, params.gravity_center, params.gravity)
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


_pulse = wind_pulse


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
    k = strength * 2.0 / (radius * (1.0 + rho * rho)) * _pulse(dist, t, speed, wavelength)
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
    k = strength * 2.0 / (radius * (1.0 + rho * rho)) * _pulse(dist, t, speed, wavelength)
    tangent = np.stack([-r[..., 2], np.zeros_like(dist), r[..., 0]], axis=-1)
    return tangent * k[..., None]


_F2 = 0.5 * (math.sqrt(3.0) - 1.0)
_G2 = (3.0 - math.sqrt(3.0)) / 6.0
#: Scales the sum of the three simplex corner terms to about [-1, 1].
NOISE_SCALE = 99.0
_M32 = np.uint64(0xFFFFFFFF)


def noise_hash(i, j):
    """32-bit hash of integer lattice coordinates (i, j), as uint64 arrays holding u32.

    Two's-complement u32 of i and j, combined and mixed with Wellons' lowbias32;
    every product wraps modulo 2^32 exactly like WGSL u32 arithmetic.
    """
    iu = np.asarray(i, np.int64).astype(np.uint64) & _M32
    ju = np.asarray(j, np.int64).astype(np.uint64) & _M32
    h = ((iu * np.uint64(0x8DA6B343)) & _M32) ^ ((ju * np.uint64(0xD8163841)) & _M32)
    h ^= h >> np.uint64(16)
    h = (h * np.uint64(0x7FEB352D)) & _M32
    h ^= h >> np.uint64(15)
    h = (h * np.uint64(0x846CA68B)) & _M32
    h ^= h >> np.uint64(16)
    return h


def simplex_corner(x, y, i, j):
    """One corner's term of :func:`simplex_noise2`: max(0.5 - x^2 - y^2, 0)^4 * dot(g, (x, y)),
    g the unit gradient at angle (noise_hash(i, j) & 7) * 45 degrees."""
    t = 0.5 - x * x - y * y
    angle = (noise_hash(i, j) & np.uint64(7)).astype(np.float64) * (0.25 * math.pi)
    t2 = np.maximum(t, 0.0) ** 2
    return t2 * t2 * (np.cos(angle) * x + np.sin(angle) * y)


_simplex_corner = simplex_corner


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
        _simplex_corner(x0, y0, ii, jj)
        + _simplex_corner(x1, y1, ii + i1.astype(np.int64), jj + j1.astype(np.int64))
        + _simplex_corner(x2, y2, ii + 1, jj + 1)
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
    add = _dot(d_tip, d_tip) + _dot(d_mid, d_mid)
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
    v1, v2, add = collision_passes(v0, v1, v2, up, h, _spheres(colliders))
    eta = gain_collision(eta, add, params.collision_gain)
    out = dict(state)
    out["v1"], out["v2"], out["collision"] = v1, v2, eta
    return out


def _spheres(colliders):
    if colliders is None:
        return np.zeros((0, 4))
    if isinstance(colliders, np.ndarray):
        return np.asarray(colliders, np.float64).reshape(-1, 4)
    from .colliders import collider_array

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


# --------------------------------------------------------------------------- culling

#: Segments along a blade for each level-of-detail class (class 0 = nearest).
#: Splitting a quadratic Bezier into k chords misses the curve by at most
#: |v0 - 2 v1 + v2| / (8 k^2); a blade bent by half its height (|v0 - 2 v1 + v2|
#: ~ h / 2) that covers H pixels is then off by H / (16 k^2) pixels: about 0.5 px
#: for a full-screen blade (480 px) with 8 segments, 0.75 px at the class limits
#: below. (15, 8, 4, 2) was indistinguishable and drew twice the triangles, which
#: costs a CPU rasterizer (lavapipe) about 20 % of a frame in the cis565 view.
LOD_SEGMENTS = (8, 4, 2, 1)
#: Segments of the culled blades drawn with ``color_by = "cull"`` (context, not detail).
CULLED_SEGMENTS = LOD_SEGMENTS[1]
#: A blade goes to class k when its projected height in pixels is >= LOD_MIN_PIXELS[k].
LOD_MIN_PIXELS = (192.0, 64.0, 20.0, 0.0)


def orientation_cull(v0, t1, cam_pos, threshold=0.9):
    """True where a blade is seen edge-on: |dot(normalize(v0 - cam), t1)| > threshold."""
    dir_c = _normalize(np.asarray(v0, np.float64) - np.asarray(cam_pos, np.float64))
    return np.abs(_dot(dir_c, t1)) > threshold


def _clip(points, view_proj):
    p = np.concatenate([points, np.ones(points.shape[:-1] + (1,))], axis=-1)
    return p @ np.asarray(view_proj, np.float64).T


def clip_outside(clip, tol):
    """True where a clip-space point (x, y, z, w) is outside the view: not
    (|x|, |y| <= w + tol and 0 <= z <= w)."""
    clip = np.asarray(clip, np.float64)
    x, y, z, w = clip[..., 0], clip[..., 1], clip[..., 2], clip[..., 3]
    lim = w + tol
    inside = (np.abs(x) <= lim) & (np.abs(y) <= lim) & (z >= 0) & (z <= w)
    return ~inside


_outside = clip_outside


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


def projected_pixels(v0, v2, height, view_proj, viewport_height):
    """Projected blade height in pixels: h * P11 * viewport_height / (2 w), with w the
    clip w of the curve's middle (v0 + v2) / 2 and P11 the vertical focal factor of
    ``view_proj`` (the length of its second row's xyz part)."""
    vp = np.asarray(view_proj, np.float64)
    mid = 0.5 * (np.asarray(v0, np.float64) + np.asarray(v2, np.float64))
    w = np.maximum(_clip(mid, vp)[..., 3], 1e-6)
    focal = np.linalg.norm(vp[1, :3])
    return np.asarray(height, np.float64) * focal * viewport_height * 0.5 / w


def lod_class(v0, v2, height, view_proj, viewport_height):
    """Level-of-detail class per blade from its projected height in pixels.

    pixels = h * P11 * viewport_height / (2 w), with w the clip w of the curve's
    middle (v0 + v2) / 2 and P11 the vertical focal factor of ``view_proj``
    (the length of its second row's xyz part). Class k is the first with
    pixels >= LOD_MIN_PIXELS[k].
    """
    pixels = projected_pixels(v0, v2, height, view_proj, viewport_height)
    cls = np.full(len(pixels), len(LOD_MIN_PIXELS) - 1)
    for k in reversed(range(len(LOD_MIN_PIXELS))):
        cls = np.where(pixels >= LOD_MIN_PIXELS[k], k, cls)
    return cls


#: What :func:`cull_reason` returns, by index: 0 kept, then the culling tests in
#: the order they are applied (the first one that culls a blade is its reason).
CULL_REASONS = ("kept", "orientation", "frustum", "distance", "occlusion")


def cull_reason(state, params, view_proj, cam_pos, ids=None):
    """Why each blade is culled: an int array (N,) indexing :data:`CULL_REASONS`.

    0 means the blade survives every enabled test; otherwise the value names the
    first enabled test that culls it, in the order orientation (1), frustum (2),
    distance (3). A blade culled by frustum and distance is a frustum blade.
    Occlusion (4) needs a depth buffer: see :func:`occlusion_cull`, applied to the
    blades this function keeps.
    ``view_proj`` (4x4, world to clip) and ``cam_pos`` describe the culling camera;
    ``ids`` (default 0..N-1) feed the distance buckets.
    """
    v0, v1, v2, up = (np.asarray(state[k], np.float64) for k in ("v0", "v1", "v2", "up"))
    n = len(v0)
    ids = np.arange(n) if ids is None else ids
    reason = np.zeros(n, np.int32)
    tests = []
    if params.cull_orientation:
        t1 = width_direction(up, state["orientation"])
        tests.append((1, lambda: orientation_cull(v0, t1, cam_pos, params.cull_orientation_threshold)))
    if params.cull_frustum:
        tests.append((2, lambda: frustum_cull(v0, v1, v2, view_proj, params.cull_frustum_tolerance)))
    if params.cull_distance:
        tests.append((3, lambda: distance_cull(v0, up, cam_pos, ids, params.cull_buckets, params.cull_distance_max)))
    for code, test in tests:
        reason = np.where((reason == 0) & test(), code, reason)
    return reason


def cull(state, params, view_proj, cam_pos, ids=None):
    """Which blades survive all enabled culling tests (bool (N,), True = drawn)."""
    return cull_reason(state, params, view_proj, cam_pos, ids) == 0


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


# --------------------------------------------------------------------------- drawing


def blade_shape_t(u, v, shape, tau):
    """Across-blade parameter t of the paper's blade shapes (section 6), u, v in [0, 1].

    ``shape`` is a :class:`~grasswidget.core.enums.BladeShape` id or label: quad and fold
    t = u; triangle t = u + v/2 - u v; quadratic t = u - u v^2; triangle-tip
    t = 1/2 + (u - 1/2) (1 - max(v - tau, 0) / (1 - tau)).
    """
    shape = BladeShape.from_label(shape) if isinstance(shape, str) else BladeShape(int(shape))
    u = np.asarray(u, np.float64)
    v = np.asarray(v, np.float64)
    if shape in (BladeShape.QUAD, BladeShape.FOLD):
        return u + 0.0 * v
    if shape == BladeShape.TRIANGLE:
        return u + 0.5 * v - u * v
    if shape == BladeShape.QUADRATIC:
        return u - u * v * v
    return 0.5 + (u - 0.5) * (1.0 - np.maximum(v - tau, 0.0) / (1.0 - tau))


def hash01(x):
    """Hash of blade ids (u32) to [0, 1), for per-blade colour variation (PCG-style;
    every product wraps modulo 2^32 like WGSL u32 arithmetic)."""
    h = (np.asarray(x, np.int64).astype(np.uint64) & _M32)
    h = (h * np.uint64(747796405) + np.uint64(2891336453)) & _M32
    h = (((h >> ((h >> np.uint64(28)) + np.uint64(4))) ^ h) * np.uint64(277803737)) & _M32
    h = (h >> np.uint64(22)) ^ h
    return h.astype(np.float64) / 4294967296.0


# --------------------------------------------------------------------------- looks

#: sRGB colour of dry (straw) grass at the tip; the root of a dry blade is 0.45 of it.
DRY_COLOR = (0.80, 0.72, 0.40)


def _mix(a, b, t):
    t = np.asarray(t, np.float64)
    a, b = np.asarray(a, np.float64), np.asarray(b, np.float64)
    if t.ndim and a.ndim > t.ndim:
        t = t[..., None]
    return a + (b - a) * t


def clump_noise(x, z, size):
    """The meadow's low-frequency patches (clumps) at ground point (x, z) metres: two
    independent :func:`simplex_noise2` of feature size ``size`` metres, each clamped to
    [-1, 1], stacked on the last axis: [..., 0] drives a patch's hue and brightness,
    [..., 1] its dryness. Derived from the blade's root, so no per-blade buffer."""
    qx = np.asarray(x, np.float64) / size
    qz = np.asarray(z, np.float64) / size
    a = simplex_noise2(qx, qz)
    b = simplex_noise2(qx + 19.1, qz - 7.3)
    return np.clip(np.stack([a, b], axis=-1), -1.0, 1.0)


def blade_base_color(root, tip, along, variation, clump, color_variation, dryness):
    """Unlit sRGB colour (..., 3) of a blade at height fraction ``along`` (0 root .. 1 tip).

    The root-to-tip ramp ``mix(root, tip, along^0.8)``; the blade's shift
    ``s = 0.7 clump[0] + 0.6 (variation - 0.5)`` (its patch, then its own hash in [0, 1))
    scales brightness by ``1 + color_variation s / 2`` and adds ``color_variation s
    (0.22, 0.05, -0.15) tip`` (yellower when brighter); then a share
    ``clamp(dryness (1 + 1.5 clump[1]), 0, 1) (0.4 + 0.6 along)`` of straw
    (:data:`DRY_COLOR` times ``0.45 + 0.55 along^0.8``). color_variation and dryness 0..1.
    """
    root, tip = np.asarray(root, np.float64), np.asarray(tip, np.float64)
    clump = np.asarray(clump, np.float64)
    v = np.clip(np.asarray(along, np.float64), 0.0, 1.0)
    ramp = v ** 0.8
    base = _mix(root, tip, ramp)
    s = 0.7 * clump[..., 0] + 0.6 * (np.asarray(variation, np.float64) - 0.5)
    cv = np.asarray(color_variation, np.float64)
    base = base * (1.0 + 0.5 * cv * s)[..., None]
    base = base + (cv * s)[..., None] * np.array([0.22, 0.05, -0.15]) * tip
    dry = np.clip(np.asarray(dryness, np.float64) * (1.0 + 1.5 * clump[..., 1]), 0.0, 1.0) * (0.4 + 0.6 * v)
    straw = np.asarray(DRY_COLOR) * (0.45 + 0.55 * ramp)[..., None]
    return np.clip(_mix(base, straw, dry), 0.0, 1.0)


def backlight(to_eye, light, along, translucency):
    """Light through a blade seen against the sun: ``translucency * max(dot(-to_eye,
    light), 0)^4 * along^2`` (tips glow most; to_eye and light unit vectors)."""
    facing = np.maximum(-np.sum(np.asarray(to_eye, np.float64) * light, axis=-1), 0.0)
    a = np.clip(np.asarray(along, np.float64), 0.0, 1.0)
    return np.asarray(translucency, np.float64) * facing ** 4 * a * a


def fog_amount(distance, density):
    """Share of the fog colour at ``distance`` metres: ``1 - exp(-density distance)``
    (density in 1/m; 0 = no fog)."""
    return 1.0 - np.exp(-np.maximum(np.asarray(density, np.float64), 0.0) * np.maximum(distance, 0.0))


def sky_color(elevation, horizon, zenith):
    """Sky colour for a view ray whose elevation has sine ``elevation``: ``horizon`` at and
    below the horizon, ``mix(horizon, zenith, sqrt(elevation))`` above."""
    return _mix(horizon, zenith, np.sqrt(np.clip(np.asarray(elevation, np.float64), 0.0, 1.0)))


def field_inside(x, z, c, half, edge):
    """How far ground point (x, z) lies inside the rectangle of centre ``c`` (x, z) and
    half sizes ``half`` (metres): 0 beyond ``edge / 2`` outside, 1 beyond ``edge / 2``
    inside, linear between."""
    c, half = np.asarray(c, np.float64), np.asarray(half, np.float64)
    d = np.maximum(np.abs(x - c[..., 0]) - half[..., 0], np.abs(z - c[..., 1]) - half[..., 1])
    return np.clip(0.5 - d / edge, 0.0, 1.0)


def ground_color(soil, beyond, inside, cover):
    """Ground colour (sRGB): ``soil`` darkened by the grass' ``cover`` (0..1; see
    :func:`ground_cover`) to ``1 - 0.6 cover`` under the field, the ground ``beyond``
    outside, blended by ``inside`` (0..1, :func:`field_inside`)."""
    under = np.asarray(soil, np.float64) * (1.0 - 0.6 * np.clip(cover, 0.0, 1.0))[..., None]
    return _mix(beyond, under, np.clip(inside, 0.0, 1.0))


def ground_cover(heights, widths, area):
    """How much a field's grass covers (shades) its soil, 0..1: ``1 - exp(-L / 4)`` with
    L the leaf area index, the blades' one-sided area ``sum(2 w h)`` (w the half width,
    metres) per ``area`` square metres of ground. A lawn of 1000 blades/m^2 of 2 x 3 cm x
    75 cm has L = 45 (cover 1); 36 blades/m^2 of 24 cm x 1.9 m, L = 16 (cover 0.98)."""
    if not area > 0:
        raise GrassValueError(f"area must be > 0 square metres; got {area!r}")
    leaf = float(np.sum(2.0 * np.asarray(widths, np.float64) * np.asarray(heights, np.float64))) / float(area)
    return float(1.0 - math.exp(-leaf / 4.0))


# --------------------------------------------------------------------------- occlusion culling

#: A ribbon point lies within this many blade widths of the curve (blade_render.wgsl:
#: c -+ width * t1, and the "fold" shape adds width / 2 along the normal: sqrt(1.25) < 1.5).
OCCLUSION_RADIUS_PER_WIDTH = 1.5
#: The occlusion test splits the curve into this many pieces (t in [k/P, (k+1)/P]), each
#: boxed by its own control points: a bent blade's one box would cover much empty screen.
OCCLUSION_PIECES = 4
#: Rows of the pyramid's level 0 start every HZB_ROW_ALIGN texels (a depth texture is
#: copied into a buffer in rows of a multiple of 256 bytes = 64 float32).
HZB_ROW_ALIGN = 64
#: Levels of the depth pyramid the level table (``s_hzb_levels``) holds: views up to
#: 2^15 pixels wide and high (both engines).
HZB_MAX_LEVELS = 16


def occlusion_bounds(v0, v1, v2, radius, view_proj, viewport_size):
    """Screen bounds of a blade for the occlusion test: ``(rect, depth)``.

    The blade lies in the box around its control points v0, v1, v2 (the curve stays
    in their triangle) grown by ``radius`` (metres); its 8 corners are projected by
    ``view_proj`` (world to clip). ``rect`` (x0, y0, x1, y1) is their extent in
    pixels of a ``viewport_size`` (width, height) view, clamped to [0, width] x
    [0, height], y down (row 0 at the top); ``depth`` the nearest corner's depth
    (0 near .. 1 far). A box that reaches behind the near plane gets the whole view
    and depth 0 (it cannot be hidden). Per blade: arrays of shape (N, 3) / (N,) /
    (4, 4) / (2,) give (N, 4) and (N,).
    """
    v0, v1, v2 = (np.asarray(x, np.float64) for x in (v0, v1, v2))
    r = np.asarray(radius, np.float64)[..., None]
    lo = np.minimum(np.minimum(v0, v1), v2) - r
    hi = np.maximum(np.maximum(v0, v1), v2) + r
    corners = np.stack([np.stack([(hi if k & 1 else lo)[..., 0], (hi if k & 2 else lo)[..., 1],
                                  (hi if k & 4 else lo)[..., 2]], axis=-1) for k in range(8)], axis=-2)
    clip = _clip(corners, view_proj)  # (..., 8, 4)
    w = clip[..., 3]
    behind = np.any((w <= 1e-6) | (clip[..., 2] < 0.0), axis=-1)
    safe_w = np.where(w <= 1e-6, 1.0, w)
    ndc = clip[..., :3] / safe_w[..., None]
    size = np.asarray(viewport_size, np.float64)
    width, height = size[..., 0:1], size[..., 1:2]
    x0 = np.clip((ndc[..., 0].min(axis=-1, keepdims=True) * 0.5 + 0.5) * width, 0.0, width)
    x1 = np.clip((ndc[..., 0].max(axis=-1, keepdims=True) * 0.5 + 0.5) * width, 0.0, width)
    y0 = np.clip((0.5 - 0.5 * ndc[..., 1].max(axis=-1, keepdims=True)) * height, 0.0, height)
    y1 = np.clip((0.5 - 0.5 * ndc[..., 1].min(axis=-1, keepdims=True)) * height, 0.0, height)
    rect = np.concatenate([x0, y0, x1, y1], axis=-1)
    depth = np.maximum(ndc[..., 2].min(axis=-1), 0.0)
    full = np.concatenate([np.zeros_like(width), np.zeros_like(height), width, height], axis=-1)
    rect = np.where(behind[..., None], np.broadcast_to(full, rect.shape), rect)
    depth = np.where(behind, 0.0, depth)
    return rect, depth


def hzb_level(rect):
    """The pyramid level at which a pixel rect (x0, y0, x1, y1) spans at most 2 x 2
    texels: the smallest L with 2^L >= ceil(max(x1 - x0, y1 - y0)) (0 for a rect
    under a pixel). Level L's texel (x, y) holds the farthest depth of the pixels
    [x 2^L, (x + 1) 2^L) x [y 2^L, (y + 1) 2^L)."""
    rect = np.asarray(rect, np.float64)
    span = np.ceil(np.maximum(rect[..., 2] - rect[..., 0], rect[..., 3] - rect[..., 1]))
    span = np.maximum(span, 1.0).astype(np.int64)
    level = np.zeros(span.shape, np.int64)
    while np.any((1 << level) < span):
        level = np.where((1 << level) < span, level + 1, level)
    return level.astype(np.uint32)


def hzb_layout(width, height):
    """Where each pyramid level lives in one float32 buffer: a list of
    ``(offset, width, height, pitch)`` in texels, level 0 first. Level 0 is the
    depth buffer (width x height, rows every HZB_ROW_ALIGN-aligned pitch); level
    k + 1 halves level k rounding up, down to 1 x 1, rows packed."""
    width, height = int(width), int(height)
    if width < 1 or height < 1:
        raise GrassValueError(f"hzb_layout needs a viewport of at least 1 x 1 pixels; got {width} x {height}")
    pitch = -(-width // HZB_ROW_ALIGN) * HZB_ROW_ALIGN
    levels = [(0, width, height, pitch)]
    offset = pitch * height
    while width > 1 or height > 1:
        width, height = -(-width // 2), -(-height // 2)
        levels.append((offset, width, height, width))
        offset += width * height
    return levels


def build_hzb(depth):
    """The max-depth pyramid of a depth image (height, width): a list of arrays,
    level 0 = ``depth``; each texel of level k + 1 the farthest of its (up to) 2 x 2
    texels of level k (the layout of :func:`hzb_layout`)."""
    levels = [np.asarray(depth, np.float32)]
    while levels[-1].shape != (1, 1):
        d = levels[-1]
        h, w = d.shape
        padded = np.full((h + h % 2, w + w % 2), -np.inf, np.float32)
        padded[:h, :w] = d
        levels.append(padded.reshape(padded.shape[0] // 2, 2, padded.shape[1] // 2, 2).max(axis=(1, 3)))
    return levels


def hzb_max(levels, rect, level):
    """Farthest depth of the pyramid ``levels`` (:func:`build_hzb`) over the pixel
    rect (x0, y0, x1, y1) at ``level`` (the texels holding pixels floor(x0)..floor(x1),
    floor(y0)..floor(y1), clamped to the view); one rect per row."""
    rect = np.atleast_2d(np.asarray(rect, np.float64))
    level = np.broadcast_to(np.asarray(level, np.int64), rect.shape[:1])
    h0, w0 = levels[0].shape
    out = np.empty(len(rect), np.float32)
    for k, (r, lv) in enumerate(zip(rect, level)):
        lv = min(int(lv), len(levels) - 1)
        px0 = min(int(np.floor(r[0])), w0 - 1)
        px1 = min(int(np.floor(r[2])), w0 - 1)
        py0 = min(int(np.floor(r[1])), h0 - 1)
        py1 = min(int(np.floor(r[3])), h0 - 1)
        out[k] = levels[lv][py0 >> lv: (py1 >> lv) + 1, px0 >> lv: (px1 >> lv) + 1].max()
    return out


def occlusion_cull(state, view_proj, depth, world_scale=1.0):
    """True where a blade is hidden: for each piece of its curve (:func:`curve_pieces`),
    the piece's nearest depth (:func:`occlusion_bounds`, radius
    OCCLUSION_RADIUS_PER_WIDTH x width x ``world_scale``) is farther than the farthest
    depth of ``depth`` (an (H, W) float32 depth buffer of the same camera, 0 near ..
    1 far) over the piece's screen rect, read at :func:`hzb_level` of the rect from
    the pyramid :func:`build_hzb`. Conservative: every pixel the blade could cover
    already holds something nearer.
    """
    depth = np.asarray(depth, np.float32)
    h, w = depth.shape
    levels = build_hzb(depth)
    radius = OCCLUSION_RADIUS_PER_WIDTH * np.asarray(state["width"], np.float64) * world_scale
    hidden = np.ones(len(radius), bool)
    for p0, p1, p2 in curve_pieces(state["v0"], state["v1"], state["v2"]):
        rect, near = occlusion_bounds(p0, p1, p2, radius, view_proj, (w, h))
        hidden &= near.astype(np.float32) > hzb_max(levels, rect, hzb_level(rect))
    return hidden


def curve_pieces(v0, v1, v2, pieces=None):
    """The control points (p0, p1, p2) of the quadratic Bezier v0, v1, v2 on each of
    ``pieces`` (default OCCLUSION_PIECES) equal spans of t: on [a, b], p0 = B(a),
    p2 = B(b), p1 = (1-a)(1-b) v0 + (a(1-b) + b(1-a)) v1 + a b v2."""
    v0, v1, v2 = (np.asarray(x, np.float64) for x in (v0, v1, v2))
    n = OCCLUSION_PIECES if pieces is None else int(pieces)

    def point(t):
        return (1 - t) ** 2 * v0 + 2 * t * (1 - t) * v1 + t * t * v2

    out = []
    for k in range(n):
        a, b = k / n, (k + 1) / n
        out.append((point(a), (1 - a) * (1 - b) * v0 + (a * (1 - b) + b * (1 - a)) * v1 + a * b * v2, point(b)))
    return out


# --------------------------------------------------------------------------- shading


def blade_shade(normal, to_eye, along, base, glow, fog, fog_color, light_direction, ambient):
    """Lit colour of a blade's surface point (sRGB, 0..1; blade_math.wgsl ``blade_shade``,
    the ribbons' and the compute rasterizer's shading). Rows of vectors (N, 3), scalars (N,).

    Two-sided (the normal is flipped to face ``to_eye``); the unlit ``base`` colour
    (:func:`blade_base_color`) lit by diffuse + 0.35 translucency of the light, an
    ``ambient`` floor and an ambient occlusion 0.55 (root) .. 1 (tip); plus the tips'
    ``glow`` against the sun (:func:`backlight`) times ``1.2 base + (0.16, 0.14, 0.02)``,
    clamped to 0..1; then a share ``fog`` (:func:`fog_amount`) of ``fog_color``."""
    n = safe_normalize(np.asarray(normal, np.float64))
    to_eye = np.asarray(to_eye, np.float64)
    n = np.where((_dot(n, to_eye) < 0.0)[..., None], -n, n)
    a = np.clip(np.asarray(along, np.float64), 0.0, 1.0)[..., None]
    base = np.asarray(base, np.float64)
    light = safe_normalize(np.asarray(light_direction, np.float64))
    diffuse = np.maximum(_dot(n, light), 0.0)[..., None]
    translucency = 0.35 * np.maximum(-_dot(n, light), 0.0)[..., None]
    ao = 0.55 + 0.45 * a
    amb = np.asarray(ambient, np.float64)[..., None]
    shade = (amb + (1.0 - amb) * (diffuse + translucency)) * ao
    glow = np.asarray(glow, np.float64)[..., None]
    rgb = np.clip(base * shade + glow * (1.2 * base + np.array([0.16, 0.14, 0.02])), 0.0, 1.0)
    fog = np.asarray(fog, np.float64)[..., None]
    return rgb + (np.asarray(fog_color, np.float64) - rgb) * fog


# --------------------------------------------------------------------------- compute rasterization

#: Most samples the compute walk takes along one blade (raster_step: at least 1 / this).
RASTER_MAX_SAMPLES = 256.0
#: Most pixels the walk writes across one cross-section (a blade sent to the compute
#: rasterizer is under GrassParams.compute_raster_max_px wide; this bounds a blade seen
#: at a grazing angle).
RASTER_MAX_ACROSS = 16
#: The depth word of a pixel no compute-rasterized blade covers (raster.wgsl).
RASTER_EMPTY = 0xFFFFFFFF


def clip_to_pixel(clip, viewport_size):
    """Clip-space points (..., 4) to (x, y, depth): pixels, x right and y down from the
    view's top-left corner, depth 0 near .. 1 far (blade_math.wgsl ``clip_to_pixel``)."""
    clip = np.asarray(clip, np.float64)
    size = np.asarray(viewport_size, np.float64)
    ndc = clip[..., :3] / clip[..., 3:4]
    return np.stack([(ndc[..., 0] * 0.5 + 0.5) * size[..., 0], (0.5 - 0.5 * ndc[..., 1]) * size[..., 1],
                     ndc[..., 2]], axis=-1)


def raster_step(s0, s1, s2, v):
    """The compute walk's step in v at v: 0.9 / (the curve's screen speed there,
    ``|2 (1 - v) (s1 - s0) + 2 v (s2 - s1)|`` pixels per unit v), clamped to
    [1 / RASTER_MAX_SAMPLES, 1]: samples about 0.9 pixels apart along the curve."""
    s0, s1, s2 = (np.asarray(x, np.float64) for x in (s0, s1, s2))
    v = np.asarray(v, np.float64)[..., None]
    speed = np.linalg.norm(2.0 * (1.0 - v) * (s1 - s0) + 2.0 * v * (s2 - s1), axis=-1)
    return np.clip(0.9 / np.maximum(speed, 1e-6), 1.0 / RASTER_MAX_SAMPLES, 1.0)


def raster_span(c0, c1, c2, across, v, shape, tau, viewport_size):
    """The ribbon's cross-section at v on screen: its two ends (x, y, depth), each (..., 3).

    ``c0, c1, c2`` are the control points in clip space, ``across`` the half-width
    vector in clip space (``view_proj @ (width * t1, 0)``); the ends are the curve point
    plus (2 t - 1) across for t = blade_shape_t(0, v) and blade_shape_t(1, v).
    """
    c0, c1, c2, across = (np.asarray(x, np.float64) for x in (c0, c1, c2, across))
    v = np.asarray(v, np.float64)[..., None]
    a = c0 + v * (c1 - c0)
    b = c1 + v * (c2 - c1)
    c = a + v * (b - a)
    vs = v[..., 0]
    shape = np.broadcast_to(np.asarray(shape), vs.shape)
    tau = np.broadcast_to(np.asarray(tau, np.float64), vs.shape)
    t_left = np.array([blade_shape_t(0.0, vv, int(s), t) for vv, s, t in zip(vs.ravel(), shape.ravel(), tau.ravel())])
    t_right = np.array([blade_shape_t(1.0, vv, int(s), t) for vv, s, t in zip(vs.ravel(), shape.ravel(), tau.ravel())])
    t_left, t_right = t_left.reshape(vs.shape)[..., None], t_right.reshape(vs.shape)[..., None]
    return (clip_to_pixel(c + (2.0 * t_left - 1.0) * across, viewport_size),
            clip_to_pixel(c + (2.0 * t_right - 1.0) * across, viewport_size))


def raster_cover(blade, sample, span_px):
    """Points the compute walk writes across a cross-section ``span_px`` pixels wide:
    ``floor(span_px + hash01(blade * 2654435761 + sample * 40503))`` (u32 arithmetic),
    clamped to [0, RASTER_MAX_ACROSS]: on average span_px, the same every frame."""
    blade = np.asarray(blade, np.int64).astype(np.uint64)
    sample = np.asarray(sample, np.int64).astype(np.uint64)
    key = (blade * np.uint64(2654435761) + sample * np.uint64(40503)) & _M32
    h = hash01(key).astype(np.float32)
    total = (np.asarray(span_px, np.float32) + h).astype(np.float64)
    return np.clip(np.floor(total), 0, RASTER_MAX_ACROSS).astype(np.int64)


def raster_payload(blade, v):
    """The shading payload of a rasterized pixel: ``blade << 8 | round(v * 255)`` (u32; blade < 2^24)."""
    blade = np.asarray(blade, np.int64)
    q = np.round(np.clip(np.asarray(v, np.float64), 0.0, 1.0) * 255.0).astype(np.int64)
    return ((blade << 8) | q) & 0xFFFFFFFF


def raster_walk(c0, c1, c2, across, blade, shape, tau, viewport_size):
    """The compute rasterizer's walk of one blade (raster.wgsl), in float32 like the GPU.

    Samples s = 0, 1, ... at v = 0, then v += raster_step(projected control points, v)
    (the last sample at v = 1, at most RASTER_MAX_SAMPLES + 1 samples); at each, the cross-section (raster_span) of length L pixels is covered by
    m = raster_cover(blade, s, L) points at (j + 0.5) / m along it. A point writes pixel floor(x, y) when it is inside the view
    and 0 < depth <= 1. Returns (x, y, depth, v) arrays, one entry per written pixel
    (a pixel may repeat)."""
    f32 = np.float32
    size = np.asarray(viewport_size, f32)
    c0, c1, c2, across = (np.asarray(x, f32) for x in (c0, c1, c2, across))
    s0, s1, s2 = (clip_to_pixel(c, size)[:2] for c in (c0, c1, c2))
    xs, ys, ds, vs = [], [], [], []
    v = f32(0.0)
    for s in range(int(RASTER_MAX_SAMPLES) + 1):
        a, b = raster_span(c0, c1, c2, across, v, shape, tau, size)
        a, b = a.astype(f32), b.astype(f32)
        span_px = np.float32(np.linalg.norm(b[:2] - a[:2]))
        m = int(raster_cover(blade, s, span_px))
        for j in range(m):
            p = a + (b - a) * f32((j + 0.5) / m)
            x, y = int(np.floor(p[0])), int(np.floor(p[1]))
            if 0 <= x < size[0] and 0 <= y < size[1] and 0.0 < p[2] <= 1.0:
                xs.append(x), ys.append(y), ds.append(float(p[2])), vs.append(float(v))
        if v >= 1.0:
            break
        v = f32(min(f32(v + f32(raster_step(s0, s1, s2, v))), f32(1.0)))
    return np.array(xs, np.int64), np.array(ys, np.int64), np.array(ds), np.array(vs)


def raster_blades(blades, viewport_size):
    """Depth and payload images of the compute rasterizer for a few blades: each item
    of ``blades`` is (c0, c1, c2, across, blade id, shape, tau) as for :func:`raster_walk`.
    The nearest depth wins per pixel; among equal depths the largest payload
    (raster.wgsl: atomicMin of the depth's float bits, then atomicMax of the payload).
    Returns (depth (H, W) float64, inf where empty; payload (H, W) uint32, 0 where empty)."""
    w, h = int(viewport_size[0]), int(viewport_size[1])
    depth = np.full((h, w), np.inf)
    payload = np.zeros((h, w), np.uint64)
    for c0, c1, c2, across, blade, shape, tau in blades:
        xs, ys, ds, vs = raster_walk(c0, c1, c2, across, blade, shape, tau, viewport_size)
        for x, y, d, v in zip(xs, ys, ds, vs):
            p = int(raster_payload(blade, v))
            if d < depth[y, x]:
                depth[y, x], payload[y, x] = d, p
            elif d == depth[y, x]:
                payload[y, x] = max(int(payload[y, x]), p)
    return depth, payload.astype(np.uint32)
