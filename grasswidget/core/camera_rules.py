"""The camera's rules, decided once for both engines (pure Python).

* :func:`default_camera`: the home view of a field (GrassScene's and the browser engine's).
* :func:`camera_world` / :func:`perspective` / :func:`view_proj`: a camera's matrices
  (camera to world, the WebGPU projection, world to clip space). The browser engine moves
  its camera between two kernel messages (an orbit drag), so it computes these matrices
  itself each frame with ``grasswidget/browser/js/rules.js``'s twins, which a node test
  checks against these functions.
* :func:`drag_rules` with :func:`orbit_drag`, :func:`pan_drag` and :func:`wheel_zoom`:
  how a pointer drag or a wheel turn moves the browser engine's camera (before the orbit
  limits, :func:`grasswidget.core.orbit_limits.clamp_orbit`, hold it). Sent to the browser
  as ``frame_rules["drag"]``; the JS twins in ``rules.js`` execute the numbers given.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import GrassValueError

__all__ = ["default_camera", "camera_world", "perspective", "view_proj", "drag_rules", "orbit_drag",
           "pan_drag", "wheel_zoom", "ORBIT_RADIANS_PER_PIXEL", "DRAG_MAX_ELEVATION", "WHEEL_PER_DELTA",
           "WHEEL_MAX_LOG", "CAMERA_SYNC_MS", "DEFAULT_FOV_DEG", "DEFAULT_NEAR", "DEFAULT_FAR"]

#: Radians of azimuth (or elevation) per CSS pixel of an orbit drag.
ORBIT_RADIANS_PER_PIXEL = 0.008
#: A drag holds the elevation within +-this (radians, short of the poles) before the orbit limits.
DRAG_MAX_ELEVATION = 1.55
#: Natural log of the distance factor per unit of a wheel event's deltaY (0.001: 100 units ~ 10 %).
WHEEL_PER_DELTA = 0.001
#: One wheel event changes the distance by at most exp(+-this).
WHEEL_MAX_LOG = 0.5
#: While dragging, the browser syncs its camera to Python at most every this many milliseconds.
CAMERA_SYNC_MS = 100
#: The home camera's vertical field of view (degrees) and depth range (near, far in metres).
DEFAULT_FOV_DEG = 45.0
DEFAULT_NEAR = 0.1
DEFAULT_FAR = 100.0


def default_camera(v0) -> dict:
    """The home view of a field whose blade roots are ``v0`` (N x 3, m): from above one edge
    (0.95 of the larger side away, 0.28 of that plus 1 m high), looking at the middle of the
    field at 0.6 m height; fov 45 degrees, near 0.1 m, far 100 m. Returns the camera dict
    (``position``, ``target``, ``fov_deg``, ``near``, ``far``) both engines start from."""
    v0 = np.asarray(v0, np.float64).reshape(-1, 3)
    if not len(v0):
        raise GrassValueError("default_camera needs at least one blade root (v0 is empty)")
    lo, hi = v0.min(axis=0), v0.max(axis=0)
    extent = float(max(hi[0] - lo[0], hi[2] - lo[2], 1.0))
    c = 0.5 * (lo + hi)
    d = extent * 0.95
    return {
        "position": [float(c[0]), 0.28 * d + 1.0, float(c[2]) + d],
        "target": [float(c[0]), 0.6, float(c[2])],
        "fov_deg": DEFAULT_FOV_DEG,
        "near": DEFAULT_NEAR,
        "far": DEFAULT_FAR,
    }


def camera_world(eye, target) -> np.ndarray:
    """Camera to world (4x4 float64, row-major; columns right, up, back, position) of a camera
    at ``eye`` looking at ``target`` (m), world up +y (straight down or up: right is +x)."""
    eye, at = np.asarray(eye, np.float64), np.asarray(target, np.float64)
    back = eye - at
    back = back / (float(np.linalg.norm(back)) or 1.0)
    right = np.cross([0.0, 1.0, 0.0], back)
    right = np.array([1.0, 0.0, 0.0]) if np.linalg.norm(right) < 1e-9 else right / np.linalg.norm(right)
    up = np.cross(back, right)
    world = np.eye(4)
    world[:3, 0], world[:3, 1], world[:3, 2], world[:3, 3] = right, up, back, eye
    return world


def perspective(fov_deg, aspect, near, far) -> np.ndarray:
    """The projection (4x4 float64, row-major) of a vertical field of view ``fov_deg``,
    ``aspect`` = width / height, WebGPU depth 0 at ``near`` and 1 at ``far`` (m)."""
    f = 1.0 / math.tan(math.radians(float(fov_deg)) / 2.0)
    proj = np.zeros((4, 4))
    proj[0, 0], proj[1, 1] = f / float(aspect), f
    proj[2, 2] = far / (near - far)
    proj[2, 3] = near * far / (near - far)
    proj[3, 2] = -1.0
    return proj


def view_proj(position, target, fov_deg, near, far, aspect) -> np.ndarray:
    """World to WebGPU clip space (4x4 float64, row-major): ``perspective @ inv(camera_world)``."""
    return perspective(fov_deg, aspect, near, far) @ np.linalg.inv(camera_world(position, target))


def drag_rules() -> dict:
    """The numbers of the browser's camera drags (``frame_rules["drag"]``, JSON-able)."""
    return {"radians_per_pixel": ORBIT_RADIANS_PER_PIXEL, "max_elevation": DRAG_MAX_ELEVATION,
            "wheel_per_delta": WHEEL_PER_DELTA, "wheel_max_log": WHEEL_MAX_LOG, "sync_ms": CAMERA_SYNC_MS}


