"""How far the blades are from rest: tip offset and bend, from a blade state (pure NumPy).

A blade at rest has its tip guide ``v2`` at ``v0 + up * height`` (straight up from
its root). Two numbers describe how the forces moved it:

* the **tip offset**: ``|v2 - (v0 + up * height)|``, metres, the distance of the tip
  guide from its rest place (0 at rest, up to about ``height * sqrt(2)`` for a blade
  lying on the ground);
* the **bend**: the angle between ``up`` and ``v2 - v0``, degrees (0 standing
  straight up, 90 lying flat; the state validation of the paper keeps v2 above the
  ground, so it stays below 90).

The state is a dict as ``GrassField.read_state()`` (and ``GrassWidget.read_state()``)
returns it: ``v0``, ``v2``, ``up`` (N, 3) and ``height`` (N,). Used by the sweeps
(:mod:`grasswidget.tools.sweep`) and the notebooks.
"""

from __future__ import annotations

import numpy as np

from ..errors import GrassTypeError, GrassValueError

__all__ = ["tip_offsets", "bend_angles_deg", "response_summary"]

_KEYS = ("v0", "v2", "up", "height")


def _arrays(state):
    if not isinstance(state, dict):
        raise GrassTypeError(f"state must be a dict as read_state() returns it; got {type(state).__name__}")
    missing = [k for k in _KEYS if k not in state]
    if missing:
        raise GrassValueError(f"state must have the keys {', '.join(_KEYS)}; missing {', '.join(missing)}")
    v0, v2, up = (np.asarray(state[k], np.float64) for k in ("v0", "v2", "up"))
    height = np.asarray(state["height"], np.float64).reshape(-1)
    n = len(height)
    for name, a in (("v0", v0), ("v2", v2), ("up", up)):
        if a.shape != (n, 3):
            raise GrassValueError(f"state[{name!r}] must have shape ({n}, 3) (one row per blade); got {a.shape}")
    return v0, v2, up, height


def tip_offsets(state) -> np.ndarray:
    """Distance of each blade's tip guide v2 from its rest place ``v0 + up * height``,
    metres, (N,) float64 (``up`` is taken as given: a unit vector in a field's state)."""
    v0, v2, up, height = _arrays(state)
    return np.linalg.norm(v2 - (v0 + up * height[:, None]), axis=1)


def bend_angles_deg(state) -> np.ndarray:
    """Angle between each blade's ``up`` and ``v2 - v0``, degrees in [0, 180], (N,) float64
    (0 for a blade standing straight; a blade whose v2 sits on v0 counts as 0)."""
    v0, v2, up, _height = _arrays(state)
    d = v2 - v0
    length = np.linalg.norm(d, axis=1) * np.linalg.norm(up, axis=1)
    cos = np.divide(np.einsum("ij,ij->i", d, up), length, out=np.ones(len(d)), where=length > 0)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def response_summary(state) -> dict:
    """``{"mean_tip_offset": metres, "mean_bend_deg": degrees, "blades": N}`` over every blade
    of ``state`` (NaN means for an empty state)."""
    offsets, bends = tip_offsets(state), bend_angles_deg(state)
    n = len(offsets)
    return {"mean_tip_offset": float(offsets.mean()) if n else float("nan"),
            "mean_bend_deg": float(bends.mean()) if n else float("nan"), "blades": n}
