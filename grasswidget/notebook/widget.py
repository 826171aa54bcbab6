"""GrassWidget: a live, controllable meadow in a Jupyter notebook, made of parts.

``GrassWidget`` is an ipywidgets ``VBox`` whose parts each have one job in their own module and
share the widget's state (:class:`~grasswidget.notebook.widget_state.WidgetState`, whose traits
are linked to the widget's) and the engine switch's events; none of them holds the widget: the
engine (:mod:`.engine_switch`, the widget's only way to an engine through its
:class:`~grasswidget.views.api.EngineView`), the panel (:mod:`.panel`), the camera and its bar
(:mod:`.camera_bar`), the ball (:mod:`.ball`), the lab bench (:mod:`.lab_bench`), the layout
(:mod:`.layout`), marimo's face (:mod:`.marimo_face`) and the files (:mod:`.saving`).

::

    import grasswidget as gw
    w = gw.GrassWidget()          # a meadow of 4096 blades, 640 x 480
    w                             # (last expression of the cell: shows it)
    w.params.wind_strength = 20   # moves the slider too
    w.save_png("meadow.png")      # 2x the view size by default
    w.close()                     # frees the GPU buffers

Engines, mouse, keys, the ball and the teaching views: docs/usage.md ("The widget", "Two engines").
"""

from __future__ import annotations

import ipywidgets as ipw
from traitlets import All

from . import cell_rerun, saving
from ..core.limits import check_steps
from ..errors import GrassTypeError, WidgetClosedError
from ..views.api import MAX_STEPS_PER_FRAME, KernelOnly, ViewMember
from .engine_switch import BACKENDS, STATS_INTERVAL, EngineSwitch, check_params, check_streaming, streaming_defaults
from .layout import PANEL_WIDTH, WidgetLayout, check_layout, close_widgets, make_stage, show_view, view_size
from .widget_state import SharedTraits, WidgetActions, WidgetState, link_state

__all__ = ["GrassWidget", "streaming_defaults", "MAX_STEPS_PER_FRAME", "STATS_INTERVAL", "BACKENDS"]


