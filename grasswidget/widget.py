"""GrassWidget: a live, controllable meadow in a Jupyter notebook.

``GrassWidget`` is an ipywidgets ``VBox`` that holds a jupyter-rfb canvas
(``rendercanvas.jupyter.RenderCanvas``) streaming the animated field, and a
control panel (sliders, culling checkboxes, play/pause/step/reset buttons, a
live stats line and a "Save PNG" button)::

    import grasswidget as gw
    w = gw.GrassWidget()          # a meadow of 4096 blades, 640 x 480
    w                             # (last expression of the cell: shows it)
    w.params.wind_strength = 20   # moves the slider too
    w.save_png("meadow.png")      # 2x the view size by default
    w.save_animation("wind.gif", seconds=3, fps=15)
    w.close()                     # frees the GPU buffers

How it streams (chosen for the adapter, see :func:`streaming_defaults`):

* ``update_mode="continuous"`` while playing, ``"ondemand"`` while paused;
  jupyter-rfb only draws while a browser view is visible, so an invisible or
  headless widget costs nothing (no view: no size, no draw request; harmless).
* ``max_fps`` 20 on a CPU adapter (lavapipe), 30 on a GPU; JPEG quality 70 /
  85; the frame is rendered at the browser's pixel ratio capped to 1 on a CPU
  adapter and to 2 on a GPU.
* Time: each drawn frame advances ``round(time_scale / max_fps / dt)`` fixed
  steps of ``params.dt`` (capped at :data:`MAX_STEPS_PER_FRAME`). The nominal
  frame interval ``1 / max_fps`` is used, never the wall clock, so the
  simulation is the same whatever the machine; when frames arrive slower than
  ``max_fps`` the meadow moves in slow motion rather than in bigger steps.

Mouse: drag to orbit, right-drag to pan, wheel to zoom (pygfx's
``OrbitController``). The canvas events reach the controller without the
renderer's per-event GPU pick readback (see :class:`_EventsWithoutPicking`).
Shift + drag puts the ball (a sphere collider, see :mod:`grasswidget.widget_ball`)
on the ground under the pointer; the "sphere" row switches it on and off, moves
and resizes it and rolls it along a circle ("Roll"). Keys, only while the canvas has focus (click it first; the keys go to a hidden
text input, not to the notebook): space = play/pause, ``s`` = step one frame,
``r`` = reset the camera.
"""

from __future__ import annotations

import datetime
import os
import time
import weakref

import ipywidgets as ipw
import numpy as np
from traitlets import Bool

from .blades import Blades
from .control_link import ControlLink
from .params import WIND_FIELDS, GrassParams, RangedFloat

__all__ = ["GrassWidget", "streaming_defaults", "MAX_STEPS_PER_FRAME"]

#: At most this many fixed steps are simulated per drawn frame.
MAX_STEPS_PER_FRAME = 64
#: Largest blade count the slider offers on a CPU adapter (about 0.6 s a frame on lavapipe).
CPU_MAX_BLADES = 1 << 18
#: Largest blade count the slider offers on a GPU.
GPU_MAX_BLADES = 1 << 22
#: How often (seconds) the stats line is refreshed (it does one small GPU readback).
STATS_INTERVAL = 0.5

#: Sliders of the panel: (GrassParams trait, slider step, readout format).
PARAM_SLIDERS = (
    ("wind_strength", 0.5, ".1f"),
    ("wind_direction", 1.0, ".0f"),
    ("wind_speed", 0.1, ".1f"),
    ("gravity", 0.1, ".1f"),
    ("stiffness_scale", 0.01, ".2f"),
)

#: Checkboxes of the panel: (label, GrassParams trait).
CULL_CHECKBOXES = (
    ("orientation culling", "cull_orientation"),
    ("frustum culling", "cull_frustum"),
    ("distance culling", "cull_distance"),
    ("LOD", "lod"),
)

_DESC = {"description_width": "110px"}


