"""What a user does with a notebook in the page: write one (:func:`write_notebook`), open it
(:func:`open_notebook`), run every cell (:func:`run_all_cells`), read its outputs, leave it
(:func:`leave_notebook`).

A notebook opened in a page that already holds the server's JupyterLab is opened inside the
same app (Lab is not loaded again); :func:`leave_notebook` closes its widgets from the kernel
first, so the page ends their views and engines as a user's ``w.close()`` would.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Optional, Sequence

from .frames import install_frame_counter, restart_frame_counter
from .kernel_calls import kernel_execute, strip_ansi
from .lab_page import activate_notebook, notebook_state, with_find_panel
from .polling import CellExecutionError, HarnessError, HarnessTimeout, poll
from .servers import JupyterLabServer


def write_notebook(path, cells: Sequence[str], kernel_name: str = "python3") -> Path:
    """Write a notebook of code cells (strings; a string starting with
    ``"#md "`` becomes a markdown cell with the rest as text) and return its
    path. The kernelspec is set so JupyterLab does not ask for a kernel."""
    import nbformat

    nb = nbformat.v4.new_notebook()
    nb.metadata["kernelspec"] = {"name": kernel_name, "display_name": "Python 3", "language": "python"}
    nb.metadata["language_info"] = {"name": "python"}
    for src in cells:
        if src.startswith("#md "):
            nb.cells.append(nbformat.v4.new_markdown_cell(src[4:]))
        else:
            nb.cells.append(nbformat.v4.new_code_cell(src))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    nbformat.write(nb, str(path))
    return path


#: JS: close every document of Lab's main area without asking (marked saved first, so no
#: "save your work?" dialog), as navigating away would; returns how many were closed.
_JS_CLOSE_DOCUMENTS = r"""
() => {
  const app = window.jupyterapp;
  if (!app) return -1;
  let n = 0;
  for (const w of [...app.shell.widgets('main')]) {
    if (w.context && w.context.model) w.context.model.dirty = false;
    w.dispose();
    n++;
  }
  return n;
}
"""


def _shows_lab_of(page, server) -> bool:
    """The page holds ``server``'s JupyterLab app, loaded and with no dialog open."""
    if getattr(server, "app", None) != "lab" or not page.url.startswith(f"{server.base_url}lab"):
        return False
    try:
        return bool(page.evaluate("() => !!(window.jupyterapp && window.jupyterapp.shell) && "
                                  "!document.querySelector('.jp-Dialog')"))
    except Exception:  # navigating, or the page is gone
        return False


#: Kernel code closing every widget (grasswidget's first: their views, loops and GPU resources),
#: run through the page's own connection so that the page hears each close and ends the widget's
#: views and page-wide state (the browser engine's engines) as a user's ``w.close()`` would.
CLOSE_WIDGETS = r"""
def __gw_close_widgets():
    import gc
    import ipywidgets
    for widget in [o for o in gc.get_objects()
                   if isinstance(o, ipywidgets.Widget) and type(o).__module__.startswith('grasswidget')]:
        widget.close()
    ipywidgets.Widget.close_all()
__gw_close_widgets()
del __gw_close_widgets
"""

#: JS: the notebooks open in Lab's main area (their paths).
_JS_OPEN_NOTEBOOKS = r"""
() => [...window.jupyterapp.shell.widgets('main')]
  .filter((w) => w.sessionContext && w.content && w.context).map((w) => w.context.path)
"""

#: JS: every browser-engine engine of the page is closed (engine.js's page-wide registry).
_JS_ENGINES_CLOSED = r"""
() => { const e = globalThis.__grasswidgetEngines; return !e || [...e.values()].every((x) => x.closed); }
"""


def _close_in_lab(page, timeout: float = 15.0) -> bool:
    """Close the notebooks open in Lab as a user ends them: every widget closed from its kernel
    (the page ends their views and engines), then the notebook closed. False (nothing may be
    left as it was) when a kernel does not answer or something of the page stays open."""
    try:
        for path in page.evaluate(_JS_OPEN_NOTEBOOKS):
            kernel_execute(page, CLOSE_WIDGETS, path, timeout=timeout)
        poll(lambda: page.evaluate(_JS_ENGINES_CLOSED), "the page's browser engines to close", 10, 0.1, page=page)
        return page.evaluate(_JS_CLOSE_DOCUMENTS) >= 0
    except Exception:
        return False


