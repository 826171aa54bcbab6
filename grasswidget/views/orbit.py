"""Orbit limits: the camera stays above the ground, the field stays in sight.

pygfx's ``OrbitController`` lets a drag take the camera under the ground plane
(the sky then shows beneath the grass), a pan carry the orbit target far off the
field, and the wheel zoom in through the target or out past the far plane.
:class:`OrbitLimits` describes what a meadow view allows and :func:`clamp_orbit`
(pure NumPy) puts a camera position and orbit target back inside those limits
(both in :mod:`grasswidget.core.orbit_limits`, which lists the limits; the
browser engine clamps its drags with the same rules). :class:`GroundOrbitController`
is pygfx's controller with every orbit, zoom and pan step held to them, so a
drag simply stops at a limit and turns back at once.
"""

from __future__ import annotations

import numpy as np

from ..core.orbit_limits import OrbitLimits, clamp_orbit
from ..errors import UnknownNameError

__all__ = ["OrbitLimits", "clamp_orbit", "GroundOrbitController"]


def _controller_class():
    from ..compat import held_orbit_controller_class

    class GroundOrbitController(held_orbit_controller_class(_hold)):
        """pygfx's ``OrbitController`` (a custom target is required) whose orbit,
        zoom and pan steps are held to an :class:`OrbitLimits` (``limits``).

        Each step is taken as pygfx computes it, then put back inside the limits
        with :func:`clamp_orbit` before the camera sees it (the hook on pygfx's
        controller lives in :func:`grasswidget.compat.held_orbit_controller_class`).
        So a drag stops at a limit and, reversed, moves back at once.
        """

        def __init__(self, *args, limits: OrbitLimits, **kwargs):
            self.limits = limits
            super().__init__(*args, **kwargs)

    return GroundOrbitController


def _hold(controller, position, target, state):
    """The step's camera pose held to ``controller.limits``: (position, rotation,
    target), or None when the step is inside them."""
    pos, tgt = clamp_orbit(position, target, controller.limits)
    if np.allclose(pos, position) and np.allclose(tgt, target):
        return None
    return pos, _look_rotation(pos, tgt, state), tgt


def _look_rotation(position, target, state):
    """The camera rotation (quaternion x, y, z, w) looking from ``position`` at
    ``target`` with the state's ``reference_up`` (no roll), as pygfx's look_at."""
    import pylinalg as la

    up = np.asarray(state.get("reference_up", (0.0, 1.0, 0.0)), np.float64)
    eye = np.asarray(position, np.float64)
    # pylinalg aims +z at the point; a pygfx camera looks along -z: aim +z away from the target
    m = la.mat_look_at(eye, 2.0 * eye - np.asarray(target, np.float64), up)
    return la.quat_from_mat(m)


def __getattr__(name):  # GroundOrbitController is built on first use (pygfx is imported then)
    if name == "GroundOrbitController":
        cls = _controller_class()
        globals()[name] = cls
        return cls
    raise UnknownNameError(f"module {__name__!r} has no attribute {name!r}")
