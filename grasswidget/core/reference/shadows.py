"""Sunlight of the reference: the sun's direction, the balls' shadows, the grass' own
shadow (on the ground and on the blades) and the darkening towards the roots. Twins of
``blade_math.wgsl``'s ``ball_shadow``, ``grass_transmittance``, ``sky_visibility`` and
``light_share`` (read by ``shaders/shadows.wgsl`` in both engines' blade, compute-raster
resolve and sky/ground shaders; see :mod:`grasswidget.core.reference`).

The model (``GrassParams.shadows``): the sun is a direction ``sun`` (unit, towards it).

* A ball (sphere collider ``(x, y, z, r)``) hides the sun from a point ``p`` when the ray
  ``p + t sun`` (t > 0) passes within ``r`` of its centre: :func:`ball_shadow`, with a soft
  edge (a penumbra growing with the distance to the ball) so that it never aliases.
* The grass is a layer of thin blades over the field's rectangle, ``grass_height`` metres
  deep, seen by light as a turbid medium (Beer-Lambert, as canopy models do since Monsi
  and Saeki): a ray travelling ``s`` metres of height through it keeps ``exp(-k s)`` of its
  light, ``k`` the optical depth per metre of height (:func:`grass_optical_depths`, from the
  blades' leaf area per m^2 of ground and the sun's elevation). The ray from a point
  towards the sun leaves the layer after ``height_above`` metres of height; only the part
  of it over the field counts (:func:`grass_transmittance`): the ground beside the field
  on its shadow side is darkened by the blades near the edge, the blades at the sunny edge
  are lit down to their roots. Thin blades have no shadow a shadow map could resolve at
  an affordable size (a blade is a few millimetres wide); the layer's statistics are what
  the eye sees of their shadows, and cost one exp per pixel, no pass, no memory.
* The sky's light reaches a point in the grass through the layer above it
  (:func:`sky_visibility`): the darkening towards each blade's root, deeper where the
  field is denser.
* :func:`light_share` turns the two visibilities into the factor of a surface's lit
  colour (the ambient share lit by the sky, the rest by the sun).
"""

from __future__ import annotations

import math

import numpy as np

from ...errors import GrassValueError
from .looks import field_inside

__all__ = [
    "sun_direction", "sun_angles", "ball_shadow", "grass_transmittance", "grass_above", "sky_visibility", "light_share",
    "grass_optical_depths", "MAX_SHADOW_BALLS", "SUN_MIN_Y", "SKY_FLOOR", "BALL_PENUMBRA", "LEAF_PROJECTION",
    "SKY_EXTINCTION", "GROUND_AMBIENT", "MAX_LAYER_DEPTH", "MAX_SKY_DEPTH", "TRANSMITTANCE_TAPS",
]

#: Balls (the first sphere colliders) whose shadows are drawn, both engines (a fixed loop in the shaders).
MAX_SHADOW_BALLS = 4
#: The sun's height (y of its unit direction) is taken as at least this in the grass' shadow (a sun
#: lower than about 3 degrees would cast shadows to infinity).
SUN_MIN_Y = 0.05
#: The share of the sky's light that still reaches the deepest roots (light scattered by the blades).
SKY_FLOOR = 0.35
#: The balls' penumbra: the soft edge widens by this many metres per metre between ball and point
#: (the sun's disc is 0.0093 rad wide; the rest is the sky's light around it), plus 5 % of the radius.
BALL_PENUMBRA = 0.03
#: Leaf projection G: the blades' shadow area per unit of their one-sided area, for leaves facing
#: every way (0.5, the spherical leaf distribution of canopy models; bent blades are near it).
LEAF_PROJECTION = 0.5
#: Extinction of the sky's (diffuse) light per unit of leaf area above a point (canopy models: 0.7-0.8).
SKY_EXTINCTION = 0.8
#: The most optical depth the whole layer has for the sun and for the sky: the project's blades are
#: wide for their count (a meadow of 2^20 has a leaf area index of 45 where real meadows have 2-8),
#: so the geometric depth is saturated smoothly to these (``d -> D (1 - exp(-d / D))``):
#: denser still reads darker, the roots never go black.
MAX_LAYER_DEPTH = 3.0
MAX_SKY_DEPTH = 1.5
#: The ground's ambient share (its colours are lit ones: this share is the sky's, the rest the sun's).
GROUND_AMBIENT = 0.4
#: Points sampled on the sun ray's way through the layer to find how much of it lies over the field.
TRANSMITTANCE_TAPS = 4


