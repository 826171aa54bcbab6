"""Adaptive resolution: lower the render scale while frames come too slowly, raise it with headroom.

:class:`ResolutionGovernor` watches the frames a live view draws while playing
(when each started, and how long the kernel was busy with it: simulation,
render, readback, encode and send) and picks a render scale from
:data:`SCALES` (1.0 = the full pixel ratio, down to 0.5 = a quarter of the
pixels):

* below the target rate (fewer than ``0.95 * target_fps`` frames per second
  over the last window) it steps one scale down;
* when the busy time per frame, scaled to the next larger scale by its pixel
  count, would still leave a quarter of the frame interval free, it steps one
  scale up;
* each decision needs a fresh window (at least :data:`WINDOW_S` seconds and
  :data:`WINDOW_FRAMES` frames), so the scale moves step by step and never
  flickers on one slow frame.

Pure Python; the wall clock is ``time.perf_counter`` unless another is given.
"""

from __future__ import annotations

import math
import numbers
import time

from ..errors import GrassValueError

__all__ = ["ResolutionGovernor", "SCALES", "check_target_fps", "TARGET_FPS_RANGE"]

#: Render scales, largest first (fraction of the full pixel ratio per axis).
SCALES = (1.0, 0.85, 0.7, 0.6, 0.5)
#: Shortest window (seconds) and fewest frames behind one decision.
WINDOW_S = 0.6
WINDOW_FRAMES = 4
#: Allowed target frame rates (frames per second).
TARGET_FPS_RANGE = (1.0, 240.0)


def check_target_fps(value) -> float:
    """``value`` as a float in :data:`TARGET_FPS_RANGE`, or ValueError naming ``target_fps``."""
    lo, hi = TARGET_FPS_RANGE
    ok = isinstance(value, numbers.Real) and not isinstance(value, bool)
    if not ok or not math.isfinite(float(value)) or not lo <= float(value) <= hi:
        raise GrassValueError(f"target_fps must be a number in [{lo:g}, {hi:g}] (frames per second); got {value!r}")
    return float(value)


class ResolutionGovernor:
    """Pick the render scale that keeps a live view at ``target_fps``.

    Args:
        target_fps: frames per second to hold (see :func:`check_target_fps`).
        now: a function returning wall-clock seconds (default ``time.perf_counter``).

    Attributes: ``scale`` (the scale in use, one of :data:`SCALES`),
    ``target_fps``, ``now``.
    """

    def __init__(self, target_fps: float, now=None):
        self.target_fps = check_target_fps(target_fps)
        self.now = now or time.perf_counter
        self.scale = SCALES[0]
        self._window = []  # (start time, busy seconds) per frame

    def restart(self):
        """Forget the frames so far (e.g. after a pause or a new field)."""
        self._window = []

    def frame(self, busy_s: float) -> float:
        """Record a frame drawn now that kept the kernel busy ``busy_s`` seconds;
        returns the scale for the next frame."""
        now = self.now()
        self._window.append((now, max(0.0, float(busy_s))))
        span = now - self._window[0][0]
        n = len(self._window) - 1  # intervals in the window
        if n < WINDOW_FRAMES or span < WINDOW_S:
            return self.scale
        rate = n / span
        busy = sum(b for _t, b in self._window[1:]) / n
        k = SCALES.index(self.scale)
        if rate < 0.95 * self.target_fps:
            if k + 1 < len(SCALES):
                self.scale = SCALES[k + 1]  # too slow: fewer pixels
                self._window = [self._window[-1]]
                return self.scale
        elif k > 0 and busy * (SCALES[k - 1] / self.scale) ** 2 <= 0.75 / self.target_fps:
            self.scale = SCALES[k - 1]  # a quarter of the frame interval would stay free
            self._window = [self._window[-1]]
            return self.scale
        self._window = self._window[-WINDOW_FRAMES:]
        return self.scale
