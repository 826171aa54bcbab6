"""The drawing and the looks of the reference: blade shapes, colour variety, clumps,
dry grass, backlight, fog, sky and ground, and the blade's shade. Twins of
``shaders/blade_render.wgsl`` and ``sky_ground.wgsl`` (see :mod:`grasswidget.core.reference`)."""

from __future__ import annotations

import math

import numpy as np

from ..enums import BladeShape, GravityMode
from ...errors import GrassValueError
from .physics import simplex_noise2
from .vectors import U32_MASK, dot, safe_normalize

__all__ = [
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
    "blade_shade",
    "FAR_ALONG",
    "far_grass_shade",
    "ground_albedo",
]


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
    h = (np.asarray(x, np.int64).astype(np.uint64) & U32_MASK)
    h = (h * np.uint64(747796405) + np.uint64(2891336453)) & U32_MASK
    h = (((h >> ((h >> np.uint64(28)) + np.uint64(4))) ^ h) * np.uint64(277803737)) & U32_MASK
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
    n = np.where((dot(n, to_eye) < 0.0)[..., None], -n, n)
    a = np.clip(np.asarray(along, np.float64), 0.0, 1.0)[..., None]
    base = np.asarray(base, np.float64)
    light = safe_normalize(np.asarray(light_direction, np.float64))
    diffuse = np.maximum(dot(n, light), 0.0)[..., None]
    translucency = 0.35 * np.maximum(-dot(n, light), 0.0)[..., None]
    ao = 0.55 + 0.45 * a
    amb = np.asarray(ambient, np.float64)[..., None]
    shade = (amb + (1.0 - amb) * (diffuse + translucency)) * ao
    glow = np.asarray(glow, np.float64)[..., None]
    rgb = np.clip(base * shade + glow * (1.2 * base + np.array([0.16, 0.14, 0.02])), 0.0, 1.0)
    fog = np.asarray(fog, np.float64)[..., None]
    return rgb + (np.asarray(fog_color, np.float64) - rgb) * fog




# --------------------------------------------------------------------------- grass seen from afar

#: Height fraction whose unlit blade colour stands for a blade seen from afar (the far ground's base).
FAR_ALONG = 0.75


def far_grass_shade(root, tip, color_variation, dryness, translucency, light_direction, ambient,
                    samples: int = 4096, seed: int = 7):
    """The mean lit colour of blades seen from afar over their unlit colour at :data:`FAR_ALONG`
    (rgb, per channel): what the far ground multiplies its grass colour by (:func:`ground_albedo`).

    The mean is over blades at rest (upright, horizontal normals) of every orientation, seen
    from every azimuth 2..15 degrees above the ground (a view across a meadow), over the
    upper three quarters of their height (what shows over the blades in front; this share
    matches the lavapipe renders of the meadow at 150-200 m within 2/255), each with its own
    colour variation, through :func:`blade_base_color`, :func:`backlight` and
    :func:`blade_shade` without fog. A fixed stratified sample (``samples``, ``seed``), so
    the same inputs give the same numbers."""
    rng = np.random.default_rng(seed)
    k = np.arange(samples)
    theta = 2.0 * np.pi * (k + rng.random(samples)) / samples
    azimuth = rng.permutation(2.0 * np.pi * (k + rng.random(samples)) / samples)
    elevation = np.radians(2.0 + 13.0 * rng.random(samples))
    along = 0.25 + 0.75 * rng.permutation((k + rng.random(samples)) / samples)
    variation = rng.random(samples)
    normal = np.stack([-np.sin(theta), np.zeros(samples), np.cos(theta)], axis=1)
    to_eye = np.stack([np.cos(elevation) * np.cos(azimuth), np.sin(elevation), np.cos(elevation) * np.sin(azimuth)],
                      axis=1)
    light = safe_normalize(np.asarray(light_direction, np.float64).reshape(1, 3))
    clump = np.zeros((samples, 2))
    row = np.asarray(root, np.float64).reshape(1, 3), np.asarray(tip, np.float64).reshape(1, 3)
    base = blade_base_color(row[0], row[1], along, variation, clump, color_variation, dryness)
    glow = backlight(to_eye, light, along, translucency)
    lit = blade_shade(normal, to_eye, along, base, glow, np.zeros(samples), np.zeros(3), light.ravel(),
                      np.full(samples, float(ambient)))
    unlit = blade_base_color(root, tip, FAR_ALONG, 0.5, np.zeros(2), color_variation, dryness)
    return lit.mean(axis=0) / np.maximum(unlit, 1e-6)


def ground_albedo(x, z, dist, soil, beyond, field_c, field_half, edge, cover, horizon, far_blend, far_grass,
                  root, tip, color_variation, dryness, sunlight=1.0):
    """The ground's colour (sRGB, lit) at ground point (x, z), ``dist`` metres from the camera
    (``sky_ground.wgsl`` ``ground_albedo``): :func:`ground_color`, the soil under the field's
    rectangle and outside it the grass seen from afar (``far_grass[3]`` = 1; 0: the bare plain
    ``beyond``, between: a mix): :func:`blade_base_color` at ``far_blend[3]`` along, variation 0.5,
    of the patches :func:`clump_noise` of size ``far_blend[2]`` gives at (x, z), times
    ``far_grass[:3]`` (:func:`far_grass_shade`). For a field to the horizon (``horizon`` = (cx, cz,
    reach, on), on != 0) the far grass also takes over the soil by the camera's distance
    (smoothstep over ``far_blend[0]..far_blend[1]`` m) and wholly past the reach (over the last
    ``2 edge`` m). ``sunlight`` (0..1, shadows.wgsl's ``ground_sunlight``; 1 with shadows off) lights
    the soil and the ground beyond the field (far grass or plain), not the far grass over a field to
    the horizon (the grass's top)."""
    x, z, dist = (np.asarray(a, np.float64) for a in (x, z, dist))
    sun = np.asarray(sunlight, np.float64)[..., None]
    far_grass = np.asarray(far_grass, np.float64)
    inside = field_inside(x, z, field_c, field_half, edge)
    clump = clump_noise(x, z, far_blend[2])
    grass = blade_base_color(root, tip, far_blend[3], 0.5, clump, color_variation, dryness) * far_grass[:3]
    beyond = _mix(np.asarray(beyond, np.float64), grass, far_grass[3]) * sun
    ground = ground_color(np.asarray(soil, np.float64) * sun, beyond, inside, cover)
    if horizon[3] == 0:
        return ground
    r = np.hypot(x - horizon[0], z - horizon[1])
    far = np.maximum(_smoothstep(far_blend[0], far_blend[1], dist),
                     _smoothstep(horizon[2] - 2.0 * edge, horizon[2], r))
    return _mix(ground, grass, far)


def _smoothstep(a, b, x):
    t = np.clip((np.asarray(x, np.float64) - a) / (b - a), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)
