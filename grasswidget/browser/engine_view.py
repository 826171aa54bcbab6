"""The browser engine's view for GrassWidget: the same interface as KernelView.

:class:`BrowserEngineView` wraps a :class:`~grasswidget.browser.view.BrowserView`
(the anywidget that simulates and draws in the browser) so that
:class:`grasswidget.GrassWidget` can drive it with the same panel and calls as
the kernel view: ``set_playing``, ``step``, ``reset_blades``, ``reset_camera``,
``save_png``, ``stats``, ``camera_state``, the ball (shift + drag, Roll).

Differences, by design:

* Time: the browser plays by the wall clock with the kernel's clock rules
  (:func:`grasswidget.core.frame_data.clock_rules`, executed by engine.js as
  :class:`grasswidget.notebook.clock.SimClock` does): whole fixed steps of ``params.dt``,
  at most ``MAX_STEPS_PER_FRAME`` a frame, the rest dropped (slow motion). The
  kernel's "steps per frame" is an average of the browser's frames here.
* One engine per widget: displayed twice, both views show the same meadow.
* The rolling ball: the browser reports the steps it simulated about every
  60 ms while the ball rolls; Python moves the ball by that much simulated time
  and sends the new position (the ball lags the grass by that interval).
* ``fps`` is frames presented per second in the browser and ``visible`` the
  browser's indirect-draw instance counts, read back asynchronously.
"""

from __future__ import annotations

import numpy as np

from ..errors import GrassTypeError, GrassValueError
from ..core.blades import Blades
from ..core.colliders import ColliderList
from ..core.frame_data import EXPORT_SUPERSAMPLE
from .view import BrowserView

__all__ = ["BrowserEngineView", "BROWSER_MAX_BLADES"]

#: Largest blade count offered with the browser engine (its device limits decide in the end).
BROWSER_MAX_BLADES = 1 << 22


class _BallScene:
    """What BallControl needs of a scene: ``field.blades`` and ``colliders``."""

    class _Field:
        def __init__(self, blades):
            self.blades = blades

    def __init__(self, view: BrowserView):
        self._view = view
        self.field = self._Field(view.blades)

    @property
    def colliders(self) -> ColliderList:
        return self._view.colliders