def sun_direction(elevation_deg, azimuth_deg):
    """Unit direction towards the sun (world space, y up) from its ``elevation_deg`` above the
    horizon and its ``azimuth_deg`` in the ground plane (0 = +x, 90 = +z, as
    ``GrassParams.wind_direction``)."""
    e, a = math.radians(float(elevation_deg)), math.radians(float(azimuth_deg))
    return (math.cos(e) * math.cos(a), math.sin(e), math.cos(e) * math.sin(a))


def sun_angles(direction):
    """``(elevation_deg, azimuth_deg)`` of a direction towards the sun (any length > 0; the inverse
    of :func:`sun_direction`, azimuth in (-180, 180])."""
    d = np.asarray(direction, np.float64).reshape(3)
    norm = float(np.linalg.norm(d))
    if not (np.all(np.isfinite(d)) and norm > 0):
        raise GrassValueError(f"direction must be a finite non-zero 3-vector; got {direction!r}")
    d = d / norm
    return math.degrees(math.asin(max(-1.0, min(1.0, d[1])))), math.degrees(math.atan2(d[2], d[0]))


def ball_shadow(p, sun, ball):
    """How much of the sun a point ``p`` (N, 3) sees past one ball ``(x, y, z, r)`` (N, 4),
    0 (in the core of its shadow) .. 1; ``sun`` (N, 3) unit towards the sun. A radius <= 0 (an
    unused slot) casts none. The ray's closest approach ``d`` to the centre at distance ``t``
    along it: visibility ``clip((d - r) / (2 w) + 1/2)`` with the penumbra ``w = BALL_PENUMBRA t
    + 0.05 r`` (t > 0), faded out as the ball moves behind the point (t from 0 down to -r)."""
    p, sun, ball = (np.asarray(x, np.float64) for x in (p, sun, ball))
    c, r = ball[..., :3], ball[..., 3]
    to_c = c - p
    t = np.sum(to_c * sun, axis=-1)
    d = np.linalg.norm(to_c - t[..., None] * sun, axis=-1)
    w = np.maximum(BALL_PENUMBRA * np.maximum(t, 0.0) + 0.05 * r, 1e-5)
    vis = np.clip((d - r) / (2.0 * w) + 0.5, 0.0, 1.0)
    ahead = np.clip(t / np.maximum(r, 1e-6) + 1.0, 0.0, 1.0)
    return np.where(r <= 0.0, 1.0, 1.0 - (1.0 - vis) * ahead)


def grass_transmittance(x, z, height_above, sun, c, half, edge, depth_per_m):
    """The share of the sun's light that reaches ground point (x, z) through ``height_above``
    metres (>= 0) of grass layer above it: ``exp(-depth_per_m height_above f)``, ``f`` the share
    of the ray's way through the layer that lies over the field (``field_inside`` of the
    rectangle ``c``, ``half``, ``edge``, at :data:`TRANSMITTANCE_TAPS` points along it; the ray
    moves ``sun.xz / max(sun.y, SUN_MIN_Y)`` sideways per metre of height). ``depth_per_m``: the
    sun's optical depth per metre of height (:func:`grass_optical_depths`)."""
    x, z, h, k, edge = (np.asarray(a, np.float64) for a in (x, z, height_above, depth_per_m, edge))
    sun = np.asarray(sun, np.float64)
    h = np.maximum(h, 0.0)
    reach = sun[..., [0, 2]] / np.maximum(sun[..., 1], SUN_MIN_Y)[..., None] * h[..., None]
    inside = 0.0
    for tap in range(TRANSMITTANCE_TAPS):
        s = (tap + 0.5) / TRANSMITTANCE_TAPS
        inside = inside + field_inside(x + s * reach[..., 0], z + s * reach[..., 1], c, half, edge)
    return np.exp(-k * h * inside / TRANSMITTANCE_TAPS)


