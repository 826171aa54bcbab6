"""The browser harness's errors and its one way of waiting: :func:`poll` a condition.

No sleep stands in for a check: every ``wait_*`` of the harness polls a condition until it
holds or a timeout expires, then raises :class:`HarnessTimeout` saying what did not happen and
what was last observed. (The only fixed-time waits are the pacing of a mouse drag,
:func:`tests.e2e.controls.drag`, and the measuring window of
:func:`tests.e2e.frames.frames_per_second`.)
"""

from __future__ import annotations

import time
from typing import Any, Callable, Optional


class HarnessError(RuntimeError):
    """Something in the browser/Jupyter setup is not as expected."""


class HarnessTimeout(HarnessError, TimeoutError):
    """A condition that was waited for did not happen in time."""


class CellExecutionError(HarnessError):
    """A notebook cell raised while running (carries ename/evalue/traceback)."""


class KernelExecutionError(HarnessError):
    """Code sent with :func:`kernel_execute` raised in the kernel."""

    def __init__(self, message: str, ename: str = "", evalue: str = "", traceback: str = ""):
        super().__init__(message)
        self.ename, self.evalue, self.traceback = ename, evalue, traceback


def poll(
    check: Callable[[], Any],
    what: str,
    timeout: float,
    interval: float = 0.1,
    page=None,
    describe: Optional[Callable[[Any], str]] = None,
):
    """Call ``check()`` until it returns a truthy value, and return that value.

    ``check`` may also return a tuple ``(ok, observed)``; then ``observed`` is
    what the error message reports as last seen and is what gets returned.

    Raises :class:`HarnessTimeout` after ``timeout`` seconds, naming ``what``
    (phrase it as the condition, e.g. "5 new frames in the view") and the
    last observed value. With ``page`` given, the pause between tries is
    ``page.wait_for_timeout`` so Playwright keeps processing events.
    """
    deadline = time.monotonic() + timeout
    last: Any = None
    last_exc: Optional[BaseException] = None
    while True:
        try:
            res = check()
            last_exc = None
        except (HarnessTimeout, KeyboardInterrupt):
            raise
        except Exception as exc:  # keep polling, but remember why it failed
            res, last_exc = None, exc
        if isinstance(res, tuple) and len(res) == 2 and isinstance(res[0], bool):
            ok, observed = res
            last = observed
            if ok:
                return observed
        else:
            last = res
            if res:
                return res
        if time.monotonic() >= deadline:
            seen = describe(last) if describe else repr(last)
            msg = f"Timed out after {timeout:.1f} s waiting for {what}; last observed: {seen}"
            if last_exc is not None:
                msg += f" (last check raised {type(last_exc).__name__}: {last_exc})"
            raise HarnessTimeout(msg)
        if page is not None:
            page.wait_for_timeout(interval * 1000)
        else:
            time.sleep(interval)


def poll_until_stable(read: Callable[[], Any], what: str, timeout: float, interval: float = 0.3, page=None):
    """Call ``read()`` until two calls ``interval`` seconds apart return equal values, and return
    that value: e.g. the boxes of a widget's parts once the browser has laid out what the kernel
    changed (no fixed pause could know when that is done).

    Raises :class:`HarnessTimeout` after ``timeout`` seconds, naming ``what`` and the last two
    values read. With ``page`` given the pause between reads is ``page.wait_for_timeout``."""
    seen: list = []

    def check():
        seen.append(read())
        return len(seen) >= 2 and seen[-1] == seen[-2], seen[-2:]

    return poll(check, what, timeout, interval, page=page)[-1]
