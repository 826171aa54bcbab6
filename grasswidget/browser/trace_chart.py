"""The lab bench's live chart: an anywidget that draws series Python sends, with uPlot.

:class:`TraceChart` is a small, engine-neutral front-end widget: its ``data`` trait
holds the x values and the series (labels, colours, values) as
:meth:`grasswidget.core.traces.TraceRecorder.chart_series` makes them, and the browser
draws them with uPlot (MIT, vendored in ``grasswidget/browser/vendor/uplot`` and put
inside the widget's own ES module and style sheet: nothing is fetched, it works
offline and in every front end that runs anywidget). Whoever owns it decides what to
draw and how often (:class:`grasswidget.notebook.lab_bench.LabBench` pushes at most
:data:`grasswidget.notebook.lab_bench.CHART_UPDATES_PER_S` updates a second).
"""

from __future__ import annotations

from pathlib import Path

import anywidget
from traitlets import Bool, Dict, Int

__all__ = ["TraceChart", "UPLOT_VERSION"]

HERE = Path(__file__).parent
VENDOR = HERE / "vendor" / "uplot"
#: The uPlot release shipped in the wheel.
UPLOT_VERSION = "1.6.32"


def _module_text() -> str:
    # uPlot's IIFE declares one top-level `var uPlot`: module-scoped inside this ES module.
    return (VENDOR / "uPlot.iife.min.js").read_text(encoding="utf-8") + "\n" + \
        (HERE / "trace_chart.js").read_text(encoding="utf-8")


class TraceChart(anywidget.AnyWidget):
    """A line chart drawn by uPlot in the browser.

    Traits: ``data`` ({"x": [...], "x_label", "y_label", "y_zero", "series": [{"label", "color",
    "values", "fill"}]}; None values are gaps), ``width`` and ``height`` (CSS pixels), ``hidden``.
    """

    # The text, not a path (a path keeps every instance alive in anywidget 0.11; see BrowserEngineWidget).
    _esm = _module_text()
    _css = (VENDOR / "uPlot.min.css").read_text(encoding="utf-8") + \
        "\n.gw-trace-chart { font: 11px sans-serif; }\n.gw-trace-chart .u-legend { font-size: 11px; }\n"

    data = Dict().tag(sync=True)
    width = Int(640).tag(sync=True)
    height = Int(180).tag(sync=True)
    #: Hide the chart (for front ends that ignore ``layout.display``, e.g. marimo); the owner sets both.
    hidden = Bool(False).tag(sync=True)
