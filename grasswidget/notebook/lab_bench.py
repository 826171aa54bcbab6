"""The lab bench of a live view: its traces and the live chart under it.

:class:`LabBench` puts together, for one :class:`~grasswidget.views.api.EngineView`:

* a :class:`~grasswidget.core.traces.TraceRecorder` (the rolling window of samples),
* the feed that fills it for the view's engine (:mod:`grasswidget.views.trace_feed`),
* a :class:`~grasswidget.browser.trace_chart.TraceChart` (uPlot in the browser;
  :attr:`LabBench.widget`, to put under the view) and the "chart" dropdown that picks
  what it shows (:attr:`LabBench.control`, a row for the owner's control panel).

It knows no GrassWidget: the owner passes the view, tells it when the chart choice,
the play state, the frozen culling or the view itself change, puts
:attr:`LabBench.widget` under the view and :attr:`LabBench.control` in its panel.
Another widget (a comparison of two views) can make one LabBench per view and read
:meth:`LabBench.traces` of each.

The chart is redrawn at most :data:`CHART_UPDATES_PER_S` times a second while
playing (the newest samples are pushed when playing stops), and the series are
thinned to at most :data:`CHART_MAX_POINTS` points, so its cost stays small whatever
the frame rate.
"""

from __future__ import annotations

import time

import ipywidgets as ipw

from ..core.teaching import INSPECTED_BLADE_COLORS
from ..core.traces import CHART_KINDS, DEFAULT_WINDOW_S, TraceRecorder
from ..errors import GrassValueError
from .control_link import ControlLink
from .layout import close_widgets

__all__ = ["LabBench", "check_chart", "CHART_UPDATES_PER_S", "CHART_MAX_POINTS", "CHART_HEIGHT", "CHART_LABELS"]

#: At most this many chart updates a second while playing.
CHART_UPDATES_PER_S = 5.0
#: At most this many points per series are sent to the chart.
CHART_MAX_POINTS = 600
#: Height of the chart, CSS pixels.
CHART_HEIGHT = 170
#: The dropdown's words for each chart (None: hidden).
CHART_LABELS = {None: "none", "tip": "tip offset", "bend": "bend angle", "culling": "culling", "frame": "frame time"}


def check_chart(value):
    """None or one of :data:`grasswidget.core.traces.CHART_KINDS`; GrassValueError names them."""
    if value is not None and (not isinstance(value, str) or value not in CHART_KINDS):
        raise GrassValueError(f"chart must be None or one of {', '.join(map(repr, CHART_KINDS))}; got {value!r}")
    return value


