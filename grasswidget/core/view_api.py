"""The one interface between :class:`~grasswidget.GrassWidget` and its view.

A GrassWidget composes a control panel with a *view*: the part that simulates,
draws and shows the meadow. There are two, one per engine:

* :class:`grasswidget.notebook.kernel_view.KernelView` ("kernel"): a GrassScene rendered
  in the kernel and streamed by jupyter-rfb;
* :class:`grasswidget.browser.engine_view.BrowserEngineView` ("browser"): the
  same WGSL run in the notebook's browser through WebGPU.

Both subclass :class:`EngineView` and implement every abstract member; the widget
talks to a view through this interface only (no attribute probing, no reaching
into a view's parts). Every member is documented here, once: the two views'
definitions say (in comments) how their engine does it, not what it is. Where the
widget adds nothing to a member (``w.read_inspected``, ``w.camera_state``, ``w.stats``,
...), its attribute is a :class:`ViewMember`: the one generic forwarding, whose help
is this module's text, instead of a hand-written method per member.

Names: a *view* is one engine's view of a widget (this interface and its two
implementations). The anywidget that runs engine.js in the page is
:class:`~grasswidget.browser.view.BrowserEngineWidget` (``BrowserEngineView.engine_widget``);
the kernel engine's clock is :class:`~grasswidget.notebook.clock.SimClock`; what a view
reads of the widget's play state is its ``playback`` (:class:`PlaybackState`).

What the two views share is written here once:

* the keys (:meth:`EngineView.on_key`): space = play/pause, ``s`` = step one
  frame, ``r`` = reset the camera, nothing with a modifier held;
* the camera setter (:attr:`EngineView.camera_state`): validation by
  :func:`check_camera_state`, merging with the current camera, position and
  target apart; the view only aims its camera (:meth:`EngineView.look`);
* the nominal steps per frame (:meth:`EngineView.nominal_steps`):
  ``round(time_scale * frame_interval / dt)``, capped to
  :data:`MAX_STEPS_PER_FRAME`.

Both engines have every feature of the interface (the teaching views included).

Camera listeners (:meth:`EngineView.add_camera_listener`): a view tells them when its camera
moved, and :meth:`EngineView.accept_camera` moves it without telling them, so views can
follow each other's camera without echoes (a comparison, :mod:`grasswidget.notebook.compare`).

The view is told what to do by the widget and reports back through callbacks
given at construction: ``playback`` (:class:`PlaybackState`, the widget's play state), ``actions``
(:class:`ViewActions`), ``on_error(err)``, ``on_stats(stats)`` and
``on_inspect(blades)``.
"""

from __future__ import annotations

import abc
import inspect
from typing import Callable, Protocol

import numpy as np

from ..errors import GrassTypeError, GrassValueError, ReadOnlyAttributeError, WidgetClosedError
from .engine_inputs import MAX_STEPS_PER_FRAME

__all__ = ["EngineView", "PlaybackState", "ViewActions", "ViewMember", "check_camera_state",
           "MAX_STEPS_PER_FRAME", "CAMERA_KEYS", "FOV_RANGE_DEG"]

#: The keys of a camera state dict.
CAMERA_KEYS = ("position", "target", "fov_deg")
#: The vertical field of view a camera may have, degrees (inclusive).
FOV_RANGE_DEG = (1.0, 179.0)


class PlaybackState(Protocol):
    """The widget's play state, as a view reads it (and, for ``playing``, may set it): two of the
    widget's traits. Not a clock: the kernel engine's clock, which turns wall time into fixed steps,
    is :class:`grasswidget.notebook.clock.SimClock` (``KernelView.clock``)."""

    #: Animate (True) or stand still (False).
    playing: bool
    #: Simulated seconds per wall-clock second while playing (0..10).
    time_scale: float


class ViewActions(Protocol):
    """What a view's keys and pointer gestures ask of the widget."""

    def toggle_play(self) -> None: ...

    def step(self, n: int | None = None) -> None: ...

    def reset_camera(self) -> None: ...

    def inspect(self, ids) -> None: ...


