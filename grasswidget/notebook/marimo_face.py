"""A GrassWidget shown in marimo.

marimo draws anywidgets but no ipywidgets containers and no ``ipywidgets.Output``
(it shows "Jupyter widgets are not supported in marimo" for a GrassWidget, an
ipywidgets ``VBox``). marimo asks an object for ``_display_()`` before anything else,
and only marimo does, so :meth:`GrassWidget._display_` is where marimo is detected:
at display time, never at import (marimo stays optional and is imported here, lazily).

What marimo then shows is made of anywidgets only, each wrapped by ``mo.ui.anywidget``:

* the live view: the browser engine's :class:`~grasswidget.browser.view.BrowserView`,
  or the kernel engine's jupyter-rfb canvas (jupyter-rfb 1.0's ``RemoteFrameBuffer`` is
  an anywidget; shown directly, without its Output context);
* the lab bench's chart (:class:`~grasswidget.browser.trace_chart.TraceChart`) under it,
  hidden while no chart is chosen;
* the panel column (camera bar, then the panel's rows) through a
  :class:`~grasswidget.notebook.control_mirror.ControlMirror`: the same ipywidgets Jupyter
  shows, drawn as HTML controls.

They stand in one ``mo.hstack`` that wraps: the panel beside the view where the page is
wide enough, under it otherwise (as in Jupyter).
"""

from __future__ import annotations

from .layout import PANEL_WIDTH

__all__ = ["marimo_display"]


def marimo_display(widget):
    """What marimo shows for ``widget`` (a GrassWidget): view and chart over each other,
    the panel column beside them. The mirror of the panel is made once per widget and
    kept (``widget.parts()`` lists it) so a cell shown again draws the same controls."""
    import marimo as mo

    mirror = widget.control_mirror()
    view, chart, panel = (mo.ui.anywidget(w) for w in (widget.view.widget, widget.bench.chart, mirror))
    # One flex box that wraps, as the Jupyter layout (grasswidget.notebook.layout): the stage keeps
    # its size, the panel column stands beside it or, in a narrow page, under it.
    return mo.Html(
        f"<div class='grasswidget grasswidget-marimo' style='display:flex;flex-flow:row wrap;"
        f"align-items:flex-start;gap:8px;max-width:100%'>"
        f"<div class='grasswidget-stage' style='flex:none;max-width:100%'>{view.text}{chart.text}</div>"
        f"<div class='grasswidget-panel-column' style='flex:0 1 {PANEL_WIDTH}px;min-width:0'>{panel.text}</div>"
        f"</div>")