class LabBench:
    """Traces and the live chart of one view (see the module docstring).

    Args:
        view: the EngineView to sample.
        width: the chart's width (CSS pixels; the view's).
        window_s: the traces' rolling window (simulated seconds, 0.1..3600; default 60).
        owner, name: a HasTraits object and the name of its chart trait (None or a chart
            kind) that the dropdown is linked to (the owner then calls :meth:`show` when it
            changes); ``on_error`` gets a value it refused. Without an owner the dropdown
            calls :meth:`show` itself.
    """

    def __init__(self, view, width, *, owner=None, name="chart", window_s=DEFAULT_WINDOW_S, on_error=None):
        from ..browser.trace_chart import TraceChart

        self.recorder = TraceRecorder(window_s)
        self.view = view
        self.feed = None
        self.kind = None
        self.playing = True
        self._due = -1e9  # next push while playing (a token bucket: on average CHART_UPDATES_PER_S at most)
        self._pushed_version = -1
        #: Pushes sent to the chart and the kernel's seconds spent making them (the chart's cost in the kernel).
        self.pushes = 0
        self.push_seconds = 0.0
        self.chart = TraceChart(width=int(width), height=CHART_HEIGHT, hidden=True)
        self.chart.layout.display = "none"
        # Option values are strings ("none" for None: a Dropdown whose value is None shows no selection).
        self.dropdown = ipw.Dropdown(options=[(label, kind or "none") for kind, label in CHART_LABELS.items()],
                                     value="none",
                                     description="chart", layout=ipw.Layout(width="190px"),
                                     style={"description_width": "40px"},
                                     tooltip="A live chart under the view: tip offset or bend of the inspected "
                                             "blades, blades kept by culling, frame time (w.chart)")
        if owner is not None:  # the owner's trait decides; the widget's observer calls show()
            self._link = ControlLink(self.dropdown, owner, name, on_error=on_error,
                                     to_obj=lambda v: None if v == "none" else v,
                                     to_control=lambda v: "none" if v is None else v)
        else:  # no owner: the dropdown drives this bench itself
            self._link = None
            self.dropdown.observe(lambda c: self.show(None if c["new"] == "none" else c["new"]), names="value")
        #: What goes under the view: the chart (hidden while ``kind`` is None).
        self.widget = ipw.VBox([self.chart], layout=ipw.Layout(max_width="100%"))
        self.widget.add_class("grasswidget-lab-bench")
        #: The row with the "chart" dropdown, for the owner's control panel.
        self.control = ipw.HBox([self.dropdown])
        self.control.add_class("grasswidget-lab-bench-control")
        self.attach(view)

    # ------------------------------------------------------------------ the view

    def attach(self, view):
        """Sample ``view`` from now on (a new engine: the traces start again)."""
        from ..views.trace_feed import make_feed

        if self.feed is not None:
            self.feed.detach()
        self.view = view
        self.recorder.clear()
        self.feed = make_feed(view, self.recorder, on_sample=self._on_sample)
        self.feed.set_charting(self.kind is not None)

    def set_culling_frozen(self, frozen: bool):
        self.feed.set_culling_frozen(frozen)

    def after_step(self):
        """A step(n) call: one sample of the state it left, in either engine, drawn or not."""
        self.feed.after_step()

    def after_reset(self):
        """A reset_blades() call: the traces start again (at step 0)."""
        self.feed.after_reset()

    def set_playing(self, playing: bool):
        self.playing = bool(playing)
        if not playing:
            self.push()

    # ------------------------------------------------------------------ traces

    @property
    def window_s(self) -> float:
        return self.recorder.window_s

    @window_s.setter
    def window_s(self, value):
        from ..core.traces import check_window

        self.recorder.window_s = check_window(value, "trace_window")
        self.push()

    def traces(self) -> dict:
        """:meth:`grasswidget.core.traces.TraceRecorder.traces` of the samples so far (frames still in
        flight in the kernel engine included)."""
        self.feed.flush()
        return self.recorder.traces()

    def save(self, path) -> str:
        self.feed.flush()
        return self.recorder.save(path)

    # ------------------------------------------------------------------ chart

    def show(self, kind):
        """Show the chart of ``kind`` (None hides it)."""
        self.kind = check_chart(kind)
        self.feed.set_charting(kind is not None)
        self.chart.layout.display = "none" if kind is None else None
        self.chart.hidden = kind is None
        self._pushed_version = -1
        self.push()

    def _on_sample(self):
        if self.kind is None:
            return
        now = time.perf_counter()
        if not self.playing:
            self.push()
        elif now >= self._due:
            period = 1.0 / CHART_UPDATES_PER_S
            # due one period after the last due time (not after now), so frames that come every
            # 0.15 s still give 5 updates a second on average; never two within half a period
            self._due = max(self._due + period, now + 0.5 * period)
            self.push()

    def push(self):
        """Send the chart its series now (nothing when hidden or unchanged)."""
        if self.kind is None or self.recorder.version == self._pushed_version:
            return
        t0 = time.perf_counter()
        self._pushed_version = self.recorder.version
        self.chart.data = self.recorder.chart_series(self.kind, INSPECTED_BLADE_COLORS, CHART_MAX_POINTS)
        self.pushes += 1
        self.push_seconds += time.perf_counter() - t0

    def close(self):
        if self.feed is not None:
            self.feed.detach()
            self.feed = None
        if self._link is not None:
            self._link.unlink()
        close_widgets(self.dropdown, self.control, self.chart, self.widget)