def streaming_defaults(cpu: bool) -> dict:
    """Streaming settings for a CPU adapter (``cpu=True``) or a GPU.

    Returns ``max_fps`` (frames per second asked of the scheduler), ``quality``
    (jupyter-rfb JPEG quality while animating), ``max_pixel_ratio`` (cap on the
    browser's device pixel ratio for the rendered frame) and ``max_blades``
    (top of the blade-count slider).
    """
    if cpu:
        return dict(max_fps=20, quality=70, max_pixel_ratio=1.0, max_blades=CPU_MAX_BLADES)
    return dict(max_fps=30, quality=85, max_pixel_ratio=2.0, max_blades=GPU_MAX_BLADES)


def _canvas_class():
    """A jupyter RenderCanvas whose frames are rendered at a capped pixel ratio."""
    from rendercanvas.jupyter import RenderCanvas

    class GrassCanvas(RenderCanvas):
        """rendercanvas.jupyter.RenderCanvas that renders at most ``max_pixel_ratio``
        physical pixels per CSS pixel (the browser's devicePixelRatio otherwise)."""

        max_pixel_ratio = 2.0

        def handle_event(self, event):
            if event.get("event_type") == "resize" and "pixel_ratio" in event:
                event = dict(event)
                event["pixel_ratio"] = min(float(event["pixel_ratio"]), float(self.max_pixel_ratio))
            super().handle_event(event)

    return GrassCanvas


class _EventsWithoutPicking:
    """Forward canvas pointer/wheel/key events to the current pygfx renderer.

    ``WgpuRenderer(enable_events=True)`` converts every canvas event through
    ``renderer.convert_event``, which does a GPU pick readback (``get_pick_info``)
    for every event with x/y: one synchronous readback per pointer move. This
    forwards the same events with ``target=None`` and no ``pick_info``, so
    handlers registered on the renderer (``OrbitController.register_events``)
    work, without picking. ``renderer()`` is called per event, so the renderer
    may be replaced (a new blade count) while this stays registered.
    """

    TYPES = ("pointer_down", "pointer_move", "pointer_up", "wheel", "key_down", "key_up")

    def __init__(self, renderer_getter, intercept=None):
        self._renderer = renderer_getter
        self._intercept = intercept

    def __call__(self, event):
        from pygfx.renderers.wgpu.engine.renderer import EVENT_TYPE_MAP

        renderer = self._renderer()
        event_type = event.get("event_type")
        if renderer is None or event_type not in EVENT_TYPE_MAP:
            return
        if self._intercept is not None and self._intercept(event):
            return  # used by the widget (e.g. shift + drag moves the ball)
        fields = {k: v for k, v in event.items() if k not in ("type", "target", "root")}
        ev = EVENT_TYPE_MAP[event_type](type=event_type, **fields, target=None, root=renderer)
        renderer.dispatch_event(ev)


def _current_cell_id():
    """The JupyterLab cell id of the running execute request, or None."""
    try:
        from IPython import get_ipython

        ip = get_ipython()
        kernel = getattr(ip, "kernel", None)
        parent = kernel.get_parent() if kernel is not None else None
        return (parent or {}).get("metadata", {}).get("cellId")
    except Exception:
        return None


#: cell id -> weakref of the GrassWidget last created by that cell.
_BY_CELL: dict = {}


