"""Re-running a notebook cell closes the GrassWidgets its earlier run made, unless something still holds them.

JupyterLab sends the cell's id with each execution. A GrassWidget remembers
(weakly) which cell made it; when that cell runs again, the widgets its earlier
run made are closed after the new run has finished (its assignments done), so
their GPU buffers are freed -- but only those that nothing else holds.

"Holds" is decided on the real object graph (:func:`holder_of`), not by looking
at top-level variables: starting at the old widget, the garbage collector's
referrers are followed backwards until one of these is reached:

* a user variable (a name in the IPython user namespace), or a module's global;
* another open ipywidget (e.g. an HBox showing it, displayed or not);

so a widget kept in a list, a dict, a tuple, an object's attribute, a closure, a
class attribute or another widget stays open. What does not count as holding:

* the widget's own wiring: its parts (view, panel, ball and the widgets it
  shows), its own private methods registered as callbacks (traitlets
  observers, comm and canvas handlers) on shared objects such as a GrassParams
  the user keeps, the comms of its widgets, and an object's own method running
  as a coroutine (the canvas's frame scheduler, a task of the event loop);
* ipywidgets' registry of open widgets (every widget is in it);
* IPython's output history: ``Out`` / ``_oh``, ``_``, ``__``, ``___``, ``_N``,
  the display hook's copies, ``user_ns_hidden`` and execution results;
* the frames on the current call stack (this check runs inside the cell's
  ``post_run_cell`` event).

When the search grows past :data:`SEARCH_LIMIT` objects it answers "held"
(keeping a widget open is safe; closing one in use is not).
"""

from __future__ import annotations

import gc
import inspect
import re
import sys
import types
import weakref

__all__ = ["holder_of", "adopt_for_cell", "current_cell_id", "registered_widgets", "SEARCH_LIMIT", "HISTORY_NAME"]

#: Objects visited at most by one :func:`holder_of` search (past it: "held").
SEARCH_LIMIT = 200_000
#: IPython's output-history names in the user namespace: _, __, ___, _N, _iN, _ii, _iii, _oh, _dh, _ih, In, Out.
HISTORY_NAME = re.compile(r"^(_{1,3}|_\d+|_i+|_i\d+|_oh|_dh|_ih|In|Out|exit|quit|get_ipython)$")

#: cell id -> weak references to the GrassWidgets that cell created (never strong:
#: the registry itself keeps no widget alive).
_BY_CELL: dict = {}


def _shell():
    try:
        from IPython import get_ipython

        return get_ipython()
    except Exception:
        return None


def current_cell_id():
    """The JupyterLab cell id of the running execute request, or None."""
    try:
        kernel = getattr(_shell(), "kernel", None)
        parent = kernel.get_parent() if kernel is not None else None
        return (parent or {}).get("metadata", {}).get("cellId")
    except Exception:
        return None


_RUNNING = (types.CoroutineType, types.GeneratorType, types.AsyncGeneratorType)


def _frame_of(running) -> types.FrameType:
    """The frame of a coroutine, generator or async generator (an empty one when it is done)."""
    frame = getattr(running, "cr_frame", None) or getattr(running, "gi_frame", None) or getattr(running, "ag_frame", None)
    return frame if frame is not None else _NO_FRAME


class _NoFrame:
    f_locals: dict = {}


_NO_FRAME = _NoFrame()


def _history_objects(shell) -> list:
    """IPython's caches of displayed values (not holders), as objects to skip by identity."""
    if shell is None:
        return []
    out = [getattr(shell, "user_ns_hidden", None), getattr(shell, "displayhook", None)]
    user_ns = getattr(shell, "user_ns", None) or {}
    out += [user_ns.get("_oh"), user_ns.get("Out")]
    history = getattr(shell, "history_manager", None)
    out.append(getattr(history, "output_hist", None))
    hook = getattr(shell, "displayhook", None)
    if hook is not None:
        out.append(vars(hook))
    return [o for o in out if o is not None]


def _widgets_in(widget) -> list:
    """The ipywidgets a widget is made of: itself and its children, recursively."""
    out, stack, seen = [], [widget], set()
    while stack:
        w = stack.pop()
        if id(w) in seen:
            continue
        seen.add(id(w))
        out.append(w)
        stack.extend(getattr(w, "children", ()) or ())
    return out


def _owned_widgets(part) -> list:
    """The ipywidgets a part of a widget owns: the part itself when it is one (and its
    children), else the ipywidgets among its attributes, directly or in a dict, list or
    tuple (a camera bar's buttons, a panel's sliders), whether shown right now or not
    (a folded panel takes its rows off the page but keeps them)."""
    import ipywidgets

    if isinstance(part, ipywidgets.Widget):
        return _widgets_in(part)
    out = []
    for value in list(getattr(part, "__dict__", {}).values()):
        items = value.values() if isinstance(value, dict) else value if isinstance(value, (list, tuple)) else (value,)
        for item in items:
            if isinstance(item, ipywidgets.Widget):
                out.extend(_widgets_in(item))
    return out


