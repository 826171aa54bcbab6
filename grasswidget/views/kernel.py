"""The kernel engine's view: a GrassScene rendered in the kernel and streamed to the browser.

:class:`KernelView` owns a jupyter-rfb canvas (``rendercanvas.jupyter.RenderCanvas``),
the :class:`~grasswidget.gpu.scene.GrassScene` drawn into it, the camera's
``OrbitController``, the canvas events (orbit, ball drag, keys), the real-time
clock that advances the simulation while playing and the adaptive render
scale. It knows nothing of the control panel: it follows its host's play state
(``host.play``), is told what to do (``step``, ``set_blades`` ...) and reports its
stats to the host (``host.show_stats``).

Time (see :class:`~grasswidget.views.clock.SimClock`): while playing, simulated time
follows the wall clock (times ``time_scale``) in whole fixed steps of
``params.dt``, at most :data:`MAX_STEPS_PER_FRAME` per frame; when that cap
binds the stats line says "slow motion 0.6x". Paused, no time passes;
``step(n)`` advances exactly n steps.

How a frame travels (each stage is timed, in ms per frame over the stats window:
``stats["render_ms"]``, ``readback_ms``, ``encode_ms``, ``send_ms``, ``ack_ms``; the
"details" line shows them): step + render (the draw function submits the GPU work),
readback (rendercanvas copies the frame into a mapped buffer without stalling the
queue and presents it when the copy is done), JPEG encode and send (on the canvas's
worker thread, so the kernel renders the next frame meanwhile: Pillow's encoder
releases the GIL; see :func:`grasswidget.compat.timed_jupyter_canvas_class`), and the
browser's acknowledgement (jupyter-rfb's frame feedback: every third frame at once, any other
within 50 ms, :func:`grasswidget.compat.throttled_ack_esm`). jupyter-rfb lets
:data:`MAX_BUFFERED_FRAMES` frames be in flight (those being encoded included), so
the kernel renders the next frame while the last one travels and is decoded; the
scheduler asks for at most ``max_fps`` frames per second (30 on a CPU adapter, 60 on
a GPU).

Frames that would not change the picture are not made again: while playing, a frame
for which no simulation step ran, the camera's view-projection and the frame size are
the same and no change was asked for (:meth:`KernelView.request_draw`: a parameter,
the ball, a reset ...) is not rendered (the canvas's draw is cancelled: no readback,
nothing sent); a rendered frame whose pixels equal the last one sent is not encoded
or sent again. Both count in ``stats["unchanged_fps"]`` and in ``fps`` (the page
shows them already); paused, nothing is drawn unless something changed.

Adaptive resolution (see :class:`~grasswidget.views.adaptive.ResolutionGovernor`):
while playing below ``target_fps`` (24 on a CPU adapter, 60 on a GPU) the
render pixel ratio goes down step by step to half, and back up when there is
headroom. Paused frames (and the lossless picture jupyter-rfb sends after the
last frame), Save PNG and exports always render at full resolution.

Mouse: drag to orbit, right-drag (or ctrl + drag) to pan, wheel to zoom (pygfx's
``OrbitController``, held to :class:`~grasswidget.views.orbit.OrbitLimits`: the camera
stays above the ground, the target over the field, the zoom in range), without
the renderer's per-event GPU pick readback (see :class:`EventsWithoutPicking`).
Shift + drag goes to the ball first. Ctrl (or
Cmd) + click inspects the blade under the pointer: one pick readback per click
(the grass material writes pick ids in this view); Ctrl (or Cmd) + drag pans, as in
the browser engine (:mod:`grasswidget.core.interaction`, applied by
:class:`~grasswidget.views.pointer_gesture.KernelPointer`).

Teaching views: :meth:`KernelView.set_options` (``culling_frozen=True``) freezes culling at the
current camera (kept across a new blade count), :meth:`KernelView.inspect`
shows blades in the inspector; their numbers reach ``host.show_inspected`` at each stats
refresh (one small readback, only while blades are inspected).

Threads: JupyterLab 4.4+ sends widget comm messages to a kernel subshell when
ipykernel 7 offers them (the ``commsOverSubshells`` setting, "perCommTarget" by
default), so the controls (the blades slider's :meth:`KernelView.set_blades`,
steps, resets, the inspector ...) run on the subshell's thread while the draw
loop runs on the kernel's main event loop, and jupyter-rfb asks for frames on
either thread. A blade-count change released the old field's GPU buffers in the
middle of a frame that was still recording and submitting work with them:
wgpu-native aborts the kernel ("Buffer with '' label has been destroyed", in
``wgpuQueueSubmit``, ``wgpuBufferGetMappedRange`` or ``wgpuCommandEncoderBeginComputePass``).
Every frame (jupyter-rfb's ``get_frame``: draw, then the start of the pixel
download) and every operation on the scene hold :attr:`KernelView.lock`, so the
old scene is released only between frames, and two frames never overlap.
"""

from __future__ import annotations

import functools
import threading
import time

import numpy as np

