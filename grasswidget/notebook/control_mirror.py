"""The panel's ipywidgets drawn as plain HTML controls by one anywidget, for front ends
without an ipywidgets manager (marimo).

The panel is described once: :class:`~grasswidget.notebook.panel.ControlPanel`, the
ball row, the camera bar and the lab bench build ipywidgets (labels, ranges, steps,
options and tooltips taken from the traits). Jupyter front ends draw those widgets
themselves. marimo draws anywidgets only, so :class:`ControlMirror` walks the same
tree of ipywidgets, describes each one as a small dict (:func:`describe`: kind,
label, range, options, value, shown or hidden) and draws that description in the
page with ``control_mirror.js`` (sliders, dropdowns, checkboxes, buttons, toggle
buttons and HTML lines in boxes that wrap). Nothing is written twice: a new control in
the panel shows in marimo as it is, and every action goes through the ipywidget's own
handlers:

* a control changed in the page sets the ipywidget's ``value`` (a dropdown its
  ``index``) in the kernel, so the panel's links (:class:`~grasswidget.notebook.control_link.ControlLink`)
  reach ``params`` and the widget's traits exactly as in Jupyter, a refused value snaps back;
* a button clicked in the page calls the ipywidget's ``click()`` (its ``on_click`` handlers);
* a change in the kernel (``w.params.wind_strength = 20`` moves the linked slider's
  value, the stats line's text, a row shown or hidden through ``layout.display``) is sent
  to the page as a patch of the changed control.

Kinds drawn: ``HBox``/``VBox``/``GridBox`` (boxes), ``FloatSlider``/``IntSlider``/
``FloatLogSlider`` (sliders), ``SelectionSlider``, ``Dropdown``, ``Checkbox``,
``Button``, ``ToggleButton``, ``HTML`` and ``Label`` (as text); any other widget shows as a line
naming its class (the panel uses none).

Wire protocol (custom anywidget messages): the page sends ``{"type": "ready"}`` when
it renders and gets ``{"type": "snapshot", "root": node}`` (a node: ``{"id", "kind",
...props, "children": [node, ...]}``); later ``{"type": "patch", "id", "props"}`` for a
changed control and a new snapshot when a box's children change. The page sends
``{"type": "set", "id", "value"}`` (a dropdown or selection slider: the option's index)
and ``{"type": "click", "id"}``.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import anywidget
import ipywidgets as ipw

from ..errors import GrassTypeError, GrassValueError

__all__ = ["ControlMirror", "describe", "widget_props", "option_labels", "MIRRORED_TRAITS"]

HERE = Path(__file__).resolve().parent

#: The traits of each ipywidget the page shows (when the widget has them); a change of one is a patch.
MIRRORED_TRAITS = ("value", "index", "description", "tooltip", "disabled", "min", "max",
                   "step", "readout_format", "button_style", "icon", "options", "continuous_update")

#: What each ipywidget class is drawn as in the page.
KINDS = (
    (ipw.Box, "box"),
    (ipw.SelectionSlider, "selection_slider"),
    (ipw.FloatLogSlider, "unsupported"),
    (ipw.FloatSlider, "slider"),
    (ipw.IntSlider, "slider"),
    (ipw.Dropdown, "dropdown"),
    (ipw.Checkbox, "checkbox"),
    (ipw.ToggleButton, "toggle"),
    (ipw.Button, "button"),
    (ipw.HTML, "html"),
    (ipw.Label, "text"),
)


def kind_of(widget) -> str:
    """How the page draws ``widget`` (see :data:`KINDS`); "unsupported" for another class."""
    for cls, kind in KINDS:
        if isinstance(widget, cls):
            return kind
    return "unsupported"


def option_labels(options) -> list:
    """The labels of a selection widget's ``options``, as ipywidgets shows them: the first item
    of a (label, value) pair, else the option itself as text."""
    return [str(o[0]) if isinstance(o, (tuple, list)) and len(o) == 2 else str(o) for o in options]


def _layout_props(widget) -> dict:
    layout = getattr(widget, "layout", None)
    props = {}
    for name in ("display", "width", "max_width", "min_height", "flex_flow", "justify_content", "align_items",
                 "margin"):
        value = getattr(layout, name, None) if layout is not None else None
        if value:
            props[name] = value
    return props


def _plain(value):
    """A value the page can hold (JSON): tuples become lists, NumPy numbers Python numbers."""
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if hasattr(value, "item") and not isinstance(value, (str, bytes)):
        return value.item()
    return value


def widget_props(widget) -> dict:
    """The props of one ipywidget as the page draws it: its kind, the mirrored traits it
    has (:data:`MIRRORED_TRAITS`), its layout (display, width, flex) and, for a control
    with a description, ``label_width`` (the style's ``description_width``)."""
    kind = kind_of(widget)
    props = {"kind": kind, "layout": _layout_props(widget)}
    if kind == "unsupported":
        props["class_name"] = type(widget).__name__
        return props
    if kind == "box":
        props["direction"] = "column" if isinstance(widget, ipw.VBox) else "row"
        return props
    for name in MIRRORED_TRAITS:
        if widget.has_trait(name) and name != "options":
            props[name] = _plain(getattr(widget, name))
    if widget.has_trait("options"):
        props["labels"] = option_labels(widget.options)
    if kind == "selection_slider":
        props.pop("value", None)  # the index says which option
    if kind == "dropdown":
        props.pop("value", None)  # values may be any Python object; the page works with the index
    style = getattr(widget, "style", None)
    width = getattr(style, "description_width", "") if style is not None else ""
    if width:
        props["label_width"] = width
    return props


def numbering():
    """A function giving each object a number, the same one each time it is met (1, 2, ...)."""
    numbers, counter = {}, itertools.count(1)

    def number_of(obj) -> int:
        if id(obj) not in numbers:
            numbers[id(obj)] = next(counter)
        return numbers[id(obj)]
    return number_of


def describe(widget, id_of=None) -> dict:
    """The pure description of an ipywidgets tree: a nested dict ``{"id", "kind", ...props,
    "children": [...]}`` (see :func:`widget_props`). ``id_of(widget)`` gives the number the
    page knows a widget by (default: a new :func:`numbering`)."""
    id_of = numbering() if id_of is None else id_of
    node = {"id": id_of(widget), **widget_props(widget)}
    if node["kind"] == "box":
        node["children"] = [describe(child, id_of) for child in widget.children]
    return node


class ControlMirror(anywidget.AnyWidget):
    """An anywidget that draws a tree of ipywidgets (a GrassWidget's panel column) as HTML
    controls and keeps both sides in step (see the module's docstring).

    Args:
        root: the ipywidget at the top of the tree (a box, usually).
        on_error: called with an exception a control's handler raised (default: ignored;
            the panel's links show their own errors on its message line).

    ``mirror.node_count`` is the number of ipywidgets mirrored; :meth:`close` stops
    observing them (the ipywidgets stay open: their owner closes them).
    """

    _esm = (HERE / "control_mirror.js").read_text(encoding="utf-8")
    _css = (HERE / "control_mirror.css").read_text(encoding="utf-8")

    def __init__(self, root, on_error=None, **kwargs):
        super().__init__(**kwargs)
        if not isinstance(root, ipw.Widget):
            raise GrassTypeError(f"root must be an ipywidget, not {type(root).__name__}")
        self._root = root
        self._on_error = on_error
        self._id_of = numbering()  # the tree's widgets and, once a box's children change, the new ones
        self._by_id = {}
        self._watched = []
        self._closed = False
        self._watch_tree()
        self.on_msg(lambda _widget, msg, _buffers: self.receive(msg))

    @property
    def node_count(self) -> int:
        return len(self._by_id)

    def widget_for(self, node_id):
        """The ipywidget the page knows as ``node_id`` (None if there is none)."""
        return self._by_id.get(node_id)

    def snapshot(self) -> dict:
        """The whole tree's description (see :func:`describe`)."""
        return describe(self._root, self._id_of)

    # ------------------------------------------------------------------ kernel -> page

    def _watch_tree(self):
        """Observe every ipywidget of the tree (and the layouts), forgetting the previous ones."""
        self._unwatch()
        todo = [self._root]
        while todo:
            widget = todo.pop()
            self._by_id[self._id_of(widget)] = widget
            if kind_of(widget) == "box":
                todo.extend(widget.children)
                self._observe(widget, self._on_children, "children")
            else:
                names = [n for n in MIRRORED_TRAITS if widget.has_trait(n)]
                handler = self._patcher(widget)
                self._observe(widget, handler, names)
            layout = getattr(widget, "layout", None)
            if layout is not None:
                self._observe(layout, self._patcher(widget), ["display", "width"])

    def _observe(self, obj, handler, names):
        obj.observe(handler, names=names)
        self._watched.append((obj, handler, names))

    def _unwatch(self):
        for obj, handler, names in self._watched:
            try:
                obj.unobserve(handler, names=names)
            except ValueError:
                pass
        self._watched = []
        self._by_id = {}

    def _patcher(self, widget):
        def patch(_change):
            if self._closed:
                return
            props = widget_props(widget)
            if props["kind"] == "box":
                props.pop("direction", None)
            self.send({"type": "patch", "id": self._id_of(widget), "props": props})
        return patch

    def _on_children(self, _change):
        if self._closed:
            return
        self._watch_tree()
        self._send_snapshot()

    def _send_snapshot(self):
        self.send({"type": "snapshot", "root": self.snapshot()})

    # ------------------------------------------------------------------ page -> kernel

    def receive(self, msg):
        """Act on a message from the page (see the module's docstring): "ready" answers with a
        snapshot, "set" sets a control's value, "click" clicks a button. Unknown ids are ignored
        (a page drawn from an older snapshot)."""
        if not isinstance(msg, dict) or self._closed:
            return
        kind = msg.get("type")
        if kind == "ready":
            self._send_snapshot()
            return
        widget = self._by_id.get(msg.get("id"))
        if widget is None:
            return
        try:
            if kind == "click" and isinstance(widget, ipw.Button):
                widget.click()
            elif kind == "set":
                self._set_from_page(widget, msg.get("value"))
        except Exception as err:  # the control's own handler failed: say so, keep the panel alive
            if self._on_error is not None:
                name = getattr(widget, "description", "") or kind_of(widget)
                self._on_error(GrassValueError(f"{name}: {err}"))
            self._patcher(widget)(None)  # the page shows the kernel's value again

    @staticmethod
    def _set_from_page(widget, value):
        kind = kind_of(widget)
        if kind in ("dropdown", "selection_slider"):
            widget.index = int(value)
        elif kind in ("checkbox", "toggle"):
            widget.value = bool(value)
        elif kind == "slider":
            widget.value = int(round(float(value))) if isinstance(widget, ipw.IntSlider) else float(value)

    def close(self):
        """Stop mirroring (the mirrored ipywidgets stay as they are) and close the anywidget."""
        self._closed = True
        self._unwatch()
        super().close()