def grass_above(along, layer_height):
    """The grass layer above a blade's point at ``along`` (0 root .. 1 tip) of a layer
    ``layer_height`` metres deep, as metres of layer: ``(1 - along)^2 layer_height``. The blades
    narrow towards their tips (the triangle-tip shape): the leaf area above a point is about
    ``(1 - along)^2`` of the whole, so the upper blades are lit and the darkness gathers at the roots."""
    a = 1.0 - np.clip(np.asarray(along, np.float64), 0.0, 1.0)
    return a * a * np.asarray(layer_height, np.float64)


def sky_visibility(x, z, height_above, c, half, edge, depth_per_m):
    """The share of the sky's light that reaches ground point (x, z) under ``height_above``
    metres (>= 0) of grass layer: ``exp(-depth_per_m height_above field_inside(x, z))``."""
    h = np.maximum(np.asarray(height_above, np.float64), 0.0)
    return np.exp(-np.asarray(depth_per_m, np.float64) * h * field_inside(x, z, c, half, edge))


def light_share(sun_visible, sky_visible, ambient, sun_scale, strength):
    """The factor (>= 0) of a surface's lit colour under these visibilities (0..1): the ambient share
    (``ambient``, 0..1) lit by the sky, at least :data:`SKY_FLOOR` of it where the sky is hidden,
    the rest by the sun times ``sun_scale`` (the ground's change of lighting with the sun's
    height; 1 for the blades, whose shading follows the sun already). ``strength`` 0..1 blends from
    1 (no shadows: the picture without them) to the full factor."""
    a = np.clip(np.asarray(ambient, np.float64), 0.0, 1.0)
    sky = SKY_FLOOR + (1.0 - SKY_FLOOR) * np.asarray(sky_visible, np.float64)
    lit = a * sky + (1.0 - a) * np.asarray(sun_visible, np.float64) * np.asarray(sun_scale, np.float64)
    return 1.0 + (lit - 1.0) * np.asarray(strength, np.float64)


def grass_optical_depths(leaf_area_index, layer_height, sun_y):
    """``(sun_depth_per_m, sky_depth_per_m)`` of a grass layer (both engines' shadow uniforms):
    its leaf area index L (one-sided blade area per m^2 of ground, ``sum(2 w h) / area`` as
    :func:`~grasswidget.core.reference.ground_cover`; w the half widths), its height (m, the mean
    blade height) and the sun's height ``sun_y`` (y of its unit direction).

    The whole layer's depth for the sun ``LEAF_PROJECTION L / max(sun_y, SUN_MIN_Y)`` and for the
    sky ``SKY_EXTINCTION L``, each saturated to :data:`MAX_LAYER_DEPTH` / :data:`MAX_SKY_DEPTH`
    (``D (1 - exp(-d / D))``), per metre of the layer's height. No layer (height <= 0): zeros."""
    leaf, layer = float(leaf_area_index), float(layer_height)
    if not (math.isfinite(leaf) and leaf >= 0):
        raise GrassValueError(f"leaf_area_index must be a finite number >= 0; got {leaf_area_index!r}")
    if not (math.isfinite(layer) and layer > 0):
        return 0.0, 0.0
    sun_d = LEAF_PROJECTION * leaf / max(float(sun_y), SUN_MIN_Y)
    sky_d = SKY_EXTINCTION * leaf
    sun_d = MAX_LAYER_DEPTH * (1.0 - math.exp(-sun_d / MAX_LAYER_DEPTH))
    sky_d = MAX_SKY_DEPTH * (1.0 - math.exp(-sky_d / MAX_SKY_DEPTH))
    return sun_d / layer, sky_d / layer