from .. import compat
from .adaptive import ResolutionGovernor, check_target_fps
from ..core.limits import StepsInterrupted, hold_interrupts
from ..core.engine_inputs import SLOW_MOTION_BELOW, STATS_INTERVAL_MS, WAITING_AFTER_S, stats_freshness
from ..core.blades import Blades
from .api import EngineView, done_future
from .clock import MAX_STEPS_PER_FRAME, SimClock
from .pointer_gesture import KernelPointer
from ..core.interaction import MAX_PIXEL_RATIO

__all__ = ["KernelView", "streaming_defaults", "EventsWithoutPicking", "MAX_STEPS_PER_FRAME",
           "CPU_MAX_BLADES", "GPU_MAX_BLADES", "STATS_INTERVAL"]

#: Largest blade count the slider offers on a CPU adapter (about 0.6 s a frame on lavapipe).
CPU_MAX_BLADES = 1 << 18
#: Largest blade count the slider offers on a GPU.
GPU_MAX_BLADES = 1 << 22
#: How often (seconds) the stats line is refreshed (it does one small GPU readback).
STATS_INTERVAL = STATS_INTERVAL_MS / 1000.0  # s; core.engine_inputs's, both engines
#: Frames jupyter-rfb may have in flight (sent, not yet acknowledged by the browser): room for the
#: compat.ACK_EVERY frames the page shows between two acknowledgements and two more on their way.
MAX_BUFFERED_FRAMES = 5


def _exclusive(method):
    """Run a :class:`KernelView` method holding the view's :attr:`~KernelView.lock`."""
    @functools.wraps(method)
    def holding_lock(self, *args, **kwargs):
        with self.lock:
            return method(self, *args, **kwargs)
    return holding_lock


def streaming_defaults(cpu: bool) -> dict:
    """Streaming settings for a CPU adapter (``cpu=True``) or a GPU.

    Returns ``max_fps`` (the stream cap: frames per second asked of the
    scheduler), ``target_fps`` (the rate adaptive resolution aims for),
    ``quality`` (jupyter-rfb JPEG quality while animating), ``max_pixel_ratio``
    (cap on the browser's device pixel ratio for the rendered frame) and
    ``max_blades`` (top of the blade-count slider).
    """
    if cpu:
        return dict(max_fps=30, target_fps=24.0, quality=70, max_pixel_ratio=1.0, max_blades=CPU_MAX_BLADES)
    return dict(max_fps=60, target_fps=60.0, quality=85, max_pixel_ratio=MAX_PIXEL_RATIO, max_blades=GPU_MAX_BLADES)


def _canvas_class():
    """A jupyter RenderCanvas with a capped, scalable pixel ratio and timed presents."""
    class GrassCanvas(compat.timed_jupyter_canvas_class()):
        """rendercanvas.jupyter.RenderCanvas that renders at ``render_scale`` times the
        browser's devicePixelRatio capped to ``max_pixel_ratio``, and reports when a
        frame's pixels arrived (``on_present``) and what became of it (``on_transport``:
        encoded on the worker thread and sent, or not sent again as unchanged; see
        :func:`grasswidget.compat.timed_jupyter_canvas_class`)."""

        max_pixel_ratio = MAX_PIXEL_RATIO
        render_scale = 1.0
        #: A lock held for each frame (draw + start of the download), or None.
        frame_lock = None
        _browser_resize = None

        def get_frame(self):
            """jupyter-rfb asks for a frame (on the thread of whichever message scheduled
            it): rendercanvas draws and starts the download, holding ``frame_lock``."""
            if self.frame_lock is None:
                return super().get_frame()
            with self.frame_lock:
                return super().get_frame()

        def handle_event(self, event):
            if compat.event_type(event) == "resize" and compat.event_ratio(event) is not None:
                self._browser_resize = dict(event)
                event = self._scaled(event)
            super().handle_event(event)

        def _scaled(self, event):
            ratio = min(float(compat.event_ratio(event)), float(self.max_pixel_ratio)) * float(self.render_scale)
            width = float(event.get("width") or 0)
            if width and self.render_scale != 1.0:  # whole physical pixels: the ratio that gives them
                ratio = max(1, int(width * ratio)) / width
            return compat.with_ratio(event, ratio)

        def set_render_scale(self, scale):
            """Render at ``scale`` (0.5..1) of the full pixel ratio from the next frame on."""
            if scale == self.render_scale:
                return
            self.render_scale = float(scale)
            if self._browser_resize is not None:
                super().handle_event(self._scaled(self._browser_resize))

    from .front_end import esm_for_front_end

    GrassCanvas._esm = esm_for_front_end(str(GrassCanvas._esm))  # marimo: made also outside a running cell
    return GrassCanvas


def _switch_texts(field) -> dict:
    """What the field's "auto" switches decided, in words (grasswidget.gpu.trial_timing.switch_texts)."""
    from ..gpu.trial_timing import switch_texts

    return switch_texts(field)


def _trial_mark(field) -> tuple:
    """(trial frames so far, a trial running) of the field's "auto" switches (grasswidget.gpu.trial_timing.trial_mark)."""
    from ..gpu.trial_timing import trial_mark

    return trial_mark(field)


