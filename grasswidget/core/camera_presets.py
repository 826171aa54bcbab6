"""Named cameras ("home", "top", "low"), computed from the field, pure NumPy.

:func:`camera_preset` gives the camera a :meth:`GrassWidget.look_from
<grasswidget.notebook.widget.GrassWidget.look_from>` button moves to, in both
engines (the widget hands the result to its view as a ``camera_state``):

- ``"home"``: the start camera (the scene's own view, as ``reset_camera()``).
- ``"top"``: straight down over the middle of the field (1.5 degrees short of
  vertical, the highest the orbit allows, :data:`MAX_ELEVATION_DEG`), high enough
  that the whole field, tips included, fits the picture with a margin: the view
  for the freeze-culling demo (freeze at "home", then look from "top"). The far
  side of the field (seen from home) is at the top of the picture.
- ``"low"``: a student's eye over the grass: just above the tallest blade's tip
  (:data:`LOW_EYE_ABOVE_GRASS` above the "grass" orbit floor), at the field's edge
  on the home side, looking across the field at its far edge, half a blade high.

All three lie inside the "grass" orbit limits of the field (:class:`OrbitLimits`,
checked in the tests), except a "home" view that is itself lower (the cis565
course view, 1 m above the ground): the widget then lowers its floor to "ground".
The presets are made for a field on a ground plane (``y`` up); on other fields
(grass on a sphere) they look from the same places around its bounding box.
"""

from __future__ import annotations

import math

import numpy as np

from .orbit_limits import GRASS_CLEARANCE, MAX_ELEVATION_DEG, OrbitLimits, clamp_orbit, grass_top
from ..errors import GrassValueError

__all__ = ["CAMERA_PRESETS", "TOP_MARGIN", "LOW_EYE_ABOVE_GRASS", "check_camera_preset",
           "camera_preset", "field_box", "floor_for"]

#: The names :func:`camera_preset` (and ``GrassWidget.look_from``) knows.
CAMERA_PRESETS = ("home", "top", "low")
#: The "top" picture holds the field's footprint times this (a margin around the field).
TOP_MARGIN = 1.08
#: Height of the "low" camera above the "grass" orbit floor (the tallest tip + GRASS_CLEARANCE), metres.
LOW_EYE_ABOVE_GRASS = 0.05


def check_camera_preset(name) -> str:
    """``name`` if it is one of :data:`CAMERA_PRESETS`, else GrassValueError naming them."""
    if not isinstance(name, str) or name not in CAMERA_PRESETS:
        raise GrassValueError(f"name (camera preset) must be one of {', '.join(map(repr, CAMERA_PRESETS))}; "
                              f"got {name!r}")
    return name


def field_box(v0, height, horizon=None) -> dict:
    """The field's extent at rest: ``lo``, ``hi`` (x, z of the outermost roots, m),
    ``center`` (x, z), ``ground`` (lowest root y) and ``top`` (highest tip y). For a field
    to the horizon (``horizon``, a :class:`~grasswidget.core.horizon.HorizonLayout`), its
    near disc's square is the extent (the part the cameras look at)."""
    v0 = np.asarray(v0, np.float64).reshape(-1, 3)
    if not len(v0):
        raise GrassValueError("blades: a camera preset needs at least one blade")
    lo, hi = v0.min(axis=0), v0.max(axis=0)
    if horizon is not None:
        r0, (cx, cz) = float(horizon.near_radius), horizon.center
        lo = np.array([cx - r0, lo[1], cz - r0])
        hi = np.array([cx + r0, hi[1], cz + r0])
    return {"lo": (float(lo[0]), float(lo[2])), "hi": (float(hi[0]), float(hi[2])),
            "center": (float(0.5 * (lo[0] + hi[0])), float(0.5 * (lo[2] + hi[2]))),
            "ground": float(lo[1]), "top": grass_top(v0, height)}


def _home_direction(home) -> np.ndarray:
    """Unit (x, 0, z) from the home target towards the home camera (+z when home looks straight down)."""
    off = np.subtract(home["position"], home["target"]).astype(np.float64)
    h = np.array([off[0], 0.0, off[2]])
    n = float(np.linalg.norm(h))
    return h / n if n > 1e-9 else np.array([0.0, 0.0, 1.0])


