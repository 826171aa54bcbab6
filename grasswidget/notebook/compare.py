"""Side by side: two to four variants of one meadow with one camera and one clock.

::

    import grasswidget as gw
    c = gw.compare({"soft": {"stiffness_scale": 0.5}, "stiff": {"stiffness_scale": 2.0}})
    c                                   # the views side by side, one panel under them
    c.step(240)                         # every view advances exactly 240 steps
    c.widgets["soft"].read_state()      # each view is a GrassWidget: params, read_state, inspect ...
    c.params.wind_strength = 30         # a shared parameter: every view gets it
    c.camera_state = {"position": (0, 6, 14)}   # every view's camera

:class:`Comparison` composes one :class:`~grasswidget.notebook.widget.GrassWidget` per
variant (same blades, same preset, same size, same engine), each with its own
:class:`~grasswidget.GrassParams`: a copy of the shared ones (:attr:`Comparison.params`)
with the variant's changes. On screen: each view with its label and its differing
parameters above it and its status line under it (the view's GrassWidget, its own panel
folded away), and one
:class:`~grasswidget.notebook.panel.ControlPanel` for all of them, linked to the shared
parameters (the controls of the differing ones are disabled there: they belong to
the views).

**One camera.** Orbit, pan or zoom any view and every other view takes the same
camera (position, orbit target, field of view): each view reports a moved camera to
its camera listeners (:meth:`~grasswidget.views.api.EngineView.add_camera_listener`;
the kernel engine after each frame it draws, the browser engine when the browser's
camera arrives) and the comparison hands it to the others with
:meth:`~grasswidget.views.api.EngineView.accept_camera`, which does not report back,
so there is no echo; a non-blocking lock keeps two views that move at the same moment
from waiting on each other (the later move is then taken at its next frame).

**One clock.** ``play()``, ``pause()``, ``step(n)``, ``reset_blades()``, the panel's
buttons and each view's keys (space, ``s``) and ctrl + click (inspects the same blade
in every view) act on every view. What "lockstep" guarantees:

* ``step(n)``: exact. Every view advances exactly ``n`` fixed steps of its own
  ``params.dt`` from where it stands; after ``c.step(n)`` from the rest pose each
  view's ``read_state()`` equals a :class:`~grasswidget.GrassScene` with that view's
  parameters stepped ``n`` steps (tested).
* playing, kernel engine: the views share one frame clock
  (:class:`~grasswidget.views.clock.SharedClock`): the shared simulated time moves on
  only when every view has drawn the last one, so the n-th frame of every view shows the
  same simulated time (to within one step where the variants' ``dt`` differ), at the
  pace of the slowest view. ``pause()`` then brings any view still behind up to the
  shared time, so paused views always stand at the same simulated time.
* playing, browser engine: each view's clock runs in the browser; play and pause reach
  them in one batch of messages, so they agree to within a frame or two, but not exactly
  (the browser reports its time only every half second). Use ``reset_blades()`` then
  ``step(n)`` for an exact comparison there.

Each view keeps its own ball (shift + drag; ``c.widgets[label].ball``), traces and chart
(``c.widgets[label].chart``), as any GrassWidget. A browser view whose page has no WebGPU
falls back to kernel streaming as a GrassWidget does, and is linked again (camera, clock).

Bad input (an unknown parameter, a value out of range, fewer than two or more than four
variants) raises before any view is made (:func:`grasswidget.core.variants.check_variants`).
"""

from __future__ import annotations

import datetime
import html
import os
import threading

import ipywidgets as ipw
import numpy as np
from traitlets import All

from . import cell_rerun
from ..core.limits import check_steps
from ..core.orbit_limits import FLOORS
from ..core.params import CheckedBool, ChoiceTrait, GrassParams, RangedFloat
from ..core.variants import apply_changes, check_variants
from ..errors import GrassTypeError, GrassValueError, WidgetClosedError

__all__ = ["compare", "Comparison", "SideBySide", "DEFAULT_VIEW_SIZE"]

#: Size (w, h) of each view of a comparison by default, CSS pixels.
DEFAULT_VIEW_SIZE = (400, 300)


