"""A real-time clock that spends wall time in whole fixed simulation steps.

:class:`SimClock` turns elapsed wall-clock seconds (times ``time_scale``) into
a whole number of fixed steps of ``dt`` per drawn frame; what is left over (less
than one step) waits in an accumulator for the next frame, so over many frames
simulated time follows the wall clock exactly, whatever the frame rate, and the
physics never sees a variable dt.

When a frame would need more than ``max_steps`` steps (a slow machine, a long
hiccup, a large ``time_scale``) it gets ``max_steps`` and the rest is dropped:
the meadow then runs in slow motion, and :attr:`SimClock.speed` says how fast
(simulated seconds per scaled wall second, over the last second or so).

Pure Python; the wall clock is ``time.perf_counter`` unless another is given
(tests pass a fake one).
"""

from __future__ import annotations

import math
import time

from ..core.engine_inputs import MAX_STEPS_PER_FRAME  # the rule both engines' clocks follow
from ..errors import GrassValueError

__all__ = ["SimClock", "SharedClock", "FollowerClock", "MAX_STEPS_PER_FRAME"]


class _StepTally:
    """What a clock's view simulated: ``steps`` (fixed steps) and ``sim_time`` (their seconds),
    recorded by :meth:`count` (SimClock and FollowerClock)."""

    steps = 0
    sim_time = 0.0

    def count(self, n: int, dt: float):
        """Record ``n`` fixed steps of ``dt`` seconds that were simulated."""
        self.steps += int(n)
        self.sim_time += int(n) * float(dt)


class SimClock(_StepTally):
    """Fixed steps for the wall time that went by.

    Args:
        max_steps: the most steps one frame may take (>= 1, default :data:`MAX_STEPS_PER_FRAME`).
        now: a function returning wall-clock seconds (default ``time.perf_counter``).

    Attributes:
        sim_time: simulated seconds since the last :meth:`reset` (float, read it,
            never set it: every step counted through :meth:`advance` or :meth:`count`).
        steps: fixed steps since the last :meth:`reset`.
        last_steps: steps handed out by the last :meth:`frame_steps`.
        capped: True when the last frame hit ``max_steps``.
        now: the wall-clock function (swap it for a simulated clock in tests).
    """

    #: Seconds over which :attr:`speed` is averaged.
    SPEED_WINDOW = 1.0

    def __init__(self, max_steps: int = MAX_STEPS_PER_FRAME, now=None):
        if isinstance(max_steps, bool) or not isinstance(max_steps, int) or max_steps < 1:
            raise GrassValueError(f"max_steps must be an integer >= 1; got {max_steps!r}")
        self.max_steps = max_steps
        self.now = now or time.perf_counter
        self.sim_time = 0.0
        self.steps = 0
        self.last_steps = 0
        self.capped = False
        self._running = False
        self._last = None
        self._acc = 0.0
        self._window = []  # (wall seconds scaled, simulated seconds) of recent frames

    # ------------------------------------------------------------------ running

    @property
    def running(self) -> bool:
        return self._running

    def start(self):
        """Start (or keep) following the wall clock from now; no time is owed for the pause."""
        if not self._running:
            self._running = True
            self._last = self.now()
            self._window = []

    def stop(self):
        """Stop exactly: wall time from now on is not simulated (the leftover under one step is dropped)."""
        self._running = False
        self._last = None
        self._acc = 0.0

    def reset(self):
        """Simulated time back to 0 (e.g. every blade back to rest)."""
        self.sim_time = 0.0
        self.steps = 0
        self._acc = 0.0
        self._window = []
        if self._running:
            self._last = self.now()

    # ------------------------------------------------------------------ steps

    def frame_steps(self, dt: float, time_scale: float = 1.0) -> int:
        """Steps of ``dt`` seconds owed for the wall time since the last call
        (times ``time_scale``), at most ``max_steps``. 0 while stopped. The caller
        must simulate exactly that many steps and then call :meth:`count`."""
        if not self._running:
            self.last_steps, self.capped = 0, False
            return 0
        if not (dt > 0 and math.isfinite(dt)):
            raise GrassValueError(f"dt must be a finite number > 0 (seconds); got {dt!r}")
        now = self.now()
        wall = max(0.0, now - self._last) * max(0.0, float(time_scale))
        self._last = now
        self._acc += wall
        n = int(math.floor(self._acc / dt + 1e-9))
        self.capped = n > self.max_steps
        if self.capped:
            n = self.max_steps
            self._acc = 0.0  # the rest is dropped: slow motion, never a catch-up burst
        else:
            self._acc = max(0.0, self._acc - n * dt)
        self.last_steps = n
        self._window.append((now, wall, n * dt))
        while len(self._window) > 2 and now - self._window[0][0] > self.SPEED_WINDOW:
            self._window.pop(0)
        return n

    @property
    def speed(self) -> float | None:
        """Simulated seconds per (time-scaled) wall second over the last second:
        1.0 in real time, < 1 in slow motion; None before there is a measurement."""
        wall = sum(w for _t, w, _s in self._window[1:])
        if len(self._window) < 2 or wall <= 0:
            return None
        return sum(s for _t, _w, s in self._window[1:]) / wall