def camera_preset(name, v0, height, *, home, aspect, fov_deg=None, limits: OrbitLimits | None = None,
                  horizon=None) -> dict:
    """The camera of preset ``name`` (:data:`CAMERA_PRESETS`) for a field.

    Args:
        name: "home", "top" or "low" (anything else: GrassValueError naming them).
        v0: (N, 3) blade roots (metres, world space, y up); height: (N,) blade heights (m).
        home: the start camera, a dict with ``position``, ``target`` (3 numbers, m) and
            ``fov_deg`` (vertical, degrees): "home" returns it; the others face the
            field from its side (its azimuth).
        aspect: the view's width / height (> 0), for "top" to fit the field.
        fov_deg: vertical field of view of the new camera (degrees, 1..179; default
            the home one).
        limits: when given, the camera is put inside these orbit limits
            (:func:`clamp_orbit`), so that the next drag does not jump.
        horizon: ``Blades.horizon`` of a field to the horizon (its near disc is the
            field the presets frame), else None.

    Returns ``{"position": (x, y, z), "target": (x, y, z), "fov_deg": f}`` (floats).
    """
    check_camera_preset(name)
    fov = float(home["fov_deg"] if fov_deg is None else fov_deg)
    if not (1.0 <= fov <= 179.0):
        raise GrassValueError(f"fov_deg must be in [1, 179] degrees; got {fov_deg!r}")
    if isinstance(aspect, bool) or not isinstance(aspect, (int, float, np.number)) or not aspect > 0:
        raise GrassValueError(f"aspect (view width / height) must be a number > 0; got {aspect!r}")
    if name == "home":
        position = np.asarray(home["position"], np.float64)
        target = np.asarray(home["target"], np.float64)
        fov = float(home["fov_deg"])
    else:
        box = field_box(v0, height, horizon)
        cx, cz = box["center"]
        half_x = 0.5 * (box["hi"][0] - box["lo"][0])
        half_z = 0.5 * (box["hi"][1] - box["lo"][1])
        toward_home = _home_direction(home)
        if name == "top":
            position, target = _top(box, cx, cz, half_x, half_z, toward_home, fov, float(aspect))
        else:
            position, target = _low(box, cx, cz, half_x, half_z, toward_home, height)
    if limits is not None:
        position, target = clamp_orbit(position, target, limits)
    return {"position": tuple(float(x) for x in position), "target": tuple(float(x) for x in target),
            "fov_deg": fov}


def _top(box, cx, cz, half_x, half_z, toward_home, fov, aspect):
    """Straight down over the middle: the footprint (at the tips' height, the nearest
    to the camera) times TOP_MARGIN fits both the vertical and the horizontal view."""
    tan_v = math.tan(math.radians(fov) / 2.0)
    above_tips = TOP_MARGIN * max(half_z / tan_v, half_x / (aspect * tan_v), 1.0)
    target = np.array([cx, box["ground"], cz])
    el = math.radians(MAX_ELEVATION_DEG)
    distance = (box["top"] - box["ground"] + above_tips) / math.sin(el)
    # the camera leans 1.5 degrees towards home, so "up" in the picture is the far side seen from home
    position = target + distance * (math.cos(el) * toward_home + np.array([0.0, math.sin(el), 0.0]))
    return position, target


def _low(box, cx, cz, half_x, half_z, toward_home, height):
    """At the field's edge on the home side, just above the tallest tip, looking across at
    the far edge, half a mean blade high."""
    # distance from the middle to the footprint's edge along toward_home
    exits = [h / abs(d) for h, d in ((half_x, toward_home[0]), (half_z, toward_home[2])) if abs(d) > 1e-9]
    edge = min(exits) if exits else 0.0
    eye = box["top"] + GRASS_CLEARANCE + LOW_EYE_ABOVE_GRASS
    position = np.array([cx, eye, cz]) + (edge + 0.5) * toward_home
    mean_height = float(np.mean(height)) if len(height) else 1.0
    target = np.array([cx, box["ground"] + 0.5 * mean_height, cz]) - edge * toward_home
    return position, target


def floor_for(blades, camera: dict, far) -> str:
    """The orbit floor a camera needs: ``"grass"`` when ``camera`` (position, target) lies inside
    the "grass" orbit limits of ``blades`` (a :class:`~grasswidget.core.blades.Blades`; far plane
    ``far`` m), else ``"ground"`` (it is lower than the grass floor allows, e.g. the cis565 course
    view 1 m above the ground, and would jump up at the first drag)."""
    grass = OrbitLimits.for_field(blades.v0, blades.up, blades.height, far, floor="grass", horizon=blades.horizon)
    return "grass" if grass.allows(camera["position"], camera["target"], tol=1e-4) else "ground"