class GrassWidget(ipw.VBox):
    """A live meadow: a jupyter-rfb canvas streaming a :class:`GrassScene`, and controls.

    Args:
        blades: a blade count (``Blades.on_plane(count)``, or the preset's field)
            or a :class:`grasswidget.Blades`.
        preset: None, or a preset name passed to ``GrassScene.preset`` (e.g.
            "cis565", "meadow") when the installed GrassScene has presets.
        size: (width, height) of the view in CSS pixels, or "WxH".
        params: a :class:`GrassParams` to use (and share); default a new one.
        max_fps, quality: override the adapter's streaming defaults
            (:func:`streaming_defaults`).
        pixel_ratio: the most rendered pixels per CSS pixel (default 1 on a CPU
            adapter, 2 on a GPU; the browser's devicePixelRatio below that).
            E.g. 0.5 on a CPU adapter renders a quarter of the pixels, about
            twice the frames/s, and the browser scales the picture up.

    Attributes:
        params: the :class:`GrassParams` (the same object the scene simulates
            with; link or observe its traits, set them from code).
        scene: the :class:`GrassScene` (None after :meth:`close`).
        canvas: the jupyter-rfb canvas widget.
        controller: the pygfx ``OrbitController`` of the camera.
        ball: the :class:`~grasswidget.widget_ball.BallControl`: ``ball.collider``
            is its :class:`SphereCollider`; ``ball.enabled``, ``ball.rolling``,
            ``ball.roll_speed``, ``ball.move_to(x, z)``, ``ball.set_radius(r)``.

    Traits: ``time_scale`` (simulated seconds per real second, 0..10; applied
    through the nominal frame interval, see the module doc) and ``playing``.
    """

    time_scale = RangedFloat(1.0, 0.0, 10.0, "simulated s per s",
                             help="Simulated seconds per real second (at the nominal frame rate).")
    playing = Bool(True, help="Animate (continuous drawing) or pause (draw on demand).")

    # Defaults, so close() (also called by ipywidgets' __del__) works on a
    # half-built widget whose __init__ raised.
    _closed = False
    canvas = None
    scene = None
    controller = None
    ball = None
    _links = ()
    _adapter_note = None

    def __init__(self, blades=4096, preset=None, size=(640, 480), params=None, *, max_fps=None, quality=None,
                 pixel_ratio=None):
        from .gpu.adapter import cpu_notice, is_cpu_adapter
        from .gpu.field import max_blade_count
        from .scene import parse_size

        if params is not None and not isinstance(params, GrassParams):
            raise TypeError(f"params must be a GrassParams or None, not {type(params).__name__}")
        self.size = parse_size(size)
        self._preset = preset
        self._cpu = is_cpu_adapter()
        defaults = streaming_defaults(self._cpu)
        if max_fps is not None:
            if isinstance(max_fps, bool) or not isinstance(max_fps, (int, float)) or not (1 <= max_fps <= 240):
                raise ValueError(f"max_fps must be a number in [1, 240]; got {max_fps!r}")
            defaults["max_fps"] = float(max_fps)
        if quality is not None:
            if isinstance(quality, bool) or not isinstance(quality, int) or not (1 <= quality <= 100):
                raise ValueError(f"quality must be an integer in [1, 100] (JPEG quality); got {quality!r}")
            defaults["quality"] = quality
        if pixel_ratio is not None:
            if isinstance(pixel_ratio, bool) or not isinstance(pixel_ratio, (int, float)) or not (0.25 <= pixel_ratio <= 4):
                raise ValueError(f"pixel_ratio must be a number in [0.25, 4]; got {pixel_ratio!r}")
            defaults["max_pixel_ratio"] = float(pixel_ratio)
        self._defaults = defaults
        # The slider's top: the adapter's comfortable maximum, within what memory allows.
        self.max_blades = min(defaults["max_blades"], max_blade_count())
        self._adapter_note = cpu_notice(short=True)  # shown in the stats line (None on a GPU)
        self._blades = self._check_blades(blades)
        self._closed = False
        self.scene = None
        self.controller = None
        self.params = params if params is not None else GrassParams()

        # ---- canvas
        canvas_cls = _canvas_class()
        self.canvas = canvas_cls(size=self.size, update_mode="continuous", max_fps=defaults["max_fps"])
        self.canvas.max_pixel_ratio = defaults["max_pixel_ratio"]
        self.canvas.quality = defaults["quality"]
        self.canvas.resizable = False
        self._events = _EventsWithoutPicking(lambda: self.scene.renderer if self.scene is not None else None,
                                             intercept=self._on_pointer)
        self.canvas.add_event_handler(self._events, *_EventsWithoutPicking.TYPES)
        self.canvas.add_event_handler(self._on_key, "key_down")

        # ---- frame bookkeeping
        self._frames = 0
        self._draw_ms = 0.0
        self._stats = {"fps": None, "visible": None, "blades": None, "draw_ms": None, "gpu_ms": None,
                       "steps_per_frame": None, "frame_size": None}
        self._stats_t = time.perf_counter()
        self._stats_frames = 0
        self._stats_confirmed = 0

        # ---- scene (needs the canvas) and controls
        self._links = []
        try:
            self._build_scene(self._blades)
            children = self._build_panel()
        except BaseException:
            self.close()
            raise
        super().__init__(children=children)
        self.add_class("grasswidget")
        self.params.observe(self._on_param_change)
        self.observe(self._on_playing, names="playing")
        self.observe(self._update_stats_line, names="time_scale")
        self._update_stats_line()

        # Re-running the cell that made a widget closes the previous one (JupyterLab
        # sends the cell id with each execution), so its GPU buffers are freed.
        cell = _current_cell_id()
        if cell:
            old = _BY_CELL.get(cell)
            old = old() if old is not None else None
            if old is not None and old is not self:
                old.close()
            _BY_CELL[cell] = weakref.ref(self)

    # ------------------------------------------------------------------ building

    def _check_blades(self, blades):
        if isinstance(blades, Blades):
            if len(blades) > self.max_blades:
                raise ValueError(f"blades: at most {self.max_blades} blades on this adapter; got {len(blades)}")
            return blades
        if isinstance(blades, bool) or not isinstance(blades, (int, np.integer)):
            raise TypeError(f"blades must be a blade count (int) or a grasswidget.Blades, not {type(blades).__name__}")
        if blades >= 1:
            from .gpu.field import check_blade_count_fits

            check_blade_count_fits(blades, "blades")  # memory and GPU buffers, as GrassScene and the CLI do
        if not (1 <= int(blades) <= self.max_blades):
            raise ValueError(f"blades must be an integer in [1, {self.max_blades}] on this adapter; got {blades!r}")
        return int(blades)

    def _make_scene(self, blades):
        from .scene import GrassScene

        if self._preset is not None:
            if not hasattr(GrassScene, "preset"):
                raise NotImplementedError(
                    f"preset={self._preset!r}: this grasswidget's GrassScene has no presets yet; use preset=None"
                )
            count = len(blades) if isinstance(blades, Blades) else blades
            return GrassScene.preset(self._preset, blades=count, size=self.size, params=self.params, canvas=self.canvas)
        return GrassScene(blades, size=self.size, params=self.params, canvas=self.canvas)

    def _build_scene(self, blades):
        """Create the scene on our canvas (replacing and releasing any previous one)."""
        import pygfx as gfx

        old = self.scene
        cam_state = old.camera.get_state() if old is not None else None
        old_target = self.controller.target if (old is not None and self.controller is not None) else None
        scene = self._make_scene(blades)
        if old is not None:
            self._release_scene(old)
        # Render at the canvas's physical size (no SSAA, no upscaling): that size is
        # the browser's pixel ratio capped for the adapter (GrassCanvas), so the
        # render cost follows the frame size chosen for streaming.
        scene.renderer.pixel_scale = 1
        self.scene = scene
        self.params = scene.params
        if self.ball is None:
            from .widget_ball import BallControl

            self.ball = BallControl(scene, on_error=self._show_error)
            self.ball.observe(self._on_ball_rolling, names="rolling")
            self.ball.collider.observe(lambda _c: self._request_draw(), names=["center", "radius"])
            self.ball.observe(lambda _c: self._request_draw(), names="enabled")
        else:
            self.ball.attach(scene)
        self._home_state = scene.camera.get_state()
        self._home_target = _orbit_target(scene)
        self.controller = gfx.OrbitController(scene.camera, register_events=scene.renderer)
        # A custom target: orbit and zoom around the point the view looks at
        # (GrassScene aims with look_at, which leaves the camera extent unrelated
        # to that distance, so pygfx's implicit target would be far off).
        self.controller.target = self._home_target if old_target is None else old_target
        if cam_state is not None:  # a new blade count keeps the view
            scene.camera.set_state(cam_state)
        self.canvas.request_draw(self._draw)

    def _slider(self, name, owner, step, fmt, lo=None, hi=None, int_=False):
        trait = owner.traits()[name]
        lo = trait.lo if lo is None else lo
        hi = trait.hi if hi is None else hi
        cls = ipw.IntSlider if int_ else ipw.FloatSlider
        kw = {} if int_ else {"readout_format": fmt}
        s = cls(value=getattr(owner, name), min=lo, max=hi, step=step, description=name,
                continuous_update=not int_, style=_DESC, layout=ipw.Layout(width="360px"),
                tooltip=(trait.help or name), **kw)
        return s

    def _build_panel(self):
        p = self.params
        err = self._show_error
        sliders = []
        # blade count: rebuilds the field, so only on release
        self.blade_slider = ipw.IntSlider(
            value=self.blade_count, min=1, max=self.max_blades, step=1, description="blades",
            continuous_update=False, style=_DESC, layout=ipw.Layout(width="360px"),
            tooltip="Number of blades (rebuilds the field; applied on release)",
        )
        self.blade_slider.observe(self._on_blade_slider, names="value")
        sliders.append(self.blade_slider)
        self.sliders = {"blades": self.blade_slider}
        for name, step, fmt in PARAM_SLIDERS:
            s = self._slider(name, p, step, fmt)
            self._links.append(ControlLink(s, p, name, err))
            self.sliders[name] = s
            sliders.append(s)
        ts = self._slider("time_scale", self, 0.05, ".2f")
        self._links.append(ControlLink(ts, self, "time_scale", err))
        self.sliders["time_scale"] = ts
        sliders.append(ts)

        choices = tuple(getattr(p.traits()["wind_field"], "choices", None) or WIND_FIELDS)
        self.wind_field_dropdown = ipw.Dropdown(options=choices, value=p.wind_field, description="wind_field",
                                                style=_DESC, layout=ipw.Layout(width="360px"))
        self._links.append(ControlLink(self.wind_field_dropdown, p, "wind_field", err))

        self.checkboxes = {}
        for label, name in CULL_CHECKBOXES:
            cb = ipw.Checkbox(value=getattr(p, name), description=label, indent=False,
                              layout=ipw.Layout(width="180px"))
            self._links.append(ControlLink(cb, p, name, err))
            self.checkboxes[name] = cb

        bl = ipw.Layout(width="130px")
        self.play_button = ipw.Button(description="Pause", icon="pause", layout=bl,
                                      tooltip="Play / pause the animation (space)")
        self.step_button = ipw.Button(description="Step", icon="step-forward", layout=bl,
                                      tooltip="Pause and advance one frame (s)")
        self.reset_blades_button = ipw.Button(description="Reset blades", icon="undo", layout=bl,
                                              tooltip="Put every blade back in its rest pose")
        self.reset_camera_button = ipw.Button(description="Reset camera", icon="video-camera", layout=bl,
                                              tooltip="Back to the starting view (r)")
        self.play_button.on_click(lambda _b: self.toggle_play())
        self.step_button.on_click(lambda _b: self.step())
        self.reset_blades_button.on_click(lambda _b: self.reset_blades())
        self.reset_camera_button.on_click(lambda _b: self.reset_camera())

        self.png_scale = ipw.Dropdown(options=[("1x", 1), ("2x", 2), ("4x", 4)], value=2, description="PNG size",
                                      style={"description_width": "70px"}, layout=ipw.Layout(width="150px"),
                                      tooltip="Resolution of Save PNG, relative to the view")
        self.save_button = ipw.Button(description="Save PNG", icon="camera", layout=bl,
                                      tooltip="Write a PNG next to the notebook")
        self.save_button.on_click(lambda _b: self._on_save_click())
        self.file_line = ipw.HTML(value="", layout=ipw.Layout(min_height="20px"))
        self.stats_line = ipw.HTML(value="", layout=ipw.Layout(min_height="20px"))
        self.message_line = ipw.HTML(value="", layout=ipw.Layout(min_height="0px"))

        left = ipw.VBox(sliders[:4])
        middle = ipw.VBox(sliders[4:] + [self.wind_field_dropdown])
        right = ipw.VBox(list(self.checkboxes.values()))
        buttons = ipw.HBox([self.play_button, self.step_button, self.reset_blades_button,
                            self.reset_camera_button])
        save = ipw.HBox([self.save_button, self.png_scale, self.file_line])
        return [self.canvas, self.stats_line, ipw.HBox([left, middle, right]), self.ball.controls, buttons, save,
                self.message_line]

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
            raise TypeError("blade_count must be an int; pass a Blades to set_blades()")
        self.set_blades(count)

    def set_blades(self, blades):
        """Replace the field: a blade count or a :class:`Blades` (camera and params are kept)."""
        self._check_open()
        blades = self._check_blades(blades)
        if blades == self._blades and not isinstance(blades, Blades):
            return
        self._build_scene(blades)
        self._blades = blades
        if self.blade_slider.value != self.blade_count:
            self.blade_slider.unobserve(self._on_blade_slider, names="value")
            try:
                self.blade_slider.value = self.blade_count
            finally:
                self.blade_slider.observe(self._on_blade_slider, names="value")
        self._request_draw()

    @property
    def max_fps(self) -> float:
        """Frames per second asked of the canvas scheduler (the nominal frame rate)."""
        return float(self._defaults["max_fps"])

    @property
    def frame_interval(self) -> float:
        """Nominal seconds between frames, 1 / max_fps (used for time_scale)."""
        return 1.0 / self.max_fps

    @property
    def steps_per_frame(self) -> int:
        """Fixed steps per drawn frame: round(time_scale * frame_interval / dt), capped."""
        n = int(round(self.time_scale * self.frame_interval / self.params.dt))
        return max(0, min(n, MAX_STEPS_PER_FRAME))

    @property
    def stats(self) -> dict:
        """The last stats shown: fps (delivered to the browser), visible, blades,
        draw_ms (CPU time of the last frame's step + render calls), gpu_ms
        (per pass, when the scene reports it), steps_per_frame, frame_size."""
        return dict(self._stats)

    # ------------------------------------------------------------------ actions

    def play(self):
        """Animate continuously (while a view is visible)."""
        self.playing = True

    def pause(self):
        """Stop the animation; the view still redraws on camera or parameter changes."""
        self.playing = False

    def toggle_play(self):
        self.playing = not self.playing

    def step(self, n: int | None = None):
        """Pause and advance ``n`` fixed steps (default: one frame's worth, at least 1)."""
        self._check_open()
        if n is None:
            n = max(1, self.steps_per_frame)
        self.playing = False
        self.scene.step(n)
        self._request_draw()

    def reset_blades(self):
        """Every blade back to its rest pose; the simulation clock back to 0."""
        self._check_open()
        self.scene.field.reset()
        self._request_draw()

    def reset_camera(self):
        """Back to the scene's starting view."""
        self._check_open()
        self.scene.reset_camera()
        # Also put back the whole camera state as it was when the scene was made
        # (fov, extent, zoom; and position/rotation from a copy of our own).
        self.scene.camera.set_state(self._home_state)
        if self.controller is not None:
            self.controller.target = self._home_target  # panning moves the target
            self.scene.camera.set_state(self._home_state)
        self._request_draw()

    def save_png(self, path=None, size=None) -> str:
        """Write a PNG of the current view and return its path.

        Args:
            path: file path (default: ``grass-YYYYmmdd-HHMMSS.png`` in the current
                working directory, i.e. next to the notebook).
            size: (width, height) or "WxH"; default twice the view size.
        """
        from .scene import parse_size

        self._check_open()
        size = parse_size(size) if size is not None else (2 * self.size[0], 2 * self.size[1])
        if path is None:
            path = _unique_name(os.getcwd(), "grass", ".png")
        path = os.fspath(path)
        if not path.lower().endswith(".png"):
            raise ValueError(f"path must end in .png; got {path!r}")
        if tuple(size) != tuple(self.scene.size) or hasattr(self.scene.canvas, "draw"):
            self.scene.save_png(path, size=size)
        else:  # scene.render() needs a canvas that draws synchronously; ours streams
            import imageio.v3 as iio

            iio.imwrite(path, self.scene.render_at(size), extension=".png")
        return path

    def save_animation(self, path, seconds=4.0, fps=20, size=None, progress=True) -> str:
        """Export an animation (GIF, or MP4 with imageio-ffmpeg); see
        :func:`grasswidget.export.save_animation`. It starts from the current
        state and puts the live state back afterwards. Returns the path."""
        from .export import save_animation

        self._check_open()
        out = save_animation(self.scene, path, seconds=seconds, fps=fps, size=size, progress=progress)
        self._request_draw()
        return out

    def close(self):
        """Close the view and the controls and release the GPU resources."""
        if self._closed:
            return
        self._closed = True
        params = getattr(self, "params", None)
        if params is not None:
            try:
                params.unobserve(self._on_param_change)
            except ValueError:
                pass
        for link in self._links:
            link.unlink()
        self._links = []
        canvas = self.canvas
        if canvas is not None:
            try:
                canvas.remove_event_handler(self._events, *_EventsWithoutPicking.TYPES)
                canvas.remove_event_handler(self._on_key, "key_down")
            except Exception:
                pass
            canvas.close()
        if self.ball is not None:
            self.ball.detach()
        if self.scene is not None:
            self._release_scene(self.scene)
        self.scene = None
        self.controller = None
        for child in self._all_children():
            if child is not canvas:
                child.close()
        super().close()

    # ------------------------------------------------------------------ internals

    def _all_children(self):
        out, todo = [], list(self.children)
        while todo:
            w = todo.pop()
            out.append(w)
            todo.extend(getattr(w, "children", ()))
        return out

    def _check_open(self):
        if self._closed:
            raise RuntimeError("this GrassWidget is closed; create a new one")

    @staticmethod
    def _release_scene(scene):
        """Drop a scene's GPU resources now instead of whenever the GC gets to them."""
        field = scene.field
        field.release()
        try:
            scene.scene.remove(field)
        except Exception:
            pass
        scene.renderer = None
        scene.canvas = None

    def _request_draw(self):
        if not self._closed:
            self.canvas.request_draw()

    def _on_param_change(self, change):
        self._request_draw()

    def _on_playing(self, change):
        playing = bool(change["new"])
        self.play_button.description = "Pause" if playing else "Play"
        self.play_button.icon = "pause" if playing else "play"
        if not self._closed:
            self.canvas.set_update_mode("continuous" if playing else "ondemand")
            self.canvas.request_draw()

    def _on_blade_slider(self, change):
        try:
            self.set_blades(int(change["new"]))
        except Exception as err:  # e.g. out of GPU memory: keep the old field
            self._show_error(err)
            self.blade_slider.unobserve(self._on_blade_slider, names="value")
            try:
                self.blade_slider.value = self.blade_count
            finally:
                self.blade_slider.observe(self._on_blade_slider, names="value")

    def _on_pointer(self, event):
        """Shift + drag moves the ball; other events go on to the camera controller."""
        if self.ball is None or self._closed:
            return False
        try:
            w, h = self.canvas.get_logical_size()
            view = (w, h) if w > 1 and h > 1 else self.size  # no browser view yet: the asked size
            used = self.ball.handle_event(event, view)
        except Exception as err:  # never let a pointer event break the canvas
            self._show_error(err)
            return False
        return used

    def _on_ball_rolling(self, change):
        if change["new"] and not self.playing:
            self.playing = True  # the ball rolls with simulated time

    def _on_key(self, event):
        key = str(event.get("key", "")).lower()
        if event.get("modifiers"):
            return
        if key in (" ", "space", "spacebar"):
            self.toggle_play()
        elif key == "s":
            self.step()
        elif key == "r":
            self.reset_camera()

    def _on_save_click(self):
        try:
            w, h = self._view_size()
            k = int(self.png_scale.value)
            path = self.save_png(size=(k * w, k * h))
        except Exception as err:
            self._show_error(err)
            return
        self.file_line.value = _file_link(path, (k * w, k * h))

    def _view_size(self):
        # The widget's size, not the measured view (a border makes that 638 x 478).
        return self.size

    def _show_error(self, err):
        import html

        self.message_line.value = f"<span style='color:#b00'>{html.escape(str(err))}</span>"

    def _draw(self):
        """The canvas draw function: advance time (when playing), render, maybe refresh stats."""
        scene = self.scene
        if scene is None or scene.renderer is None:
            return
        t0 = time.perf_counter()
        if self.playing:
            # A rolling ball moves between chunks of steps (simulated time, not wall clock).
            for chunk in self.ball.step_chunks(self.steps_per_frame, self.params.dt):
                try:
                    self.ball.advance(chunk * self.params.dt)
                except Exception as err:  # e.g. a user path that raises: stop rolling, keep drawing
                    self.ball.rolling = False
                    self._show_error(f"ball path: {type(err).__name__}: {err}; rolling stopped")
                scene.step(chunk)
        draw = getattr(scene, "_draw", None)  # the scene's own draw: renders and feeds scene.stats
        if callable(draw):
            draw()
        else:
            scene.renderer.render(scene.scene, scene.camera)
        self._draw_ms = 1000.0 * (time.perf_counter() - t0)
        self._frames += 1
        if time.perf_counter() - self._stats_t >= STATS_INTERVAL:
            self._refresh_stats()

    def _refresh_stats(self):
        now = time.perf_counter()
        dt = max(now - self._stats_t, 1e-6)
        try:
            confirmed = int(self.canvas.get_stats()["confirmed_frames"])
        except Exception:
            confirmed = None
        if confirmed is not None and confirmed >= self._stats_confirmed:
            fps = (confirmed - self._stats_confirmed) / dt
            self._stats_confirmed = confirmed
        else:
            fps = (self._frames - self._stats_frames) / dt
        self._stats_frames = self._frames
        self._stats_t = now
        scene = self.scene
        visible, gpu_ms = None, None
        stats = getattr(scene, "stats", None)
        if stats is not None:
            try:
                if callable(getattr(stats, "as_dict", None)):
                    d = stats.as_dict()
                else:
                    d = stats if isinstance(stats, dict) else vars(stats)
                visible = d.get("visible", d.get("visible_blades"))
                gpu_ms = d.get("gpu_ms")
            except Exception:
                visible = gpu_ms = None
        if visible is None:
            try:
                visible = scene.visible_count()
            except Exception:
                visible = None
        self._stats.update(
            fps=fps, visible=visible, blades=scene.field.count, draw_ms=self._draw_ms, gpu_ms=gpu_ms,
            steps_per_frame=self.steps_per_frame if self.playing else 0,
            frame_size=tuple(int(x) for x in self.canvas.get_physical_size()),
        )
        self._update_stats_line()

    def _update_stats_line(self, *_):
        s = self._stats
        parts = []
        parts.append(f"{s['fps']:.1f} frames/s delivered" if s["fps"] is not None else "– frames/s delivered")
        blades = self.blade_count
        if s["visible"] is not None:
            parts.append(f"{s['visible']:,} / {blades:,} blades visible")
        else:
            parts.append(f"{blades:,} blades")
        if s["draw_ms"] is not None:
            parts.append(f"draw {s['draw_ms']:.0f} ms")
        if s["gpu_ms"]:
            parts.append("GPU " + ", ".join(f"{k} {v:.2f} ms" for k, v in dict(s["gpu_ms"]).items()))
        n = int(round(self.time_scale * self.frame_interval / self.params.dt))
        capped = " (capped)" if n > MAX_STEPS_PER_FRAME else ""
        parts.append(f"{self.steps_per_frame} steps/frame{capped}")
        if s["frame_size"]:
            parts.append("{}×{} px".format(*s["frame_size"]))
        if self._adapter_note:
            parts.append(self._adapter_note)
        self.stats_line.value = "<code>" + " · ".join(parts) + "</code>"

    def __repr__(self):
        state = "closed" if self._closed else ("playing" if self.playing else "paused")
        return f"<GrassWidget {self.blade_count} blades, {self.size[0]}x{self.size[1]}, {state}>"


