"""What the front end running now (Jupyter or marimo) needs of an anywidget made by a view.

marimo 0.25 turns an anywidget's module text into a file of the running cell, so an anywidget made
outside a cell (a view made in a widget message's handler: an engine switch) fails there; these
helpers give it the module as a URL instead. They never import marimo.
"""

from __future__ import annotations

import base64
import sys

__all__ = ["running_in_marimo", "esm_for_front_end", "class_for_front_end"]


def running_in_marimo() -> bool:
    """True in the kernel of a marimo notebook (``marimo edit`` or ``marimo run``). Never imports
    marimo: where nothing has loaded it, this is not marimo."""
    mo = sys.modules.get("marimo")
    if mo is None:
        return False
    try:
        return bool(mo.running_in_notebook())
    except Exception:  # an older or half-initialised marimo: not a notebook we can serve
        return False


def esm_for_front_end(esm: str) -> str:
    """An anywidget's ES module text as the front end running now takes it: unchanged in Jupyter; in
    marimo as a ``data:text/javascript;base64,`` URL. marimo 0.25 turns module text into a file of
    the running cell, so a widget made outside a cell (the kernel engine's view made when a browser
    turns out to have no WebGPU, in a widget message's handler) fails with an AssertionError; a
    JavaScript data URL it loads as it is. Jupyter's anywidget would take a data URL for module
    text, hence only in marimo."""
    if not running_in_marimo() or esm.startswith("data:"):
        return esm
    return "data:text/javascript;base64," + base64.b64encode(esm.encode("utf-8")).decode("ascii")


#: The subclasses made by class_for_front_end, one per anywidget class.
_MARIMO_CLASSES: dict = {}


def class_for_front_end(widget_class):
    """An anywidget class as the front end running now can make it also outside a running cell:
    ``widget_class`` itself in Jupyter; in marimo a subclass (made once) whose module is
    :func:`esm_for_front_end`'s URL. For anywidgets that a widget message's handler may make (the
    browser engine's view when backend="auto" switches engines, after the page reported its adapter)."""
    if not running_in_marimo():
        return widget_class
    subclass = _MARIMO_CLASSES.get(widget_class)
    if subclass is None:
        subclass = type(widget_class.__name__, (widget_class,), {"__module__": widget_class.__module__,
                                                                  "__doc__": widget_class.__doc__})
        # set after the class is made: anywidget would take a module text at class creation for a path
        subclass._esm = esm_for_front_end(str(widget_class._esm))
        _MARIMO_CLASSES[widget_class] = subclass
    return subclass
