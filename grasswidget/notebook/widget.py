"""GrassWidget: a live, controllable meadow in a Jupyter notebook.

``GrassWidget`` is an ipywidgets ``VBox`` that composes two parts, each in its
own module:

* a view (a :class:`grasswidget.core.view_api.EngineView`; the widget talks to it
  through that interface only): :class:`grasswidget.notebook.kernel_view.KernelView`,
  the jupyter-rfb canvas streaming a :class:`~grasswidget.gpu.scene.GrassScene`
  rendered in the kernel, or :class:`grasswidget.browser.engine_view.BrowserEngineView`,
  the same simulation run in the browser;
* a control panel (:class:`grasswidget.notebook.panel.ControlPanel`): sliders, culling
  checkboxes, the ball row (:mod:`grasswidget.notebook.ball`), play/pause/step/
  reset buttons, a live stats line, a "Save PNG" button and the teaching row
  (colour by, freeze culling, legend, inspected blade), linked to the
  :class:`GrassParams` traits.

::

    import grasswidget as gw
    w = gw.GrassWidget()          # a meadow of 4096 blades, 640 x 480
    w                             # (last expression of the cell: shows it)
    w.params.wind_strength = 20   # moves the slider too
    w.save_png("meadow.png")      # 2x the view size by default
    w.save_animation("wind.gif", seconds=3, fps=15)
    w.close()                     # frees the GPU buffers

Two engines (``backend=``): "kernel" renders in the kernel and streams frames
(:mod:`grasswidget.notebook.kernel_view`); "browser" runs the same WGSL simulation,
culling and ribbons in the notebook's browser through WebGPU (:mod:`grasswidget.browser`),
as fast as the student's own GPU; "auto" (the default) runs the kernel engine, except
where the kernel renders on a CPU adapter and the page's browser offers a hardware
WebGPU adapter: there the browser engine takes over when the widget is first shown
(:mod:`grasswidget.notebook.engine_auto`, the rule in :mod:`grasswidget.core.engine_choice`).
A browser without WebGPU makes a "browser" widget fall back to kernel streaming with one
line saying so.

Streaming and time: see :mod:`grasswidget.notebook.kernel_view`. Mouse: drag to orbit,
right-drag to pan, wheel to zoom (the camera stays above the grass, or the
ground with ``camera_floor="ground"``, and the field in sight, see
:mod:`grasswidget.core.orbit_limits`); ``look_from("home" | "top" | "low")`` and
the camera bar's buttons move it to a named view
(:mod:`grasswidget.core.camera_presets`). Layouts (:mod:`grasswidget.notebook.layout`):
the panel beside the view, or under it in a narrow notebook; ``layout="lecture"``
gives a 1280 x 720 view and the panel folded to one line. Shift + drag puts the ball (a sphere
collider) on the ground under the pointer; the "sphere" row switches it on and
off, moves and resizes it and rolls it along a circle ("Roll"). Keys, only
while the canvas has focus (click it first; the keys go to a hidden text
input, not to the notebook): space = play/pause, ``s`` = step one frame,
``r`` = reset the camera. Ctrl + click on a blade inspects it (``w.inspect(ids)``
from code); "freeze culling" (``w.culling_frozen = True``) freezes culling at the
current camera, so orbiting away shows what that view culls.
"""

from __future__ import annotations

import datetime
import os

import ipywidgets as ipw
import numpy as np
from traitlets import All, Any, validate

from . import cell_rerun
from .adaptive import check_target_fps
from ..core.blades import Blades
from ..core.limits import check_steps
from ..core.presets import preset_params
from ..core.view_api import MAX_STEPS_PER_FRAME, EngineView, ViewMember
from ..errors import GrassTypeError, GrassValueError, WidgetClosedError
from .kernel_view import STATS_INTERVAL, KernelView, streaming_defaults
from .panel import ControlPanel
from .camera_bar import CameraBar
from .layout import PANEL_WIDTH, WidgetLayout, close_widgets
from ..core.camera_presets import camera_preset, check_camera_preset, floor_for
from ..core.orbit_limits import FLOORS, clamp_orbit
from ..core.params import CheckedBool, ChoiceTrait, GrassParams, RangedFloat, sunlight_defaults
from .shadows_default import ShadowsDefault

__all__ = ["GrassWidget", "streaming_defaults", "MAX_STEPS_PER_FRAME", "STATS_INTERVAL", "BACKENDS"]

#: The engines a GrassWidget can run on (``backend=``).
BACKENDS = ("kernel", "browser", "auto")


def _check_number(name, value, lo, hi, integer=False):
    kind = "an integer" if integer else "a number"
    types = (int, np.integer) if integer else (int, float, np.integer, np.floating)
    if isinstance(value, bool) or not isinstance(value, types) or not (lo <= value <= hi):
        raise GrassValueError(f"{name} must be {kind} in [{lo}, {hi}]; got {value!r}")
    return value


