"""A GrassWidget (and a comparison of them) shown in marimo.

marimo draws anywidgets but no ipywidgets containers and no ``ipywidgets.Output``
(it shows "Jupyter widgets are not supported in marimo" for a GrassWidget, an
ipywidgets ``VBox``). marimo asks an object for ``_display_()`` before anything else,
and only marimo does, so :meth:`GrassWidget._display_` is where marimo is detected:
at display time, never at import (marimo stays optional and is imported here, lazily).

What marimo then shows is made of anywidgets only, each drawn by marimo itself:

* :class:`MarimoStage`: the widget's stage (the live view, then the lab bench's chart),
  as marimo's anywidget elements: the browser engine's
  :class:`~grasswidget.browser.engine_widget.BrowserEngineWidget` or the kernel engine's jupyter-rfb
  canvas (jupyter-rfb 1.0's ``RemoteFrameBuffer`` is an anywidget; shown directly,
  without its Output context), and the :class:`~grasswidget.browser.trace_chart.TraceChart`
  (hidden while no chart is chosen). When the widget changes its view (a browser without
  WebGPU: the kernel engine takes over) the stage shows the new one;
* the panel column (camera bar, then the panel's rows) through a
  :class:`~grasswidget.notebook.control_mirror.ControlMirror`: the same ipywidgets Jupyter
  shows, drawn as HTML controls.

They stand in one flex box that wraps: the panel beside the view where the page is
wide enough, under it otherwise (as in Jupyter, :mod:`grasswidget.notebook.layout`).
"""

from __future__ import annotations

from pathlib import Path

import anywidget
import ipywidgets as ipw
from traitlets import Unicode

from ..compat import marimo_anywidget_element
from .layout import PANEL_WIDTH
from ..views.front_end import class_for_front_end, esm_for_front_end, running_in_marimo

__all__ = ["MarimoFace", "marimo_display", "marimo_compare_display", "marimo_row_display", "MarimoStage", "running_in_marimo",
           "esm_for_front_end", "class_for_front_end"]

HERE = Path(__file__).resolve().parent


class MarimoStage(anywidget.AnyWidget):
    """The anywidgets of an ipywidgets box (a GrassWidget's stage: view and chart), shown in
    marimo and kept in step with the box's children.

    Args:
        box: the ipywidgets box whose anywidgets (at any depth, in order) are shown; a change
            of its (or a nested box's) ``children`` shows the new ones.

    ``html`` (synced) is the markup of marimo's elements for them; ``shown`` the anywidgets
    shown now. The elements are kept here (marimo holds them weakly) until the next change.
    """

    _esm = (HERE / "marimo_stage.js").read_text(encoding="utf-8")
    html = Unicode("").tag(sync=True)

    def __init__(self, box, **kwargs):
        super().__init__(**kwargs)
        self._box = box
        self._boxes = []
        self._elements = []
        self.shown = ()
        self._refresh()

    def _walk(self, widget, found, boxes):
        if isinstance(widget, anywidget.AnyWidget):
            found.append(widget)
        elif isinstance(widget, ipw.Box):
            boxes.append(widget)
            for child in widget.children:
                self._walk(child, found, boxes)

    def _refresh(self, _change=None):
        for box in self._boxes:
            box.unobserve(self._refresh, names="children")
        found, self._boxes = [], []
        self._walk(self._box, found, self._boxes)
        for box in self._boxes:
            box.observe(self._refresh, names="children")
        made = [marimo_anywidget_element(w) for w in found]  # also where no cell runs (an engine switch)
        self._elements = [element for element, _html in made]
        self.shown = tuple(found)
        self.html = "".join(html for _element, html in made)

    def close(self):
        """Stop following the box and close this anywidget (the shown ones stay)."""
        for box in self._boxes:
            box.unobserve(self._refresh, names="children")
        self._boxes, self._elements = [], []
        super().close()