def _orbit_target(scene):
    """The point the scene's camera orbits around: ``scene.home_target`` when the
    scene says, else the point on the view axis nearest the field's centre."""
    target = getattr(scene, "home_target", None)
    if target is not None:
        return np.asarray(target, np.float64)
    cam = scene.camera
    pos = np.asarray(cam.world.position, np.float64)
    forward = -np.asarray(cam.world.matrix, np.float64)[:3, 2]
    forward /= max(np.linalg.norm(forward), 1e-12)
    v0 = scene.field.blades.v0
    center = 0.5 * (v0.min(axis=0) + v0.max(axis=0)).astype(np.float64)
    d = float(np.dot(center - pos, forward))
    d = min(max(d, 1.0), 0.5 * float(cam.depth_range[1]) if cam.depth_range else 50.0)
    return pos + forward * d


def _unique_name(folder, stem, ext):
    stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
    path = os.path.join(folder, f"{stem}-{stamp}{ext}")
    k = 2
    while os.path.exists(path):
        path = os.path.join(folder, f"{stem}-{stamp}-{k}{ext}")
        k += 1
    return path


def _file_link(path, size):
    import html

    rel = os.path.relpath(os.path.abspath(path), os.getcwd())
    name = html.escape(os.path.basename(path))
    if rel.startswith(".."):
        return f"saved <code>{html.escape(os.path.abspath(path))}</code> ({size[0]}×{size[1]})"
    return f"saved <a href='{html.escape(rel)}' target='_blank' download>{name}</a> ({size[0]}×{size[1]})"
