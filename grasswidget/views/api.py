"""The one interface between :class:`~grasswidget.GrassWidget` and the engine that shows its meadow.

A *view* (:class:`EngineView`) is one engine's view of a widget: the part that simulates,
draws and shows the meadow. There are two, side by side in this package:

* :class:`grasswidget.views.kernel.KernelView` ("kernel"): a GrassScene rendered in the
  kernel and streamed by jupyter-rfb;
* :class:`grasswidget.views.browser.BrowserEngineView` ("browser"): the same WGSL run in the
  notebook's browser through WebGPU (its anywidget is
  :class:`~grasswidget.browser.engine_widget.BrowserEngineWidget`, not a view).

Both implement every member of :class:`EngineView`; no member is faked or empty in one of
them (tests/notebook/test_view_api.py holds both to that). What only the kernel engine has
(its GrassScene, canvas and camera controller) is the KernelView's own, not the interface's.

A view talks back through one object, its *host* (:class:`ViewHost`): the play state it
follows (:class:`PlayState`: ``playing`` and ``time_scale``, traits the view observes and
may set; the one channel of play state), what its keys and pointer ask for
(``toggle_play``, ``step``, ``reset_camera``, ``inspect``) and what it reports
(``show_error``, ``show_stats``, ``show_inspected``, ``engine_unavailable``,
``engine_adapter``). A picture is one call, :meth:`EngineView.snapshot`, that returns a
:class:`concurrent.futures.Future` of the written path (the browser engine's answers
later; ``result()`` waits for it, handling the notebook's messages meanwhile).

What the two views share is written here once: the keys (space = play/pause, ``s`` =
step one frame, ``r`` = reset the camera, nothing with a modifier held); the camera
setter (:attr:`EngineView.camera_state`, validated by :func:`check_camera_state`); the
nominal steps per frame (``round(time_scale * frame_interval / dt)``, capped to
:data:`MAX_STEPS_PER_FRAME`); the camera listeners of a comparison
(:meth:`EngineView.add_camera_listener`, :meth:`EngineView.accept_camera` moves the camera
without telling them, so linked views never echo).
"""

from __future__ import annotations

import abc
import dataclasses
import concurrent.futures
import inspect
from typing import Callable, Protocol

import numpy as np
from traitlets import HasTraits

from ..core.engine_inputs import MAX_STEPS_PER_FRAME
from ..core.params import CheckedBool, RangedFloat
from ..errors import GrassTypeError, GrassValueError, ReadOnlyAttributeError, WidgetClosedError
from ..core.interaction import key_action

__all__ = ["EngineView", "PlayState", "ViewHost", "ViewMember", "KernelOnly", "ViewReadings", "reading_doc", "check_camera_state", "done_future",
           "MAX_STEPS_PER_FRAME", "CAMERA_KEYS", "FOV_RANGE_DEG"]

#: The keys of a camera state dict.
CAMERA_KEYS = ("position", "target", "fov_deg")
#: The vertical field of view a camera may have, degrees (inclusive).
FOV_RANGE_DEG = (1.0, 179.0)


class PlayState(HasTraits):
    """The play state a view follows: the one channel between the widget, its panel and its view.
    The view observes both traits (and sets ``playing`` when the page's own keys toggle it)."""

    playing = CheckedBool(True, help="Animate (True) or stand still (False); pausing stops simulated time at once.")
    time_scale = RangedFloat(1.0, 0.0, 10.0, "simulated s per s",
                             help="Simulated seconds per wall-clock second while playing.")


class ViewHost(Protocol):
    """What a view asks of, and reports to, whoever shows it (one object instead of callbacks)."""

    #: The play state the view follows (observed; ``playing`` may be set by the view).
    play: PlayState

    def toggle_play(self) -> None:
        """The view's key asks: play if paused, pause if playing."""

    def step(self) -> None:
        """The view's key asks: pause and advance one frame's worth of steps."""

    def reset_camera(self) -> None:
        """The view's key asks: back to the start camera."""

    def inspect(self, ids) -> None:
        """A ctrl + click asks: inspect these blade ids (``[]`` clears)."""

    def show_error(self, err) -> None:
        """Show an exception or a text on the message line (never raises)."""

    def show_stats(self, stats: dict) -> None:
        """The stats were refreshed (:attr:`EngineView.stats`)."""

    def show_inspected(self, rows: list) -> None:
        """The inspected blades' numbers (as :meth:`EngineView.read_inspected` gives them; ``[]``: none)."""

    def engine_unavailable(self, reason: str) -> None:
        """The engine cannot run here (a browser without WebGPU): ``reason`` in words."""

    def engine_adapter(self, detail: str) -> None:
        """The engine has started on an adapter (the browser engine's report, in words)."""


