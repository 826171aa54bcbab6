"""GrassWidget: a live, controllable meadow in a Jupyter notebook.

``GrassWidget`` is an ipywidgets ``VBox`` made of parts, each with one job in its own module. They
share the widget's state (:class:`~grasswidget.notebook.widget_state.WidgetState`, whose traits
are linked to the widget's) and the engine switch's events; none of them holds the widget:

* the engine (:class:`~grasswidget.notebook.engine_switch.EngineSwitch`): which engine runs and
  its view (an :class:`~grasswidget.views.api.EngineView`, the widget's only way to an engine),
  the "auto" rule, the fall back without WebGPU, the swap at run time;
* the control panel (:class:`~grasswidget.notebook.panel.ControlPanel`, ``w.panel``);
* the camera (:class:`~grasswidget.notebook.camera_bar.CameraHome`) and its bar
  (:class:`~grasswidget.notebook.camera_bar.CameraBar`);
* the ball (:class:`~grasswidget.notebook.ball.BallControl`, ``w.ball``);
* the lab bench (:class:`~grasswidget.notebook.lab_bench.LabBench`, ``w.lab_bench``): traces and chart;
* the layout (:class:`~grasswidget.notebook.layout.WidgetLayout`): the panel beside or under the view;
* marimo's face (:class:`~grasswidget.notebook.marimo_face.MarimoFace`);
* the files (:mod:`grasswidget.notebook.saving`).

::

    import grasswidget as gw
    w = gw.GrassWidget()          # a meadow of 4096 blades, 640 x 480
    w                             # (last expression of the cell: shows it)
    w.params.wind_strength = 20   # moves the slider too
    w.save_png("meadow.png")      # 2x the view size by default
    w.close()                     # frees the GPU buffers

Engines (``backend=``): "kernel" renders in the kernel and streams frames
(:mod:`grasswidget.views.kernel`); "browser" runs the same WGSL in the notebook's browser through
WebGPU (:mod:`grasswidget.views.browser`); "auto" (the default) runs the kernel engine unless the
kernel renders on a CPU adapter and the page offers a hardware WebGPU adapter
(:mod:`grasswidget.notebook.engine_auto`). Mouse, keys, the ball and the teaching views: see the
README and docs/.
"""

from __future__ import annotations

import ipywidgets as ipw
from traitlets import All, Any, validate

from . import cell_rerun, saving
from ..core.presets import parse_size
from ..core.limits import check_steps
from ..core.orbit_limits import FLOORS
from ..core.params import CheckedBool, ChoiceTrait, GrassParams, RangedFloat
from ..errors import GrassTypeError, WidgetClosedError
from ..views.api import MAX_STEPS_PER_FRAME, ViewMember
from ..views.kernel import STATS_INTERVAL, KernelOnly, streaming_defaults
from .engine_switch import BACKENDS, EngineSwitch, check_streaming
from .layout import LAYOUT_VIEW_SIZES, PANEL_WIDTH, WidgetLayout, check_layout, close_widgets
from .widget_state import WidgetActions, WidgetState, link_state

__all__ = ["GrassWidget", "streaming_defaults", "MAX_STEPS_PER_FRAME", "STATS_INTERVAL", "BACKENDS"]