def compare(variants, blades=4096, preset=None, backend="kernel", size=DEFAULT_VIEW_SIZE, params=None,
            **widget_options) -> "Comparison":
    """Two to four variants of one meadow side by side, with one camera and one clock.

    Args:
        variants: {label: {GrassParams trait: value}}, 2 to 4 entries, e.g.
            ``{"soft": {"stiffness_scale": 0.5}, "stiff": {"stiffness_scale": 2.0}}``
            (an empty dict: the shared parameters unchanged).
        blades: a blade count or a :class:`~grasswidget.Blades`, the same for every view
            (default 4096).
        preset: None or a ``GrassScene.preset`` name ("cis565", "meadow").
        backend: "kernel" (default), "browser" or "auto", as GrassWidget's.
        size: (w, h) or "WxH" of each view, CSS pixels (default 400 x 300).
        params: the shared :class:`GrassParams` (used, not copied: setting one of its
            traits reaches every view that does not vary it); default a new one.
        widget_options: passed on to each GrassWidget (``target_fps``, ``pixel_ratio``,
            ``max_fps``, ``quality``).

    Returns a :class:`Comparison` (an ipywidget; show it as a cell's last expression).
    """
    return Comparison(variants, blades=blades, preset=preset, backend=backend, size=size, params=params,
                      **widget_options)


def _value_text(value) -> str:
    if isinstance(value, float):
        return f"{value:g}"
    if isinstance(value, tuple):
        return "(" + ", ".join(_value_text(v) for v in value) + ")"
    return repr(value) if isinstance(value, str) else str(value)