def leave_notebook(page, server: JupyterLabServer, reload: bool = False) -> None:
    """End a test's notebook: close it in the page and end its kernel through the server
    (:meth:`JupyterLabServer.shutdown_kernels`, which keeps one kernel, reset, when the server
    reuses kernels). Where the page holds this server's JupyterLab (and ``reload`` is False) its
    widgets are closed from the kernel (:data:`CLOSE_WIDGETS`: the page ends their views and
    engines), the notebook is closed inside Lab and Lab stays loaded, so the next
    :func:`open_notebook` opens its notebook in the same app without loading Lab again (about 3 s
    on 2 busy cores); otherwise (after a failed test: ``reload=True``, or when a kernel does not
    answer or an engine stays open) the page goes to ``about:blank``, as navigating away."""
    closed = not reload and _shows_lab_of(page, server) and _close_in_lab(page)
    if not closed:
        page.goto("about:blank")
    server.shutdown_kernels()


def open_notebook(page, server: JupyterLabServer, relpath: str, timeout: float = 90.0,
                  reload: bool = False) -> None:
    """Open ``relpath`` in Lab and wait until the notebook panel is
    open, its kernel is connected and idle; installs the frame counter.
    A kernel the server kept (:meth:`JupyterLabServer.shutdown_kernels`), else the spare kernel
    it started ahead (:meth:`JupyterLabServer.start_spare_kernel`), is handed to the notebook
    first, so Lab connects to it instead of starting one. With the server's ``spare_kernels`` on
    (and ``reuse_kernels`` off), a new spare kernel is started for the next notebook once this one is open.

    Where the page already holds this server's Lab (:func:`leave_notebook` left it loaded) the
    notebook is opened inside it (``docmanager:open``), after closing any document still open
    (a notebook as :func:`leave_notebook` does), and the frame counter starts again from 0;
    otherwise (or with ``reload``, or when a browser engine of a notebook before is still open)
    the page navigates to the notebook's URL and Lab loads (with its saved workspace reset)."""
    if getattr(server, "warm_session", None) is not None:
        server.take_warm_session(relpath)
    elif getattr(server, "spare_session", None) is not None:
        server.take_spare_session(relpath)
    in_app = not reload and _shows_lab_of(page, server)
    if in_app and page.evaluate(_JS_OPEN_NOTEBOOKS):  # one still open: end it as leave_notebook does
        in_app = _close_in_lab(page)
    if in_app and not page.evaluate(_JS_ENGINES_CLOSED):  # something of a notebook before still runs
        in_app = False
    if in_app:
        page.evaluate(_JS_CLOSE_DOCUMENTS)
        page.evaluate("async (path) => { await window.jupyterapp.commands.execute('docmanager:open', "
                      "{path, factory: 'Notebook'}); }", relpath)
        restart_frame_counter(page)
    else:
        page.goto(server.url_for(relpath), wait_until="domcontentloaded", timeout=timeout * 1000)

    def check():
        st = notebook_state(page, relpath)
        ok = st.get("ok") and st["connection"] == "connected" and st["kernelStatus"] == "idle"
        return bool(ok), st

    poll(check, f"notebook {relpath!r} to open with a connected, idle kernel", timeout, 0.25, page=page)
    activate_notebook(page, relpath)
    install_frame_counter(page)
    if getattr(server, "spare_kernels", False) and not server.reuse_kernels:
        server.start_spare_kernel()  # for the next notebook, starting while this one runs


def wait_for_kernel_idle(page, path: Optional[str] = None, timeout: float = 60.0) -> dict:
    """Wait until no cell of the notebook is running or queued and the
    kernel reports 'idle'. Returns the last notebook state."""

    def check():
        st = notebook_state(page, path)
        ok = bool(st.get("ok")) and st["kernelStatus"] == "idle" and st["running"] == 0 and st["pending"] == 0
        return ok, st

    return poll(check, "the kernel to be idle with no running or queued cells", timeout, 0.2, page=page)