def holder_of(widget, user_ns=None, *, parts=(), skip=(), limit: int = SEARCH_LIMIT,
              report: dict | None = None) -> str | None:
    """What holds ``widget`` besides its own wiring and IPython's history, or None.

    Args:
        widget: an ipywidget (a GrassWidget).
        user_ns: the user namespace (default: IPython's, when running in IPython).
        parts: the objects the widget is made of (``GrassWidget.parts()``: its view,
            panel, scene ...). Holding a part holds the widget; the search starts at
            all of them at once, so the wiring between them costs no extra heap scans.
        skip: more objects that do not count as holders (compared by identity).
        limit: objects visited at most; past it the answer is "search limit".
        report: a dict to fill with ``levels`` (referrer scans of the heap) and ``visited``.

    Returns a short description of the first holder found ("variable 'keep'",
    "module 'foo'", "open widget HBox", "search limit") or None when nothing
    holds it (see the module docstring for what counts).
    """
    import ipywidgets

    from .. import compat

    shell = _shell()
    if user_ns is None:
        user_ns = getattr(shell, "user_ns", None) or {}
    registry = compat.widget_registry()
    ignored = {id(o) for o in (registry, *_history_objects(shell), *skip)}
    module_dicts = {id(vars(m)): name for name, m in list(sys.modules.items())
                    if m is not None and isinstance(getattr(m, "__dict__", None), dict)}
    own_widgets = _widgets_in(widget)
    for part in parts:
        own_widgets += _owned_widgets(part)
    own = {id(w) for w in own_widgets}
    # their comms hold their message handlers (ipywidgets wraps them, so they are not plain methods)
    ignored.update(id(w.comm) for w in own_widgets if getattr(w, "comm", None) is not None)
    frame = inspect.currentframe()
    while frame is not None:  # this search and whoever called it (the post_run_cell event)
        ignored.add(id(frame))
        frame = frame.f_back
    del frame
    try:
        from IPython.core.interactiveshell import ExecutionResult
    except ImportError:  # pragma: no cover
        ExecutionResult = ()

    frontier = [widget]
    for obj in [*parts, *(w for w in own_widgets if w is not widget)]:
        if obj is not None and all(obj is not o for o in frontier):
            frontier.append(obj)
    seen = {id(o) for o in frontier}
    levels = 0
    report = report if report is not None else {}
    while frontier:
        levels += 1
        report.update(levels=levels, visited=len(seen))
        if len(seen) > limit:
            return "search limit"
        frontier_ids = {id(o) for o in frontier}
        referrers = gc.get_referrers(*frontier)
        bookkeeping = {id(frontier), id(referrers)}
        following = []
        for ref in referrers:
            rid = id(ref)
            if rid in seen or rid in ignored or rid in bookkeeping:
                continue
            if ref is user_ns:
                names = [k for k, v in list(ref.items()) if id(v) in frontier_ids and not HISTORY_NAME.match(str(k))]
                if names:
                    return f"variable {names[0]!r}"
                continue
            if rid in module_dicts:
                return f"module {module_dicts[rid]!r}"
            if isinstance(ref, types.ModuleType):
                return f"module {ref.__name__!r}"
            if isinstance(ref, ExecutionResult):
                continue  # IPython's record of a cell's displayed value
            if isinstance(ref, types.MethodType) and id(ref.__self__) in frontier_ids \
                    and ref.__func__.__name__.startswith("_"):
                continue  # an object's own private handler, registered as a callback: its wiring
            if isinstance(ref, _RUNNING) and id(_frame_of(ref).f_locals.get("self")) in frontier_ids:
                continue  # an object's own method running as a coroutine or generator (a canvas's scheduler)
            if isinstance(ref, ipywidgets.Widget) and rid not in own and ref.comm is not None:
                return f"open widget {type(ref).__name__}"
            # anything else (a list, dict, tuple, cell, function, object, a suspended generator's
            # frame ...) holds it for whoever holds that: search on from there
            seen.add(rid)
            following.append(ref)
        del referrers
        frontier = following
        del following
    return None


def registered_widgets() -> dict:
    """{cell id: [weak references to the widgets that cell made and that are not closed yet]}."""
    return {cell: [r for r in refs if r() is not None and not r().closed] for cell, refs in _BY_CELL.items()}


def _after_cell(callback):
    """Run ``callback`` once after the running IPython cell finishes (its assignments
    done), or now outside IPython."""
    shell = _shell()
    events = getattr(shell, "events", None)
    if events is None:
        callback()
        return

    def once(*_args):
        try:
            events.unregister("post_run_cell", once)
        finally:
            callback()

    events.register("post_run_cell", once)


def adopt_for_cell(cell, widget, *, after_cell=_after_cell, holder=holder_of):
    """Remember ``widget`` as made by ``cell``; once this run of the cell is over, close
    the widgets an earlier run of it made that nothing holds (:func:`holder_of`).

    ``after_cell(callback)`` schedules the decision (default: IPython's
    ``post_run_cell``); ``holder(widget, parts=...)`` decides (default :func:`holder_of`;
    tests pass their own namespace). ``widget.parts()`` names what the widget is made of.
    """
    earlier = [ref for ref in _BY_CELL.get(cell, []) if ref() is not None and ref() is not widget]
    _BY_CELL[cell] = [weakref.ref(widget)]

    def close_unheld():
        for ref in earlier:
            old = ref()
            if old is None or old.closed:
                continue
            if holder(old, parts=old.parts()) is not None:
                _BY_CELL.setdefault(cell, []).append(ref)  # still the cell's; decided again at its next run
            else:
                old.close()
            del old

    if earlier:
        after_cell(close_unheld)