class BrowserEngineView:
    """GrassWidget's view when the grass runs in the browser (see the module docstring).

    Args: as :class:`~grasswidget.notebook.kernel_view.KernelView` (blades, size, params,
    preset, clock, actions, on_error, on_stats), plus ``on_unavailable(reason)``,
    called once when the browser has no WebGPU adapter (the widget falls back),
    and ``pixel_ratio`` (rendered pixels per CSS pixel; None: the display's, at most 2).
    """

    backend = "browser"
    #: The colour-by views (params.color_by "lod" and "cull") work here; freeze culling and the inspector do not.
    teaching_views = True
    scene = None        # no kernel scene: the browser holds the state
    canvas = None
    controller = None
    events = None

    def __init__(self, blades, size, params, *, preset=None, clock, actions, on_error, on_stats,
                 on_unavailable, pixel_ratio=None):
        from ..core.framing import preset_field

        self.size = tuple(size)
        self.params = params
        self._clock = clock
        self._actions = actions
        self._on_error = on_error
        self._on_stats = on_stats
        self._on_unavailable = on_unavailable
        self._closed = False
        self._unavailable_sent = False
        self.ball = None
        camera = None
        if preset is not None:
            blades, _size, view = preset_field(preset, blades)
            camera = {"position": list(map(float, view["position"])), "target": list(map(float, view["target"])),
                      "fov_deg": float(view["fov_deg"]), "near": float(view["near"]), "far": float(view["far"])}
        elif not isinstance(blades, Blades):
            blades = Blades.on_plane(int(blades))
        self.view = BrowserView(blades, params=params, size=self.size, camera=camera,
                                pixel_ratio=float(pixel_ratio or 0.0))
        self.view.playing = bool(clock.playing)
        self.view.time_scale = float(clock.time_scale)
        self.widget = self.view
        self.ball_scene = _BallScene(self.view)
        self._stats = {"fps": None, "visible": None, "blades": len(blades), "draw_ms": None, "gpu_ms": None,
                       "steps_per_frame": None, "frame_size": None}
        self.view.on("stats", self._on_browser_stats)
        self.view.on("error", self._on_error)
        self.view.on("device_lost", lambda msg: self._on_error(msg.get("message", "WebGPU device lost")))
        self.view.on("ball", self._on_ball_msg)
        self.view.on("key", self._on_key_msg)
        self.view.on("steps", self._on_steps_msg)
        self.view.observe(self._on_gpu_status, names="gpu_status")
        self.view.observe(self._on_browser_playing, names="playing")

    # ------------------------------------------------------------------ status

    @property
    def gpu_status(self) -> dict:
        return dict(self.view.gpu_status)

    def _on_gpu_status(self, change):
        state = (change["new"] or {}).get("state")
        if state == "unavailable" and not self._unavailable_sent and not self._closed:
            self._unavailable_sent = True
            try:
                self._on_unavailable((change["new"] or {}).get("detail", ""))
            except Exception as err:  # noqa: BLE001 - never raise into the comm handler
                self._on_error(err)

    def _on_browser_playing(self, change):
        # Space in the browser view toggles the view's playing: tell the widget.
        if bool(change["new"]) != bool(self._clock.playing):
            self._clock.playing = bool(change["new"])

    # ------------------------------------------------------------------ the ball

    def attach_ball(self, ball):
        self.ball = ball
        ball.collider.observe(self._on_ball_changed, names=["center", "radius"])
        ball.observe(self._on_ball_changed, names="enabled")
        ball.observe(self._on_rolling, names="rolling")
        self.view.colliders_changed()
        self.view.report_steps = bool(ball.rolling)

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
        if not self._closed:
            self.view.colliders_changed()

    def _on_rolling(self, change):
        self.view.report_steps = bool(change["new"])

    def _on_ball_msg(self, msg):
        if self.ball is None:
            return
        try:
            if msg.get("phase") == "down" and not self.ball.enabled:
                self.ball.enabled = True
            self.ball.move_to(float(msg["x"]), float(msg["z"]))
        except Exception as err:  # noqa: BLE001
            self._on_error(err)

    def _on_steps_msg(self, msg):
        ball = self.ball
        if ball is None or not ball.rolling:
            return
        try:
            ball.advance(int(msg.get("steps", 0)) * self.params.dt)
        except Exception as err:  # noqa: BLE001 - a user path that raises stops the rolling
            ball.rolling = False
            self._on_error(f"ball path: {type(err).__name__}: {err}; rolling stopped")

    def _on_key_msg(self, msg):
        key = msg.get("key")
        try:
            if key == "s":
                self._actions.step()
            elif key == "r":
                self._actions.reset_camera()
        except Exception as err:  # noqa: BLE001
            self._on_error(err)

    # ------------------------------------------------------------------ blades and time

    @property
    def blade_count(self) -> int:
        return len(self.view.blades)

    def set_blades(self, blades):
        if not isinstance(blades, Blades):
            blades = Blades.on_plane(int(blades))
        self.view.set_blades(blades)
        self.ball_scene.field.blades = blades
        if self.ball is not None:
            self.ball.attach(self.ball_scene)
        self._stats["blades"] = len(blades)

    @property
    def max_fps(self) -> float:
        """The browser presents up to its display rate; 60 is the nominal figure."""
        return 60.0

    @property
    def frame_interval(self) -> float:
        return 1.0 / self.max_fps

    @property
    def steps_per_frame(self) -> int:
        """Average fixed steps per presented frame (the browser follows the wall clock)."""
        s = self._stats.get("steps_per_frame")
        if s is not None:
            return int(s)
        return max(0, int(round(self._clock.time_scale * self.frame_interval / self.params.dt)))

    def set_playing(self, playing: bool):
        if not self._closed:
            self.view.playing = bool(playing)

    def set_time_scale(self, time_scale: float):
        if not self._closed:
            self.view.time_scale = float(time_scale)

    def step(self, n: int):
        self.view.step(n)

    def reset_blades(self):
        self.view.reset()

    def reset_camera(self):
        self.view.reset_camera()

    def request_draw(self):
        """The browser draws every animation frame; parameter changes arrive as traits."""

    # ------------------------------------------------------------------ camera

    @property
    def camera_state(self) -> dict:
        cam = self.view.camera
        return {"position": tuple(float(x) for x in cam["position"]),
                "target": tuple(float(x) for x in cam["target"]),
                "fov_deg": float(cam["fov_deg"])}

    @camera_state.setter
    def camera_state(self, state):
        new = dict(self.view.camera, **_check_camera_state(state))
        if np.allclose(new["position"], new["target"]):
            raise GrassValueError(f"camera_state position and target must differ; both are {tuple(new['position'])}")
        self.view.camera = new

    # ------------------------------------------------------------------ pictures and state

    def save_png(self, path, size):
        """Rendered by the browser at ``size``, anti-aliased like the kernel engine's exports
        (``EXPORT_SUPERSAMPLE`` times larger, filtered down); written here (waits for the
        browser's answer)."""
        import imageio.v3 as iio

        img = self.view.snapshot(size, supersample=EXPORT_SUPERSAMPLE)
        iio.imwrite(path, img, extension=".png")
        return path

    def save_png_async(self, path, size, done):
        """Ask the browser for a picture; write it and call ``done(path)`` when it arrives
        (used by the Save PNG button, which runs inside a comm message and cannot wait)."""
        import imageio.v3 as iio

        def write(msg, buffers):
            try:
                w, h = int(msg["width"]), int(msg["height"])
                img = np.frombuffer(bytes(buffers[0]), np.uint8).reshape(h, w, 4)
                iio.imwrite(path, img, extension=".png")
                done(path)
            except Exception as err:  # noqa: BLE001
                self._on_error(err)

        self.view.request_async(self.view.snapshot_request(size, EXPORT_SUPERSAMPLE), write)

    def read_state(self, timeout=None) -> dict:
        state = self.view.read_state() if timeout is None else self.view.read_state(timeout=timeout)
        state.pop("step_count", None)
        return state

    # ------------------------------------------------------------------ stats

    @property
    def stats(self) -> dict:
        return dict(self._stats)

    def current_stats(self) -> dict:
        s = dict(self._stats)
        s["blades"] = self.blade_count
        return s

    def refresh_stats(self):
        self._on_stats(self.current_stats())

    def _on_browser_stats(self, msg):
        per_class = msg.get("visible")
        fps = msg.get("fps")
        steps = int(msg.get("steps") or 0)
        frames = max(1, round((fps or 0) * 0.5))
        self._stats.update(
            fps=fps,
            visible=int(sum(per_class)) if per_class else None,
            visible_per_class=list(per_class) if per_class else None,
            blades=self.blade_count,
            draw_ms=msg.get("frame_ms"),
            steps_per_frame=int(round(steps / frames)) if self._clock.playing else 0,
            frame_size=tuple(msg.get("frame_size") or ()) or None,
            adapter=msg.get("adapter"),
            step_count=msg.get("step_count"),
        )
        self._on_stats(self.current_stats())

    # ------------------------------------------------------------------ keys, closing

    def on_key(self, event):
        """Keys are handled in the browser view itself (space, s, r)."""

    def close(self):
        if self._closed:
            return
        self._closed = True
        self._detach_ball()
        self.view.close()


def _check_camera_state(state) -> dict:
    """Validate a camera_state dict: position, target (3 finite numbers each, apart), fov_deg in (1, 179)."""
    if not isinstance(state, dict):
        raise GrassTypeError(f"camera_state must be a dict with position, target and fov_deg; got {state!r}")
    unknown = set(state) - {"position", "target", "fov_deg"}
    if unknown:
        raise GrassValueError(f"camera_state keys are position, target and fov_deg; got {sorted(unknown)}")
    out = {}
    for key in ("position", "target"):
        if key in state:
            v = np.asarray(state[key], np.float64).reshape(-1)
            if v.size != 3 or not np.all(np.isfinite(v)):
                raise GrassValueError(f"camera_state {key} must be 3 finite numbers (metres); got {state[key]!r}")
            out[key] = [float(x) for x in v]
    if "fov_deg" in state:
        fov = state["fov_deg"]
        if isinstance(fov, bool) or not isinstance(fov, (int, float, np.number)) or not (1.0 <= float(fov) <= 179.0):
            raise GrassValueError(f"camera_state fov_deg must be a number in [1, 179] degrees; got {fov!r}")
        out["fov_deg"] = float(fov)
    return out