_JS_CELL_ERRORS = with_find_panel(r"""
(path) => {
  const p = __gwFindPanel(path);
  const errs = [];
  p.content.widgets.forEach((c, i) => {
    if (c.model.type !== 'code') return;
    for (const o of c.model.outputs.toJSON()) {
      if (o.output_type === 'error') errs.push({cell: i, ename: o.ename, evalue: o.evalue, traceback: (o.traceback || []).join('\n')});
    }
  });
  const unrun = [];
  p.content.widgets.forEach((c, i) => { if (c.model.type === 'code' && c.model.executionCount == null && c.model.sharedModel.getSource().trim()) unrun.push(i); });
  return {errs, unrun};
}
""")


def run_all_cells(
    page, path: Optional[str] = None, timeout: float = 120.0, clear_first: bool = True, raise_on_error: bool = True
) -> None:
    """Run all cells (``notebook:run-all-cells``) and wait until they are done.

    With ``raise_on_error`` a cell error raises :class:`CellExecutionError`
    with the traceback. Note: a cell displaying a continuously animating
    widget still finishes; the animation runs on the kernel's event loop."""
    activate_notebook(page, path)
    if clear_first:
        page.evaluate("() => window.jupyterapp.commands.execute('notebook:clear-all-cell-outputs')")
    res = page.evaluate(
        """async (ms) => {
          let timer;
          const to = new Promise((res) => { timer = setTimeout(() => res('timeout'), ms); });
          try {
            const r = await Promise.race([window.jupyterapp.commands.execute('notebook:run-all-cells'), to]);
            return r === 'timeout' ? 'timeout' : 'done';
          } finally { clearTimeout(timer); }
        }""",
        int(timeout * 1000),
    )
    if res == "timeout":
        raise HarnessTimeout(f"Timed out after {timeout:.1f} s waiting for notebook:run-all-cells to finish")
    wait_for_kernel_idle(page, path, timeout=timeout)
    info = page.evaluate(_JS_CELL_ERRORS, path)
    if info["errs"] and raise_on_error:
        e = info["errs"][0]
        raise CellExecutionError(
            f"cell {e['cell']} raised {e['ename']}: {e['evalue']}\n{strip_ansi(e['traceback'])}"
        )
    if info["unrun"] and raise_on_error:
        raise CellExecutionError(f"cells {info['unrun']} did not run")


_JS_OUTPUT_TEXT = with_find_panel(r"""
({path, index}) => {
  const p = __gwFindPanel(path);
  if (!p) return null;
  const cells = p.content.widgets.filter((c) => c.model.type === 'code');
  const pick = index === null ? cells : [cells[index < 0 ? cells.length + index : index]];
  return pick.filter(Boolean).map((c) => c.outputArea ? c.outputArea.node.innerText : '').join('\n');
}
""")


def cell_output_text(page, cell_index: Optional[int] = None, path: Optional[str] = None) -> str:
    """Visible text of the outputs of the ``cell_index``-th *code* cell
    (negative counts from the end; None: all code cells joined). This
    includes the text of widgets such as Label, HTML and button captions."""
    res = page.evaluate(_JS_OUTPUT_TEXT, {"path": path, "index": cell_index})
    if res is None:
        raise HarnessError("no notebook panel found")
    return res


def wait_for_output_text(
    page, text: str, cell_index: Optional[int] = None, path: Optional[str] = None, timeout: float = 20.0
) -> str:
    """Wait until ``text`` (a str, or a compiled regex) appears in the
    outputs (see :func:`cell_output_text`). Returns the full output text."""
    if isinstance(text, re.Pattern):
        match = lambda s: bool(text.search(s))  # noqa: E731
    else:
        match = lambda s: text in s  # noqa: E731

    def check():
        s = cell_output_text(page, cell_index, path)
        return match(s), s[-500:]

    poll(check, f"output text {text!r}", timeout, 0.2, page=page)
    return cell_output_text(page, cell_index, path)