def _panel_property(name):
    return property(lambda self: getattr(self.panel, name) if self.panel is not None else None,
                    doc=f"The control panel's ``{name}`` (see :class:`grasswidget.notebook.panel.ControlPanel`).")


class GrassWidget(ipw.VBox):
    """A live meadow: a view streaming a :class:`GrassScene`, and a control panel.

    Args:
        blades: a blade count (``Blades.on_plane(count)``, or the preset's field)
            or a :class:`grasswidget.Blades`.
        preset: None, or a preset name passed to ``GrassScene.preset`` (e.g.
            "cis565", "meadow").
        size: (width, height) of the view in CSS pixels, or "WxH" (default 640 x 480;
            1280 x 720 with ``layout="lecture"``).
        params: a :class:`GrassParams` to use (and share); default a new one.
        max_fps, quality: override the adapter's streaming defaults
            (:func:`streaming_defaults`): the stream cap (frames/s) and JPEG quality.
        target_fps: frames per second adaptive resolution aims for while playing
            (default 24 on a CPU adapter, 60 on a GPU; 1..240).
        pixel_ratio: the most rendered pixels per CSS pixel (default 1 on a CPU
            adapter, 2 on a GPU; the browser's devicePixelRatio below that).
            E.g. 0.5 on a CPU adapter renders a quarter of the pixels, about
            twice the frames/s, and the browser scales the picture up.
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
        params: the :class:`GrassParams` (the same object the scene simulates
            with; link or observe its traits, set them from code).
        view: the :class:`~grasswidget.core.view_api.EngineView` of the live engine (None after close).
        panel: the :class:`~grasswidget.notebook.panel.ControlPanel` (None after close).
        scene: the :class:`GrassScene` (None after :meth:`close`).
        canvas: the jupyter-rfb canvas widget.
        controller: the pygfx ``OrbitController`` of the camera.
        ball: the :class:`~grasswidget.notebook.ball.BallControl`: ``ball.collider``
            is its :class:`SphereCollider`; ``ball.enabled``, ``ball.rolling``,
            ``ball.roll_speed``, ``ball.move_to(x, z)``, ``ball.set_radius(r)``.
        sliders, checkboxes, blade_slider, wind_field_dropdown, play_button,
        step_button, reset_blades_button, reset_camera_button, save_button,
        png_scale, file_line, stats_line, message_line, switch_choices: the panel's controls
            (``blade_slider``: the blade count control's slider, in powers of two, see
            :mod:`grasswidget.notebook.blade_count_control`; ``switch_choices``: {trait: SwitchChoice}, the
            auto / on / off choices of cull_occlusion and compute_raster, :mod:`grasswidget.notebook.switch_choice`).

    Traits: ``time_scale`` (simulated seconds per real second, 0..10), ``playing``,
    ``culling_frozen`` (cull against a copy of the camera taken when it was set),
    ``camera_floor`` ("grass" or "ground": what the orbit keeps the camera above) and
    ``panel_folded`` (only the camera bar shows).

    Time: while playing, simulated time follows the wall clock in whole fixed
    steps of ``params.dt`` (:attr:`sim_time` counts it); when a frame would need
    more than :data:`MAX_STEPS_PER_FRAME` steps the meadow runs in slow motion and
    the stats line says so. ``pause()`` stops it at once, ``step(n)`` advances
    exactly n steps, ``save_animation`` is deterministic (fixed steps per frame).
    """

    time_scale = RangedFloat(1.0, 0.0, 10.0, "simulated s per s",
                             help="Simulated seconds per wall-clock second while playing.")
    playing = CheckedBool(True, help="Animate (continuous drawing) or pause (draw on demand).")
    culling_frozen = CheckedBool(False, help="Cull against a copy of the camera taken when this was set (see GrassScene.freeze_culling).")
    chart = Any(None, allow_none=True,
                    help='The live chart under the view: None (hidden), "tip" (tip offset of each inspected blade), '
                         '"bend" (bend angle), "culling" (blades kept after each culling test) or "frame" (where '
                         "a frame's time goes), against simulated time (see grasswidget.notebook.lab_bench).")
    camera_floor = ChoiceTrait("grass", FLOORS, help='What the orbit keeps the camera above: "grass" (0.3 m above '
                               'the tallest blade\'s tip, so never inside the field) or "ground" (0.3 m above the '
                               'ground, down among the blades). A widget whose start camera is lower than the grass '
                               'starts with "ground".')
    panel_folded = CheckedBool(False, help="Show only the camera bar (play/pause, camera presets, more) under or beside the "
                        "view; True from the start with layout='lecture'.")
    camera_bar = None
    _layout = None
    _mirror = None
    _marimo_stage = None

    # Defaults, so close() (also called by ipywidgets' __del__) works on a
    # half-built widget whose __init__ raised.
    _closed = False
    _auto = None
    view: EngineView | None = None
    panel = None
    ball = None
    bench = None

    # The view's members the widget adds nothing to: each *is* the live view's member of that name
    # (grasswidget.core.view_api.ViewMember, documented once in EngineView; help() shows that text).
    scene = ViewMember()
    canvas = ViewMember()
    controller = ViewMember()
    camera_state = ViewMember(settable=True)
    max_fps = ViewMember()
    frame_interval = ViewMember()
    steps_per_frame = ViewMember()
    sim_time = ViewMember()
    render_scale = ViewMember(no_view=1.0)
    stats = ViewMember()
    read_state = ViewMember()
    set_wind_wgsl = ViewMember()
    inspect = ViewMember()
    inspected = ViewMember(no_view=())
    read_inspected = ViewMember()
    sliders = _panel_property("sliders")
    checkboxes = _panel_property("checkboxes")
    switch_choices = _panel_property("switch_choices")
    blade_slider = _panel_property("blade_slider")
    wind_field_dropdown = _panel_property("wind_field_dropdown")
    play_button = _panel_property("play_button")
    step_button = _panel_property("step_button")
    reset_blades_button = _panel_property("reset_blades_button")
    reset_camera_button = _panel_property("reset_camera_button")
    save_button = _panel_property("save_button")
    png_scale = _panel_property("png_scale")
    file_line = _panel_property("file_line")
    stats_line = _panel_property("stats_line")
    message_line = _panel_property("message_line")

    def __init__(self, blades=4096, preset=None, size=None, params=None, *, max_fps=None, quality=None,
                 pixel_ratio=None, backend="auto", target_fps=None, layout="default",
                 function_overrides=None):
        from ..core.presets import PRESETS, parse_size
        from ..core.wgsl_overrides import FunctionOverrides
        from .layout import LAYOUT_VIEW_SIZES, check_layout

        #: "default" or "lecture" (see :mod:`grasswidget.notebook.layout`); ``w.layout`` stays ipywidgets' Layout.
        self.layout_mode = check_layout(layout)
        if size is None:
            size = LAYOUT_VIEW_SIZES[self.layout_mode]

        if not isinstance(backend, str) or backend not in BACKENDS:
            raise GrassValueError(f"backend must be one of {', '.join(map(repr, BACKENDS))}; got {backend!r}")
        self._requested_backend = backend
        self._auto = None
        if backend == "auto":  # the kernel's adapter decides now where it can; else the page's, when shown
            from .engine_auto import AutoEngine, kernel_adapter

            self._auto = AutoEngine(*kernel_adapter(), on_choice=self._on_engine_choice)
            backend = self._auto.engine
        if function_overrides is not None and not isinstance(function_overrides, FunctionOverrides):
            raise GrassTypeError("function_overrides must be a FunctionOverrides (e.g. gw.exercise(name).overrides(code)) "
                                 f"or None; got {type(function_overrides).__name__}")
        self._function_overrides = function_overrides
        if params is not None and not isinstance(params, GrassParams):
            raise GrassTypeError(f"params must be a GrassParams or None, not {type(params).__name__}")
        if preset is not None and preset not in PRESETS:
            raise GrassValueError(f"preset must be None or one of {', '.join(PRESETS)}; got {preset!r}")
        self.size = parse_size(size)
        overrides = {}
        if max_fps is not None:
            overrides["max_fps"] = float(_check_number("max_fps", max_fps, 1, 240))
        if quality is not None:
            if isinstance(quality, bool) or not isinstance(quality, int) or not (1 <= quality <= 100):
                raise GrassValueError(f"quality must be an integer in [1, 100] (JPEG quality); got {quality!r}")
            overrides["quality"] = quality
        if pixel_ratio is not None:
            overrides["max_pixel_ratio"] = float(_check_number("pixel_ratio", pixel_ratio, 0.25, 4))
        if target_fps is not None:
            overrides["target_fps"] = check_target_fps(target_fps)
        self._streaming_overrides = overrides
        # The kernel's adapter (2 s to open lavapipe) is asked only when the kernel renders.
        if backend == "kernel":
            from ..gpu.adapter import is_cpu_adapter

            self._cpu = is_cpu_adapter()
        else:
            self._cpu = None
        streaming = dict(streaming_defaults(self._cpu if self._cpu is not None else True), **overrides)
        self._streaming = streaming
        self._preset = preset
        if backend == "kernel":
            from ..gpu.field import max_blade_count

            # The slider's top: the adapter's comfortable maximum, within what memory and the GPU's buffers allow.
            self.max_blades = min(streaming["max_blades"], max_blade_count())
        else:  # the browser's device decides; the blade state is still built in the kernel's memory
            from ..browser.engine_view import BROWSER_MAX_BLADES
            from ..core.memory import max_blades_for_memory

            host = max_blades_for_memory()
            self.max_blades = BROWSER_MAX_BLADES if host is None else min(BROWSER_MAX_BLADES, host)
        streaming["max_blades"] = self.max_blades
        self._blades = self._check_blades(blades)
        self._closed = False
        # A preset's own values (the cis565 preset's 40 m distance culling), as GrassScene.preset gives them.
        # The sunlight's default follows the adapter that draws (core.params.sunlight_defaults): shadows
        # on when the kernel renders on a GPU, or (below) when "auto" moves to a browser's GPU.
        self._own_params = params is None
        if params is None:
            sun = sunlight_defaults(cpu_adapter=self._cpu is not False)
            params = GrassParams(**{**sun, **(preset_params(preset) if preset else {})})
        self.params = params
        # Later adapters (the browser engine's report, a fall back to the kernel) set it the same way,
        # while it is the widget's own default (notebook/shadows_default.py).
        self._sun_default = ShadowsDefault(self.params, own=self._own_params)

        try:
            if backend == "kernel":
                self.view = self._kernel_view()
            else:
                self.view = self._browser_view()
            self._make_ball()
            self.panel = ControlPanel(self.params, self, self, blade_count=self.blade_count,
                                      max_blades=self.max_blades, view_size=(min(self.size[0], PANEL_WIDTH),
                                                                             self.size[1]),
                                      ball_row=self.ball.controls)
            self.panel.view_size = self.size  # Save PNG multiplies the view's size (the rows fit the column)
            self._start_camera()
            from .lab_bench import LabBench

            self.bench = LabBench(self.view, self.size[0], owner=self, name="chart", on_error=self._show_error)
        except BaseException:
            self.close()
            raise
        # The view, then the panel column beside it or, where the notebook is narrow, under it.
        self.panel_folded = self.layout_mode == "lecture"
        self.camera_bar = CameraBar(self, on_error=self._show_error)
        # The panel's rows, then the lab bench's "chart" choice (its chart goes under the view).
        self._layout = WidgetLayout(self.camera_bar.row, [*self.panel.rows, self.bench.control], self.size[0])
        self._layout.fold(self.panel_folded)
        # The view with the lab bench's live chart right under it.
        probe = [self._auto.probe] if self._auto is not None and self._auto.probe is not None else []
        self._stage = ipw.VBox([self.view.widget, self.bench.widget, *probe], layout=ipw.Layout(max_width="100%"))
        super().__init__(children=[self._stage, self._layout.column], layout=self._layout.root_layout)
        self.add_class("grasswidget")
        self.observe(self._on_camera_floor, names="camera_floor")
        self.observe(lambda change: self._layout.fold(bool(change["new"])), names="panel_folded")
        self.params.observe(self._on_param_change)
        self.observe(self._on_playing, names="playing")
        self.observe(self._on_time_scale, names="time_scale")
        self.observe(self._on_culling_frozen, names="culling_frozen")
        self.observe(self._on_chart, names="chart")
        self._show_stats(self.view.current_stats())
        if self._auto is not None:
            self._show_note(self._auto.choice.reason)

        # Re-running the cell that made a widget closes the previous one (JupyterLab
        # sends the cell id with each execution), so its GPU buffers are freed; one
        # that something still holds (a variable, a list, an attribute, a closure,
        # another widget) stays open (see grasswidget.notebook.cell_rerun).
        cell = cell_rerun.current_cell_id()
        if cell:
            cell_rerun.adopt_for_cell(cell, self)

    # ------------------------------------------------------------------ building

    def _check_blades(self, blades):
        if isinstance(blades, Blades):
            if len(blades) > self.max_blades:
                raise GrassValueError(f"blades: at most {self.max_blades} blades on this adapter; got {len(blades)}")
            return blades
        if isinstance(blades, bool) or not isinstance(blades, (int, np.integer)):
            raise GrassTypeError(f"blades must be a blade count (int) or a grasswidget.Blades, not {type(blades).__name__}")
        if blades >= 1 and self._cpu is not None:  # the kernel renders (the browser's own limits apply there)
            from ..gpu.field import check_blade_count_fits

            check_blade_count_fits(blades, "blades")  # memory and GPU buffers, as GrassScene and the CLI do
        if not (1 <= int(blades) <= self.max_blades):
            raise GrassValueError(f"blades must be an integer in [1, {self.max_blades}] on this adapter; got {blades!r}")
        return int(blades)

    def _kernel_view(self):
        if self._cpu is None:  # a browser widget falling back: now the kernel's adapter matters
            from ..gpu.adapter import is_cpu_adapter

            self._cpu = is_cpu_adapter()
            blades = self._streaming["max_blades"]
            self._streaming = dict(streaming_defaults(self._cpu), **self._streaming_overrides)
            self._streaming["max_blades"] = blades
        view = KernelView(self._blades, self.size, self.params, preset=self._preset, streaming=self._streaming,
                          playback=self, actions=self, on_error=self._show_error, on_stats=self._show_stats,
                          on_inspect=self._show_inspected)
        if self._function_overrides is not None:
            try:
                view.set_function_overrides(self._function_overrides)
            except BaseException:
                view.close()
                raise
        return view

    def _browser_view(self):
        from ..browser.engine_view import BrowserEngineView
        from ..browser.view import BrowserEngineWidget
        from .marimo_face import class_for_front_end

        # marimo: also made where no cell runs (the "auto" switch happens in the probe's message handler)
        return BrowserEngineView(self._blades, self.size, self.params, preset=self._preset, playback=self,
                                 actions=self, on_error=self._show_error, on_stats=self._show_stats,
                                 on_inspect=self._show_inspected, on_unavailable=self._on_browser_unavailable,
                                 on_adapter=self._sun_default.apply_engine_adapter,
                                 pixel_ratio=self._streaming_overrides.get("max_pixel_ratio"),
                                 target_fps=self._streaming["target_fps"],
                                 function_overrides=self._function_overrides,
                                 widget_class=class_for_front_end(BrowserEngineWidget))

    def _make_ball(self):
        from .ball import BallControl

        self.ball = BallControl(self.view.ball_scene, on_error=self._show_error)
        self.ball.observe(self._on_ball_rolling, names="rolling")
        self.ball.collider.observe(lambda _c: self._request_draw(), names=["center", "radius"])
        self.ball.observe(lambda _c: self._request_draw(), names="enabled")
        self.view.attach_ball(self.ball)

    # ------------------------------------------------------------------ properties

    @property
    def blade_count(self) -> int:
        """Number of blades; setting it rebuilds the field (a Blades given at
        construction is then replaced by ``Blades.on_plane(count)``)."""
        b = self._blades
        return len(b) if isinstance(b, Blades) else int(b)

    @blade_count.setter
    def blade_count(self, count):
        count = self._check_blades(count)
        if isinstance(count, Blades):
            raise GrassTypeError("blade_count must be an int; pass a Blades to set_blades()")
        self.set_blades(count)

    def set_blades(self, blades):
        """Replace the field: a blade count or a :class:`Blades` (camera and params are kept)."""
        self._check_open()
        blades = self._check_blades(blades)
        if not isinstance(blades, Blades) and not isinstance(self._blades, Blades) and blades == self._blades:
            return
        self.view.set_blades(blades)
        self._blades = blades
        self.panel.show_blade_count(self.blade_count)
        self._request_draw()

    @property
    def backend(self) -> str:
        """The engine that is live: "kernel" or "browser" (a "browser" widget whose browser
        has no WebGPU adapter turns "kernel"). An "auto" widget says "kernel" until the page
        has reported its adapter, then the engine the rule chose (see :attr:`engine_reason`)."""
        return self.view.backend if self.view is not None else self._requested_backend

    @property
    def engine_reason(self) -> str | None:
        """For ``backend="auto"``: one sentence saying which engine runs and why (also shown on
        the message line), e.g. "browser engine: the kernel renders on a CPU adapter (llvmpipe)
        and this browser offers a GPU (nvidia ampere)"; None for "kernel" and "browser"."""
        return self._auto.choice.reason if self._auto is not None else None

    @property
    def adapter_probe(self):
        """For ``backend="auto"`` with the kernel on a CPU adapter: the
        :class:`~grasswidget.browser.adapter_probe.AdapterProbe` shown with the view, whose
        ``report`` (the page's WebGPU adapter) decides the engine once; else None."""
        return self._auto.probe if self._auto is not None else None

    @property
    def target_fps(self) -> float:
        """Frames per second adaptive resolution aims for while playing (1..240;
        default 24 on a CPU adapter, 60 on a GPU). A bad value raises ValueError
        naming ``target_fps`` and the range, and the old value stays. The kernel
        engine's setting (the browser engine draws at the browser's own rate)."""
        if self.view is None:
            return float(self._streaming["target_fps"])
        return float(self.view.target_fps)

    @target_fps.setter
    def target_fps(self, value):
        value = check_target_fps(value)
        if self.view is not None:
            self.view.target_fps = value
        self._streaming["target_fps"] = value
        self._streaming_overrides["target_fps"] = value

    # ------------------------------------------------------------------ actions

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
        if n is None:
            n = max(1, self.steps_per_frame)
        n = check_steps(n)
        self.playing = False
        try:
            self.view.step(n)
        finally:  # interrupted too: the steps that ran get their sample
            self.bench.after_step()

    def reset_blades(self):
        """Every blade back to its rest pose; the simulation clock back to 0; the traces start again."""
        self._check_open()
        self.view.reset_blades()
        self.bench.after_reset()

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
        check_camera_preset(name)
        if name == "home":
            self.view.reset_camera()
        else:
            blades = self.view.blades
            cam = camera_preset(name, blades.v0, blades.height, home=self._home_camera,
                                aspect=self.size[0] / self.size[1], fov_deg=self.view.camera_state["fov_deg"],
                                limits=self.view.orbit_limits, horizon=blades.horizon)
            self.view.camera_state = cam
        if self.camera_floor == "grass" and floor_for(self.view.blades, self.view.camera_state,
                                                      self.view.depth_range[1]) == "ground":
            self.camera_floor = "ground"

    def _start_camera(self):
        """Remember the start camera (for the presets) and start on the floor it needs."""
        self._home_camera = dict(self.view.camera_state)
        self.camera_floor = floor_for(self.view.blades, self._home_camera, self.view.depth_range[1])
        self.view.set_camera_floor(self.camera_floor)

    def _on_camera_floor(self, change):
        """A new floor: new orbit limits in the view; a camera now below them rises at once."""
        if self._closed or self.view is None:
            return
        self.view.set_camera_floor(change["new"])
        cam = self.view.camera_state
        position, target = clamp_orbit(cam["position"], cam["target"], self.view.orbit_limits)
        if not (np.allclose(position, cam["position"]) and np.allclose(target, cam["target"])):
            self.view.camera_state = {"position": tuple(position), "target": tuple(target)}

    def traces(self) -> dict:
        """What simulated time did, sampled while it advances (the lab bench; see
        :mod:`grasswidget.notebook.trace_feed` for when samples are taken): NumPy arrays in a dict,
        over the last :attr:`trace_window` simulated seconds.

        ``t`` (T,) simulated s since reset_blades(); ``step`` (T,) step count; ``ids`` (K,) the blades
        inspected in the window; ``v0``, ``v2`` (T, K, 3) m in the field's local space;
        ``tip_offset`` (T, K) m from rest; ``bend_deg`` (T, K) degrees from ``up``; ``collision``
        (T, K) collision strength eta (0..1); ``force`` {name: (T, K)} magnitudes of gravity,
        recovery, wind (m/s^2) and the collision push (m per step); ``kept`` {test: (T,)} blades
        kept after each culling test (orientation, frustum, distance, occlusion); ``drawn``
        {path: (T,)} drawn as ribbons and in compute; ``frame_ms`` {stage: (T,)}. NaN where a
        number is unknown (a blade not inspected at that time). See
        :meth:`grasswidget.core.traces.TraceRecorder.traces`."""
        self._check_open()
        return self.bench.traces()

    def save_traces(self, path) -> str:
        """Write :meth:`traces` to ``path`` (``.csv``: one row per sample; ``.npz``: the arrays) and
        return the path; ``grasswidget.load_traces(path)`` reads it back. Another extension raises
        GrassValueError naming the allowed ones, a missing folder MissingFileError."""
        self._check_open()
        return self.bench.save(path)

    @property
    def trace_window(self) -> float:
        """Rolling window of :meth:`traces`, simulated seconds (default 60; 0.1..3600; a value out
        of range raises GrassValueError naming ``trace_window`` and the range, and the old one stays)."""
        return self.bench.window_s if self.bench is not None else None

    @trace_window.setter
    def trace_window(self, value):
        from ..core.traces import check_window

        self._check_open()
        self.bench.window_s = check_window(value, "trace_window")

    def save_png(self, path=None, size=None) -> str:
        """Write a PNG of the current view and return its path (in browser mode the
        browser renders it at that size and Python writes it; this waits for it).

        Args:
            path: file path (default: ``output/grass-YYYYmmdd-HHMMSS.png`` under the
                current working directory, i.e. in ``output/`` beside the notebook;
                the folder is created).
            size: (width, height) or "WxH"; default twice the view size.
        """
        from ..core.presets import check_png_path, parse_size

        self._check_open()
        size = parse_size(size) if size is not None else (2 * self.size[0], 2 * self.size[1])
        if path is None:
            path = _unique_name(default_picture_folder(), "grass", ".png")
        path = check_png_path(path)
        self.view.save_png(path, size)
        return path

    def save_html(self, path, still: bool = True, title: str = "grasswidget meadow") -> str:
        """Write a live page: one self-contained HTML file that runs this meadow in any
        browser with WebGPU, with no Python and no kernel. Returns the path.

        The page carries the browser engine, the WGSL and the blades, and starts from
        the current parameters, camera, ball and play state; it offers orbit, play /
        pause, wind and culling controls, colour by and the ball (shift + drag). In a
        browser without WebGPU it shows a still picture of the same view (rendered
        now in the kernel engine; ``still=False`` leaves it out) and one line saying
        WebGPU is needed. See :mod:`grasswidget.tools.html_export`.

        Args:
            path: file name ending in .html, in an existing folder.
            still: render the still picture (about a second on a CPU adapter).
            title: the page's title.

        Raises GrassValueError for a name not ending in .html or more than
        ``grasswidget.browser.page.PAGE_MAX_BLADES`` blades, MissingFileError for a
        missing folder.
        """
        from ..browser.page import check_page_blades, check_page_path
        from ..tools.html_export import save_html

        self._check_open()
        check_page_path(path)
        check_page_blades(self.blade_count)
        blades = self.view.blades
        near, far = self.view.depth_range
        cam = self.camera_state
        camera = {"position": list(cam["position"]), "target": list(cam["target"]), "fov_deg": float(cam["fov_deg"]),
                  "near": near, "far": far}
        ball = self.ball
        colliders = [ball.collider] if ball is not None and ball.enabled else []
        return save_html(path, blades, self.params, size=self.size, camera=camera, colliders=colliders,
                         ball_radius=float(ball.collider.radius) if ball is not None else None,
                         playing=bool(self.playing), time_scale=float(self.time_scale), still=still, title=title,
                         camera_floor=self.camera_floor)

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
        self._function_overrides = overrides

    @property
    def function_overrides(self):
        """The user WGSL in force in place of stock blade-math functions, or None."""
        return self._function_overrides

    def save_png_later(self, size, done) -> bool:
        """The Save PNG button: write a PNG of ``size`` (w, h) into ``output/`` beside the notebook
        (:func:`default_picture_folder`) and call
        ``done(path)`` once written, without blocking the kernel (the browser engine answers
        later; the kernel engine writes it at once). Returns True (it is under way)."""
        self._check_open()
        path = _unique_name(default_picture_folder(), "grass", ".png")
        self.view.save_png_later(path, size, done)
        return True

    def save_animation(self, path, seconds=4.0, fps=20, size=None, progress=True, on_frame=None) -> str:
        """Export an animation (GIF, or MP4 with imageio-ffmpeg); see
        :func:`grasswidget.tools.export.save_animation`. It starts from the current
        state and puts the live state back afterwards. Returns the path.
        ``on_frame(k, t)`` runs before each frame (see there; with the kernel engine it
        may move ``w.scene.colliders``, which the film's scene is).

        It always renders with the kernel engine: in browser mode the browser's
        current blade state is read back and a kernel scene (which needs a WebGPU
        adapter in the kernel, lavapipe will do) films it from the same camera;
        the browser's own animation is not disturbed."""
        from ..tools.export import save_animation

        self._check_open()
        if self.backend == "browser":
            return self._save_animation_from_browser(path, seconds, fps, size, progress, on_frame)
        out = save_animation(self.scene, path, seconds=seconds, fps=fps, size=size, progress=progress,
                             on_frame=on_frame)
        self._request_draw()
        return out

    def _save_animation_from_browser(self, path, seconds, fps, size, progress, on_frame):
        from ..tools.export import save_animation
        from ..gpu.scene import GrassScene

        state = self.view.read_state()
        scene = GrassScene(self.view.blades, size=self.size, params=self.params.copy())
        try:
            scene.field.write_state(state)
            live = self.view.colliders
            scene.colliders = list(live)
            scene.colliders.set_array(getattr(live, "bulk", ()))
            cam = self.camera_state
            scene.look(cam["position"], cam["target"], cam["fov_deg"])
            return save_animation(scene, path, seconds=seconds, fps=fps, size=size, progress=progress,
                                  on_frame=on_frame)
        finally:
            scene.release()

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
        from .control_mirror import ControlMirror

        self._check_open()
        if self._mirror is None:
            self._mirror = ControlMirror(self._layout.column, on_error=self._show_error)
        return self._mirror

    def marimo_parts(self) -> tuple:
        """What marimo shows: the stage (view and chart, following an engine switch; a
        :class:`~grasswidget.notebook.marimo_face.MarimoStage`) and :meth:`control_mirror`.
        Made on first use (needs marimo), then the same ones."""
        return self.marimo_stage(), self.control_mirror()

    def marimo_stage(self):
        """The stage alone (view and chart) as marimo shows it, without the panel: a
        :class:`~grasswidget.notebook.marimo_face.MarimoStage`, made on first use (needs
        marimo), then the same one (a comparison shows its views' stages with one shared panel)."""
        from .marimo_face import MarimoStage

        self._check_open()
        if self._marimo_stage is None:
            self._marimo_stage = MarimoStage(self._stage)
        return self._marimo_stage

    def parts(self) -> tuple:
        """The objects this widget is made of and owns: its view, the view's widget,
        scene and camera controller, the control panel, the ball, the camera bar, the lab
        bench (chart) and the layout (those that exist; their ipywidgets, shown or not).
        Something holding one of them holds the widget (see :mod:`grasswidget.notebook.cell_rerun`)."""
        view = self.view
        found = (view, self.panel, self.ball, getattr(self, "camera_bar", None), getattr(self, "bench", None),
                 getattr(self, "_layout", None), getattr(self, "_stage", None), self._mirror,
                 self._marimo_stage)
        if view is not None:
            found += (view.widget, view.scene, view.controller, view.canvas)
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
        params = getattr(self, "params", None)
        if params is not None:
            try:
                params.unobserve(self._on_param_change, names=All)
            except ValueError:
                pass
        if self.bench is not None:
            self.bench.close()
        if self._mirror is not None:
            self._mirror.close()
        if self._marimo_stage is not None:
            self._marimo_stage.close()
        if self.panel is not None:
            self.panel.close()
        if self.camera_bar is not None:
            self.camera_bar.close()
        if self.view is not None:
            self.view.close()
        if self._auto is not None:
            self._auto.close()
        if self.ball is not None:
            self.ball.detach()
        layout, stage = getattr(self, "_layout", None), getattr(self, "_stage", None)
        if layout is not None:
            layout.close()  # an open box would keep the closed rows (and through them this widget) alive
        if stage is not None:
            close_widgets(stage)
        own_layout = self.layout  # ipywidgets' close leaves a box's Layout (a widget of its own) open
        super().close()
        own_layout.close()

    # ------------------------------------------------------------------ internals

    def _check_open(self):
        if self._closed:
            raise WidgetClosedError("this GrassWidget is closed; create a new one")

    def _request_draw(self):
        if not self._closed and self.view is not None:
            self.view.request_draw()

    def _show_error(self, err):
        if self.panel is not None:
            self.panel.show_error(err)

    def _show_stats(self, stats):
        if self.panel is not None:
            self.panel.show_stats(dict(stats, playing=bool(self.playing)))  # the status says "paused"

    def _on_param_change(self, change):
        self._request_draw()

    def _on_playing(self, change):
        playing = bool(change["new"])
        self.panel.show_playing(playing)
        if not self._closed:
            self.view.set_playing(playing)
            self.bench.set_playing(playing)
            self._show_stats(self.view.current_stats())

    def _show_inspected(self, blades):
        if self.panel is not None:
            self.panel.show_inspected(blades)

    def _on_culling_frozen(self, change):
        if self._closed:
            return
        self.view.set_culling_frozen(bool(change["new"]))
        self.bench.set_culling_frozen(bool(change["new"]))

    @validate("chart")
    def _valid_chart(self, proposal):
        from .lab_bench import check_chart

        return check_chart(proposal["value"])

    def _on_chart(self, change):
        if not self._closed:
            self.bench.show(change["new"])

    def _replace_view(self, new):
        """Put ``new`` (the other engine's view) in place of the live view, with the camera, floor,
        ball, play state, frozen culling and inspected blades carried over; the old view closes."""
        old = self.view
        camera, inspected = old.camera_state, tuple(old.inspected)
        self.view = new
        new.set_camera_floor(self.camera_floor)
        self.ball.attach(new.ball_scene)  # into the new engine's colliders first, then the view sends them
        new.attach_ball(self.ball)
        try:
            new.camera_state = camera
        except Exception:
            pass
        self._stage.children = [new.widget, *self._stage.children[1:]]
        self.bench.attach(new)
        old.close()
        new.set_time_scale(self.time_scale)
        new.set_playing(self.playing)
        if self.culling_frozen:
            new.set_culling_frozen(True)
        if inspected:
            try:
                new.inspect(list(inspected))
            except Exception:
                pass

    def _on_engine_choice(self, choice):
        """The page reported its adapter ("auto"): run the engine the rule chose, say which and why."""
        if self._closed or self.view is None:
            return
        try:
            if choice.engine == "browser" and self.view.backend != "browser":
                self._replace_view(self._browser_view())
                self._sun_default.apply(cpu_adapter=False)  # the page's GPU draws now: the sunlight's GPU default
        except Exception as err:  # noqa: BLE001 - never raise into the comm handler; the kernel view stays
            self._show_error(f"{choice.reason}; starting the browser engine failed ({err}): the kernel engine stays")
            return
        self._show_note(choice.reason)

    def _show_note(self, text):
        if self.panel is not None:
            self.panel.show_note(text)

    def _on_browser_unavailable(self, reason):
        """The browser has no WebGPU adapter: switch to kernel streaming, keep every control."""
        if self._closed or self.view is None or self.view.backend != "browser":
            return
        try:
            new = self._kernel_view()
        except Exception as err:  # no adapter in the kernel either
            self._show_error(f"WebGPU is not available in this browser ({reason}), and the kernel cannot "
                             f"render either: {err}")
            return
        self._replace_view(new)
        self._sun_default.apply(cpu_adapter=self._cpu is not False)  # the kernel's adapter draws now
        self._show_error(f"WebGPU is not available in this browser ({reason}): the kernel renders the view "
                         "and streams it instead (use Chrome or Edge, or enable WebGPU, for backend='browser')")

    def _on_time_scale(self, change):
        if not self._closed:
            self.view.set_time_scale(change["new"])
            self._show_stats(self.view.current_stats())

    def _on_ball_rolling(self, change):
        if change["new"] and not self.playing:
            self.playing = True  # the ball rolls with simulated time

    def __repr__(self):
        state = "closed" if self._closed else ("playing" if self.playing else "paused")
        return f"<GrassWidget {self.blade_count} blades, {self.size[0]}x{self.size[1]}, {state}>"


#: Where Save PNG and ``save_png()`` without a path write: this folder under the working
#: directory (the notebook's folder in Jupyter), as the notebooks save their pictures.
PICTURE_FOLDER = "output"


def default_picture_folder() -> str:
    """``output/`` under the current working directory (created if missing): where Save PNG
    and ``GrassWidget.save_png()`` without a path write."""
    folder = os.path.join(os.getcwd(), PICTURE_FOLDER)
    os.makedirs(folder, exist_ok=True)
    return folder


def _unique_name(folder, stem, ext):
    stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
    path = os.path.join(folder, f"{stem}-{stamp}{ext}")
    k = 2
    while os.path.exists(path):
        path = os.path.join(folder, f"{stem}-{stamp}-{k}{ext}")
        k += 1
    return path