class GrassWidget(ipw.VBox, SharedTraits):
    """A live meadow: a view of the engine that simulates and draws it, and a control panel
    (every argument, attribute and trait in detail: docs/usage.md#the-widgets-members).

    Args:
        blades: a blade count (default 4096) or a :class:`grasswidget.Blades`.
        preset: None or a preset name ("cis565", "meadow", ...).
        size: (width, height) CSS pixels or "WxH" (default 640 x 480; 1280 x 720 with ``layout="lecture"``).
        params: a :class:`GrassParams` to use and share (default a new one).
        max_fps, quality: the stream cap (frames/s, 1..240) and JPEG quality (1..100); default
            :func:`streaming_defaults` for the adapter.
        pixel_ratio: the most rendered pixels per CSS pixel (0.25..4; default 1 on a CPU adapter, 2 on a GPU).
        backend: "auto" (default), "kernel" or "browser" (``w.backend`` says which is live,
            ``w.engine_reason`` why).
        target_fps: frames/s adaptive resolution aims for (1..240; default 24 on a CPU adapter, 60 on a GPU).
        layout: "default" or "lecture" (``w.layout_mode``; ``w.layout`` stays ipywidgets' Layout).
        function_overrides: a :class:`~grasswidget.core.wgsl_overrides.FunctionOverrides` (user WGSL in
            place of stock blade-math functions, both engines) or None.

    Attributes: ``params``, ``view`` (the live EngineView), ``engine``, ``state``, ``panel``,
    ``ball``, ``camera_bar``, ``camera_home``, ``lab_bench``; ``scene``, ``canvas``,
    ``controller`` in the kernel engine only (None in the browser engine).
    Traits (:class:`~grasswidget.notebook.widget_state.SharedTraits`): ``time_scale``
    (simulated s per s, 0..10), ``playing``, ``culling_frozen``, ``chart``, ``camera_floor``
    ("grass" or "ground") and ``panel_folded``.
    """

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
        check_params(params)
        self.size = view_size(self.layout_mode, size)
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
        # Re-running the cell that made a widget closes the previous one, one that something still
        # holds aside (see grasswidget.notebook.cell_rerun).
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
        self.ball.join(view)
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
        self._stage = make_stage(view, self.lab_bench.widget, *probe)
        self._face = MarimoFace(self._stage, self._layout.column, engine.show_error)
        # A new view (an engine switch): the ball joins its colliders first, then the stage and the chart follow.
        for event, show in (("error", self.panel.show_error), ("stats", self.panel.show_stats),
                            ("inspected", self.panel.show_inspected), ("note", self.panel.show_note),
                            ("view", self.ball.join), ("view", lambda new: show_view(self._stage, new)),
                            ("view", self.lab_bench.attach)):
            engine.on(event, show)
        self.ball.observe(lambda change: setattr(state, "playing", True) if change["new"] else None,
                          names="rolling")  # the ball rolls with simulated time
        self.ball.collider.observe(engine.request_draw, names=["center", "radius"])
        self.ball.observe(engine.request_draw, names="enabled")
        state.observe(lambda change: self.panel.show_playing(bool(change["new"])), names="playing")
        state.observe(lambda change: self.lab_bench.set_playing(bool(change["new"])), names="playing")
        state.observe(lambda change: self.lab_bench.set_culling_frozen(bool(change["new"])), names="culling_frozen")
        state.observe(lambda change: self.lab_bench.show(change["new"]), names="chart")
        state.observe(lambda change: self._layout.fold(bool(change["new"])), names="panel_folded")
        self.params.observe(engine.request_draw, names=All)
        self.panel.show_stats(dict(view.stats, playing=bool(state.playing)))

    # ------------------------------------------------------------------ the engine and the field

    @property
    def view(self):
        """The live engine's :class:`~grasswidget.views.api.EngineView` (the closed one after :meth:`close`)."""
        return self.engine.view if self.engine is not None else None

    @property
    def backend(self) -> str:
        """The live engine, "kernel" or "browser" ("auto": "kernel" until the page reports its adapter;
        a browser without WebGPU turns "kernel"); see docs/usage.md#two-engines-kernel-or-browser."""
        return self.view.backend if self.view is not None else self.engine.requested

    @property
    def engine_reason(self) -> str | None:
        """For ``backend="auto"``: one sentence saying which engine runs and why (also on the message
        line); None for "kernel" and "browser"."""
        return self.engine.auto.choice.reason if self.engine.auto is not None else None

    @property
    def adapter_probe(self):
        """For ``backend="auto"`` with the kernel on a CPU adapter: the AdapterProbe shown with the view,
        whose ``report`` (the page's WebGPU adapter) decides the engine once; else None."""
        return self.engine.auto.probe if self.engine.auto is not None else None

    @property
    def target_fps(self) -> float:
        """Frames/s adaptive resolution aims for while playing (1..240; default 24 on a CPU adapter, 60
        on a GPU); a bad value raises ValueError naming ``target_fps`` and the range, the old one stays."""
        if self.view is None:
            return float(self.engine.streaming["target_fps"])
        return self.view.readings.target_fps

    @target_fps.setter
    def target_fps(self, value):
        self.engine.set_target_fps(value)

    @property
    def blade_count(self) -> int:
        """Number of blades; setting it (an int) rebuilds the field as ``Blades.on_plane(count)``."""
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
        self.engine.request_draw()

    def set_function_overrides(self, overrides):
        """Run user WGSL (a FunctionOverrides, or None for the stock functions) in place of stock
        blade-math functions; ExerciseShaderError when it does not compile (the old ones stay). The
        browser engine takes them only at construction (docs/usage.md#the-widgets-members)."""
        self._check_open()
        self.view.set_function_overrides(overrides)
        self.engine.function_overrides = overrides

    @property
    def function_overrides(self):
        """The user WGSL in force in place of stock blade-math functions, or None."""
        return self.engine.function_overrides

    # ------------------------------------------------------------------ time and camera

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
        """Pause and advance exactly ``n`` fixed steps of ``params.dt`` (default one frame's worth, at
        least 1; 0..MAX_STEPS = 1,000,000, else GrassValueError). Ctrl-C stops a long kernel run between
        GPU submissions (StepsInterrupted; the steps that ran count): docs/usage.md#the-widgets-members."""
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

    def reset_camera(self):
        """Back to the scene's starting view (``look_from("home")``)."""
        self.look_from("home")

    def look_from(self, name):
        """Move the camera to "home" (the start camera), "top" (straight down, the whole field) or "low"
        (a student's eye at the field's edge), in both engines, held to the orbit limits; another name
        raises GrassValueError naming these (docs/usage.md#camera-and-layouts)."""
        self._check_open()
        self.camera_home.look_from(name)

    # ------------------------------------------------------------------ lab bench

    def traces(self) -> dict:
        """The lab bench's samples of the last :attr:`trace_window` simulated seconds: NumPy arrays by
        name (``t``, ``step``, ``tip_offset``, ...; NaN where unknown), as
        :meth:`grasswidget.core.traces.TraceRecorder.traces` documents them."""
        self._check_open()
        return self.lab_bench.traces()

    def save_traces(self, path) -> str:
        """Write :meth:`traces` to ``path`` (.csv or .npz; else GrassValueError, a missing folder
        MissingFileError) and return it; ``grasswidget.load_traces(path)`` reads it back."""
        self._check_open()
        return self.lab_bench.save(path)

    @property
    def trace_window(self) -> float:
        """Rolling window of :meth:`traces`, simulated seconds (default 60; 0.1..3600; out of range:
        GrassValueError naming ``trace_window``, the old one stays)."""
        return self.lab_bench.window_s if self.lab_bench is not None else None

    @trace_window.setter
    def trace_window(self, value):
        self._check_open()
        self.lab_bench.window_s = value

    # ------------------------------------------------------------------ files

    def save_png(self, path=None, size=None) -> str:
        """Write a PNG of the current view and return its path: ``path`` default
        ``output/grass-YYYYmmdd-HHMMSS.png`` (folder created), ``size`` (w, h) or "WxH", default twice
        the view's size. The browser engine renders it in the page; this waits for it."""
        self._check_open()
        return saving.save_png(self.view, path, size)

    def save_html(self, path, still: bool = True, title: str = "grasswidget meadow") -> str:
        """Write a live page of this meadow (one self-contained .html that runs it with WebGPU, no
        kernel; a still picture without WebGPU unless ``still=False``) and return the path; see
        :func:`grasswidget.notebook.saving.save_html` for the limits."""
        self._check_open()
        return saving.save_html(self.view, path, size=self.size, params=self.params, ball=self.ball,
                                playing=self.playing, time_scale=self.time_scale, still=still, title=title,
                                camera_floor=self.camera_floor)

    def save_animation(self, path, seconds=4.0, fps=20, size=None, progress=True, on_frame=None) -> str:
        """Film the meadow from its current state (GIF, or MP4 with imageio-ffmpeg), deterministic, with
        the kernel engine; ``on_frame(k, t)`` runs before each frame. Returns the path
        (:func:`grasswidget.notebook.saving.save_animation`)."""
        self._check_open()
        return saving.save_animation(self.view, path, self.size, self.camera_state, self.params, seconds=seconds,
                                     fps=fps, size=size, progress=progress, on_frame=on_frame)

    # ------------------------------------------------------------------ marimo

    def _display_(self):
        """What marimo shows for this widget (the view, the chart and the panel as anywidgets; Jupyter
        front ends draw the ipywidgets): :mod:`grasswidget.notebook.marimo_face`."""
        from .marimo_face import marimo_display

        if self._closed:
            return repr(self)  # "<GrassWidget ... closed>", as Jupyter shows a closed widget's text
        return marimo_display(self)

    def control_mirror(self):
        """The panel column as one anywidget of plain HTML controls, for front ends without ipywidgets
        (marimo); made on first use, then the same one."""
        self._check_open()
        return self._face.mirror()

    def marimo_stage(self):
        """The stage alone (view and chart) as marimo shows it, without the panel (needs marimo);
        made on first use, then the same one."""
        self._check_open()
        return self._face.stage()

    def marimo_parts(self) -> tuple:
        """What marimo shows: :meth:`marimo_stage` and :meth:`control_mirror`."""
        return self.marimo_stage(), self.control_mirror()

    # ------------------------------------------------------------------ parts, closing

    def parts(self) -> tuple:
        """The objects this widget is made of and owns (engine, state, view and its widget, the kernel
        engine's scene, controller and canvas, panel, ball, camera bar and home, lab bench, layout,
        marimo's face and what it made): holding one holds the widget (:mod:`.cell_rerun`)."""
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
        if getattr(self, "params", None) is not None and self.engine is not None:
            try:
                self.params.unobserve(self.engine.request_draw, names=All)
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

    def __repr__(self):
        state = "closed" if self._closed else ("playing" if self.playing else "paused")
        return f"<GrassWidget {self.blade_count} blades, {self.size[0]}x{self.size[1]}, {state}>"