class MarimoFace:
    """The front-end face of one GrassWidget for marimo: its stage (:class:`MarimoStage`) and its
    panel column as a :class:`~grasswidget.notebook.control_mirror.ControlMirror`, each made on
    first use (needs marimo for the stage) and then the same one.

    Args:
        stage: the widget's stage box (view, chart).
        column: the widget's panel column (camera bar and rows).
        on_error: where a value the mirror's controls refuse is reported.
    """

    def __init__(self, stage, column, on_error):
        self._box, self._column, self._on_error = stage, column, on_error
        self._stage = self._mirror = None

    def stage(self) -> MarimoStage:
        if self._stage is None:
            self._stage = MarimoStage(self._box)
        return self._stage

    def mirror(self):
        from .control_mirror import ControlMirror

        if self._mirror is None:
            self._mirror = ControlMirror(self._column, on_error=self._on_error)
        return self._mirror

    def made(self) -> tuple:
        """The anywidgets made so far."""
        return tuple(p for p in (self._stage, self._mirror) if p is not None)

    def close(self):
        for part in self.made():
            part.close()


def marimo_display(widget):
    """What marimo shows for ``widget`` (a GrassWidget): the stage (view and chart) and,
    beside it, the panel column. Both anywidgets are made once per widget and kept
    (``widget.parts()`` lists them), so a cell shown again draws the same ones."""
    import marimo as mo

    stage, mirror = widget.marimo_parts()
    stage_element, panel_element = mo.ui.anywidget(stage), mo.ui.anywidget(mirror)
    return mo.Html(
        f"<div class='grasswidget grasswidget-marimo' style='display:flex;flex-flow:row wrap;"
        f"align-items:flex-start;gap:8px;max-width:100%'>"
        f"<div class='grasswidget-stage-column' style='flex:none;max-width:100%'>{stage_element.text}</div>"
        f"<div class='grasswidget-panel-column' style='flex:0 1 {PANEL_WIDTH}px;min-width:0'>{panel_element.text}</div>"
        f"</div>")


def marimo_compare_display(comparison):
    """What marimo shows for ``comparison`` (a :class:`~grasswidget.notebook.compare.Comparison`):
    a column per view (its label line, its stage and its status and message lines) in a row that
    wraps, then the one shared panel (camera bar and rows), as in Jupyter. The anywidgets are made
    once per comparison (``comparison.marimo_parts()``)."""
    import marimo as mo

    columns, panel = comparison.marimo_parts()
    width = comparison.size[0]
    cells = "".join(
        f"<div class='grasswidget-compare-column' style='flex:none;width:{width}px;max-width:100%'>"
        f"{mo.ui.anywidget(head).text}{mo.ui.anywidget(stage).text}{mo.ui.anywidget(status).text}</div>"
        for head, stage, status in columns)
    return mo.Html(
        "<div class='grasswidget grasswidget-compare grasswidget-marimo' style='max-width:100%'>"
        f"<div class='grasswidget-compare-views' style='display:flex;flex-flow:row wrap;gap:6px 10px;"
        f"align-items:flex-start'>{cells}</div>"
        f"<div class='grasswidget-panel-column' style='max-width:{max(2 * width + 10, PANEL_WIDTH)}px'>"
        f"{mo.ui.anywidget(panel).text}</div></div>")


def marimo_row_display(titled_widgets):
    """What marimo shows for GrassWidgets side by side (``ex.compare(code, backend="browser")``):
    ``titled_widgets`` is a list of (title, GrassWidget); each widget as marimo shows it alone
    (:func:`marimo_display`), under its title, in a row that wraps."""
    import html

    import marimo as mo

    cells = "".join(f"<div style='flex:none;max-width:100%'><b>{html.escape(title)}</b>{marimo_display(w).text}</div>"
                    for title, w in titled_widgets)
    return mo.Html(f"<div class='grasswidget-row grasswidget-marimo' style='display:flex;flex-flow:row wrap;"
                   f"gap:8px 16px;align-items:flex-start;max-width:100%'>{cells}</div>")
