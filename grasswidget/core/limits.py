"""The largest numbers the blade physics takes and stays finite (pure Python, no GPU import).

The simulation runs in float32 (largest value about 3.4e38). Lengths are taken as
``sqrt(dot(d, d))``, so a distance is safe while its square is, i.e. below about 1.8e19 m;
a push or a lean of that order, squared once more by the collision strength
(``collision_gain * |d|^2``), must stay finite too. The limits below keep every product
the step forms (gravity, wind, recovery, collision pushes, the state validation of the
paper's section 5.2) many orders of magnitude below float32's range, and are still far
beyond any scene: a planet's radius (Earth: 6.4e6 m) fits in :data:`MAX_COORDINATE`.

Inputs past a limit are refused with a :class:`~grasswidget.errors.ParameterError` or a
:class:`~grasswidget.errors.GrassValueError` that names the input and the range:
``GrassParams.wind_center`` / ``gravity_center`` (:data:`MAX_COORDINATE`), a
``SphereCollider``'s ``center`` and ``radius`` (the same), ``Blades`` roots, heights,
widths and stiffnesses (:data:`MAX_COORDINATE`, :data:`MAX_BLADE_HEIGHT`,
:data:`MAX_BLADE_WIDTH`, :data:`MAX_BLADE_STIFFNESS`), and ``step(n)``
(:data:`MAX_STEPS`). What still goes non-finite (a user's ``wind_wgsl`` that returns NaN
or inf) is put back at rest by the simulation's last validation step
(``reference.validate_finite``), with one warning.

Float32 resolves about 1 m at 1e7 m from the origin (8 mm at 1e5 m): a field far from
the origin stays finite but its blades lose their shape; keep fields within a few km.
"""

from __future__ import annotations

import numbers

from ..errors import GrassValueError

__all__ = ["MAX_COORDINATE", "MAX_BLADE_HEIGHT", "MAX_BLADE_WIDTH", "MAX_BLADE_STIFFNESS", "MAX_STEPS",
           "steps_error_text", "check_steps"]

#: Largest |x|, |y| or |z| (metres) of a blade root, a wind or gravity centre, a sphere
#: collider's centre, and the largest collider radius: 1e7 m (squares 1e14, far below float32's 3.4e38).
MAX_COORDINATE = 1e7
#: Largest blade height h (metres).
MAX_BLADE_HEIGHT = 1e3
#: Largest blade width w (metres).
MAX_BLADE_WIDTH = 1e2
#: Largest blade stiffness s (1/s^2); times ``stiffness_scale`` (at most 20) it stays below 2e7.
MAX_BLADE_STIFFNESS = 1e6
#: Most fixed steps one ``step(n)`` call takes (GrassField, GrassScene, GrassWidget, both engines):
#: 1,000,000 steps, 2.3 hours of simulated time at the default dt of 1/120 s. A longer run is a
#: loop of calls; the widget's kernel engine can be interrupted between GPU submissions.
MAX_STEPS = 1_000_000


def steps_error_text(n) -> str:
    """The error text for a step count ``n`` that is not an integer in [0, MAX_STEPS]."""
    return f"n (number of steps) must be an integer in [0, {MAX_STEPS:,}] (MAX_STEPS, grasswidget.core.limits); got {n!r}"


def check_steps(n) -> int:
    """``n`` as an int when it is an integer (not a bool) in [0, MAX_STEPS]; else a
    GrassValueError (a ValueError) naming ``n``, the range and MAX_STEPS."""
    if isinstance(n, bool) or not isinstance(n, numbers.Integral) or not 0 <= n <= MAX_STEPS:
        raise GrassValueError(steps_error_text(n))
    return int(n)