class SharedClock:
    """One simulated time for several views (a comparison, :mod:`grasswidget.notebook.compare`).

    Each view gets a :meth:`follower`: a clock with :class:`SimClock`'s interface that the
    view's frame loop uses unchanged. The shared clock holds the simulated time every view
    steps towards (:attr:`time`); it moves on, by the wall time since it last moved (times
    ``time_scale``), only when every view that draws has caught up with it. So while
    playing, the n-th frame of every view shows the same simulated time (to within one
    step of each view's own ``dt``), and the pace is that of the slowest view. A view
    that stops drawing (hidden, closed) holds the others back for at most
    :attr:`STALL_S` seconds; it catches up (at most ``max_steps`` a frame) when it
    draws again. A frame that would need more than ``max_steps`` steps makes the time
    move by ``max_steps`` steps only (slow motion, never a catch-up burst).

    Args:
        max_steps: the most steps one frame may take (>= 1).
        now: a function returning wall-clock seconds (default ``time.perf_counter``).
    """

    #: Wall seconds a view that does not draw may hold the shared time back.
    STALL_S = 0.5

    def __init__(self, max_steps: int = MAX_STEPS_PER_FRAME, now=None):
        if isinstance(max_steps, bool) or not isinstance(max_steps, int) or max_steps < 1:
            raise GrassValueError(f"max_steps must be an integer >= 1; got {max_steps!r}")
        self.max_steps = max_steps
        self.now = now or time.perf_counter
        #: Simulated seconds the views step towards (never decreases).
        self.time = 0.0
        self.followers = []
        self._running = False
        self._last = None
        self._moved_at = None
        self._window = []

    @property
    def running(self) -> bool:
        return self._running

    def follower(self) -> "FollowerClock":
        """A new clock for one view, following this one from its current time."""
        f = FollowerClock(self)
        self.followers.append(f)
        return f

    def start(self):
        if not self._running:
            self._running = True
            self._last = self._moved_at = self.now()
            self._window = []

    def stop(self):
        self._running = False
        self._last = None

    def advance(self, dt: float, time_scale: float):
        """Move the shared time on when every drawing view has caught up with it (or one
        has stalled for :attr:`STALL_S`); called by a follower at the start of its frame."""
        if not self._running:
            return
        now = self.now()
        behind = any(f.owed() > 0 for f in self.followers if f.dt is not None)
        if behind and now - self._moved_at < self.STALL_S:
            return
        wall = max(0.0, now - self._last) * max(0.0, float(time_scale))
        moved = min(wall, self.max_steps * float(dt))
        self.time += moved
        self._last = self._moved_at = now
        self._window.append((now, wall, moved))
        while len(self._window) > 2 and now - self._window[0][0] > SimClock.SPEED_WINDOW:
            self._window.pop(0)

    @property
    def speed(self) -> float | None:
        """Simulated seconds per (time-scaled) wall second over the last second, as SimClock.speed."""
        wall = sum(w for _t, w, _s in self._window[1:])
        if len(self._window) < 2 or wall <= 0:
            return None
        return sum(s for _t, _w, s in self._window[1:]) / wall


class FollowerClock(_StepTally):
    """One view's clock in a :class:`SharedClock` (the :class:`SimClock` interface a view uses).

    :meth:`frame_steps` hands out the whole steps that bring this view's simulated time up
    to the shared time (at most ``max_steps``); :meth:`reset` starts this view's own count
    again at 0 from the shared time's present value. ``sim_time``, ``steps``,
    ``last_steps``, ``capped`` and ``speed`` read as SimClock's.
    """

    def __init__(self, shared: SharedClock):
        self.shared = shared
        self.max_steps = shared.max_steps
        self.sim_time = 0.0
        self.steps = 0
        self.last_steps = 0
        self.capped = False
        #: The view's dt of its last frame (None before its first: it holds no one back).
        self.dt = None
        self.origin = shared.time  # shared time at which this view's own time was 0

    @property
    def running(self) -> bool:
        return self.shared.running

    def start(self):
        self.shared.start()

    def stop(self):
        self.shared.stop()

    def reset(self):
        self.sim_time, self.steps = 0.0, 0
        self.origin = self.shared.time

    def owed(self, dt: float | None = None) -> int:
        """Whole steps of ``dt`` (default: this view's last dt) this view is behind the shared time."""
        dt = dt if dt is not None else self.dt
        if not dt:
            return 0
        return max(0, int(math.floor((self.shared.time - self.origin - self.sim_time) / dt + 1e-6)))

    def frame_steps(self, dt: float, time_scale: float = 1.0) -> int:
        if not self.shared.running:
            self.last_steps, self.capped = 0, False
            return 0
        if not (dt > 0 and math.isfinite(dt)):
            raise GrassValueError(f"dt must be a finite number > 0 (seconds); got {dt!r}")
        self.dt = float(dt)
        self.shared.advance(dt, time_scale)
        n = self.owed(dt)
        self.capped = n > self.max_steps
        n = min(n, self.max_steps)
        self.last_steps = n
        return n

    @property
    def speed(self) -> float | None:
        return self.shared.speed
