"""The kernel engine's view: a GrassScene rendered in the kernel and streamed to the browser.

:class:`KernelView` owns a jupyter-rfb canvas (``rendercanvas.jupyter.RenderCanvas``),
the :class:`~grasswidget.scene.GrassScene` drawn into it, the camera's
``OrbitController``, the canvas events (orbit, ball drag, keys) and the clock
that advances the simulation while playing. It knows nothing of the control
panel: the widget that composes them tells it what to do (``set_playing``,
``step``, ``set_blades`` ...) and receives its stats through ``on_stats``.

How it streams (chosen for the adapter, see :func:`streaming_defaults`):

* ``update_mode="continuous"`` while playing, ``"ondemand"`` while paused;
  jupyter-rfb only draws while a browser view is visible, so an invisible or
  headless widget costs nothing (no view: no size, no draw request; harmless).
* ``max_fps`` 20 on a CPU adapter (lavapipe), 30 on a GPU; JPEG quality 70 /
  85; the frame is rendered at the browser's pixel ratio capped to 1 on a CPU
  adapter and to 2 on a GPU.
* Time: each drawn frame advances ``round(time_scale / max_fps / dt)`` fixed
  steps of ``params.dt`` (capped at :data:`MAX_STEPS_PER_FRAME`).

Mouse: drag to orbit, right-drag to pan, wheel to zoom (pygfx's
``OrbitController``, held to :class:`~grasswidget.orbit.OrbitLimits`: the camera
stays above the ground, the target over the field, the zoom in range), without
the renderer's per-event GPU pick readback (see :class:`EventsWithoutPicking`).
Shift + drag goes to the ball first. Ctrl (or
Cmd) + click inspects the blade under the pointer: one pick readback per click
(the grass material writes pick ids in this view).

Teaching views: :meth:`KernelView.set_culling_frozen` freezes culling at the
current camera (kept across a new blade count), :meth:`KernelView.inspect`
shows blades in the inspector; their numbers reach ``on_inspect`` at each stats
refresh (one small readback, only while blades are inspected).
"""

from __future__ import annotations

import time

import numpy as np

from . import compat
from .blades import Blades
from .errors import GrassValueError

__all__ = ["KernelView", "streaming_defaults", "EventsWithoutPicking", "MAX_STEPS_PER_FRAME",
           "CPU_MAX_BLADES", "GPU_MAX_BLADES", "STATS_INTERVAL"]

#: At most this many fixed steps are simulated per drawn frame.
MAX_STEPS_PER_FRAME = 64
#: Largest blade count the slider offers on a CPU adapter (about 0.6 s a frame on lavapipe).
CPU_MAX_BLADES = 1 << 18
#: Largest blade count the slider offers on a GPU.
GPU_MAX_BLADES = 1 << 22
#: How often (seconds) the stats line is refreshed (it does one small GPU readback).
STATS_INTERVAL = 0.5


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
            ratio = compat.event_ratio(event)
            if compat.event_type(event) == "resize" and ratio is not None:
                event = compat.with_ratio(event, min(float(ratio), float(self.max_pixel_ratio)))
            super().handle_event(event)

    return GrassCanvas


class EventsWithoutPicking:
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
        renderer = self._renderer()
        event_type = compat.event_type(event)
        event_class = compat.pygfx_event_class(event_type)
        if renderer is None or event_class is None:
            return
        if self._intercept is not None and self._intercept(event):
            return  # e.g. shift + drag moves the ball
        ev = event_class(type=event_type, **compat.pygfx_event_fields(event), target=None, root=renderer)
        renderer.dispatch_event(ev)


def orbit_target(scene):
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