def _doc_field(doc: str):
    return dataclasses.field(metadata={"doc": doc})


@dataclasses.dataclass(frozen=True)
class ViewReadings:
    """What a view says now (:attr:`EngineView.readings`), read in one call; each field documented
    in its ``metadata["doc"]`` (:func:`reading_doc`)."""

    max_fps: float = _doc_field(
        "Frames per second asked of the canvas scheduler, the nominal frame rate (the kernel's stream cap; "
        "the browser's nominal display rate, 60).")
    steps_per_frame: int = _doc_field(
        "Fixed steps of one nominal frame, round(time_scale * frame_interval / dt), capped to "
        "MAX_STEPS_PER_FRAME: what ``step()`` advances by default. While playing the real-time clock decides "
        "each frame's steps (``stats['steps_per_frame']``); the browser engine reports the average of its "
        "last frames.")
    sim_time: float | None = _doc_field(
        "Simulated seconds since the last ``reset_blades()`` (read-only): every fixed step taken while "
        "playing or by ``step()`` adds ``params.dt``. None before the browser engine's first stats message; "
        "there it is as of the last one (about every 0.5 s; its clock runs in the browser).")
    target_fps: float = _doc_field(
        "Frames per second adaptive resolution aims for while playing (1..240; set through the widget, "
        "which validates it; the browser engine keeps and reports it, drawing at the browser's own rate).")
    render_scale: float = _doc_field(
        "Fraction of the full pixel ratio live frames render at now (0.5..1; 1 while paused and always in "
        "the browser engine). Save PNG and exports always render at full resolution.")
    depth_range: tuple = _doc_field("(near, far): the camera's clip planes in metres (near > 0, far > near).")
    orbit_limits: object = _doc_field(
        "The :class:`~grasswidget.core.orbit_limits.OrbitLimits` every drag, pan and wheel step is held to.")
    inspected: tuple = _doc_field("Ids of the inspected blades (ctrl + click or ``inspect``; ``()`` when none).")


def reading_doc(name: str) -> str:
    """The documentation of the :class:`ViewReadings` field ``name``."""
    return next(f.metadata["doc"] for f in dataclasses.fields(ViewReadings) if f.name == name)