class EventsWithoutPicking:
    """Forward canvas pointer/wheel/key events to the current pygfx renderer.

    ``WgpuRenderer(enable_events=True)`` converts every canvas event through
    ``renderer.convert_event``, which does a GPU pick readback (``get_pick_info``)
    for every event with x/y: one synchronous readback per pointer move. This
    forwards the same events with ``target=None`` and no ``pick_info``, so
    handlers registered on the renderer (``OrbitController.register_events``)
    work, without picking. ``renderer()`` is called per event, so the renderer
    may be replaced (a new blade count) while this stays registered. ``intercept(event)`` sees
    each event first: True (used, e.g. shift + drag moves the ball), or a list of the events
    to forward in its place (the ctrl gesture), else the event goes on as it is.
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
        events = [event]
        if self._intercept is not None:
            used = self._intercept(event)
            if used is True:
                return  # e.g. shift + drag moves the ball
            if isinstance(used, list):
                events = used
        for one in events:
            kind = compat.event_type(one)
            ev = compat.pygfx_event_class(kind)(type=kind, **compat.pygfx_event_fields(one), target=None, root=renderer)
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


class KernelView(EngineView):
    """A GrassScene rendered in the kernel, streamed by jupyter-rfb, animated by a clock
    (the kernel engine's :class:`~grasswidget.views.api.EngineView`).

    Args:
        blades: a blade count or a :class:`Blades` for the first scene.
        size: (w, h) of the view in CSS pixels.
        params: the :class:`GrassParams` the scene simulates with.
        preset: None or a ``GrassScene.preset`` name.
        streaming: a :func:`streaming_defaults` dict (possibly overridden).
        host: the :class:`~grasswidget.views.api.ViewHost` (its ``play`` is read each frame and
            observed; keys, ctrl + click and reports go to it).

    Attributes: ``widget`` (the ipywidget to show: the canvas), and what only this engine has:
    ``canvas`` (the jupyter-rfb canvas), ``scene`` (the GrassScene), ``controller`` (pygfx's
    orbit controller), ``ball`` (set with :meth:`attach_ball`), ``stats``,
    ``clock`` (the :class:`~grasswidget.views.clock.SimClock`), ``governor`` (the
    :class:`~grasswidget.views.adaptive.ResolutionGovernor`), ``timing`` (the
    :class:`FrameTiming` of the frames on their way).
    """

    backend = "kernel"
    scene = None
    controller = None
    canvas = None
    _inspect_stale = True  # read_inspected renders first when something changed since the last frame

    def __init__(self, blades, size, params, *, host, preset=None, streaming):
        super().__init__(size, params, host=host)
        #: Re-entrant lock held by every frame and every operation on the scene (see
        #: the module docstring, "Threads": controls may run on a comm subshell's thread).
        self.lock = threading.RLock()
        self._preset = preset
        self._streaming = dict(streaming)
        self._frozen_camera = None  # the frozen culling camera, kept across set_blades
        self._camera_floor = "grass"  # what the orbit stays above (set_options), kept across set_blades
        self._inspected = ()
        self._report_pending = False  # report the inspected numbers after the next frame
        self._inspect_stale = True    # read_inspected renders first (something changed since the last frame)
        self.scene = None
        self.controller = None
        self.ball = None

        self.clock = SimClock(MAX_STEPS_PER_FRAME)
        self.governor = ResolutionGovernor(self._streaming["target_fps"])
        self.canvas = _canvas_class()(size=self.size, update_mode="continuous" if self.play.playing else "ondemand",
                                     max_fps=self._read_max_fps())
        self.canvas.frame_lock = self.lock
        self.canvas.max_pixel_ratio = self._streaming["max_pixel_ratio"]
        self.canvas.quality = self._streaming["quality"]
        self.canvas.max_buffered_frames = MAX_BUFFERED_FRAMES
        self.canvas.resizable = False
        self.canvas.on_present = self._on_present
        self.canvas.on_transport = self._on_transport
        self.pointer = KernelPointer()  # the pointer rules, the browser engine's too
        self.events = EventsWithoutPicking(lambda: self.scene.renderer if self.scene is not None else None,
                                           intercept=self._on_pointer)
        self.canvas.add_event_handler(self.events, *EventsWithoutPicking.TYPES)
        self.canvas.add_event_handler(self.on_key, "key_down")
        # At rest off screen: jupyter-rfb draws only while a view is on screen; the clock stops too.
        compat.observe_view_visibility(self.canvas, self._on_visibility)
        compat.observe_frame_feedback(self.canvas, self._on_frame_arrived)  # how old the stats are

        self._frames = 0
        self._draw_ms = 0.0
        from ..gpu.adapter import cpu_notice

        self.timing = FrameTiming()
        self._stats = {"fps": None, "visible": None, "rastered": None, "occluded": None, "blades": None, "draw_ms": None, "gpu_ms": None,
                       "steps_per_frame": None, "frame_size": None, "render_ms": None, "readback_ms": None,
                       "encode_ms": None, "send_ms": None, "ack_ms": None, "unchanged_fps": None,
                       "scale": 1.0, "sim_speed": None,
                       "target_fps": self._read_target_fps(), "step_count": 0, "switches": None, "trial": False,
                       "adapter": cpu_notice(short=True)}  # the CPU-adapter notice (None on a GPU)
        self._stats_t = time.perf_counter()
        self._stats_frames = 0
        self._ticks = 0  # draws asked for: rendered, or skipped as nothing changed
        self._stats_ticks = 0
        self._unchanged = 0  # frames not rendered or not sent as unchanged, since the frame-rate window began
        self._render_key = None  # what the last rendered frame showed (see _render_key_now)
        self._unchanged_t = None  # when a frame was last skipped as unchanged (the page's picture is current)
        # How old the stats are (core.engine_inputs.stats_freshness), perf_counter seconds: the newest
        # frame drawn, the newest the browser acknowledged, the first one sent (None: none yet),
        # a change not drawn yet, and whether no view is on screen.
        self._drawn_t = self._arrived_t = self._first_sent_t = self._changed_t = None
        self._at_rest = False
        self._fps_t = self._stats_t  # the window the delivered frame rate is measured over
        self._trial_mark = (0, False)  # the "auto" switches' trial frames at the last stats window
        self._stats_confirmed = 0
        #: User WGSL replacing blade-math functions (an exercise's), kept across blade changes; None: stock.
        self.function_overrides = None
        self.set_blades(blades)

    # ------------------------------------------------------------------ scene

    def _make_scene(self, blades):
        from ..gpu.scene import GrassScene

        if self._preset is not None:
            count = len(blades) if isinstance(blades, Blades) else blades
            return GrassScene.preset(self._preset, blades=count, size=self.size, params=self.params,
                                     canvas=self.canvas)
        return GrassScene(blades, size=self.size, params=self.params, canvas=self.canvas)

    @_exclusive
    def set_blades(self, blades):
        # Build the scene for ``blades`` on this canvas, replacing and releasing
        # the previous one (the camera view, the orbit target and the ball are kept).
        from .orbit import GroundOrbitController, OrbitLimits

        old = self.scene
        cam_state = old.camera.get_state() if old is not None else None
        old_target = self.controller.target if (old is not None and self.controller is not None) else None
        scene = self._make_scene(blades)
        if self.function_overrides is not None:
            scene.field.set_function_overrides(self.function_overrides)
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
        self.governor.restart()
        if self.ball is not None:
            self.ball.attach(self)
        self._home_state = scene.camera.get_state()
        self._home_target = orbit_target(scene)
        # Orbit, zoom and pan within limits: the camera stays above the ground, the field in sight.
        self.controller = GroundOrbitController(scene.camera, limits=OrbitLimits.for_scene(scene, self._camera_floor),
                                                register_events=scene.renderer)
        # A custom target: orbit and zoom around the point the view looks at
        # (GrassScene aims with look_at, which leaves the camera extent unrelated
        # to that distance, so pygfx's implicit target would be far off).
        self.controller.target = self._home_target if old_target is None else old_target
        if cam_state is not None:  # a new blade count keeps the view
            scene.camera.set_state(cam_state)
        self.canvas.request_draw(self._draw_for_canvas)

    @property
    def widget(self):
        # The jupyter-rfb canvas (the ipywidget to show).
        return self.canvas

    def attach_ball(self, ball):
        # The :class:`~grasswidget.notebook.ball.BallControl` to move with shift + drag and roll.
        self.ball = ball

    @property
    def blades(self):
        # The field's :class:`Blades` (rest pose).
        return self.scene.field.blades

    @property
    def _blade_count(self) -> int:
        # A closed view answers with what it had when it closed (its scene is gone).
        if self.scene is None:
            return self._closed_view["blade_count"]
        return self.scene.field.count

    @property
    def colliders(self):
        # The scene's sphere colliders.
        return self.scene.colliders

    @_exclusive
    def read_state(self, timeout=None) -> dict:
        # The field's state (a GPU readback; ``timeout`` is not needed here).
        return self.scene.field.read_state()

    @_exclusive
    def set_wind_wgsl(self, body, select=True):
        # Compile ``body`` as the custom wind in the kernel (see GrassField.set_wind_wgsl).
        self.scene.field.set_wind_wgsl(body, select=select)

    # ------------------------------------------------------------------ time

    def _read_max_fps(self) -> float:
        # The stream cap: frames per second asked of the canvas scheduler.
        return float(self._streaming["max_fps"])

    def _read_sim_time(self) -> float:
        # Simulated seconds since the last reset_blades().
        return self.clock.sim_time

    def _read_target_fps(self) -> float:
        # Frames per second adaptive resolution aims for while playing.
        return self.governor.target_fps

    def _set_target_fps(self, value):
        self.governor.target_fps = check_target_fps(value)
        self.governor.restart()

    def _read_render_scale(self) -> float:
        # Fraction of the full pixel ratio the live frames render at (1 when paused).
        return float(self.canvas.render_scale)

    @_exclusive
    def _set_playing(self, playing: bool):
        # Draw continuously (playing) or on demand (paused). Pausing stops the clock
        # at once and puts the render scale back to 1, so the still frame is sharp.
        self._render_key = None  # the first frame after play or pause is rendered
        if not playing:
            self.clock.stop()
            self.governor.restart()
            self.canvas.set_render_scale(1.0)
        if not self.closed:
            self.canvas.set_update_mode("continuous" if playing else "ondemand")
            self.canvas.request_draw()

    @_exclusive
    def step(self, n: int):
        # Advance exactly ``n`` fixed steps and redraw (what ran, when interrupted).
        try:
            self._simulate(n)
        finally:
            self.request_draw()

    def _simulate(self, n):
        """n fixed steps, the ball moving between chunks (simulated time, not wall clock).
        Ctrl-C is held back to the end of a chunk's GPU submission: the clock then counts the
        steps that ran and StepsInterrupted (a KeyboardInterrupt) says how many."""
        dt = self.params.dt
        done = 0
        with hold_interrupts() as held:
            for chunk in (self.ball.step_chunks(n, dt) if self.ball is not None else [n]):
                if self.ball is not None:
                    try:
                        self.ball.advance(chunk * dt)
                    except Exception as err:  # e.g. a user path that raises: stop rolling, keep drawing
                        self.ball.rolling = False
                        self.host.show_error(f"ball path: {type(err).__name__}: {err}; rolling stopped")
                try:
                    self.scene.step(chunk)
                except StepsInterrupted as err:
                    self.clock.count(err.done, dt)
                    raise StepsInterrupted(done + err.done, n) from None
                self.clock.count(chunk, dt)
                done += chunk
                if held.hit:
                    raise StepsInterrupted(done, n)

    @_exclusive
    def set_function_overrides(self, overrides):
        # Replace blade-math functions with user WGSL (GrassField.set_function_overrides), now
        # and in every scene built for a new blade count; None: the stock functions.
        self.scene.field.set_function_overrides(overrides)
        self.function_overrides = overrides

    @_exclusive
    def reset_blades(self):
        # Every blade back to its rest pose; the step counter and sim_time back to 0.
        self.scene.field.reset()
        self.clock.reset()
        self.request_draw()

    @_exclusive
    def reset_camera(self):
        # Back to the scene's starting view (position, rotation, fov, orbit target).
        self.scene.reset_camera()
        self.scene.camera.set_state(self._home_state)
        if self.controller is not None:
            self.controller.target = self._home_target  # panning moves the target
            self.scene.camera.set_state(self._home_state)
        self.request_draw()

    @_exclusive
    def _set_camera_floor(self, floor: str):
        # New orbit limits for the controller: above the grass's tips or above the ground.
        from .orbit import OrbitLimits

        self._camera_floor = floor
        if self.controller is not None and self.scene is not None:
            self.controller.limits = OrbitLimits.for_scene(self.scene, floor)

    def _read_orbit_limits(self):
        return self.controller.limits if self.controller is not None else None

    def _current_camera(self) -> dict:
        # position, target (the orbit centre) and fov_deg (vertical) of the camera; a closed
        # view's is the one it had when it closed.
        if self.scene is None:
            return dict(self._closed_view["camera"])
        cam = self.scene.camera
        target = self.controller.target if self.controller is not None else orbit_target(self.scene)
        return {"position": tuple(float(x) for x in cam.world.position),
                "target": tuple(float(x) for x in target),
                "fov_deg": self.scene.vertical_fov()}

    def _read_depth_range(self) -> tuple:
        return tuple(float(x) for x in self.scene.camera.depth_range)

    @_exclusive
    def _look(self, position, target, fov_deg):
        # Aim the scene's camera; the controller orbits around ``target`` from now on.
        self.scene.look(position, target, fov_deg)
        if self.controller is not None:
            self.controller.target = np.asarray(target, np.float64)

    def request_draw(self):
        self._inspect_stale = True  # something changed: the inspector's numbers are of the next frame
        if self._changed_t is None:
            self._changed_t = time.perf_counter()  # the stats are of an older picture until it is drawn
        if self._at_rest and not self.closed:  # nothing will be drawn: the status line says how old it is
            self.host.show_stats(self.stats)
        if not self.closed:
            self.canvas.request_draw()

    # ------------------------------------------------------------------ teaching views

    @_exclusive
    def _set_culling_frozen(self, frozen: bool):
        # Freeze culling at the current camera (True) or cull against it again (False).
        if frozen:
            self.scene.freeze_culling()
            self._frozen_camera = self.scene.field.frozen_camera
        else:
            self.scene.unfreeze_culling()
            self._frozen_camera = None
        self.request_draw()

    @_exclusive
    def inspect(self, ids):
        # Inspect these blade ids (at most 64; [] clears); ValueError names the limit.
        self.scene.inspect(ids)
        self._inspected = tuple(self.scene.inspected)
        if not self._inspected:
            self.host.show_inspected([])
        self._report_pending = bool(self._inspected)  # the numbers exist after the next frame
        self.request_draw()

    def _read_inspected(self) -> tuple:
        return self._inspected

    @_exclusive
    def read_inspected(self, timeout=None) -> list:
        # The inspected blades' numbers (GrassScene.read_inspected) for the current state:
        # when the state, the ids or the parameters changed since the last drawn frame, a
        # frame of the view's size is rendered offscreen first (the inspector runs in renders).
        # ``timeout`` is unused (the kernel answers at once).
        if not self._inspected:
            return []
        if self._inspect_stale:
            self.scene.render_at(self.scene.size)
            self._inspect_stale = False
        return self.scene.read_inspected()

    @_exclusive
    def pick_blade(self, x, y):
        """The id of the blade drawn at logical pixel (x, y) in the last frame, or None
        (one GPU pick readback)."""
        info = self.scene.renderer.get_pick_info((x, y))
        field = self.scene.field
        if info.get("world_object") in (field, field.occlusion.draws):  # either occlusion phase's draws
            return info.get("blade_index")
        return None

    def _report_inspected(self):
        self.host.show_inspected(self.scene.read_inspected() if self._inspected else [])

    # ------------------------------------------------------------------ pictures

    @_exclusive
    def snapshot(self, path, size):
        # The kernel renders at once (offscreen and anti-aliased, whatever the canvas): a done Future.
        return done_future(lambda: self.scene.save_png(path, size=size))

    def _draw_for_canvas(self):
        """The canvas's draw function: :meth:`draw`; a frame it did not render (nothing changed) is
        cancelled, so nothing is read back or sent."""
        if not self.draw():
            compat.cancel_draw()

    @_exclusive
    def draw(self) -> bool:
        """One frame: advance time (when playing), render, maybe refresh stats. Returns False when
        nothing was rendered: no scene, or playing with nothing changed since the last frame (no step
        ran, the same camera and frame size, no change asked for: :meth:`request_draw`, and the page
        shows the last frame: no new view, resize or return on screen since)."""
        scene = self.scene
        if scene is None or scene.renderer is None:
            return False
        t0 = time.perf_counter()
        playing = bool(self.play.playing)
        steps = 0
        if playing and not self._at_rest:
            if not self.clock.running:
                self.clock.start()
            steps = self.clock.frame_steps(self.params.dt, self.play.time_scale)
            self._simulate(steps)
        elif self._at_rest:  # a frame asked for while out of sight (e.g. play() from a cell): time stays put
            self.clock.stop()
        self._ticks += 1
        key = self._render_key_now()
        if (playing and steps == 0 and self._changed_t is None and not self._report_pending and key == self._render_key
                and not self.canvas.frame_owed()):
            # Nothing this view knows of changed since the last frame (no step ran, the camera and
            # the frame size are the same, no change was asked for): the page already shows it.
            self._frame_unchanged()
            self.canvas.keep_lossless_due()  # the page keeps the last frame: its lossless picture still comes
            self.canvas.set_render_scale(self.governor.frame(self.timing.busy_s()))
            if time.perf_counter() - self._stats_t >= STATS_INTERVAL:
                self.refresh_stats()
            return False
        self._render_key = key
        scene.draw_frame()
        self._inspect_stale = False
        self._changed_t = None
        if self._camera_listeners:  # a linked view (a comparison) follows this camera
            self._report_camera_moved()
        t1 = time.perf_counter()
        self._drawn_t = t1
        self._draw_ms = 1000.0 * (t1 - t0)
        self.timing.drawn(t0, t1)
        if self._report_pending:
            self._report_pending = False
            self._report_inspected()
        self._frames += 1
        if playing:
            # The next frame's scale, from how long the kernel was busy per frame.
            self.canvas.set_render_scale(self.governor.frame(self.timing.busy_s()))
        if time.perf_counter() - self._stats_t >= STATS_INTERVAL:
            self.refresh_stats()
        self._notify_frame()  # the traces' sample of this frame (grasswidget.views.trace_feed)
        return True

    def _on_visibility(self, visible: bool):
        """No view of this widget on screen (scrolled away, a collapsed output; a hidden tab stops
        the frames' acknowledgements): jupyter-rfb asks for no frame, so nothing is simulated,
        rendered or sent, and the clock stops as :meth:`pause` stops it. Back on screen, the next
        frame starts it again: simulated time goes on from where it stopped, the time away is not
        owed (no catch-up burst, no slow motion on the stats line). A frame drawn while out of
        sight anyway (asked for from a cell: ``play()``, a parameter) advances no time."""
        with self.lock:
            self._at_rest = not visible
            if not visible:
                self.clock.stop()
        if not visible:
            self.host.show_stats(self.stats)  # the status line says it rests, and since when

    def _on_frame_arrived(self, _index):
        """The page acknowledged frames: the newest one shown arrived now (to within the comm's delay)."""
        self._arrived_t = time.perf_counter()

    def _render_key_now(self):
        """What decides the pixels besides the simulation and the asked-for changes: the camera's
        view-projection matrix, the frame size and the step count."""
        scene = self.scene
        matrix = np.asarray(scene.camera.camera_matrix, np.float64).tobytes()
        return (matrix, tuple(self.canvas.get_physical_size()), int(scene.field.step_count))

    def _frame_unchanged(self):
        """A frame the page already shows (not rendered, or rendered and not sent again)."""
        self._unchanged += 1
        self._unchanged_t = time.perf_counter()

    def _on_present(self, t):
        self.timing.presented(t)

    def _on_transport(self, kind, seconds):
        """The canvas encoded and sent a frame, or did not send it again as unchanged."""
        if kind == "encode":
            self.timing.encoded(seconds)
        elif kind == "send":
            self.timing.sent(time.perf_counter(), seconds)
            if self._first_sent_t is None:
                self._first_sent_t = time.perf_counter()
        elif kind == "unchanged":
            self.timing.unchanged()
            self._frame_unchanged()

    # ------------------------------------------------------------------ stats

    @property
    def stats(self) -> dict:
        # The stats dict for the stats line, with what is known now (no readback).
        s = dict(self._stats)
        s["blades"] = self._blade_count
        s["scale"] = self._read_render_scale()
        s["target_fps"] = self._read_target_fps()
        playing = bool(self.play.playing)
        s["steps_per_frame"] = self.clock.last_steps if playing else 0
        s["step_count"] = int(self.scene.field.step_count) if self.scene is not None else s.get("step_count")
        s["sim_speed"] = self.clock.speed if playing else None
        s["slow_motion"] = playing and s["sim_speed"] is not None and s["sim_speed"] < SLOW_MOTION_BELOW
        s.update(self._freshness(playing))
        return s

    def _freshness(self, playing) -> dict:
        """``frame_age_s``, ``at_rest``, ``stale``, ``waiting`` (core.engine_inputs.stats_freshness).
        A frame "arrived" when the browser acknowledged it; with no browser (nothing sent: a
        script, tests) when it was drawn. Sent frames never acknowledged count as waited for
        from the first one sent."""
        now = time.perf_counter()
        if self._first_sent_t is None:
            frame_t = self._drawn_t
        else:
            frame_t = self._arrived_t
        if frame_t is not None and self._unchanged_t is not None:  # an unchanged frame: the page's is current
            frame_t = max(frame_t, self._unchanged_t)
        out = stats_freshness(now, frame_t, playing=playing, at_rest=self._at_rest, changed_t=self._changed_t)
        if frame_t is None and self._first_sent_t is not None and playing and not self._at_rest:
            out["waiting"] = now - self._first_sent_t > WAITING_AFTER_S
        return out

    @_exclusive
    def refresh_stats(self):
        # Measure frames/s delivered (confirmed by the browser) and the time of each
        # stage of a frame, read the visible count and GPU times, and pass the stats to
        # ``on_stats``.
        if self._ticks == self._stats_ticks and self._stats["fps"] is not None:
            # No frame since the last window (a refresh right after the one a frame made):
            # nothing new to measure; the last window's figures stand.
            self.host.show_stats(self.stats)
            return
        now = time.perf_counter()
        dt = max(now - self._stats_t, 1e-6)
        ack_ms = None
        fps = self._stats["fps"]
        try:
            rfb = self.canvas.get_stats()
        except Exception:
            rfb = None
        sent, confirmed = (rfb["sent_frames"], rfb["confirmed_frames"]) if rfb else (0, 0)
        fps_dt = max(now - self._fps_t, 1e-6)
        if confirmed:
            ack_ms = 1000.0 * rfb["roundtrip"]
        unchanged_fps = self._stats.get("unchanged_fps")
        if confirmed or (sent and fps_dt > WAITING_AFTER_S) or (not sent and self._unchanged and self._first_sent_t):
            # Frames/s over the window since the last acknowledged frames. Acknowledgements lag
            # (about 0.5 s on a loaded machine): a window that sent frames but got none
            # acknowledged yet stays open rather than reading 0 frames/s while frames arrive.
            # Frames not sent again as unchanged count: the page shows them already.
            fps = (confirmed + self._unchanged) / fps_dt
            unchanged_fps = self._unchanged / fps_dt
            self.canvas.reset_stats()  # the next figures cover the next window only
            self._fps_t = now
            self._unchanged = 0
        elif not sent:  # nothing sent: no browser; frames drawn, and frames unchanged
            fps = (self._frames - self._stats_frames + self._unchanged) / dt
            unchanged_fps = self._unchanged / dt
            self._fps_t = now
            self._unchanged = 0
        self._stats_frames = self._frames
        self._stats_ticks = self._ticks
        self._stats_t = now
        scene = self.scene
        visible, gpu_ms, occluded, rastered = None, None, None, None
        stats = getattr(scene, "stats", None)
        if stats is not None:
            try:
                # The counts of the frame just drawn, read now, so that visible / rastered /
                # occluded are of the same frame as step_count (and as that frame's trace
                # sample). Twice a second at most (STATS_INTERVAL); the frame's pixels are read
                # back for the browser right after anyway, so this waits for nothing more.
                stats.settle()
                d = stats.as_dict()
                visible = d.get("visible", d.get("visible_blades"))
                gpu_ms = d.get("gpu_ms")
                occluded = d.get("occluded")  # None when occlusion culling did not run in that frame
                rastered = d.get("rastered")
            except Exception:
                visible = gpu_ms = occluded = rastered = None
        if visible is None:
            try:
                visible = scene.visible_count()
            except Exception:
                visible = None
        self._stats.update(
            fps=fps, visible=visible, rastered=rastered, occluded=occluded, blades=scene.field.count, draw_ms=self._draw_ms, gpu_ms=gpu_ms,
            frame_size=tuple(int(x) for x in self.canvas.get_physical_size()), ack_ms=ack_ms,
            unchanged_fps=unchanged_fps,
            switches=_switch_texts(scene.field), trial=self._trial_window(scene.field),
            **self.timing.averages(),
        )
        self.host.show_stats(self.stats)
        if self._inspected:
            self._report_inspected()

    def _trial_window(self, field) -> bool:
        """Whether a trial of the "auto" switches ran in the stats window ending now."""
        mark = _trial_mark(field)
        ran = mark[1] or mark[0] != self._trial_mark[0]
        self._trial_mark = mark
        return ran

    # ------------------------------------------------------------------ events

    def _on_pointer(self, event):
        """The pointer rules (grasswidget.core.interaction, as the browser engine's): ctrl + click
        inspects a blade, ctrl + drag pans; shift + drag moves the ball; other events go on to
        the camera controller. Returns True (used) or the events the controller gets instead."""
        if self.closed:
            return False
        action, events = self.pointer.feed(event)
        if action == "inspect":
            try:
                blade = self.pick_blade(event["x"], event["y"])
                if blade is not None:
                    self.host.inspect([int(blade)])
            except Exception as err:  # never let a pointer event break the canvas
                self.host.show_error(err)
            return True
        if action != "ball" or self.ball is None:
            return events
        try:
            w, h = self.canvas.get_logical_size()
            view = (w, h) if w > 1 and h > 1 else self.size  # no browser view yet: the asked size
            return self.ball.handle_event(event, view, self.scene)
        except Exception as err:  # never let a pointer event break the canvas
            self.host.show_error(err)
            return False

    # ------------------------------------------------------------------ closing

    @_exclusive
    def _close(self):
        # Close the canvas and release the scene's GPU resources.
        if self.scene is not None:  # what reading a closed view's stats and camera_state still gives
            self._closed_view = {"blade_count": self._blade_count, "camera": self._current_camera()}
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


class FrameTiming:
    """Where a streamed frame's time goes, in ms per frame averaged over the frames since the last
    :meth:`averages`: ``render_ms`` (the draw function: steps + render submit), ``readback_ms``
    (from the end of the draw until rendercanvas presents the pixels), ``encode_ms`` (the JPEG, on
    the canvas's worker thread, overlapping the next render) and ``send_ms`` (handing the message to
    the comm). Frames the canvas did not send again as unchanged have render and readback only."""

    #: Presented frames waiting for their encode and send (or their "unchanged"), oldest first, at most.
    MAX_PENDING = 8

    def __init__(self):
        #: (start, end) perf_counter seconds of the draw of the newest frame, until it is presented; or None.
        self.last_draw = None
        self._pending = []  # draw start (perf_counter s) of each presented frame not yet sent or skipped
        self._last_full = 0.0  # kernel seconds of the last frame that was sent: draw start to sent
        self._sums = {"render_ms": [], "readback_ms": [], "encode_ms": [], "send_ms": []}

    def drawn(self, t0, t1):
        self.last_draw = (t0, t1)
        self._sums["render_ms"].append(1000.0 * (t1 - t0))

    def presented(self, t):
        if self.last_draw is not None:
            self._sums["readback_ms"].append(1000.0 * (t - self.last_draw[1]))
            self._pending = (self._pending + [self.last_draw[0]])[-self.MAX_PENDING:]
            self.last_draw = None

    def encoded(self, seconds):
        self._sums["encode_ms"].append(1000.0 * seconds)

    def sent(self, t, seconds=0.0):
        self._sums["send_ms"].append(1000.0 * seconds)
        if self._pending:
            self._last_full = t - self._pending.pop(0)

    def unchanged(self):
        if self._pending:
            self._pending.pop(0)

    def busy_s(self) -> float:
        """Kernel seconds per frame: the last sent frame's render + readback + encode + send
        (with the wait for the worker thread), or the frame just drawn's render if that took
        longer (or none was sent)."""
        current = (self.last_draw[1] - self.last_draw[0]) if self.last_draw is not None else 0.0
        return max(self._last_full, current)

    def averages(self) -> dict:
        out = {k: (sum(v) / len(v) if v else None) for k, v in self._sums.items()}
        for v in self._sums.values():
            v.clear()
        return out