class KernelView:
    """A GrassScene rendered in the kernel, streamed by jupyter-rfb, animated by a clock.

    Args:
        blades: a blade count or a :class:`Blades` for the first scene.
        size: (w, h) of the view in CSS pixels.
        params: the :class:`GrassParams` the scene simulates with.
        preset: None or a ``GrassScene.preset`` name.
        streaming: a :func:`streaming_defaults` dict (possibly overridden).
        clock: a HasTraits with ``playing`` and ``time_scale`` (read, observed by the widget).
        actions: called by keys: ``toggle_play()``, ``step()``, ``reset_camera()``.
        on_error: called with an exception or a text to show.
        on_stats: called with the stats dict whenever it is refreshed.

    Attributes: ``widget`` (the ipywidget to show: the canvas), ``canvas``,
    ``scene``, ``controller``, ``ball`` (set with :meth:`attach_ball`), ``stats``.
    """

    backend = "kernel"
    #: This view draws the teaching views (colour by, frozen culling, inspector).
    teaching_views = True

    def __init__(self, blades, size, params, *, preset=None, streaming, clock, actions, on_error, on_stats,
                 on_inspect=None):
        self.size = tuple(size)
        self.params = params
        self._preset = preset
        self._streaming = dict(streaming)
        self._clock = clock
        self._actions = actions
        self._on_error = on_error
        self._on_stats = on_stats
        self._on_inspect = on_inspect
        self._frozen_camera = None  # the frozen culling camera, kept across set_blades
        self._inspected = ()
        self._report_pending = False  # report the inspected numbers after the next frame
        self.scene = None
        self.controller = None
        self.ball = None
        self._closed = False

        self.canvas = _canvas_class()(size=self.size, update_mode="continuous", max_fps=self.max_fps)
        self.canvas.max_pixel_ratio = self._streaming["max_pixel_ratio"]
        self.canvas.quality = self._streaming["quality"]
        self.canvas.resizable = False
        self.widget = self.canvas
        self.events = EventsWithoutPicking(lambda: self.scene.renderer if self.scene is not None else None,
                                           intercept=self._on_pointer)
        self.canvas.add_event_handler(self.events, *EventsWithoutPicking.TYPES)
        self.canvas.add_event_handler(self.on_key, "key_down")

        self._frames = 0
        self._draw_ms = 0.0
        from .gpu.adapter import cpu_notice

        self._stats = {"fps": None, "visible": None, "blades": None, "draw_ms": None, "gpu_ms": None,
                       "steps_per_frame": None, "frame_size": None,
                       "adapter": cpu_notice(short=True)}  # the CPU-adapter notice (None on a GPU)
        self._stats_t = time.perf_counter()
        self._stats_frames = 0
        self._stats_confirmed = 0
        self.set_blades(blades)

    # ------------------------------------------------------------------ scene

    def _make_scene(self, blades):
        from .scene import GrassScene

        if self._preset is not None:
            count = len(blades) if isinstance(blades, Blades) else blades
            return GrassScene.preset(self._preset, blades=count, size=self.size, params=self.params,
                                     canvas=self.canvas)
        return GrassScene(blades, size=self.size, params=self.params, canvas=self.canvas)

    def set_blades(self, blades):
        """Build the scene for ``blades`` on this canvas, replacing and releasing
        the previous one (the camera view, the orbit target and the ball are kept)."""
        from .orbit import GroundOrbitController, OrbitLimits

        old = self.scene
        cam_state = old.camera.get_state() if old is not None else None
        old_target = self.controller.target if (old is not None and self.controller is not None) else None
        scene = self._make_scene(blades)
        if old is not None:
            old.release()
        # Render at the canvas's physical size (no SSAA, no upscaling): that size is
        # the browser's pixel ratio capped for the adapter (GrassCanvas), so the
        # render cost follows the frame size chosen for streaming.
        scene.renderer.pixel_scale = 1
        scene.field.material.pick_write = True  # ctrl + click picks a blade
        if self._frozen_camera is not None:
            scene.field.freeze_culling(self._frozen_camera)
        self._inspected = tuple(i for i in self._inspected if i < scene.field.count)
        if self._inspected:
            scene.inspect(self._inspected)
        self.scene = scene
        if self.ball is not None:
            self.ball.attach(scene)
        self._home_state = scene.camera.get_state()
        self._home_target = orbit_target(scene)
        # Orbit, zoom and pan within limits: the camera stays above the ground, the field in sight.
        self.controller = GroundOrbitController(scene.camera, limits=OrbitLimits.for_scene(scene),
                                                register_events=scene.renderer)
        # A custom target: orbit and zoom around the point the view looks at
        # (GrassScene aims with look_at, which leaves the camera extent unrelated
        # to that distance, so pygfx's implicit target would be far off).
        self.controller.target = self._home_target if old_target is None else old_target
        if cam_state is not None:  # a new blade count keeps the view
            scene.camera.set_state(cam_state)
        self.canvas.request_draw(self.draw)

    def attach_ball(self, ball):
        """The :class:`~grasswidget.widget_ball.BallControl` to move with shift + drag and roll."""
        self.ball = ball

    @property
    def blade_count(self) -> int:
        return self.scene.field.count

    # ------------------------------------------------------------------ time

    @property
    def max_fps(self) -> float:
        """Frames per second asked of the canvas scheduler (the nominal frame rate)."""
        return float(self._streaming["max_fps"])

    @property
    def frame_interval(self) -> float:
        """Nominal seconds between frames, 1 / max_fps (used for time_scale)."""
        return 1.0 / self.max_fps

    @property
    def steps_per_frame(self) -> int:
        """Fixed steps per drawn frame: round(time_scale * frame_interval / dt), capped."""
        return max(0, min(self._wanted_steps(), MAX_STEPS_PER_FRAME))

    def _wanted_steps(self):
        return int(round(self._clock.time_scale * self.frame_interval / self.params.dt))

    def set_playing(self, playing: bool):
        """Draw continuously (playing) or on demand (paused)."""
        if not self._closed:
            self.canvas.set_update_mode("continuous" if playing else "ondemand")
            self.canvas.request_draw()

    def step(self, n: int):
        """Advance exactly ``n`` fixed steps and redraw."""
        self.scene.step(n)
        self.request_draw()

    def reset_blades(self):
        """Every blade back to its rest pose; the step counter back to 0."""
        self.scene.field.reset()
        self.request_draw()

    def reset_camera(self):
        """Back to the scene's starting view (position, rotation, fov, orbit target)."""
        self.scene.reset_camera()
        self.scene.camera.set_state(self._home_state)
        if self.controller is not None:
            self.controller.target = self._home_target  # panning moves the target
            self.scene.camera.set_state(self._home_state)
        self.request_draw()

    @property
    def camera_state(self) -> dict:
        """position, target (the orbit centre) and fov_deg (vertical) of the camera."""
        cam = self.scene.camera
        target = self.controller.target if self.controller is not None else orbit_target(self.scene)
        return {"position": tuple(float(x) for x in cam.world.position),
                "target": tuple(float(x) for x in target),
                "fov_deg": self.scene.vertical_fov()}

    @camera_state.setter
    def camera_state(self, state):
        from .browser.engine_view import _check_camera_state

        state = _check_camera_state(state)
        current = self.camera_state
        position = state.get("position", current["position"])
        target = state.get("target", current["target"])
        if np.allclose(position, target):
            raise GrassValueError(f"camera_state position and target must differ; both are {tuple(position)}")
        self.scene.look(position, target, state.get("fov_deg"))
        if self.controller is not None:
            self.controller.target = np.asarray(target, np.float64)
        self.request_draw()

    def request_draw(self):
        if not self._closed:
            self.canvas.request_draw()

    # ------------------------------------------------------------------ teaching views

    def set_culling_frozen(self, frozen: bool):
        """Freeze culling at the current camera (True) or cull against it again (False)."""
        if frozen:
            self.scene.freeze_culling()
            self._frozen_camera = self.scene.field.frozen_camera
        else:
            self.scene.unfreeze_culling()
            self._frozen_camera = None
        self.request_draw()

    def inspect(self, ids):
        """Inspect these blade ids (at most 64; [] clears); ValueError names the limit."""
        self.scene.inspect(ids)
        self._inspected = tuple(self.scene.inspected)
        if self._on_inspect is not None and not self._inspected:
            self._on_inspect([])
        self._report_pending = bool(self._inspected)  # the numbers exist after the next frame
        self.request_draw()

    @property
    def inspected(self) -> tuple:
        return self._inspected

    def pick_blade(self, x, y):
        """The id of the blade drawn at logical pixel (x, y) in the last frame, or None
        (one GPU pick readback)."""
        info = self.scene.renderer.get_pick_info((x, y))
        if info.get("world_object") is self.scene.field:
            return info.get("blade_index")
        return None

    def _report_inspected(self):
        if self._on_inspect is not None:
            self._on_inspect(self.scene.read_inspected() if self._inspected else [])

    # ------------------------------------------------------------------ pictures

    def save_png(self, path, size):
        """Write a PNG of the current view at ``size`` (w, h) pixels."""
        if tuple(size) != tuple(self.scene.size) or hasattr(self.scene.canvas, "draw"):
            self.scene.save_png(path, size=size)
        else:  # scene.render() needs a canvas that draws synchronously; ours streams
            import imageio.v3 as iio

            iio.imwrite(path, self.scene.render_at(size), extension=".png")
        return path

    def draw(self):
        """The canvas draw function: advance time (when playing), render, maybe refresh stats."""
        scene = self.scene
        if scene is None or scene.renderer is None:
            return
        t0 = time.perf_counter()
        if self._clock.playing:
            # A rolling ball moves between chunks of steps (simulated time, not wall clock).
            for chunk in self.ball.step_chunks(self.steps_per_frame, self.params.dt):
                try:
                    self.ball.advance(chunk * self.params.dt)
                except Exception as err:  # e.g. a user path that raises: stop rolling, keep drawing
                    self.ball.rolling = False
                    self._on_error(f"ball path: {type(err).__name__}: {err}; rolling stopped")
                scene.step(chunk)
        scene.draw_frame()
        self._draw_ms = 1000.0 * (time.perf_counter() - t0)
        if self._report_pending:
            self._report_pending = False
            self._report_inspected()
        self._frames += 1
        if time.perf_counter() - self._stats_t >= STATS_INTERVAL:
            self.refresh_stats()

    # ------------------------------------------------------------------ stats

    @property
    def stats(self) -> dict:
        """The last stats: fps (delivered to the browser), visible, blades, draw_ms,
        gpu_ms, steps_per_frame, frame_size (see GrassWidget.stats)."""
        return {k: v for k, v in self._stats.items() if k != "capped"}

    def current_stats(self) -> dict:
        """The stats dict for the stats line, with what is known now (no readback)."""
        s = dict(self._stats)
        s["blades"] = self.blade_count
        s["steps_per_frame"] = self.steps_per_frame
        s["capped"] = self._wanted_steps() > MAX_STEPS_PER_FRAME
        return s

    def refresh_stats(self):
        """Measure frames/s delivered (confirmed by the browser), read the visible count
        and GPU times, and pass the stats to ``on_stats``."""
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
                d = stats.as_dict()
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
            steps_per_frame=self.steps_per_frame if self._clock.playing else 0,
            frame_size=tuple(int(x) for x in self.canvas.get_physical_size()),
        )
        self._on_stats(self.current_stats())
        if self._inspected:
            self._report_inspected()

    # ------------------------------------------------------------------ events

    def _on_pointer(self, event):
        """Ctrl + click inspects a blade; shift + drag moves the ball; other events go
        on to the camera controller."""
        if self._closed:
            return False
        if self._is_inspect_click(event):
            try:
                blade = self.pick_blade(event["x"], event["y"])
                if blade is not None:
                    self._actions.inspect([int(blade)])
            except Exception as err:  # never let a pointer event break the canvas
                self._on_error(err)
            return True
        if self.ball is None:
            return False
        try:
            w, h = self.canvas.get_logical_size()
            view = (w, h) if w > 1 and h > 1 else self.size  # no browser view yet: the asked size
            return self.ball.handle_event(event, view)
        except Exception as err:  # never let a pointer event break the canvas
            self._on_error(err)
            return False

    @staticmethod
    def _is_inspect_click(event):
        mods = tuple(event.get("modifiers") or ())
        return (compat.event_type(event) == "pointer_down" and event.get("button", 1) == 1
                and ("Control" in mods or "Meta" in mods) and "x" in event and "y" in event)

    def on_key(self, event):
        """Keys (canvas focused): space = play/pause, s = step one frame, r = reset the camera."""
        key = str(event.get("key", "")).lower()
        if event.get("modifiers"):
            return
        if key in (" ", "space", "spacebar"):
            self._actions.toggle_play()
        elif key == "s":
            self._actions.step()
        elif key == "r":
            self._actions.reset_camera()

    # ------------------------------------------------------------------ closing

    def close(self):
        """Close the canvas and release the scene's GPU resources."""
        if self._closed:
            return
        self._closed = True
        canvas = self.canvas
        try:
            canvas.remove_event_handler(self.events, *EventsWithoutPicking.TYPES)
            canvas.remove_event_handler(self.on_key, "key_down")
        except Exception:
            pass
        canvas.close()
        if self.scene is not None:
            self.scene.release()
        self.scene = None
        self.controller = None
