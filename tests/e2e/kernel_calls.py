"""Talking to a notebook's kernel through the page's own kernel connection, without adding a
cell: :func:`kernel_execute`, :func:`kernel_eval`, and :func:`wait_for_kernel` (poll an
expression until it holds, e.g. that a slider moved in the page reached Python).
"""

from __future__ import annotations

import json
import re
import time
import uuid
from dataclasses import dataclass, field
from typing import Any, Callable, Optional

from .lab_page import with_find_panel
from .polling import HarnessError, HarnessTimeout, KernelExecutionError, poll


_ANSI_RE = re.compile(r"\x1b\[[0-9;]*[A-Za-z]")


def strip_ansi(text: str) -> str:
    """``text`` without terminal colour codes (as in a kernel's traceback)."""
    return _ANSI_RE.sub("", text)


_JS_KERNEL_EXECUTE = with_find_panel(r"""
async ({path, code, timeoutMs}) => {
  const p = __gwFindPanel(path);
  if (!p) return {fatal: 'no notebook panel found for ' + path};
  const k = p.sessionContext.session && p.sessionContext.session.kernel;
  if (!k) return {fatal: 'the notebook has no kernel'};
  const out = {stdout: '', stderr: '', results: [], error: null, status: null, timeout: false};
  const future = k.requestExecute({code, silent: false, store_history: false, allow_stdin: false, stop_on_error: false});
  future.onIOPub = (msg) => {
    const t = msg.header.msg_type, c = msg.content;
    if (t === 'stream') { if (c.name === 'stdout') out.stdout += c.text; else out.stderr += c.text; }
    else if (t === 'execute_result') out.results.push(c.data['text/plain']);
    else if (t === 'error') out.error = {ename: c.ename, evalue: c.evalue, traceback: c.traceback.join('\n')};
  };
  let timer;
  const to = new Promise((res) => { timer = setTimeout(() => res(null), timeoutMs); });
  try {
    const reply = await Promise.race([future.done, to]);
    if (reply === null) { out.timeout = true; try { future.dispose(); } catch (e) {} }
    else {
      out.status = reply.content.status;
      if (out.status === 'error' && !out.error) out.error = {ename: reply.content.ename, evalue: reply.content.evalue, traceback: (reply.content.traceback || []).join('\n')};
    }
  } catch (e) { out.fatal = String(e); }
  finally { clearTimeout(timer); }
  return out;
}
""")


@dataclass
class KernelResult:
    """What :func:`kernel_execute` collected from the kernel."""

    stdout: str = ""
    stderr: str = ""
    results: list = field(default_factory=list)  #: text/plain of execute_result(s)


def kernel_execute(page, code: str, path: Optional[str] = None, timeout: float = 30.0) -> KernelResult:
    """Execute ``code`` in the notebook's kernel (through the page's own
    kernel connection, ``sessionContext.session.kernel.requestExecute``)
    without adding a cell, and return its stdout/stderr/results.

    Raises :class:`KernelExecutionError` if the code raised and
    :class:`HarnessTimeout` if no reply came within ``timeout``."""
    out = page.evaluate(_JS_KERNEL_EXECUTE, {"path": path, "code": code, "timeoutMs": int(timeout * 1000)})
    if out.get("fatal"):
        raise HarnessError(f"kernel_execute failed: {out['fatal']}")
    if out["timeout"]:
        raise HarnessTimeout(
            f"Timed out after {timeout:.1f} s waiting for the kernel to reply to: {code[:200]!r}; "
            f"stdout so far: {out['stdout'][-500:]!r}"
        )
    if out["error"]:
        e = out["error"]
        tb = strip_ansi(e["traceback"])
        raise KernelExecutionError(
            f"kernel code raised {e['ename']}: {e['evalue']}\n{tb}", e["ename"], e["evalue"], tb
        )
    return KernelResult(out["stdout"], out["stderr"], out["results"])


def kernel_eval(page, expr: str, path: Optional[str] = None, timeout: float = 30.0) -> Any:
    """Evaluate a Python expression in the kernel and return its value,
    round-tripped through JSON (so it must be JSON-serialisable; use e.g.
    ``float(...)`` or ``.tolist()``)."""
    marker = "@@gw-" + uuid.uuid4().hex + "@@"
    code = f"import json as _gw_json\nprint({marker!r} + _gw_json.dumps({expr}))\ndel _gw_json"
    res = kernel_execute(page, code, path, timeout)
    for line in res.stdout.splitlines():
        if line.startswith(marker):
            return json.loads(line[len(marker):])
    raise HarnessError(f"kernel_eval({expr!r}) printed no result; stdout was {res.stdout!r}")


_MISSING = object()


def wait_for_kernel(
    page,
    expr: str,
    expected: Any = _MISSING,
    predicate: Optional[Callable[[Any], bool]] = None,
    path: Optional[str] = None,
    timeout: float = 20.0,
    interval: float = 0.25,
) -> Any:
    """Poll ``kernel_eval(expr)`` until it equals ``expected`` (floats are
    compared with 1e-9 relative tolerance) or ``predicate(value)`` is true.
    Returns the value. Use it to check that something done in the page
    reached Python, e.g. ``wait_for_kernel(page, "s.value", 25.0)``."""
    if predicate is None:
        if expected is _MISSING:
            raise TypeError("give expected or predicate")

        def predicate(v):
            if isinstance(v, (int, float)) and isinstance(expected, (int, float)):
                return abs(v - expected) <= 1e-9 * max(1.0, abs(expected))
            return v == expected

        what = f"kernel expression {expr} to equal {expected!r}"
    else:
        what = f"kernel expression {expr} to satisfy {getattr(predicate, '__name__', 'predicate')}"

    deadline = time.monotonic() + timeout

    def check():
        # Each read may take what is left of the wait: a kernel busy on 2 loaded cores answered one read in
        # over 15 s in a clean-clone CI run, within the wait's 60 s (its replies come in order, so a read
        # sent again would only queue behind the slow one).
        v = kernel_eval(page, expr, path, timeout=max(1.0, deadline - time.monotonic()))
        return bool(predicate(v)), v

    return poll(check, what, timeout, interval, page=page)