def check_camera_state(state) -> dict:
    """Validate a (partial) camera state and return it with plain floats.

    ``state`` is a dict with any of ``position`` and ``target`` (3 finite numbers
    each, metres, world space) and ``fov_deg`` (vertical field of view, degrees,
    in :data:`FOV_RANGE_DEG`). Raises GrassTypeError for a non-dict and
    GrassValueError naming the key and its range for anything else.
    """
    if not isinstance(state, dict):
        raise GrassTypeError(f"camera_state must be a dict with position, target and fov_deg; got {state!r}")
    unknown = set(state) - set(CAMERA_KEYS)
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
        lo, hi = FOV_RANGE_DEG
        if isinstance(fov, bool) or not isinstance(fov, (int, float, np.number)) or not (lo <= float(fov) <= hi):
            raise GrassValueError(f"camera_state fov_deg must be a number in [{lo:g}, {hi:g}] degrees; got {fov!r}")
        out["fov_deg"] = float(fov)
    return out


class EngineView(abc.ABC):
    """A GrassWidget's view (see the module docstring); both engines implement all of it.

    Every abstract member below is implemented by both views; concrete members
    are the shared behaviour. Sizes are CSS pixels, distances metres (world
    space), times seconds, angles degrees.

    Constructor arguments every view takes (stored by :meth:`__init__`):
    ``size`` ((w, h) CSS pixels), ``params`` (the shared GrassParams),
    ``playback`` (:class:`PlaybackState`), ``actions`` (:class:`ViewActions`),
    ``on_error(err)`` (an exception or a text to show), ``on_stats(dict)``
    (called whenever the stats are refreshed) and ``on_inspect(blades)`` (the
    inspected blades' numbers, a list of dicts; ``[]`` when none).
    """

    #: The engine: "kernel" or "browser".
    backend: str = ""

    def __init__(self, size, params, *, playback: PlaybackState, actions: ViewActions, on_error: Callable,
                 on_stats: Callable, on_inspect: Callable | None = None):
        self.size = (int(size[0]), int(size[1]))
        self.params = params
        self.playback = playback
        self.actions = actions
        self.report_error = on_error
        self.report_stats = on_stats
        self.report_inspected = on_inspect if on_inspect is not None else (lambda blades: None)
        self.closed = False
        #: Functions ``fn(view)`` called when the camera moved (see :meth:`add_camera_listener`).
        self.camera_listeners = []
        self.reported_camera = None  # the camera as the listeners last heard of it
        #: Callables run (no arguments) after each frame the kernel draws, and at each stats message
        #: of the browser engine: where the traces take their samples (grasswidget.notebook.trace_feed).
        self.frame_hooks = []

    def notify_frame(self) -> None:
        """Run :attr:`frame_hooks`; an error in one is reported on the message line, never raised
        into the frame."""
        for hook in list(self.frame_hooks):
            try:
                hook()
            except Exception as err:  # a broken listener must not stop the view
                self.report_error(f"traces: {type(err).__name__}: {err}")

    # ------------------------------------------------------------------ what the widget shows

    @property
    @abc.abstractmethod
    def widget(self):
        """The ipywidget to show for this view (the streaming canvas, or the browser engine's anywidget)."""

    @property
    def scene(self):
        """The kernel engine's :class:`~grasswidget.gpu.scene.GrassScene` (None in the browser engine, which
        keeps its state in the browser, and after close)."""
        return None

    @property
    def canvas(self):
        """The kernel engine's jupyter-rfb canvas widget (None in the browser engine)."""
        return None

    @property
    def controller(self):
        """The kernel engine's pygfx ``OrbitController`` of the camera (None in the browser engine, which orbits
        in the page)."""
        return None

    # ------------------------------------------------------------------ the field

    @property
    @abc.abstractmethod
    def blades(self):
        """The :class:`~grasswidget.core.blades.Blades` of the field (its rest pose)."""

    @property
    def blade_count(self) -> int:
        """Number of blades in the field."""
        return len(self.blades)

    @property
    @abc.abstractmethod
    def colliders(self):
        """The live :class:`~grasswidget.core.colliders.ColliderList` (sphere colliders acting on the grass)."""

    @property
    @abc.abstractmethod
    def ball_scene(self):
        """What :class:`~grasswidget.notebook.ball.BallControl` attaches to: an object with ``field.blades``
        and ``colliders`` (the kernel's GrassScene; a stand-in in the browser engine)."""

    @abc.abstractmethod
    def attach_ball(self, ball) -> None:
        """Move ``ball`` (a BallControl) with shift + drag and roll it with simulated time from now on."""

    @abc.abstractmethod
    def set_blades(self, blades) -> None:
        """Replace the field by ``blades`` (a count or a Blades); the camera, the ball and the
        teaching views are kept."""

    @abc.abstractmethod
    def read_state(self, timeout: float | None = None) -> dict:
        """The blade state of the live engine, as ``GrassField.read_state()`` returns it.

        The browser engine asks the browser and waits for its answer (processing widget messages
        meanwhile, so it works inside a running cell); no answer within ``timeout`` seconds (None: 30)
        raises BrowserTimeoutError (a TimeoutError) naming the browser view."""

    @abc.abstractmethod
    def set_wind_wgsl(self, body: str, select: bool = True) -> None:
        """Use a WGSL snippet as the wind (the body of ``fn user_wind(p, t) -> vec3<f32>``), in the
        live engine. Raises :class:`~grasswidget.errors.WindShaderError` with the line inside ``body``
        when it does not compile (in the browser engine: compiled by the browser; this waits for its
        answer); the old wind stays in force. With ``select``, ``params.wind_field`` becomes "custom".
        Assigning ``params.wind_wgsl`` does the same, reporting an error on the message line."""

    @abc.abstractmethod
    def set_function_overrides(self, overrides) -> None:
        """Run user WGSL (a :class:`~grasswidget.core.wgsl_overrides.FunctionOverrides`, or None for
        the stock functions) in place of stock blade-math functions: the kernel engine compiles them
        now (ExerciseShaderError with the user's line on failure, the old ones stay); the browser
        engine compiles them when it starts and refuses a change later (GrassValueError)."""

    # ------------------------------------------------------------------ time

    @property
    @abc.abstractmethod
    def max_fps(self) -> float:
        """Frames per second asked of the canvas scheduler, the nominal frame rate (the kernel's stream
        cap; the browser's nominal display rate, 60)."""

    @property
    def frame_interval(self) -> float:
        """Nominal seconds between frames at the stream cap, 1 / max_fps."""
        return 1.0 / self.max_fps

    def nominal_steps(self) -> int:
        """Fixed steps of one nominal frame: ``round(time_scale * frame_interval / dt)``, in
        [0, :data:`MAX_STEPS_PER_FRAME`] (the one place this formula is written)."""
        wanted = int(round(float(self.playback.time_scale) * self.frame_interval / float(self.params.dt)))
        return max(0, min(wanted, MAX_STEPS_PER_FRAME))

    @property
    def steps_per_frame(self) -> int:
        """Fixed steps of one nominal frame, round(time_scale * frame_interval / dt), capped: what
        ``step()`` advances by default. While playing the real-time clock decides each frame's steps
        (``stats["steps_per_frame"]``); the browser engine reports the average of its last frames."""
        return self.nominal_steps()

    @property
    @abc.abstractmethod
    def sim_time(self) -> float | None:
        """Simulated seconds since the last ``reset_blades()`` (read-only): every fixed step taken while
        playing or by ``step()`` adds ``params.dt``. None before the browser engine's first stats message;
        there it is as of the last one (about every 0.5 s; its clock runs in the browser)."""

    @property
    @abc.abstractmethod
    def target_fps(self) -> float:
        """Frames per second adaptive resolution aims for while playing (1..240; set through the widget,
        which validates it)."""

    @target_fps.setter
    @abc.abstractmethod
    def target_fps(self, value: float) -> None: ...

    @property
    @abc.abstractmethod
    def render_scale(self) -> float:
        """Fraction of the full pixel ratio live frames render at now (0.5..1; 1 while paused). Save PNG
        and exports always render at full resolution."""

    @abc.abstractmethod
    def set_playing(self, playing: bool) -> None:
        """Animate (True) or stand still (False); pausing stops simulated time at once."""

    @abc.abstractmethod
    def set_time_scale(self, time_scale: float) -> None:
        """Simulated seconds per wall-clock second from now on (already validated: 0..10)."""

    @abc.abstractmethod
    def step(self, n: int) -> None:
        """Advance exactly ``n`` (in [0, MAX_STEPS], validated by the widget: ``core.limits.check_steps``)
        fixed steps of ``params.dt`` and redraw. The kernel engine stops on Ctrl-C between two GPU
        submissions, counts the steps that ran and raises ``core.limits.StepsInterrupted``."""

    @abc.abstractmethod
    def reset_blades(self) -> None:
        """Every blade back to its rest pose; the simulation clock back to 0."""

    @abc.abstractmethod
    def request_draw(self) -> None:
        """Draw a new frame soon (something changed); a view that draws every frame does nothing."""

    # ------------------------------------------------------------------ camera

    @property
    def camera_state(self) -> dict:
        """The camera as a dict: ``position`` and ``target`` (3-tuples of metres, world space; the target
        is the orbit centre) and ``fov_deg`` (vertical field of view, degrees). A drag in the view updates
        it; assigning a dict with any of the three keys moves the camera, in both engines (validated by
        :func:`check_camera_state`; the keys left out keep their values; position and target must differ)."""
        return self.current_camera()

    @camera_state.setter
    def camera_state(self, state):
        state = check_camera_state(state)
        current = self.current_camera()
        position = state.get("position", current["position"])
        target = state.get("target", current["target"])
        if np.allclose(position, target):
            raise GrassValueError(f"camera_state position and target must differ; both are {tuple(position)}")
        self.look(tuple(position), tuple(target), state.get("fov_deg", current["fov_deg"]))
        self.request_draw()

    def add_camera_listener(self, fn: Callable) -> None:
        """Call ``fn(view)`` whenever this view's camera has moved (a drag, the wheel, a pan, code):
        the kernel engine checks after each frame it draws, the browser engine when the browser's
        camera reaches the kernel. Used to link the cameras of a comparison
        (:mod:`grasswidget.notebook.compare`)."""
        if fn not in self.camera_listeners:
            self.camera_listeners.append(fn)
        if self.reported_camera is None:
            self.reported_camera = self.current_camera()

    def remove_camera_listener(self, fn: Callable) -> None:
        """Stop calling ``fn`` (nothing happens when it was not added)."""
        if fn in self.camera_listeners:
            self.camera_listeners.remove(fn)

    def report_camera_moved(self) -> bool:
        """Tell the camera listeners when the camera differs from what they last heard
        (position and target by more than 1e-6 m, the field of view by more than 1e-6 degrees);
        returns whether it did. A view calls this where its camera may have moved."""
        if not self.camera_listeners or self.closed:
            return False
        now = self.current_camera()
        last = self.reported_camera
        if last is not None and all(np.allclose(now[k], last[k], rtol=0.0, atol=1e-6) for k in CAMERA_KEYS):
            return False
        self.reported_camera = now
        for fn in list(self.camera_listeners):
            fn(self)
        return True

    def accept_camera(self, state) -> None:
        """Move the camera to ``state`` (as :attr:`camera_state` takes it) without telling the
        camera listeners: the move came from them (a linked view), so no echo goes back."""
        self.camera_state = state
        self.reported_camera = self.current_camera()

    @abc.abstractmethod
    def current_camera(self) -> dict:
        """The camera now, as :attr:`camera_state` gives it (tuples of floats, fov_deg a float)."""

    @property
    @abc.abstractmethod
    def depth_range(self) -> tuple:
        """(near, far): the camera's clip planes in metres (near > 0, far > near)."""

    @abc.abstractmethod
    def look(self, position, target, fov_deg) -> None:
        """Aim the camera from ``position`` at ``target`` (metres; apart, checked) with a vertical field of
        view of ``fov_deg`` degrees (checked); ``target`` becomes the orbit centre."""

    @abc.abstractmethod
    def reset_camera(self) -> None:
        """Back to the starting view (position, target, field of view)."""

    @abc.abstractmethod
    def set_camera_floor(self, floor: str) -> None:
        """Hold the orbit above ``floor`` from now on: "grass" (the tallest blade's tip plus 0.3 m)
        or "ground" (0.3 m above the ground); already checked (core.orbit_limits.FLOORS)."""

    @property
    @abc.abstractmethod
    def orbit_limits(self):
        """The :class:`~grasswidget.core.orbit_limits.OrbitLimits` every drag, pan and wheel step is held to."""

    # ------------------------------------------------------------------ teaching views

    @abc.abstractmethod
    def set_culling_frozen(self, frozen: bool) -> None:
        """Freeze culling at the current camera (True) or cull against the live camera again (False)."""

    @abc.abstractmethod
    def inspect(self, ids) -> None:
        """Show blades in the inspector (v0, v1, v2, control polygon, force arrows); ``[]`` clears.
        At most 64 ids in [0, blade_count - 1], integers; anything else raises GrassValueError naming
        the limit (nothing changes then)."""

    @property
    @abc.abstractmethod
    def inspected(self) -> tuple:
        """Ids of the inspected blades (ctrl + click or :meth:`inspect`; ``()`` when none)."""

    @abc.abstractmethod
    def read_inspected(self, timeout: float | None = None) -> list:
        """The inspected blades' numbers, as :meth:`GrassScene.read_inspected` returns them: one dict
        per blade with ``id``, ``height`` (m), ``stiffness`` (1/s^2, times ``params.stiffness_scale``),
        ``v0``, ``v1``, ``v2`` and the forces on v2 of the next step (gravity, recovery, wind in m/s^2;
        collision: the push of one step in m), for the current state and parameters; ``[]`` when none
        is inspected.

        In the browser engine the browser computes them (the same inspect.wgsl) and this waits for its
        answer, up to ``timeout`` seconds (None: 30; BrowserTimeoutError naming the browser view)."""

    # ------------------------------------------------------------------ pictures and stats

    @abc.abstractmethod
    def save_png(self, path: str, size) -> str:
        """Write a PNG of the current view at ``size`` (w, h) pixels to ``path``; return ``path``
        (waits for the browser's picture in the browser engine)."""

    @abc.abstractmethod
    def save_png_later(self, path: str, size, done: Callable[[str], None]) -> None:
        """Write a PNG like :meth:`save_png` without blocking the kernel, then call ``done(path)``
        (the Save PNG button, which runs inside a comm message and cannot wait). The kernel engine
        writes it at once."""

    @property
    def stats(self) -> dict:
        """The last stats shown: fps (frames/s delivered to the browser, confirmed by it; frames drawn
        when there is no browser), target_fps, visible (with rastered and occluded: the counts of one
        frame; in the kernel engine the frame at step_count, read when the stats are refreshed; in
        the browser engine the newest the page had read back, a frame or two older), blades, render_ms / readback_ms / encode_send_ms /
        ack_ms (where a frame's time goes, averaged since the last refresh), draw_ms (step + render calls
        of the last frame), gpu_ms (per pass, when the scene reports it), steps_per_frame (of the last
        frame), frame_size (rendered pixels), scale (render scale), sim_speed (simulated / scaled wall
        seconds while playing), step_count (simulation steps so far; None until the browser engine's
        first stats message), switches ({"cull_occlusion", "compute_raster"}: what the "auto" switches
        decided, in words; None before the first window) and trial (True when a trial of the "auto"
        switches ran in the window measured: its frame rate is not the view's); and how old they are
        (:func:`grasswidget.core.engine_inputs.stats_freshness`, the same rule in both engines):
        frame_age_s (wall seconds since the newest frame they describe arrived: acknowledged by the
        browser, or drawn when there is no browser; None before the first), at_rest (True while no
        view is on screen: nothing is drawn, the numbers are the last frame's), stale (True when
        they may not describe what the view would draw now: at rest, playing with a frame older than
        a stats interval, or a change not drawn for longer than one) and waiting (True while playing
        on screen with no frame for ``engine_inputs.WAITING_AFTER_S``, 2 s). Every key is there from
        the start."""
        return self.current_stats()

    @abc.abstractmethod
    def current_stats(self) -> dict:
        """The stats dict with what is known now (no GPU readback, no browser round trip)."""

    @abc.abstractmethod
    def refresh_stats(self) -> None:
        """Measure what can be measured now and pass the stats to ``on_stats``."""

    # ------------------------------------------------------------------ keys, closing

    def on_key(self, event) -> None:
        """A key pressed while the view has focus: ``event`` is a dict with ``key`` (the DOM key name)
        and ``modifiers`` (held modifier names). Space = play/pause, ``s`` = step one frame,
        ``r`` = reset the camera; a key with a modifier held is not ours (the notebook's)."""
        if event.get("modifiers"):
            return
        key = str(event.get("key", "")).lower()
        if key in (" ", "space", "spacebar"):
            self.actions.toggle_play()
        elif key == "s":
            self.actions.step()
        elif key == "r":
            self.actions.reset_camera()

    @abc.abstractmethod
    def close(self) -> None:
        """Release the view's resources (GPU buffers, the canvas or the browser model); idempotent.
        :attr:`closed` is True afterwards."""