def done_future(fn, *args) -> concurrent.futures.Future:
    """A Future already holding ``fn(*args)``'s result, or the exception it raised."""
    future = concurrent.futures.Future()
    try:
        future.set_result(fn(*args))
    except Exception as err:  # noqa: BLE001 - the caller sees it from result()
        future.set_exception(err)
    return future


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

    Sizes are CSS pixels, distances metres (world space), times seconds, angles degrees.
    Constructor arguments every view takes: ``size`` ((w, h) CSS pixels), ``params`` (the
    shared GrassParams) and ``host`` (a :class:`ViewHost`).
    """

    #: The engine: "kernel" or "browser".
    backend: str = ""

    def __init__(self, size, params, *, host: ViewHost):
        self.size = (int(size[0]), int(size[1]))
        self.params = params
        self.host = host
        self.play: PlayState = host.play
        #: True after :meth:`close`.
        self.closed = False
        self._camera_listeners = []
        self._reported_camera = None  # the camera as the listeners last heard of it
        #: Callables run (no arguments) after each frame the kernel draws, and at each stats message
        #: of the browser engine: where the traces take their samples (grasswidget.views.trace_feed).
        self.frame_hooks = []
        self.play.observe(self._play_changed, names=["playing", "time_scale"])

    def _play_changed(self, change):
        if self.closed:
            return
        if change["name"] == "playing":
            self._set_playing(bool(change["new"]))
        else:
            self._set_time_scale(float(change["new"]))
        self.host.show_stats(self.stats)

    @abc.abstractmethod
    def _set_playing(self, playing: bool) -> None:
        """The engine's part of ``play.playing`` changing (a view observes it; nobody calls this)."""

    def _set_time_scale(self, time_scale: float) -> None:
        """The engine's part of ``play.time_scale`` changing; a view that reads it each frame needs none."""

    def _notify_frame(self) -> None:
        """Run :attr:`frame_hooks`; an error in one is reported on the message line, never raised
        into the frame."""
        for hook in list(self.frame_hooks):
            try:
                hook()
            except Exception as err:  # a broken listener must not stop the view
                self.host.show_error(f"traces: {type(err).__name__}: {err}")

    # ------------------------------------------------------------------ what the widget shows

    @property
    @abc.abstractmethod
    def widget(self):
        """The ipywidget to show for this view (the streaming canvas, or the browser engine's anywidget)."""

    # ------------------------------------------------------------------ the field

    @property
    @abc.abstractmethod
    def blades(self):
        """The :class:`~grasswidget.core.blades.Blades` of the field (its rest pose)."""

    @property
    @abc.abstractmethod
    def colliders(self):
        """The live :class:`~grasswidget.core.colliders.ColliderList` (sphere colliders acting on the grass)."""

    @abc.abstractmethod
    def attach_ball(self, ball) -> None:
        """Move ``ball`` (a :class:`~grasswidget.notebook.ball.BallControl`, already attached to this
        view's colliders) with shift + drag and roll it with simulated time from now on."""

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

    # ------------------------------------------------------------------ readings

    @property
    def readings(self) -> ViewReadings:
        """What the view says now, in one read (a :class:`ViewReadings`: frame rates, the simulated
        clock, the render scale, the camera's clip planes and orbit limits, the inspected ids)."""
        return ViewReadings(**{f.name: self._read(f.name) for f in dataclasses.fields(ViewReadings)})

    def _read(self, name: str):
        """One field of :attr:`readings` alone (a :class:`ViewMember` of the widget reads just that one)."""
        value = getattr(self, "_read_" + name)()
        kind = {"max_fps": float, "steps_per_frame": int, "target_fps": float, "render_scale": float,
                "inspected": tuple}.get(name)
        return value if kind is None else kind(value)

    @abc.abstractmethod
    def _read_max_fps(self) -> float:
        """The engine's :attr:`ViewReadings.max_fps`."""

    def _read_steps_per_frame(self) -> int:
        """The engine's :attr:`ViewReadings.steps_per_frame` (the nominal steps unless it knows better)."""
        return self._nominal_steps()

    @abc.abstractmethod
    def _read_sim_time(self) -> float | None:
        """The engine's :attr:`ViewReadings.sim_time`."""

    @abc.abstractmethod
    def _read_target_fps(self) -> float:
        """The engine's :attr:`ViewReadings.target_fps`."""

    @abc.abstractmethod
    def _read_render_scale(self) -> float:
        """The engine's :attr:`ViewReadings.render_scale`."""

    @abc.abstractmethod
    def _read_depth_range(self) -> tuple:
        """The engine's :attr:`ViewReadings.depth_range`."""

    @abc.abstractmethod
    def _read_orbit_limits(self):
        """The engine's :attr:`ViewReadings.orbit_limits`."""

    @abc.abstractmethod
    def _read_inspected(self) -> tuple:
        """The engine's :attr:`ViewReadings.inspected`."""

    # ------------------------------------------------------------------ time

    def _nominal_steps(self) -> int:
        """Fixed steps of one nominal frame: ``round(time_scale * frame_interval / dt)``, in
        [0, :data:`MAX_STEPS_PER_FRAME`] (the one place this formula is written)."""
        wanted = int(round(float(self.play.time_scale) / self._read_max_fps() / float(self.params.dt)))
        return max(0, min(wanted, MAX_STEPS_PER_FRAME))

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
        return self._current_camera()

    @camera_state.setter
    def camera_state(self, state):
        state = check_camera_state(state)
        current = self._current_camera()
        position = state.get("position", current["position"])
        target = state.get("target", current["target"])
        if np.allclose(position, target):
            raise GrassValueError(f"camera_state position and target must differ; both are {tuple(position)}")
        self._look(tuple(position), tuple(target), state.get("fov_deg", current["fov_deg"]))
        self.request_draw()

    def add_camera_listener(self, fn: Callable) -> Callable[[], None]:
        """Call ``fn(view)`` whenever this view's camera has moved (a drag, the wheel, a pan, code):
        the kernel engine checks after each frame it draws, the browser engine when the browser's
        camera reaches the kernel. Returns a function of no arguments that stops the calls
        (idempotent). Used to link the cameras of a comparison (:mod:`grasswidget.notebook.compare`)."""
        if fn not in self._camera_listeners:
            self._camera_listeners.append(fn)
        if self._reported_camera is None:
            self._reported_camera = self._current_camera()

        def remove():
            if fn in self._camera_listeners:
                self._camera_listeners.remove(fn)

        return remove

    def _report_camera_moved(self) -> bool:
        """Tell the camera listeners when the camera differs from what they last heard
        (position and target by more than 1e-6 m, the field of view by more than 1e-6 degrees);
        returns whether it did. A view calls this where its camera may have moved."""
        if not self._camera_listeners or self.closed:
            return False
        now = self._current_camera()
        last = self._reported_camera
        if last is not None and all(np.allclose(now[k], last[k], rtol=0.0, atol=1e-6) for k in CAMERA_KEYS):
            return False
        self._reported_camera = now
        for fn in list(self._camera_listeners):
            fn(self)
        return True

    def accept_camera(self, state) -> None:
        """Move the camera to ``state`` (as :attr:`camera_state` takes it) without telling the
        camera listeners: the move came from them (a linked view), so no echo goes back."""
        self.camera_state = state
        self._reported_camera = self._current_camera()

    @abc.abstractmethod
    def _current_camera(self) -> dict:
        """The camera now, as :attr:`camera_state` gives it (tuples of floats, fov_deg a float)."""

    @abc.abstractmethod
    def _look(self, position, target, fov_deg) -> None:
        """Aim the camera from ``position`` at ``target`` (metres; apart, checked) with a vertical field of
        view of ``fov_deg`` degrees (checked); ``target`` becomes the orbit centre (:attr:`camera_state`'s
        setter calls it)."""

    @abc.abstractmethod
    def reset_camera(self) -> None:
        """Back to the starting view (position, target, field of view)."""

    def set_options(self, *, camera_floor: str | None = None, culling_frozen: bool | None = None,
                    target_fps: float | None = None) -> None:
        """Change the view's options, only those given (None: unchanged), all already checked by the
        widget's traits:

        - ``camera_floor``: hold the orbit above "grass" (the tallest blade's tip plus 0.3 m) or
          "ground" (0.3 m above the ground) from now on (:data:`grasswidget.core.orbit_limits.FLOORS`);
        - ``culling_frozen``: freeze culling at the current camera (True) or cull against the live
          camera again (False);
        - ``target_fps``: frames per second adaptive resolution aims for while playing (1..240;
          :attr:`target_fps` reads it back).
        """
        if camera_floor is not None:
            self._set_camera_floor(camera_floor)
        if culling_frozen is not None:
            self._set_culling_frozen(bool(culling_frozen))
        if target_fps is not None:
            self._set_target_fps(target_fps)

    @abc.abstractmethod
    def _set_camera_floor(self, floor: str) -> None:
        """The engine's part of ``set_options(camera_floor=...)``."""

    @abc.abstractmethod
    def _set_culling_frozen(self, frozen: bool) -> None:
        """The engine's part of ``set_options(culling_frozen=...)``."""

    @abc.abstractmethod
    def _set_target_fps(self, value: float) -> None:
        """The engine's part of ``set_options(target_fps=...)``."""

    # ------------------------------------------------------------------ teaching views

    @abc.abstractmethod
    def inspect(self, ids) -> None:
        """Show blades in the inspector (v0, v1, v2, control polygon, force arrows); ``[]`` clears.
        At most 64 ids in [0, blade_count - 1], integers; anything else raises GrassValueError naming
        the limit (nothing changes then)."""

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
    def snapshot(self, path: str, size) -> concurrent.futures.Future:
        """Write a PNG of the current view at ``size`` (w, h) pixels to ``path``, rendered at full
        resolution; returns a Future of ``path``. The kernel engine writes it now (the Future is done);
        the browser engine asks the browser and writes it when the picture comes, without blocking
        (the Save PNG button runs inside a comm message and cannot wait); its ``result(timeout)``
        waits, handling the notebook's messages meanwhile."""

    @property
    @abc.abstractmethod
    def stats(self) -> dict:
        """The stats with what is known now (no GPU readback, no browser round trip): fps (frames/s
        delivered to the browser, confirmed by it, plus those not sent again as unchanged; frames drawn
        when there is no browser), target_fps,
        visible (with rastered and occluded: the counts of one frame; in the kernel engine the frame at
        step_count, read when the stats are refreshed; in the browser engine the newest the page had
        read back, a frame or two older), blades; where a frame's time goes, in ms per frame averaged
        over the stats window (the kernel engine's live view; None where unknown): render_ms (steps +
        render calls), readback_ms (the pixels downloaded), encode_ms (the JPEG, on a worker thread while
        the next frame renders), send_ms (handing it to the comm), ack_ms (sent to the page's
        acknowledgement, jupyter-rfb's frame feedback); unchanged_fps (frames/s the view did not render or
        send again because nothing changed: the page already shows them; counted in fps), draw_ms (step + render calls of
        the last frame), gpu_ms (per pass, when the scene reports it: the simulation's on a GPU adapter only, FrameStats.simulation_timed), steps_per_frame (of the last
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

    @abc.abstractmethod
    def refresh_stats(self) -> None:
        """Measure what can be measured now and pass the stats to the host's ``show_stats``."""

    # ------------------------------------------------------------------ keys, closing

    def on_key(self, event) -> None:
        """A key pressed while the view has focus: ``event`` is a dict with ``key`` (the DOM key name)
        and ``modifiers`` (held modifier names). Space = play/pause, ``s`` = step one frame,
        ``r`` = reset the camera; a key with a modifier held is not ours (the notebook's). The map is
        :func:`grasswidget.core.interaction.key_action` (the live page runs the same)."""
        action = key_action(event.get("key", ""), tuple(event.get("modifiers") or ()))
        if action is not None:
            getattr(self.host, action)()

    def close(self) -> None:
        """Release the view's resources (GPU buffers, the canvas or the browser model); idempotent.
        :attr:`closed` is True afterwards."""
        if self.closed:
            return
        self.closed = True
        try:
            self.play.unobserve(self._play_changed, names=["playing", "time_scale"])
        except ValueError:
            pass
        self._close()

    @abc.abstractmethod
    def _close(self) -> None:
        """The engine's part of :meth:`close` (called once)."""


