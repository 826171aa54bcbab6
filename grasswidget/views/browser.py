"""The browser engine's view for GrassWidget: a :class:`~grasswidget.views.api.EngineView`.

:class:`BrowserEngineView` wraps a :class:`~grasswidget.browser.engine_widget.BrowserEngineWidget`
(the anywidget that simulates and draws in the browser) so that
:class:`grasswidget.GrassWidget` drives it through the same interface as the
kernel view (:mod:`grasswidget.views.api`): the host's play state, ``step``,
``reset_blades``, ``reset_camera``, ``snapshot``, ``stats``, ``camera_state``,
the keys, the ball (shift + drag, Roll), and the teaching views (colour by, freeze
culling, the blade inspector and ``read_inspected``).

Differences, by design:

* Time: the browser plays by the wall clock with the kernel's clock rules
  (:func:`grasswidget.core.engine_inputs.clock_rules`, executed by engine.js as
  :class:`grasswidget.views.clock.SimClock` does): whole fixed steps of ``params.dt``,
  at most ``MAX_STEPS_PER_FRAME`` a frame, the rest dropped (slow motion). The
  kernel's "steps per frame" is an average of the browser's frames here.
* One engine per widget: displayed twice, both views show the same meadow.
* The rolling ball: the browser reports the steps it simulated about every
  60 ms while the ball rolls; Python moves the ball by that much simulated time
  and sends the new position (the ball lags the grass by that interval).
* ``fps`` is frames presented per second in the browser and ``visible`` the
  browser's indirect-draw instance counts (both occlusion phases) plus ``rastered``,
  the blades its compute rasterizer drew (``params.compute_raster``), ``occluded`` the
  blades culled by occlusion (None while occlusion culling is off), read back
  asynchronously; ``switches`` what the "auto" switches decided, in words, as the kernel
  view's (:mod:`grasswidget.browser.trial_feed`: the same rule, fed by the browser's frame times).
* Teaching views: freeze culling copies the browser's camera (its matrices
  computed here, :func:`grasswidget.core.teaching.frozen_view`) at the size the
  browser last drew; the inspector's numbers reach ``on_inspect`` at each stats
  message (one small request while blades are inspected); ctrl + click inspects
  the blade whose rest pose is nearest the pointer's ray.
"""

from __future__ import annotations

import concurrent.futures

import numpy as np

from ..core.blades import Blades
from ..core.colliders import ColliderList
from ..core.engine_inputs import EXPORT_SUPERSAMPLE, SLOW_MOTION_BELOW, stats_freshness
from .api import EngineView
from .engines import BROWSER_MAX_BLADES
from .front_end import class_for_front_end
from ..errors import GrassTypeError, GrassValueError
from ..browser.engine_widget import ANSWER_TIMEOUT, BrowserEngineWidget
from ..browser.kernel_pump import BrowserTimeoutError, wait_for

__all__ = ["BrowserEngineView", "BROWSER_MAX_BLADES"]



class BrowserAnswer(concurrent.futures.Future):
    """A Future the browser's answer completes. ``result(timeout)`` handles the notebook's
    messages while it waits (so it works inside a running cell), at most ``timeout`` seconds
    (None: ``ANSWER_TIMEOUT``, 30); then it gives up: BrowserTimeoutError (a TimeoutError)
    naming what was asked, and an answer that comes later is dropped."""

    def __init__(self, what: str):
        super().__init__()
        self.what = what

    def result(self, timeout=None):
        if not self.done():
            try:
                wait_for(lambda: True if self.done() else None, ANSWER_TIMEOUT if timeout is None else timeout,
                         self.what)
            except BrowserTimeoutError as err:
                if not self.done():
                    self.set_exception(err)
        return super().result(0)


