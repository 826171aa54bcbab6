"""Wait for a browser's answer inside a running notebook cell (process comm messages).

A cell that calls ``w.read_state()`` blocks the kernel's event loop, so the
browser's answer (a comm message) would only be handled after the cell ends:
too late. :func:`wait_for` keeps handling comm messages while it waits:

* ipykernel 7 (subshell-capable kernels): shell messages reach the main thread
  through an inproc socket pair; we read that socket ourselves, dispatch comm
  messages at once (as ipykernel itself does for a cell awaiting a widget reply)
  and hand every other message (another cell's execute request) back to the
  kernel's loop, in order, to run after this cell. Every ipykernel internal this
  needs is a function of :mod:`grasswidget.compat` (``kernel_shell_socket``,
  ``kernel_dispatch_comm``, ``kernel_requeue_shell``, ``kernel_parent_ident``).
* ipykernel 6: ``jupyter_ui_poll`` (which pumps ``kernel.do_one_iteration``).

Outside a kernel nothing can answer: it raises at once.
"""

from __future__ import annotations

import asyncio
import time

from .. import compat
from ..errors import BrowserTimeoutError

__all__ = ["wait_for", "BrowserTimeoutError"]


def _kernel():
    try:
        from IPython import get_ipython
    except ImportError:  # pragma: no cover
        return None
    shell = get_ipython()
    return getattr(shell, "kernel", None) if shell is not None else None


def _timeout(what, timeout):
    return BrowserTimeoutError(
        f"{what}: the browser view did not answer within {timeout:g} s "
        "(is the widget displayed in an open notebook tab, in a browser with WebGPU?)"
    )


def wait_for(check, timeout: float, what: str):
    """Call ``check()`` until it returns something other than None, handling the
    notebook's comm messages meanwhile; return that value.

    Raises :class:`BrowserTimeoutError` (a TimeoutError) naming ``what`` after
    ``timeout`` seconds, or at once when no notebook kernel is running.
    """
    value = check()
    if value is not None:
        return value
    kernel = _kernel()
    if kernel is None:
        raise BrowserTimeoutError(f"{what}: no notebook kernel is running, so no browser view can answer")
    deadline = time.monotonic() + timeout
    if compat.kernel_has_shell_socket(kernel):
        return _wait_ipykernel7(kernel, check, deadline, timeout, what)
    from jupyter_ui_poll import ui_events

    with ui_events() as poll:
        while True:
            poll(20)
            value = check()
            if value is not None:
                return value
            if time.monotonic() > deadline:
                raise _timeout(what, timeout)
            time.sleep(0.005)


def _wait_ipykernel7(kernel, check, deadline, timeout, what):
    import zmq

    sock = compat.kernel_shell_socket(kernel)
    parent = kernel.get_parent("shell")
    ident = compat.kernel_parent_ident(kernel, "shell")
    deferred = []

    def handle_one():
        frames = sock.recv_multipart(copy=False)
        try:
            _idents, parts = kernel.session.feed_identities(frames, copy=False)
            msg_type = kernel.session.deserialize(parts, content=False, copy=False)["header"].get("msg_type")
        except Exception:
            msg_type = None
        if msg_type in ("comm_msg", "comm_open", "comm_close"):
            _run_now(compat.kernel_dispatch_comm(kernel, frames))
            kernel.set_parent(ident, parent, channel="shell")
        else:
            deferred.append(frames)

    try:
        while True:
            value = check()
            if value is not None:
                return value
            left = deadline - time.monotonic()
            if left <= 0:
                raise _timeout(what, timeout)
            if sock.poll(min(50, max(1, int(left * 1000))), zmq.POLLIN):
                handle_one()
    finally:
        # Leave the socket empty: zmq signals its file descriptor only when messages
        # arrive on an empty queue, so a message left here would never wake the
        # kernel's loop (it would hang until the next message).
        while sock.poll(0, zmq.POLLIN):
            handle_one()
        kernel.set_parent(ident, parent, channel="shell")
        for frames in deferred:  # run after this cell, in the order they came
            compat.kernel_requeue_shell(kernel, frames)


def _run_now(coro):
    """Run a coroutine that does not really suspend (a comm handler) to its end now.
    One that does suspend (an async handler) is finished by the kernel's loop later."""
    try:
        waiting = coro.send(None)
    except StopIteration:
        return
    asyncio.ensure_future(_finish(coro, waiting))


async def _finish(coro, waiting):
    """Drive ``coro`` on: await what it waits for (an asyncio future), then resume it."""
    while True:
        try:
            await waiting
        except BaseException as err:  # noqa: BLE001 - hand the failure to the coroutine
            try:
                waiting = coro.throw(err)
            except StopIteration:
                return
            continue
        try:
            waiting = coro.send(None)
        except StopIteration:
            return