_NO_DEFAULT = object()


class ViewMember:
    """The one forwarding between an object that owns a view (GrassWidget, ``view`` attribute) and its
    :class:`EngineView`: a class attribute ``name = ViewMember()`` of the owner *is* the view's member
    of the same name, written and documented once, in :class:`EngineView` (``help()`` shows that text).

    Reading gives ``owner.view.<name>`` (with ``reading=True``: ``owner.view.readings.<name>``, read
    alone): a property's value, or the view's bound method (called as the
    owner's). Assigning sets it on the view (only where ``settable``). A method, or an assignment, on an
    owner whose view is closed raises :class:`~grasswidget.errors.WidgetClosedError`. A property read
    with no view (a half-built owner) gives ``no_view`` (None unless given).

    Use it where the owner adds nothing; a member with behaviour of its own (validation, a default
    path, state the owner keeps) stays a method of the owner.
    """

    def __init__(self, *, settable: bool = False, no_view=None, reading: bool = False):
        self.settable = bool(settable)
        self.no_view = no_view
        #: True: the member is the field of that name of the view's :attr:`~EngineView.readings`.
        self.reading = bool(reading)
        self.name = None

    def __set_name__(self, owner, name):
        if self.reading:
            if name not in {f.name for f in dataclasses.fields(ViewReadings)}:
                raise GrassValueError(f"ViewMember {owner.__name__}.{name}: ViewReadings has no field {name!r}")
            self.name, self.is_method, self.__doc__ = name, False, reading_doc(name)
            return
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
        if view is None:
            return self.no_view
        return view._read(self.name) if self.reading else getattr(view, self.name)

    def __set__(self, owner, value):
        if not self.settable:
            raise ReadOnlyAttributeError(f"{type(owner).__name__}.{self.name} can only be read")
        setattr(self._open_view(owner), self.name, value)


class KernelOnly:
    """An owner's attribute (a GrassWidget's ``scene``, ``canvas``, ``controller``) that is its live
    view's member of the same name while the kernel engine runs (``view.backend == "kernel"``: a
    :class:`~grasswidget.views.kernel.KernelView`), and None with another engine (which has no such
    part: the browser keeps its state, canvas and camera in the page). Not part of the interface."""

    def __set_name__(self, owner, name):
        self.name = name
        self.__doc__ = f"The kernel engine's ``{name}`` (see :class:`KernelView`); None in the browser engine."

    def __get__(self, owner, owner_type=None):
        if owner is None:
            return self
        view = owner.view
        return getattr(view, self.name) if view is not None and view.backend == "kernel" else None