_NO_DEFAULT = object()


class ViewMember:
    """The one forwarding between an object that owns a view (GrassWidget, ``view`` attribute) and its
    :class:`EngineView`: a class attribute ``name = ViewMember()`` of the owner *is* the view's member
    of the same name, written and documented once, in :class:`EngineView` (``help()`` shows that text).

    Reading gives ``owner.view.<name>``: a property's value, or the view's bound method (called as the
    owner's). Assigning sets it on the view (only where ``settable``). A method, or an assignment, on an
    owner whose view is closed raises :class:`~grasswidget.errors.WidgetClosedError`. A property read
    with no view (a half-built owner) gives ``no_view`` (None unless given).

    Use it where the owner adds nothing; a member with behaviour of its own (validation, a default
    path, state the owner keeps) stays a method of the owner.
    """

    def __init__(self, *, settable: bool = False, no_view=None):
        self.settable = bool(settable)
        self.no_view = no_view
        self.name = None

    def __set_name__(self, owner, name):
        if not hasattr(EngineView, name):
            raise GrassValueError(f"ViewMember {owner.__name__}.{name}: EngineView has no member {name!r}")
        self.name = name
        self.interface_member = inspect.getattr_static(EngineView, name)
        self.is_method = callable(self.interface_member) and not isinstance(self.interface_member, property)
        self.__doc__ = inspect.getdoc(self.interface_member)

    def _open_view(self, owner):
        view = owner.view
        if view is None or view.closed:
            raise WidgetClosedError(f"this {type(owner).__name__} is closed; create a new one")
        return view

    def __get__(self, owner, owner_type=None):
        if owner is None:
            return self
        if self.is_method:
            return getattr(self._open_view(owner), self.name)
        view = owner.view
        return self.no_view if view is None else getattr(view, self.name)

    def __set__(self, owner, value):
        if not self.settable:
            raise ReadOnlyAttributeError(f"{type(owner).__name__}.{self.name} can only be read")
        setattr(self._open_view(owner), self.name, value)