def orbit_drag(position, target, dx, dy, rules=None) -> np.ndarray:
    """The camera position after an orbit drag of (dx, dy) CSS pixels around ``target``:
    azimuth less dx, elevation plus dy (times ``radians_per_pixel``), elevation held within
    +-``max_elevation``, distance kept. ``rules``: :func:`drag_rules` (default)."""
    r_ = rules or drag_rules()
    off = np.subtract(np.asarray(position, np.float64), np.asarray(target, np.float64))
    r = float(np.linalg.norm(off))
    az = math.atan2(off[0], off[2]) - dx * r_["radians_per_pixel"]
    el = math.asin(max(-1.0, min(1.0, off[1] / r)))
    el = max(-r_["max_elevation"], min(r_["max_elevation"], el + dy * r_["radians_per_pixel"]))
    off = np.array([r * math.cos(el) * math.sin(az), r * math.sin(el), r * math.cos(el) * math.cos(az)])
    return np.asarray(target, np.float64) + off


def pan_drag(position, target, fov_deg, dx, dy, height_px) -> tuple:
    """``(position, target)`` after a pan drag of (dx, dy) CSS pixels in a view ``height_px``
    CSS pixels high: both move in the view plane so that the point at the target's distance
    follows the pointer."""
    pos, tgt = np.asarray(position, np.float64), np.asarray(target, np.float64)
    world = camera_world(pos, tgt)
    dist = float(np.linalg.norm(pos - tgt))
    k = 2 * dist * math.tan(math.radians(float(fov_deg)) / 2) / float(height_px)
    move = world[:3, 0] * (-dx * k) + world[:3, 1] * (dy * k)
    return pos + move, tgt + move


def wheel_zoom(position, target, delta_y, rules=None) -> np.ndarray:
    """The camera position after a wheel event of ``delta_y``: the distance to the target times
    exp(delta_y ``wheel_per_delta``), the exponent held within +-``wheel_max_log``."""
    r_ = rules or drag_rules()
    k = math.exp(max(-r_["wheel_max_log"], min(r_["wheel_max_log"], delta_y * r_["wheel_per_delta"])))
    tgt = np.asarray(target, np.float64)
    return tgt + (np.asarray(position, np.float64) - tgt) * k
