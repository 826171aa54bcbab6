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
import signal
import threading
from contextlib import contextmanager

from ..errors import GrassValueError

__all__ = ["MAX_COORDINATE", "MAX_BLADE_HEIGHT", "MAX_BLADE_WIDTH", "MAX_BLADE_STIFFNESS", "MAX_STEPS",
           "steps_error_text", "check_steps",
           "StepsInterrupted", "hold_interrupts",
           "NonFiniteStateWarning", "nonfinite_cause", "nonfinite_message", "warn_nonfinite"]

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


class StepsInterrupted(KeyboardInterrupt):
    """Ctrl-C (a kernel interrupt) during a long ``step(n)``: raised once the GPU submission in
    flight was recorded, so the state stays consistent. A ``KeyboardInterrupt`` (not a
    GrassError: ``except Exception`` does not swallow it). Attributes: ``done`` (the fixed steps
    that ran and are counted in ``step_count``) and ``requested`` (the ``n`` asked for)."""

    def __init__(self, done: int, requested: int):
        super().__init__(f"step({requested:,}) interrupted after {done:,} steps; the state and the step "
                         f"counter hold those {done:,} steps")
        self.done, self.requested = int(done), int(requested)


class _Held:
    """The SIGINT that arrived while held (``hit``), see :func:`hold_interrupts`."""

    def __init__(self):
        self.hit = False

    def __call__(self, signum, frame):
        self.hit = True


_active: list = []  # the holder in force (nested holds share it)


@contextmanager
def hold_interrupts():
    """Hold Ctrl-C (SIGINT) back inside the block: the handler only records it (``held.hit``), so a
    loop of GPU submissions can check ``held.hit`` between two of them, stop there with its
    counters right and raise :class:`StepsInterrupted`. The previous handler is back after the
    block. Nested holds share the outer one. Outside the main thread (where signals cannot be
    handled) or under a handler not set from Python, nothing is held and ``hit`` stays False."""
    if _active:
        yield _active[-1]
        return
    held = _Held()
    old = None
    if threading.current_thread() is threading.main_thread():
        previous = signal.getsignal(signal.SIGINT)
        if previous is not None and previous is not signal.SIG_IGN:
            try:
                old = signal.signal(signal.SIGINT, held)
            except (ValueError, OSError):
                old = None
    _active.append(held)
    try:
        yield held
    finally:
        _active.pop()
        if old is not None:
            signal.signal(signal.SIGINT, old)


class NonFiniteStateWarning(RuntimeWarning):
    """Blades went non-finite (NaN or inf) in the simulation and its last validation step put
    them back at rest (``reference.validate_finite``). Warned once per cause (a wind WGSL, the
    user's blade-math functions), not once per frame."""


def warn_nonfinite(message: str):
    """Issue a :class:`NonFiniteStateWarning` attributed to the first caller outside the grasswidget
    package (the user's ``read_state()``, ``step`` or cell), not to the library line that noticed it,
    so the warning shows where the user's code is and a filter by module works."""
    import inspect
    import os
    import warnings

    package = os.path.dirname(os.path.dirname(os.path.abspath(__file__))) + os.sep
    frame = inspect.currentframe().f_back  # stacklevel 2: who called this
    level = 2
    while frame is not None and os.path.abspath(frame.f_code.co_filename).startswith(package):
        frame = frame.f_back
        level += 1
    del frame
    warnings.warn(message, NonFiniteStateWarning, stacklevel=level)


def nonfinite_cause(params, overrides: bool = False) -> str:
    """What most likely made blades non-finite with these params: the user's wind WGSL when the
    wind field is "custom", else the user's blade-math functions (``overrides``), else the wind
    field by name (every built-in input is range-checked, so that would be a bug)."""
    if params.wind_field == "custom":
        return "the wind WGSL (params.wind_wgsl, wind_field 'custom')"
    if overrides:
        return "the user's blade-math functions (set_function_overrides)"
    return f"wind_field {params.wind_field!r} (a grasswidget bug: please report it)"


def nonfinite_message(params, overrides: bool = False) -> str:
    """The warning's text: what went non-finite, under what, and what was done."""
    cause = nonfinite_cause(params, overrides)
    hint = " Make user_wind return finite numbers." if params.wind_field == "custom" else ""
    return (f"blades went non-finite (NaN or inf) under {cause}; the simulation's state validation "
            f"put them back at rest.{hint}")