class Comparison(ipw.VBox):
    """Views of the same blades with different parameters, one camera, one clock (see the module).

    Attributes:
        widgets: {label: :class:`~grasswidget.notebook.widget.GrassWidget`}, in the given order:
            each has ``params`` (its own GrassParams), ``read_state()``, ``inspect``,
            ``save_png``, ``camera_state`` ... (and, like any GrassWidget, traces and charts).
        variants: {label: {trait: value}}: each view's changes to the shared parameters.
        differing: the names of the parameters some variant changes (sorted).
        params: the shared :class:`GrassParams` (what the panel edits).
        panel: the :class:`~grasswidget.notebook.panel.ControlPanel` under the views.
        labels: {label: the ipywidgets HTML above each view}.
        clock: the :class:`~grasswidget.views.clock.SharedClock` the kernel engine's views
            follow (None with the browser engine).

    Traits: ``playing``, ``time_scale``, ``culling_frozen`` and ``camera_floor``, applied to every
    view; ``panel_folded`` (only the shared camera bar shows).
    """

    camera_floor = ChoiceTrait("grass", FLOORS, help='What every view\'s orbit keeps the camera above: "grass" '
                               '(the tallest blade\'s tip) or "ground" (as GrassWidget.camera_floor).')
    panel_folded = CheckedBool(False, help="Show only the camera bar of the shared panel (play/pause, camera presets, more).")
    time_scale = RangedFloat(1.0, 0.0, 10.0, "simulated s per s",
                             help="Simulated seconds per wall-clock second while playing (every view).")
    playing = CheckedBool(True, help="Animate every view (True) or pause them all (False).")
    culling_frozen = CheckedBool(False, help="Freeze culling in every view at its current camera (the shared one).")

    _closed = False
    widgets: dict = {}
    panel = None
    camera_bar = None
    _marimo = None  # (columns, panel mirror): what marimo shows, made on first display there

    def __init__(self, variants, blades=4096, preset=None, backend="kernel", size=DEFAULT_VIEW_SIZE, params=None,
                 **widget_options):
        from ..core.presets import parse_size
        from .widget import GrassWidget

        if params is not None and not isinstance(params, GrassParams):
            raise GrassTypeError(f"params must be a GrassParams or None, not {type(params).__name__}")
        self.params = params if params is not None else GrassParams()
        self.variants = check_variants(variants, self.params)  # before any view (or GPU buffer) exists
        self.differing = tuple(sorted({name for changes in self.variants.values() for name in changes}))
        self.size = parse_size(size)
        self.widgets = {}
        self.labels = {}
        self._sync_lock = threading.Lock()
        self.clock = None
        self._followers = {}
        self._linked = {}
        self._unlink = {}  # label -> the function that stops its view's camera calls
        try:
            for label, changes in self.variants.items():
                own = apply_changes(self.params.copy(), changes, where=f"variant {label!r}")
                self.widgets[label] = GrassWidget(blades, preset=preset, size=self.size, params=own, backend=backend,
                                                **widget_options)
            self._link_views()
            self._build_panel()
        except BaseException:
            self.close()
            raise
        columns = [self._column(label, w) for label, w in self.widgets.items()]
        per_row = 2 if len(columns) > 2 else len(columns)
        grid = ipw.GridBox(columns, layout=ipw.Layout(
            grid_template_columns=f"repeat({per_row}, {self.size[0]}px)", grid_gap="6px 10px", width="auto"))
        width = per_row * self.size[0] + (per_row - 1) * 10
        from .camera_bar import CameraBar

        #: The shared panel's first line: play/pause while folded, the camera presets (every view), more/less.
        self.camera_bar = CameraBar(self, on_error=self._show_error)
        self._more = ipw.VBox(list(self.panel.rows), layout=ipw.Layout(width="100%"))
        self._grid = grid
        super().__init__(children=[grid, self.camera_bar.row, self._more],
                         layout=ipw.Layout(width=f"{width}px", max_width="100%"))
        self.add_class("grasswidget-compare")
        self.observe(self._on_playing, names="playing")
        self.observe(self._on_time_scale, names="time_scale")
        self.observe(self._on_culling_frozen, names="culling_frozen")
        self.observe(self._on_camera_floor, names="camera_floor")
        self.observe(lambda change: setattr(self._more.layout, "display", "none" if change["new"] else ""),
                     names="panel_folded")
        self.params.observe(self._on_shared_param, names=All)
        self._show_summary()
        # Re-running the cell that made a comparison closes the previous one (and its views)
        # when nothing else holds it, as for a GrassWidget (grasswidget.notebook.cell_rerun).
        cell = cell_rerun.current_cell_id()
        if cell:
            cell_rerun.adopt_for_cell(cell, self)

    # ------------------------------------------------------------------ building

    def _link_views(self):
        for label, w in self.widgets.items():
            self._link_view(label, w.view)
            w.playing = self.playing
            w.observe(self._on_view_playing, names="playing")
            # A browser view without WebGPU is replaced by a kernel view (the engine's "view" event):
            # that is when to link the new one.
            w.engine.on("view", self._on_view_replaced)
            w.params.observe(self._on_view_param, names=list(self.differing) or All)

    def _link_view(self, label, view):
        """Make ``view`` (the EngineView of view ``label``) follow the shared camera and clock."""
        from ..views.clock import MAX_STEPS_PER_FRAME, SharedClock

        if view.backend == "kernel":
            if self.clock is None:
                self.clock = SharedClock(MAX_STEPS_PER_FRAME)
            follower = self.clock.follower()
            view.clock = follower  # the view's frame loop now follows the shared time
            self._followers[label] = follower
        self.widgets[label].engine.commands = self  # keys and ctrl + click act on every view
        self._unlink[label] = view.add_camera_listener(self._on_view_camera)
        self._linked[label] = view

    def _on_view_replaced(self, _view):
        """A view's GrassWidget may have replaced its view (a browser without WebGPU: the kernel
        streams instead, and the message line says so): link the new one, at the shared camera."""
        for label, w in self.widgets.items():
            if w.view is not None and w.view is not self._linked.get(label) and not w.closed:
                if label in self._unlink:
                    self._unlink.pop(label)()
                self._followers.pop(label, None)
                self._link_view(label, w.view)
                others = [v.view for lb, v in self.widgets.items() if lb != label and v.view is not None]
                if others:
                    w.view.accept_camera(others[0].camera_state)

    def _build_panel(self):
        from .panel import ControlPanel

        first = next(iter(self.widgets.values()))
        self.panel = ControlPanel(self.params, self, self, blade_count=first.blade_count,
                                  max_blades=min(w.max_blades for w in self.widgets.values()),
                                  view_size=self.size)
        controls = {**self.panel.sliders, **self.panel.look_sliders, **self.panel.checkboxes,
                    **{n: c.dropdown for n, c in self.panel.switch_choices.items()},
                    "wind_field": self.panel.wind_field_dropdown, "color_by": self.panel.color_by_dropdown,
                    "shadows": self.panel.shadows_checkbox}
        # The details (a frame's timings) are each view's own: the panel's toggle would show nothing.
        self.panel.details_button.layout.display = "none"
        for name in self.differing:
            control = controls.get(name)
            if control is not None:
                control.disabled = True
                control.tooltip = f"{name} differs between the views (see the line above each view)"

    def _column(self, label, w):
        """The label, then the view's GrassWidget with its own panel folded away except its status
        line and message line (what sits between the view and its panel, e.g. a chart, stays)."""
        self.labels[label] = ipw.HTML(value=self._label_html(label), layout=ipw.Layout(max_width=f"{self.size[0]}px"))
        keep = (w.panel.rows[0], w.panel.message_line)  # the status row (stats line) and the message line
        for row in w.panel.rows:
            if all(row is not k for k in keep):
                row.layout.display = "none"
        w.panel.details_button.layout.display = "none"
        if w.camera_bar is not None:  # the shared panel's camera bar moves every view
            w.camera_bar.row.layout.display = "none"
        return ipw.VBox([self.labels[label], w], layout=ipw.Layout(width=f"{self.size[0]}px"))

    def _label_html(self, label) -> str:
        w = self.widgets[label]
        parts = [f"{html.escape(name)} = {html.escape(_value_text(getattr(w.params, name)))}" for name in self.differing]
        tail = " · ".join(parts) if parts else "shared parameters"
        return f"<b>{html.escape(label)}</b> <small style='color:#555'>{tail}</small>"

    # ------------------------------------------------------------------ properties

    @property
    def closed(self) -> bool:
        """True after :meth:`close`."""
        return self._closed

    @property
    def backend(self) -> str:
        """The engine of the views: "kernel" or "browser" (as each GrassWidget's ``backend``)."""
        return next(iter(self.widgets.values())).backend

    @property
    def blade_count(self) -> int:
        """Blades in each view; setting it rebuilds every view's field (:meth:`set_blades`)."""
        return next(iter(self.widgets.values())).blade_count

    @blade_count.setter
    def blade_count(self, count):
        self.set_blades(count)

    @property
    def camera_state(self) -> dict:
        """The shared camera: position and target (metres, world space) and fov_deg (vertical
        field of view, degrees). A drag in any view moves it; assigning a dict (any of the three
        keys; validated as ``GrassWidget.camera_state``) moves every view's camera."""
        return next(iter(self.widgets.values())).camera_state

    @camera_state.setter
    def camera_state(self, state):
        self._check_open()
        views = list(self.widgets.values())
        views[0].camera_state = state  # validates; bad input raises here, nothing moved
        self._follow(views[0].view)

    @property
    def steps_per_frame(self) -> int:
        """Fixed steps of one nominal frame of the first view: what ``step()`` advances by default."""
        return next(iter(self.widgets.values())).steps_per_frame

    @property
    def sim_times(self) -> dict:
        """{label: simulated seconds since that view's last reset} (as each view's ``sim_time``)."""
        return {label: w.sim_time for label, w in self.widgets.items()}

    # ------------------------------------------------------------------ the clock

    def play(self):
        """Animate every view (one shared clock in the kernel engine; see the module)."""
        self.playing = True

    def pause(self):
        """Stop every view; in the kernel engine views still behind the shared time catch up to it."""
        self.playing = False

    def toggle_play(self):
        self.playing = not self.playing

    def step(self, n: int | None = None):
        """Pause and advance every view exactly ``n`` fixed steps of its own ``params.dt``
        (default: one frame's worth of the first view, at least 1)."""
        self._check_open()
        if n is None:
            n = max(1, self.steps_per_frame)
        n = check_steps(n)  # [0, MAX_STEPS], before any view moves
        self.playing = False
        for w in self.widgets.values():
            w.step(int(n))
        self._realign_shared_time()

    def reset_blades(self):
        """Every blade of every view back to its rest pose; every view's clock back to 0."""
        self._check_open()
        for w in self.widgets.values():
            w.reset_blades()

    def reset_camera(self):
        """Every view back to the starting view (the same for all: same blades, same preset)."""
        self.look_from("home")

    def look_from(self, name):
        """Move the shared camera to a named view ("home", "top", "low"; as
        ``GrassWidget.look_from``): every view looks from there."""
        self._check_open()
        first = next(iter(self.widgets.values()))
        first.look_from(name)  # checks the name; may lower the floor (then every view's follows)
        self._follow(first.view)
        if first.camera_floor != self.camera_floor:
            self.camera_floor = first.camera_floor

    def _on_camera_floor(self, change):
        for w in self.widgets.values():
            if w.camera_floor != change["new"]:
                w.camera_floor = change["new"]

    def _on_playing(self, change):
        playing = bool(change["new"])
        if self.panel is not None:
            self.panel.show_playing(playing)
        for w in self.widgets.values():
            if bool(w.playing) != playing:
                w.playing = playing
        if not playing:
            self._catch_up()
        self._show_summary()

    def _catch_up(self):
        """Paused kernel views still behind the shared time take the steps they owe."""
        for label, follower in self._followers.items():
            owed = follower.owed()
            if owed > 0 and not self.widgets[label].closed:
                self.widgets[label].step(owed)

    def _realign_shared_time(self):
        """After explicit steps, the shared time is where the views stand (so playing on
        does not wait for it to catch up with them)."""
        if self.clock is not None and self._followers:
            self.clock.time = max(f.origin + f.sim_time for f in self._followers.values())

    def _on_view_playing(self, change):
        # A view's key (space) or its browser toggled it: every view follows.
        if bool(change["new"]) != bool(self.playing):
            self.playing = bool(change["new"])

    def _on_time_scale(self, change):
        for w in self.widgets.values():
            w.time_scale = change["new"]

    def _on_culling_frozen(self, change):
        for w in self.widgets.values():
            w.culling_frozen = bool(change["new"])

    # ------------------------------------------------------------------ the camera

    def _on_view_camera(self, view):
        """A view's camera moved: every other view takes it (no echo: accept_camera)."""
        if self._closed or not self._sync_lock.acquire(blocking=False):
            return
        try:
            self._follow(view)
        finally:
            self._sync_lock.release()

    def _follow(self, source):
        state = source.camera_state
        for w in self.widgets.values():
            if w.view is not source and not w.closed:
                try:
                    w.view.accept_camera(state)
                except Exception as err:  # never raise into a frame or a comm handler
                    w.view.host.show_error(err)

    # ------------------------------------------------------------------ parameters

    def _on_shared_param(self, change):
        """A shared parameter changed: every view that does not vary it takes it."""
        name = change["name"]
        for label, w in self.widgets.items():
            if name not in self.variants[label]:
                try:
                    setattr(w.params, name, change["new"])
                except Exception as err:
                    self._show_error(err)

    def _on_view_param(self, change):
        label = next((lb for lb, w in self.widgets.items() if w.params is change["owner"]), None)
        if label is not None and label in self.labels:
            self.labels[label].value = self._label_html(label)

    # ------------------------------------------------------------------ what the panel asks

    def set_blades(self, blades):
        """Replace every view's field (a blade count or a Blades); cameras and params are kept."""
        self._check_open()
        for w in self.widgets.values():
            w.set_blades(blades)
        if self.panel is not None:
            self.panel.show_blade_count(self.blade_count)
        self._show_summary()

    def inspect(self, ids):
        """Inspect the same blades in every view (ctrl + click in any view; ``[]`` clears)."""
        self._check_open()
        for w in self.widgets.values():
            w.inspect(ids)

    def read_states(self, timeout: float = 30.0) -> dict:
        """{label: that view's ``read_state()``}."""
        self._check_open()
        return {label: w.read_state(timeout=timeout) for label, w in self.widgets.items()}

    def _pictures(self, size, paths):
        from ..tools.sheet import labelled_sheet

        import imageio.v3 as iio

        pictures = [np.asarray(iio.imread(p)) for p in paths]
        h, w = size[1], size[0]
        per_row = 2 if len(pictures) > 2 else len(pictures)
        rows = -(-len(pictures) // per_row)
        cells = np.full((rows, per_row, h, w, 4), 255, np.uint8)
        labels = list(self.widgets)
        notes = [[""] * per_row for _ in range(rows)]
        for k, img in enumerate(pictures):
            rgba = img if img.shape[-1] == 4 else np.dstack([img, np.full(img.shape[:2], 255, np.uint8)])
            cells[k // per_row, k % per_row] = rgba[:h, :w]
            notes[k // per_row][k % per_row] = labels[k] + (": " + ", ".join(
                f"{n} = {_value_text(getattr(self.widgets[labels[k]].params, n))}" for n in self.differing)
                if self.differing else "")
        return labelled_sheet(cells, title=f"{self.blade_count} blades", notes=notes)

    def save_png(self, path=None, size=None) -> str:
        """Write one PNG with every view (each at ``size``, default twice the view size; in
        rows of two), each labelled with its variant; returns the path (default
        ``compare-YYYYmmdd-HHMMSS.png`` next to the notebook)."""
        import tempfile

        from PIL import Image

        from ..core.presets import check_png_path, parse_size

        self._check_open()
        size = parse_size(size) if size is not None else (2 * self.size[0], 2 * self.size[1])
        if path is None:
            stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
            path, k = os.path.join(os.getcwd(), f"compare-{stamp}.png"), 2
            while os.path.exists(path):
                path, k = os.path.join(os.getcwd(), f"compare-{stamp}-{k}.png"), k + 1
        path = check_png_path(path)
        with tempfile.TemporaryDirectory() as tmp:
            paths = [w.save_png(os.path.join(tmp, f"{k}.png"), size=size) for k, w in enumerate(self.widgets.values())]
            Image.fromarray(self._pictures(size, paths), "RGBA").save(path)
        return path

    def save_png_later(self, size, done) -> bool:
        """The panel's Save PNG button: write :meth:`save_png`'s picture of every view at ``size``
        next to the notebook without blocking the kernel (browser views answer later), then call
        ``done(path)``. Returns True (under way)."""
        import tempfile

        from PIL import Image

        self._check_open()
        if self.backend == "kernel":
            done(self.save_png(size=size))
            return True
        tmp = tempfile.TemporaryDirectory()
        paths = [os.path.join(tmp.name, f"{k}.png") for k in range(len(self.widgets))]
        stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
        out = os.path.join(os.getcwd(), f"compare-{stamp}.png")
        futures = [w.view.snapshot(path, size) for w, path in zip(self.widgets.values(), paths)]
        finished = []

        def one_done(_future):
            if finished or not all(f.done() for f in futures):
                return
            finished.append(True)
            try:
                err = next((f.exception() for f in futures if f.exception() is not None), None)
                if err is not None:
                    self.panel.show_error(err)
                    return
                Image.fromarray(self._pictures(size, paths), "RGBA").save(out)
            finally:
                tmp.cleanup()
            done(out)

        for future in futures:
            future.add_done_callback(one_done)
        return True

    def parts(self) -> tuple:
        """What this comparison is made of and owns: its views (GrassWidgets) and their parts,
        and the panel (see :mod:`grasswidget.notebook.cell_rerun`)."""
        found = [p for p in (self.panel, self.camera_bar) if p is not None]
        for w in self.widgets.values():
            found += [w, *w.parts()]
        for bar in [self.camera_bar]:
            if bar is not None:  # its Play button is off the page while the panel is unfolded
                found += [bar.row, bar.play_button, bar.floor_checkbox, bar.more_button, *bar.preset_buttons.values()]
        if self._marimo is not None:
            columns, panel = self._marimo
            found += [panel, *(mirror for head, _stage, status in columns for mirror in (head, status))]
        return tuple(found)

    # ------------------------------------------------------------------ marimo

    def _display_(self):
        """What marimo shows (only marimo asks for ``_display_``; Jupyter draws the ipywidgets):
        the views' stages and the shared panel as anywidgets (see
        :func:`~grasswidget.notebook.marimo_face.marimo_compare_display`)."""
        from .marimo_face import marimo_compare_display

        if self._closed:
            return repr(self)
        return marimo_compare_display(self)

    def marimo_parts(self) -> tuple:
        """What marimo shows: ``(columns, panel)``; ``columns`` a list of (label and status,
        stage, status and message lines) per view (the label line and the view's status and
        message lines as :class:`~grasswidget.notebook.control_mirror.ControlMirror`, the
        stage the view's :meth:`GrassWidget.marimo_stage`), ``panel`` the shared camera bar and
        rows as one ControlMirror. Made on first use (needs marimo), then the same ones."""
        from .control_mirror import ControlMirror

        self._check_open()
        if self._marimo is None:
            columns = []
            for label, w in self.widgets.items():
                head = ControlMirror(ipw.VBox([self.labels[label]]), on_error=self._show_error)
                status = ControlMirror(ipw.VBox([w.panel.rows[0], w.panel.message_line]), on_error=self._show_error)
                columns.append((head, w.marimo_stage(), status))
            panel = ControlMirror(ipw.VBox([self.camera_bar.row, self._more]), on_error=self._show_error)
            self._marimo = (columns, panel)
        return self._marimo

    # ------------------------------------------------------------------ closing

    def close(self):
        """Close every view and the panel and release their GPU resources."""
        if self._closed:
            return
        self._closed = True
        if getattr(self, "camera_bar", None) is not None:
            self.camera_bar.close()
        try:
            self.params.unobserve(self._on_shared_param, names=All)
        except ValueError:
            pass
        if self._marimo is not None:
            columns, panel = self._marimo
            for head, _stage, status in columns:  # the stages are the views' own: closed with them
                head.close()
                status.close()
            panel.close()
        if self.panel is not None:
            self.panel.close()
        for w in self.widgets.values():
            w.close()
        from .layout import close_widgets

        # The boxes and labels made here (each with its Layout): left open, ipywidgets' registry keeps them.
        grid = getattr(self, "_grid", None)
        close_widgets(*getattr(self, "labels", {}).values(), *(grid.children if grid is not None else ()), grid,
                      getattr(self, "_more", None))
        own_layout = self.layout
        super().close()
        own_layout.close()

    def _check_open(self):
        if self._closed:
            raise WidgetClosedError("this comparison is closed; create a new one")

    def _show_error(self, err):
        if self.panel is not None:
            self.panel.show_error(err)

    def _show_summary(self):
        if self.panel is not None:
            state = "playing" if self.playing else "paused"
            self.panel.stats_line.value = (f"<small>{len(self.widgets)} views · {self.blade_count:,} blades each · "
                                           f"{state} · one camera, one clock</small>")

    def __repr__(self):
        state = "closed" if self._closed else ("playing" if self.playing else "paused")
        return f"<Comparison {', '.join(self.widgets)}: {self.blade_count} blades, {state}>"


class SideBySide(ipw.HBox):
    """GrassWidgets in a row, each under its title (``ex.compare(code, backend="browser")``):
    ``widgets`` is {title: GrassWidget}. An ipywidgets HBox in Jupyter; in marimo each widget as
    marimo shows it alone, under its title. :meth:`close` closes the widgets."""

    def __init__(self, widgets: dict):
        self.widgets = dict(widgets)
        super().__init__([ipw.VBox([ipw.HTML(f"<b>{html.escape(title)}</b>"), w]) for title, w in self.widgets.items()])

    @property
    def closed(self) -> bool:
        """True once :meth:`close` ran or any of the row's widgets was closed."""
        return any(w.closed for w in self.widgets.values())

    def __repr__(self):
        titles = ", ".join(self.widgets)
        return f"<SideBySide {titles}: {'closed' if self.closed else 'open'}>"

    def _display_(self):
        """What marimo shows (only marimo asks): the widgets side by side, each with its panel;
        once closed, its text ("<SideBySide ...: closed>"), as a closed GrassWidget shows."""
        from .marimo_face import marimo_row_display

        if self.closed:
            return repr(self)
        return marimo_row_display(list(self.widgets.items()))

    def close(self):
        for w in self.widgets.values():
            w.close()
        super().close()