class GrassWidget(ipw.VBox):
    """A live meadow: a view of the engine that simulates and draws it, and a control panel.

    Args:
        blades: a blade count (``Blades.on_plane(count)``, or the preset's field)
            or a :class:`grasswidget.Blades`.
        preset: None, or a preset name passed to ``GrassScene.preset`` (e.g.
            "cis565", "meadow").
        size: (width, height) of the view in CSS pixels, or "WxH" (default 640 x 480;
            1280 x 720 with ``layout="lecture"``).
        params: a :class:`GrassParams` to use (and share); default a new one.
        max_fps, quality: override the adapter's streaming defaults
            (:func:`streaming_defaults`): the stream cap (frames/s, 1..240) and JPEG quality (1..100).
        target_fps: frames per second adaptive resolution aims for while playing
            (default 24 on a CPU adapter, 60 on a GPU; 1..240).
        pixel_ratio: the most rendered pixels per CSS pixel (0.25..4; default 1 on a CPU
            adapter, 2 on a GPU; the browser's devicePixelRatio below that).
        layout: "default" (the panel unfolded beside or under the view) or "lecture"
            (a 1280 x 720 view unless ``size`` is given, the panel folded to one
            line: play/pause, camera presets, "more"). ``w.layout_mode`` says which;
            ``w.layout`` is ipywidgets' Layout as on every widget.
        backend: "auto" (default: the kernel engine, unless the kernel renders on a CPU
            adapter and the browser offers a hardware WebGPU adapter: then the browser
            engine, decided when the widget is first shown; ``w.engine_reason`` says
            why), "kernel" (render in the kernel, stream frames) or "browser" (simulate
            and draw in the browser with WebGPU). ``w.backend`` says which is live.
        function_overrides: user WGSL run in place of stock blade-math functions (a
            :class:`~grasswidget.core.wgsl_overrides.FunctionOverrides`, e.g.
            ``gw.exercise("forces").overrides(code)``; default None: the stock ones), in
            both engines; see :meth:`set_function_overrides`.

    Attributes:
        params: the :class:`GrassParams` (the same object the engine simulates with).
        view: the :class:`~grasswidget.views.api.EngineView` of the live engine.
        engine: the :class:`~grasswidget.notebook.engine_switch.EngineSwitch`.
        state: the :class:`~grasswidget.notebook.widget_state.WidgetState` the parts share
            (its traits are linked to the widget's traits of the same names).
        panel: the :class:`~grasswidget.notebook.panel.ControlPanel`: its controls are its own
            attributes (``w.panel.sliders``, ``w.panel.play_button``, ``w.panel.stats_line``,
            ``w.panel.message_line``, ...).
        scene, canvas, controller: what only the kernel engine has (None in the browser
            engine): its :class:`GrassScene`, jupyter-rfb canvas and pygfx ``OrbitController``.
        ball: the :class:`~grasswidget.notebook.ball.BallControl` (``ball.collider``,
            ``ball.enabled``, ``ball.rolling``, ``ball.move_to(x, z)``, ...).
        camera_bar: the :class:`~grasswidget.notebook.camera_bar.CameraBar`.
        lab_bench: the :class:`~grasswidget.notebook.lab_bench.LabBench` (traces, chart; "bench" alone is
            the benchmark, :mod:`grasswidget.tools.benchmark`).

    Traits: ``time_scale`` (simulated seconds per real second, 0..10), ``playing``,
    ``culling_frozen`` (cull against a copy of the camera taken when it was set),
    ``chart`` (the live chart under the view), ``camera_floor`` ("grass" or "ground": what
    the orbit keeps the camera above) and ``panel_folded`` (only the camera bar shows).

    Time: while playing, simulated time follows the wall clock in whole fixed steps of
    ``params.dt`` (:attr:`sim_time` counts it); when a frame would need more than
    :data:`MAX_STEPS_PER_FRAME` steps the meadow runs in slow motion and the stats line says
    so. ``pause()`` stops it at once, ``step(n)`` advances exactly n steps,
    ``save_animation`` is deterministic (fixed steps per frame).
    """

    time_scale = RangedFloat(1.0, 0.0, 10.0, "simulated s per s",
                             help="Simulated seconds per wall-clock second while playing.")
    playing = CheckedBool(True, help="Animate (continuous drawing) or pause (draw on demand).")
    culling_frozen = CheckedBool(False, help="Cull against a copy of the camera taken when this was set "
                                 "(see GrassScene.freeze_culling).")
    chart = Any(None, allow_none=True,
                help='The live chart under the view: None (hidden), "tip" (tip offset of each inspected blade), '
                     '"bend" (bend angle), "culling" (blades kept after each culling test) or "frame" (where '
                     "a frame's time goes), against simulated time (see grasswidget.notebook.lab_bench).")
    camera_floor = ChoiceTrait("grass", FLOORS, help='What the orbit keeps the camera above: "grass" (0.3 m above '
                               'the tallest blade\'s tip, so never inside the field) or "ground" (0.3 m above the '
                               'ground, down among the blades). A widget whose start camera is lower than the grass '
                               'starts with "ground".')
    panel_folded = CheckedBool(False, help="Show only the camera bar (play/pause, camera presets, more) under or "
                               "beside the view; True from the start with layout='lecture'.")

    # Defaults, so close() (also called by ipywidgets' __del__) works on a half-built widget.
    _closed = False
    engine = state = panel = ball = lab_bench = camera_bar = camera_home = _layout = _stage = _face = None
    _links = ()

    # The view's members the widget adds nothing to: each *is* the live view's member of that name
    # (grasswidget.views.api.ViewMember, documented once in EngineView; help() shows that text).
    camera_state = ViewMember(settable=True)
    max_fps = ViewMember(reading=True)
    steps_per_frame = ViewMember(reading=True)
    sim_time = ViewMember(reading=True)
    render_scale = ViewMember(reading=True, no_view=1.0)
    stats = ViewMember()
    read_state = ViewMember()
    set_wind_wgsl = ViewMember()
    inspect = ViewMember()
    inspected = ViewMember(reading=True, no_view=())
    read_inspected = ViewMember()
    # What only the kernel engine has (None in the browser engine): its GrassScene, jupyter-rfb canvas
    # and pygfx OrbitController.
    scene = KernelOnly()
    canvas = KernelOnly()
    controller = KernelOnly()

    def __init__(self, blades=4096, preset=None, size=None, params=None, *, max_fps=None, quality=None,
                 pixel_ratio=None, backend="auto", target_fps=None, layout="default",
                 function_overrides=None):
        #: "default" or "lecture" (see :mod:`grasswidget.notebook.layout`); ``w.layout`` stays ipywidgets' Layout.
        self.layout_mode = check_layout(layout)
        if params is not None and not isinstance(params, GrassParams):
            raise GrassTypeError(f"params must be a GrassParams or None, not {type(params).__name__}")
        self.size = parse_size(LAYOUT_VIEW_SIZES[self.layout_mode] if size is None else size)
        overrides = check_streaming(max_fps=max_fps, quality=quality, pixel_ratio=pixel_ratio, target_fps=target_fps)
        self.state = WidgetState()
        self.engine = EngineSwitch(backend, self.size, self.state, streaming_overrides=overrides, preset=preset,
                                   function_overrides=function_overrides)
        #: The most blades this widget's engine takes here (the blade slider's top).
        self.max_blades = self.engine.max_blades
        self._blades = self.engine.check_blades(blades)
        self.params = self.engine.default_params() if params is None else params
        self._links = link_state(self, self.state)
        actions = WidgetActions(toggle_play=self.toggle_play, step=self.step, reset_blades=self.reset_blades,
                                reset_camera=self.reset_camera, look_from=self.look_from, set_blades=self.set_blades,
                                inspect=lambda ids: self.inspect(ids), target_fps=lambda: self.target_fps,
                                save_png_later=lambda size, done: saving.save_png_later(self.view, size, done,
                                                                                        self.engine.show_error))
        self.engine.commands = actions
        try:
            self._build(actions, own_params=params is None)
        except BaseException:
            self.close()
            raise
        super().__init__(children=[self._stage, self._layout.column], layout=self._layout.root_layout)
        self.add_class("grasswidget")
        self.engine.announce()
        # Re-running the cell that made a widget closes the previous one (JupyterLab sends the cell id
        # with each execution), so its GPU buffers are freed; one that something still holds stays open
        # (see grasswidget.notebook.cell_rerun).
        cell = cell_rerun.current_cell_id()
        if cell:
            cell_rerun.adopt_for_cell(cell, self)

    def _build(self, actions, own_params):
        """Make the parts and connect them through the state's traits and the engine's events."""
        from .ball import BallControl
        from .camera_bar import CameraBar, CameraHome
        from .lab_bench import LabBench
        from .marimo_face import MarimoFace
        from .panel import ControlPanel

        state, engine = self.state, self.engine
        view = engine.start(self._blades, self.params, own_params)
        self.ball = BallControl(view, on_error=engine.show_error)
        view.attach_ball(self.ball)
        self.panel = ControlPanel(self.params, state, actions, blade_count=self.blade_count,
                                  max_blades=self.max_blades, ball_row=self.ball.controls,
                                  view_size=(min(self.size[0], PANEL_WIDTH), self.size[1]))
        self.panel.view_size = self.size  # Save PNG multiplies the view's size (the rows fit the column)
        self.camera_home = CameraHome(engine, state, self.size)
        self.lab_bench = LabBench(view, self.size[0], owner=state, name="chart", on_error=engine.show_error)
        state.panel_folded = self.layout_mode == "lecture"
        self.camera_bar = CameraBar(state, actions, on_error=engine.show_error)
        self._layout = WidgetLayout(self.camera_bar.row, [*self.panel.rows, self.lab_bench.control], self.size[0])
        self._layout.fold(state.panel_folded)
        probe = [engine.auto.probe] if engine.auto is not None and engine.auto.probe is not None else []
        # The view with the lab bench's live chart right under it.
        self._stage = ipw.VBox([view.widget, self.lab_bench.widget, *probe], layout=ipw.Layout(max_width="100%"))
        self._face = MarimoFace(self._stage, self._layout.column, engine.show_error)
        for event, show in (("error", self.panel.show_error), ("stats", self.panel.show_stats),
                            ("inspected", self.panel.show_inspected), ("note", self.panel.show_note),
                            ("view", self._on_view)):
            engine.on(event, show)
        self.ball.observe(lambda change: setattr(state, "playing", True) if change["new"] else None,
                          names="rolling")  # the ball rolls with simulated time
        self.ball.collider.observe(lambda _c: self._request_draw(), names=["center", "radius"])
        self.ball.observe(lambda _c: self._request_draw(), names="enabled")
        state.observe(lambda change: self.panel.show_playing(bool(change["new"])), names="playing")
        state.observe(lambda change: self.lab_bench.set_playing(bool(change["new"])), names="playing")
        state.observe(lambda change: self.lab_bench.set_culling_frozen(bool(change["new"])), names="culling_frozen")
        state.observe(lambda change: self.lab_bench.show(change["new"]), names="chart")
        state.observe(lambda change: self._layout.fold(bool(change["new"])), names="panel_folded")
        self.params.observe(self._request_draw, names=All)
        self.panel.show_stats(dict(view.stats, playing=bool(state.playing)))

    def _on_view(self, new):
        """The engine switched views: the ball, the stage and the lab bench follow the new one."""
        self.ball.attach(new)  # into the new engine's colliders first, then the view sends them
        new.attach_ball(self.ball)
        self._stage.children = [new.widget, *self._stage.children[1:]]
        self.lab_bench.attach(new)

    # ------------------------------------------------------------------ the engine

    @property
    def view(self):
        """The live engine's :class:`~grasswidget.views.api.EngineView` (the closed one after :meth:`close`)."""
        return self.engine.view if self.engine is not None else None

    @property
    def backend(self) -> str:
        """The engine that is live: "kernel" or "browser" (a "browser" widget whose browser
        has no WebGPU adapter turns "kernel"). An "auto" widget says "kernel" until the page
        has reported its adapter, then the engine the rule chose (see :attr:`engine_reason`)."""
        return self.view.backend if self.view is not None else self.engine.requested

    @property
    def engine_reason(self) -> str | None:
        """For ``backend="auto"``: one sentence saying which engine runs and why (also shown on
        the message line), e.g. "browser engine: the kernel renders on a CPU adapter (llvmpipe)
        and this browser offers a GPU (nvidia ampere)"; None for "kernel" and "browser"."""
        return self.engine.auto.choice.reason if self.engine.auto is not None else None

    @property
    def adapter_probe(self):
        """For ``backend="auto"`` with the kernel on a CPU adapter: the
        :class:`~grasswidget.browser.adapter_probe.AdapterProbe` shown with the view, whose
        ``report`` (the page's WebGPU adapter) decides the engine once; else None."""
        return self.engine.auto.probe if self.engine.auto is not None else None

    @property
    def target_fps(self) -> float:
        """Frames per second adaptive resolution aims for while playing (1..240;
        default 24 on a CPU adapter, 60 on a GPU). A bad value raises ValueError
        naming ``target_fps`` and the range, and the old value stays. The kernel
        engine's setting (the browser engine draws at the browser's own rate)."""
        if self.view is None:
            return float(self.engine.streaming["target_fps"])
        return self.view.readings.target_fps

    @target_fps.setter
    def target_fps(self, value):
        self.engine.set_target_fps(value)

    @property
    def blade_count(self) -> int:
        """Number of blades; setting it rebuilds the field (a Blades given at
        construction is then replaced by ``Blades.on_plane(count)``)."""
        b = self._blades
        return int(b) if isinstance(b, int) else len(b)

    @blade_count.setter
    def blade_count(self, count):
        count = self.engine.check_blades(count)
        if not isinstance(count, int):
            raise GrassTypeError("blade_count must be an int; pass a Blades to set_blades()")
        self.set_blades(count)

    def set_blades(self, blades):
        """Replace the field: a blade count or a :class:`Blades` (camera and params are kept)."""
        self._check_open()
        blades = self.engine.check_blades(blades)
        if isinstance(blades, int) and isinstance(self._blades, int) and blades == self._blades:
            return
        self.view.set_blades(blades)
        self._blades = self.engine.blades = blades
        self.panel.show_blade_count(self.blade_count)
        self._request_draw()

    def set_function_overrides(self, overrides):
        """Run user WGSL in place of stock blade-math functions (a
        :class:`~grasswidget.core.wgsl_overrides.FunctionOverrides`, e.g. an exercise's
        forces; see ``gw.exercise``) in the live simulation and culling; None restores the
        stock ones. Raises :class:`~grasswidget.errors.ExerciseShaderError` (line and column
        in the user's code) when it does not compile; the functions before stay in force.
        The kernel engine changes them live; the browser engine compiles them when it starts
        (``GrassWidget(function_overrides=...)``) and refuses other ones later."""
        self._check_open()
        self.view.set_function_overrides(overrides)
        self.engine.function_overrides = overrides

    @property
    def function_overrides(self):
        """The user WGSL in force in place of stock blade-math functions, or None."""
        return self.engine.function_overrides

    # ------------------------------------------------------------------ time

    def play(self):
        """Animate continuously (while a view is visible)."""
        self._check_open()
        self.playing = True

    def pause(self):
        """Stop the animation; the view still redraws on camera or parameter changes."""
        self._check_open()
        self.playing = False

    def toggle_play(self):
        """Play if paused, pause if playing."""
        self._check_open()
        self.playing = not self.playing

    def step(self, n: int | None = None):
        """Pause and advance exactly ``n`` fixed steps of ``params.dt`` (default: one
        frame's worth, at least 1); in browser mode the browser runs them, in order
        with every other request. ``n`` is an integer in [0, MAX_STEPS] (1,000,000,
        :mod:`grasswidget.core.limits`); more raises a GrassValueError naming the limit.
        In the kernel engine a long run can be interrupted (Ctrl-C, the notebook's stop
        button): it stops between two GPU submissions and raises
        :class:`~grasswidget.core.limits.StepsInterrupted` (a KeyboardInterrupt); the
        steps that ran are counted (``w.sim_time``, the field's step counter)."""
        self._check_open()
        n = check_steps(max(1, self.steps_per_frame) if n is None else n)
        self.playing = False
        try:
            self.view.step(n)
        finally:  # interrupted too: the steps that ran get their sample
            self.lab_bench.after_step()

    def reset_blades(self):
        """Every blade back to its rest pose; the simulation clock back to 0; the traces start again."""
        self._check_open()
        self.view.reset_blades()
        self.lab_bench.after_reset()

    # ------------------------------------------------------------------ camera

    def reset_camera(self):
        """Back to the scene's starting view (``look_from("home")``)."""
        self.look_from("home")

    def look_from(self, name):
        """Move the camera to a named view, in both engines (``camera_state`` follows):

        - ``"home"``: the start camera (as :meth:`reset_camera`);
        - ``"top"``: straight down over the middle of the field, the whole field in
          the picture (freeze culling at "home", then look from "top" to see what it culls);
        - ``"low"``: a student's eye just above the grass, at the field's edge on the
          home side, looking across the field.

        Computed from the field's extent by :func:`grasswidget.core.camera_presets.camera_preset`
        and held to the orbit limits. A camera lower than the "grass" floor allows (the
        cis565 course view's home) lowers ``camera_floor`` to "ground"; no preset raises it.
        Any other name raises GrassValueError naming the presets.
        """
        self._check_open()
        self.camera_home.look_from(name)

    # ------------------------------------------------------------------ lab bench

    def traces(self) -> dict:
        """What simulated time did over the last :attr:`trace_window` simulated seconds, sampled while
        it advances (the lab bench): NumPy arrays in a dict (``t``, ``step``, ``ids``, ``v0``, ``v2``,
        ``tip_offset``, ``bend_deg``, ``collision``, ``force``, ``kept``, ``drawn``, ``frame_ms``; NaN
        where unknown), as :meth:`grasswidget.core.traces.TraceRecorder.traces` documents them."""
        self._check_open()
        return self.lab_bench.traces()

    def save_traces(self, path) -> str:
        """Write :meth:`traces` to ``path`` (``.csv``: one row per sample; ``.npz``: the arrays) and
        return the path; ``grasswidget.load_traces(path)`` reads it back. Another extension raises
        GrassValueError naming the allowed ones, a missing folder MissingFileError."""
        self._check_open()
        return self.lab_bench.save(path)

    @property
    def trace_window(self) -> float:
        """Rolling window of :meth:`traces`, simulated seconds (default 60; 0.1..3600; a value out
        of range raises GrassValueError naming ``trace_window`` and the range, and the old one stays)."""
        return self.lab_bench.window_s if self.lab_bench is not None else None

    @trace_window.setter
    def trace_window(self, value):
        self._check_open()
        self.lab_bench.window_s = value

    # ------------------------------------------------------------------ files

    def save_png(self, path=None, size=None) -> str:
        """Write a PNG of the current view and return its path (in browser mode the
        browser renders it at that size and Python writes it; this waits for it).

        Args:
            path: file path (default: ``output/grass-YYYYmmdd-HHMMSS.png`` under the
                current working directory, i.e. in ``output/`` beside the notebook;
                the folder is created).
            size: (width, height) or "WxH"; default twice the view size.
        """
        self._check_open()
        size = parse_size(size) if size is not None else (2 * self.size[0], 2 * self.size[1])
        return saving.save_png(self.view, path, size)

    def save_html(self, path, still: bool = True, title: str = "grasswidget meadow") -> str:
        """Write a live page of this meadow (one self-contained HTML file that runs it in any browser
        with WebGPU, no Python, no kernel; a still picture where WebGPU is missing unless
        ``still=False``; ``title`` the page's title) and return the path: ``path`` ends in .html in an
        existing folder, at most ``grasswidget.browser.page.PAGE_MAX_BLADES`` blades (else
        GrassValueError / MissingFileError). See :func:`grasswidget.notebook.saving.save_html`."""
        self._check_open()
        return saving.save_html(self.view, path, size=self.size, params=self.params, ball=self.ball,
                                playing=self.playing, time_scale=self.time_scale, still=still, title=title,
                                camera_floor=self.camera_floor)

    def save_animation(self, path, seconds=4.0, fps=20, size=None, progress=True, on_frame=None) -> str:
        """Export an animation (GIF, or MP4 with imageio-ffmpeg) from the current state, deterministic,
        rendered by the kernel engine (a browser view's state is read back and filmed from the same
        camera); ``on_frame(k, t)`` runs before each frame. Returns the path. See
        :func:`grasswidget.notebook.saving.save_animation` and :func:`grasswidget.tools.export.save_animation`."""
        self._check_open()
        return saving.save_animation(self.view, path, self.size, self.camera_state, self.params, seconds=seconds,
                                     fps=fps, size=size, progress=progress, on_frame=on_frame)

    # ------------------------------------------------------------------ marimo

    def _display_(self):
        """What marimo shows for this widget (only marimo asks for ``_display_``; Jupyter front
        ends draw the ipywidgets as always): the view, the chart and the panel as anywidgets
        (see :mod:`grasswidget.notebook.marimo_face`)."""
        from .marimo_face import marimo_display

        if self._closed:
            return repr(self)  # "<GrassWidget ... closed>", as Jupyter shows a closed widget's text
        return marimo_display(self)

    def control_mirror(self):
        """The panel column (camera bar and rows) as one anywidget of plain HTML controls, for
        front ends without ipywidgets (marimo); made on first use, then the same one
        (:class:`~grasswidget.notebook.control_mirror.ControlMirror`)."""
        self._check_open()
        return self._face.mirror()

    def marimo_stage(self):
        """The stage alone (view and chart) as marimo shows it, without the panel: a
        :class:`~grasswidget.notebook.marimo_face.MarimoStage`, made on first use (needs
        marimo), then the same one (a comparison shows its views' stages with one shared panel)."""
        self._check_open()
        return self._face.stage()

    def marimo_parts(self) -> tuple:
        """What marimo shows: the stage (view and chart, following an engine switch; a
        :class:`~grasswidget.notebook.marimo_face.MarimoStage`) and :meth:`control_mirror`.
        Made on first use (needs marimo), then the same ones."""
        return self.marimo_stage(), self.control_mirror()

    # ------------------------------------------------------------------ parts, closing

    def parts(self) -> tuple:
        """The objects this widget is made of and owns: its engine, state and view (with the view's
        widget, and the kernel engine's scene, camera controller and canvas), the control panel, the
        ball, the camera bar, the lab bench (chart), the layout and marimo's face (those that exist;
        their ipywidgets, shown or not). Something holding one of them holds the widget (see
        :mod:`grasswidget.notebook.cell_rerun`)."""
        found = (self.engine, self.state, self.view, self.panel, self.ball, self.camera_bar, self.lab_bench,
                 self.camera_home, self._layout, self._stage, self._face, *(self._face.made() if self._face else ()))
        if self.view is not None:
            found += (self.view.widget, self.scene, self.controller, self.canvas)
        return tuple(p for p in found if p is not None)

    @property
    def closed(self) -> bool:
        """True after :meth:`close` (the GPU resources are released)."""
        return self._closed

    def close(self):
        """Close the view and the controls and release the GPU resources."""
        if self._closed:
            return
        self._closed = True
        if getattr(self, "params", None) is not None:
            try:
                self.params.unobserve(self._request_draw, names=All)
            except ValueError:
                pass
        for link in self._links:
            link.unlink()
        for part in (self.lab_bench, self._face, self.panel, self.camera_bar, self.camera_home, self.engine):
            if part is not None:
                part.close()
        if self.ball is not None:
            self.ball.detach()
        if self._layout is not None:
            self._layout.close()  # an open box would keep the closed rows (and through them this widget) alive
        if self._stage is not None:
            close_widgets(self._stage)
        own_layout = self.layout  # ipywidgets' close leaves a box's Layout (a widget of its own) open
        super().close()
        own_layout.close()

    def _check_open(self):
        if self._closed:
            raise WidgetClosedError("this GrassWidget is closed; create a new one")

    def _request_draw(self, _change=None):
        if not self._closed and self.view is not None:
            self.view.request_draw()

    @validate("chart")
    def _valid_chart(self, proposal):
        from .lab_bench import check_chart

        return check_chart(proposal["value"])

    def __repr__(self):
        state = "closed" if self._closed else ("playing" if self.playing else "paused")
        return f"<GrassWidget {self.blade_count} blades, {self.size[0]}x{self.size[1]}, {state}>"