class BrowserEngineView(EngineView):
    """GrassWidget's view when the grass runs in the browser (see the module docstring).

    Args: as :class:`~grasswidget.views.kernel.KernelView` (blades, size, params, host,
    preset); the host's ``engine_unavailable(reason)`` is called once when the browser has no
    WebGPU adapter (the widget falls back), its ``engine_adapter(text)`` once when the browser
    engine has started on an adapter (its ``gpu_status`` detail: vendor, architecture,
    description; the sunlight's default). ``pixel_ratio`` (rendered pixels per CSS pixel; None: the display's, at most 2)
    and ``target_fps`` (kept and reported; the browser draws at its own rate).
    ``widget_class``: the anywidget to make, a BrowserEngineWidget subclass (default: the one the
    front end running now can make, :func:`grasswidget.views.front_end.class_for_front_end`).
    The host's ``show_inspected(rows)`` gets the inspected blades' numbers at each stats message.

    Attributes: ``engine_widget`` (the :class:`~grasswidget.browser.engine_widget.BrowserEngineWidget`).
    """

    backend = "browser"

    def __init__(self, blades, size, params, *, host, preset=None, pixel_ratio=None, target_fps=60.0,
                 function_overrides=None, widget_class=None):
        from ..core.presets import preset_field

        super().__init__(size, params, host=host)
        self._target_fps = float(target_fps)
        self._inspect_request_pending = False
        self._unavailable_sent = False
        self._adapter_sent = False
        self.ball = None
        camera = None
        self._preset = preset
        if preset is not None:
            blades, _size, view = preset_field(preset, blades)
            camera = {"position": list(map(float, view["position"])), "target": list(map(float, view["target"])),
                      "fov_deg": float(view["fov_deg"]), "near": float(view["near"]), "far": float(view["far"])}
        elif not isinstance(blades, Blades):
            blades = Blades.on_plane(int(blades))
        # A front end may hand a subclass (marimo: the module as a URL, grasswidget.notebook.marimo_face).
        widget_class = class_for_front_end(BrowserEngineWidget) if widget_class is None else widget_class
        if not (isinstance(widget_class, type) and issubclass(widget_class, BrowserEngineWidget)):
            raise GrassTypeError(f"widget_class must be BrowserEngineWidget or a subclass; got {widget_class!r}")
        self.engine_widget = widget_class(blades, params=params, size=self.size, camera=camera,
                                        pixel_ratio=float(pixel_ratio or 0.0), function_overrides=function_overrides)
        self.engine_widget.playing = bool(self.play.playing)
        self.engine_widget.time_scale = float(self.play.time_scale)
        self._stats = {"fps": None, "visible": None, "rastered": None, "occluded": None, "blades": len(blades), "draw_ms": None, "gpu_ms": None,
                       "steps_per_frame": None, "frame_size": None, "step_count": None, "switches": None,
                       "trial": False}  # the keys a stats message fills, known from the start
        self._trial_mark = (0, False)  # the "auto" switches' trial frames at the last stats message
        # How old the stats are (core.engine_inputs.stats_freshness), perf_counter seconds: the newest
        # stats message (a frame drawn), a change sent since, and whether the engine rests.
        self._frame_t = self._changed_t = None
        self._at_rest = False
        self.engine_widget.on("stats", self._on_browser_stats)
        self.engine_widget.on("rest", self._on_rest)
        self.engine_widget.on("error", self.host.show_error)
        self.engine_widget.on("device_lost", lambda msg: self.host.show_error(msg.get("message", "WebGPU device lost")))
        self.engine_widget.on("ball", self._on_ball_msg)
        self.engine_widget.on("key", self._on_key_msg)
        self.engine_widget.on("steps", self._on_steps_msg)
        self.engine_widget.on("pick", self._on_pick_msg)
        self.engine_widget.observe(self._on_gpu_status, names="gpu_status")
        self.engine_widget.observe(self._on_browser_playing, names="playing")
        self.engine_widget.observe(lambda _change: self._report_camera_moved(), names="camera")

    @property
    def widget(self):
        # The :class:`~grasswidget.browser.engine_widget.BrowserEngineWidget` anywidget (the ipywidget to show).
        return self.engine_widget

    # ------------------------------------------------------------------ status

    @property
    def gpu_status(self) -> dict:
        return dict(self.engine_widget.gpu_status)

    def _on_gpu_status(self, change):
        state = (change["new"] or {}).get("state")
        if state == "ok" and not self._adapter_sent and not self.closed:
            self._adapter_sent = True
            try:
                self.host.engine_adapter((change["new"] or {}).get("detail", ""))
            except Exception as err:  # noqa: BLE001 - never raise into the comm handler
                self.host.show_error(err)
        if state == "unavailable" and not self._unavailable_sent and not self.closed:
            self._unavailable_sent = True
            try:
                self.host.engine_unavailable((change["new"] or {}).get("detail", ""))
            except Exception as err:  # noqa: BLE001 - never raise into the comm handler
                self.host.show_error(err)

    def _on_browser_playing(self, change):
        # Space in the browser view toggles the view's playing: tell the widget.
        if bool(change["new"]) != bool(self.play.playing):
            self.play.playing = bool(change["new"])

    # ------------------------------------------------------------------ the ball

    def attach_ball(self, ball):
        self.ball = ball
        ball.collider.observe(self._on_ball_changed, names=["center", "radius"])
        ball.observe(self._on_ball_changed, names="enabled")
        ball.observe(self._on_rolling, names="rolling")
        self.engine_widget.colliders_changed()
        self.engine_widget.report_steps = bool(ball.rolling)

    def _detach_ball(self):
        ball, self.ball = self.ball, None
        if ball is None:
            return
        for obj, fn, names in ((ball.collider, self._on_ball_changed, ["center", "radius"]),
                               (ball, self._on_ball_changed, "enabled"), (ball, self._on_rolling, "rolling")):
            try:
                obj.unobserve(fn, names=names)
            except ValueError:
                pass

    def _on_ball_changed(self, _change):
        if not self.closed:
            self.engine_widget.colliders_changed()

    def _on_rolling(self, change):
        self.engine_widget.report_steps = bool(change["new"])

    def _on_ball_msg(self, msg):
        if self.ball is None:
            return
        try:
            if msg.get("x") is not None or msg.get("z") is not None:  # both None: the pointer is on the sky
                self.ball.move_to(float(msg["x"]), float(msg["z"]))
            if msg.get("phase") == "down" and not self.ball.enabled:
                self.ball.enabled = True
        except Exception as err:  # noqa: BLE001
            self.host.show_error(err)

    def _on_steps_msg(self, msg):
        ball = self.ball
        if ball is None or not ball.rolling:
            return
        try:
            ball.advance(int(msg.get("steps", 0)) * self.params.dt)
        except Exception as err:  # noqa: BLE001 - a user path that raises stops the rolling
            ball.rolling = False
            self.host.show_error(f"ball path: {type(err).__name__}: {err}; rolling stopped")

    def _on_pick_msg(self, msg):
        """Ctrl + click in the browser: inspect the blade on the pointer's ray (none: nothing)."""
        from ..core.teaching import pick_blade_on_ray

        b = self.engine_widget.blades
        try:
            blade = pick_blade_on_ray(b.v0, b.up, b.height, b.width, msg["origin"], msg["direction"])
            if blade is not None:
                self.host.inspect([blade])
        except Exception as err:  # noqa: BLE001 - never raise into the comm handler
            self.host.show_error(err)

    def _on_key_msg(self, msg):
        """A key pressed in the focused browser view ({"key", "modifiers"}): see :meth:`on_key`."""
        try:
            self.on_key({"key": msg.get("key", ""), "modifiers": tuple(msg.get("modifiers") or ())})
        except Exception as err:  # noqa: BLE001 - never raise into the comm handler
            self.host.show_error(err)

    # ------------------------------------------------------------------ blades and time

    @property
    def blades(self) -> Blades:
        # The field's rest pose (what the browser was sent).
        return self.engine_widget.blades

    @property
    def colliders(self) -> ColliderList:
        # The sphere colliders sent to the browser.
        return self.engine_widget.colliders

    def set_blades(self, blades):
        if not isinstance(blades, Blades):  # a count: the preset's field of that many blades (as the kernel's)
            if self._preset is not None:
                from ..core.presets import preset_field

                blades = preset_field(self._preset, int(blades))[0]
            else:
                blades = Blades.on_plane(int(blades))
        self.engine_widget.set_blades(blades)
        if self.ball is not None:
            self.ball.attach(self)
        self._stats["blades"] = len(blades)

    def _read_max_fps(self) -> float:
        # The browser presents up to its display rate; 60 is the nominal figure.
        return 60.0

    def _read_steps_per_frame(self) -> int:
        # Average fixed steps per presented frame, as the browser last reported it (it follows
        # the wall clock); before any report, the nominal steps.
        s = self._stats.get("steps_per_frame")
        if s is not None:
            return int(s)
        return self._nominal_steps()

    def _read_sim_time(self) -> float | None:
        # Simulated seconds since the last reset as of the browser's last stats message (about
        # every 0.5 s): its step count times ``params.dt``; None before the first one.
        count = self._stats.get("step_count")
        return None if count is None else int(count) * float(self.params.dt)

    def _read_target_fps(self) -> float:
        # Kept and reported only: the browser presents at its display's rate (no adaptive resolution).
        return self._target_fps

    def _set_target_fps(self, value):
        self._target_fps = float(value)

    def _read_render_scale(self) -> float:
        # Always 1: the browser renders at full resolution.
        return 1.0

    def _set_playing(self, playing: bool):
        self._last_stats_t = None  # the speed of time is measured afresh
        if not self.closed:
            self.engine_widget.playing = bool(playing)

    def _set_time_scale(self, time_scale: float):
        self._last_stats_t = None
        if not self.closed:
            self.engine_widget.time_scale = float(time_scale)

    def step(self, n: int):
        self.engine_widget.step(n)
        self._changed()

    def reset_blades(self):
        self.engine_widget.reset()
        self._changed()

    def _changed(self):
        """Something the picture shows changed: the stats are of an older frame until the next one."""
        if self._changed_t is None:
            import time

            self._changed_t = time.perf_counter()
        if self._at_rest and not self.closed:  # nothing will be drawn: the status line says how old it is
            self.host.show_stats(self.stats)

    def reset_camera(self):
        self.engine_widget.reset_camera()

    def _set_camera_floor(self, floor: str):
        # The browser gets the floor as new orbit numbers (``frame_rules["orbit"]``).
        self.engine_widget.camera_floor = floor

    def _read_orbit_limits(self):
        return self.engine_widget.orbit_limits

    def request_draw(self):
        # The browser draws every animation frame; parameter changes arrive as traits. The stats
        # are of an older picture until the browser's next stats message.
        self._changed()

    # ------------------------------------------------------------------ camera

    def _current_camera(self) -> dict:
        cam = self.engine_widget.camera
        return {"position": tuple(float(x) for x in cam["position"]),
                "target": tuple(float(x) for x in cam["target"]),
                "fov_deg": float(cam["fov_deg"])}

    def _read_depth_range(self) -> tuple:
        cam = self.engine_widget.camera
        return float(cam.get("near", 0.1)), float(cam.get("far", 100.0))

    def _look(self, position, target, fov_deg):
        # Send the browser the new camera (near and far planes kept).
        self.engine_widget.camera = dict(self.engine_widget.camera, position=[float(x) for x in position],
                                        target=[float(x) for x in target], fov_deg=float(fov_deg))

    # ------------------------------------------------------------------ pictures and state

    def snapshot(self, path, size):
        # Rendered by the browser at ``size``, anti-aliased like the kernel engine's exports
        # (``EXPORT_SUPERSAMPLE`` times larger, filtered down); written here when it comes.
        import imageio.v3 as iio

        future = BrowserAnswer(f"a snapshot ({int(size[0])} x {int(size[1])}) from the browser view")
        request = self.engine_widget.snapshot_request(size, EXPORT_SUPERSAMPLE)  # a bad size raises here

        def write(msg, buffers):
            if future.done():  # given up (a timeout): a late picture is dropped
                return
            try:
                w, h = int(msg["width"]), int(msg["height"])
                img = np.frombuffer(bytes(buffers[0]), np.uint8).reshape(h, w, 4)
                iio.imwrite(path, img, extension=".png")
                future.set_result(path)
            except Exception as err:  # noqa: BLE001 - the Future carries it
                future.set_exception(err)

        self.engine_widget.request_async(request, write)
        return future

    @property
    def function_overrides(self):
        """The user WGSL the browser compiled in place of stock blade-math functions, or None."""
        return self.engine_widget.function_overrides

    def set_function_overrides(self, overrides):
        # The browser compiles user functions when its engine starts: only the ones it has are accepted.
        if overrides != self.engine_widget.function_overrides:
            raise GrassValueError("the browser engine takes user functions when the widget is made "
                                  "(GrassWidget(function_overrides=...), or gw.exercise(...).widget(code)); "
                                  "make a new widget, or use backend='kernel' to change them live")

    def set_wind_wgsl(self, body, select=True):
        # Compiled by the browser; waits for its answer (see BrowserEngineWidget.set_wind_wgsl).
        self.engine_widget.set_wind_wgsl(body, select=select)

    def read_state(self, timeout=None) -> dict:
        state = self.engine_widget.read_state() if timeout is None else self.engine_widget.read_state(timeout=timeout)
        state.pop("step_count", None)
        return state

    # ------------------------------------------------------------------ teaching views

    def _set_culling_frozen(self, frozen: bool):
        # Freeze culling at the browser's current camera (True) or cull against it again (False).
        if frozen:
            self.engine_widget.freeze_culling()
        else:
            self.engine_widget.unfreeze_culling()

    @property
    def frozen_camera(self):
        """The :class:`~grasswidget.core.teaching.FrozenView` culled against, or None."""
        return self.engine_widget.frozen_camera

    def inspect(self, ids):
        # Inspect these blade ids (at most 64; [] clears); ValueError names the limit.
        self.engine_widget.inspect(ids)
        if not self.engine_widget.inspected:
            self._report_inspected([])
        else:
            self._request_inspected()

    def _read_inspected(self) -> tuple:
        return tuple(self.engine_widget.inspected)

    def read_inspected(self, timeout=None) -> list:
        # The inspected blades' numbers (GrassScene.read_inspected's format), from the browser.
        return self.engine_widget.read_inspected() if timeout is None else self.engine_widget.read_inspected(timeout=timeout)

    def _report_inspected(self, rows):
        self.host.show_inspected(rows)

    def _request_inspected(self):
        """Ask the browser for the inspected numbers; the panel shows them when they come."""
        if self._inspect_request_pending or self.closed:
            return
        ids = list(self.engine_widget.inspected)

        def done(msg, buffers):
            self._inspect_request_pending = False
            try:
                if msg.get("type") != "inspected":
                    return
                self._report_inspected(self.engine_widget.inspected_from_answer(msg, buffers, ids))
            except Exception as err:  # noqa: BLE001
                self.host.show_error(err)

        self._inspect_request_pending = True
        self.engine_widget.request_async({"type": "read_inspected"}, done)

    # ------------------------------------------------------------------ stats

    @property
    def stats(self) -> dict:
        import time

        s = dict(self._stats)
        s["blades"] = len(self.blades)
        s["target_fps"] = self._read_target_fps()  # as the kernel's (the blade control's estimate aims for it)
        # How old: the newest stats message is the newest frame known to be drawn.
        s.update(stats_freshness(time.perf_counter(), self._frame_t, playing=bool(self.play.playing),
                                 at_rest=self._at_rest, changed_t=self._changed_t,
                                 interval_s=self.engine_widget.stats_interval_ms / 1000.0))
        return s

    def _on_rest(self, msg):
        """No view of the engine is on screen: it draws nothing (and sends no stats) until one is;
        the stats say so, and the status line."""
        self._at_rest = True
        if msg.get("step_count") is not None:
            self._stats["step_count"] = msg["step_count"]
        self.host.show_stats(self.stats)

    def refresh_stats(self):
        self.host.show_stats(self.stats)

    def _sim_speed(self, steps):
        """Simulated seconds per time-scaled wall second since the previous stats message
        (``steps`` fixed steps of ``params.dt`` were taken in the browser meanwhile), as
        the kernel's clock measures it; None when unknown (the first message, paused,
        time_scale 0)."""
        import time

        now, last = time.perf_counter(), getattr(self, "_last_stats_t", None)
        self._last_stats_t = now
        scale = float(self.play.time_scale)
        if last is None or not self.play.playing or scale <= 0 or now - last <= 0:
            return None
        return steps * float(self.params.dt) / ((now - last) * scale)

    def _on_browser_stats(self, msg):
        import time

        self._frame_t = time.perf_counter()  # a stats message comes from a frame drawn (none at rest)
        self._changed_t, self._at_rest = None, False
        per_class = msg.get("visible")
        fps = msg.get("fps")
        steps = int(msg.get("steps") or 0)
        frames = max(1, round((fps or 0) * self.engine_widget.stats_interval_ms / 1000.0))  # in this message
        sim_speed = self._sim_speed(steps)
        rastered = msg.get("rastered")
        rastered = int(rastered) if rastered is not None else None
        self._stats.update(
            fps=fps,
            # every blade drawn: as ribbons (per LOD class) and in compute (rastered), as the kernel counts
            visible=int(sum(per_class)) + (rastered or 0) if per_class else None,
            visible_per_class=list(per_class) if per_class else None,
            rastered=rastered,
            # blades culled by occlusion (both phases' draws are in visible); None while it is off
            occluded=int(msg["occluded"]) if msg.get("occluded") is not None else None,
            blades=len(self.blades),
            draw_ms=msg.get("frame_ms"),
            steps_per_frame=int(round(steps / frames)) if self.play.playing else 0,
            frame_size=tuple(msg.get("frame_size") or ()) or None,
            adapter=msg.get("adapter"),
            step_count=msg.get("step_count"),
            sim_speed=sim_speed,
            slow_motion=sim_speed is not None and sim_speed < SLOW_MOTION_BELOW,
            # what the "auto" switches decided, in words, as the kernel view's (browser.trial_feed)
            switches=self.engine_widget.auto_switches.texts(),
            trial=self._trial_window(),
        )
        self.host.show_stats(self.stats)
        if self.engine_widget.inspected:
            self._request_inspected()
        self._notify_frame()  # the traces' sample (grasswidget.views.trace_feed)

    def _trial_window(self) -> bool:
        """Whether a trial of the "auto" switches ran over the frames of this stats message."""
        state = self.engine_widget.auto_switches.state
        mark = (state.trial_frames_run, state.measuring)
        ran = mark[1] or mark[0] != self._trial_mark[0]
        self._trial_mark = mark
        return ran

    # ------------------------------------------------------------------ keys, closing

    def _close(self):
        self._detach_ball()
        self.engine_widget.close()
