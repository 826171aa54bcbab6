"""The widget's engine: which one runs, the view it shows, and the switch between them.

:class:`EngineSwitch` is the one part of a :class:`~grasswidget.GrassWidget` that knows
the engines. It checks what an engine takes (blade counts, streaming settings), builds
the live view (:class:`~grasswidget.views.kernel.KernelView` or
:class:`~grasswidget.views.browser.BrowserEngineView`), runs the "auto" rule
(:mod:`grasswidget.notebook.engine_auto`) and the fall back to kernel streaming when the
browser has no WebGPU, and swaps the view at run time with the camera, floor, ball, play
state, frozen culling and inspected blades carried over.

It is the views' host (:class:`~grasswidget.views.api.ViewHost`): their play state is
the widget's :class:`~grasswidget.notebook.widget_state.WidgetState` (``playing`` and
``time_scale``, observed by the view), their keys and clicks go to ``commands`` (an
object with ``toggle_play()``, ``step()``, ``reset_camera()`` and ``inspect(ids)``), and
what they report goes out as events (:meth:`EngineSwitch.on`): ``"error"`` (an exception
or a text), ``"stats"`` (the stats dict, with ``playing``), ``"inspected"`` (rows),
``"note"`` (a sentence for the message line) and ``"view"`` (the new view after a swap).
The other parts follow the live view through the ``"view"`` event, never through the
widget.
"""

from __future__ import annotations

import numpy as np

from . import engine_auto
from ..core.blades import Blades
from ..errors import GrassTypeError, GrassValueError
from ..views import engines
from ..views.kernel import STATS_INTERVAL, KernelView, streaming_defaults
from .shadows_default import ShadowsDefault

__all__ = ["EngineSwitch", "BACKENDS", "check_backend", "check_params", "check_streaming", "streaming_defaults", "STATS_INTERVAL"]

#: The engines a GrassWidget can run on (``backend=``).
BACKENDS = ("kernel", "browser", "auto")

#: The events :meth:`EngineSwitch.on` takes.
EVENTS = ("error", "stats", "inspected", "note", "view")


def _check_number(name, value, lo, hi, integer=False):
    kind = "an integer" if integer else "a number"
    types = (int, np.integer) if integer else (int, float, np.integer, np.floating)
    if isinstance(value, bool) or not isinstance(value, types) or not (lo <= value <= hi):
        raise GrassValueError(f"{name} must be {kind} in [{lo}, {hi}]; got {value!r}")
    return value


def check_streaming(*, max_fps=None, quality=None, pixel_ratio=None, target_fps=None) -> dict:
    """The streaming settings a user gave (None: the adapter's default), checked: ``max_fps``
    1..240 frames/s, ``quality`` an integer 1..100 (JPEG), ``pixel_ratio`` 0.25..4 rendered pixels
    per CSS pixel, ``target_fps`` 1..240. Returns {max_fps, quality, max_pixel_ratio, target_fps}
    with the ones given; a bad one raises GrassValueError naming it and its range."""
    from ..views.adaptive import check_target_fps

    out = {}
    if max_fps is not None:
        out["max_fps"] = float(_check_number("max_fps", max_fps, 1, 240))
    if quality is not None:
        if isinstance(quality, bool) or not isinstance(quality, int) or not (1 <= quality <= 100):
            raise GrassValueError(f"quality must be an integer in [1, 100] (JPEG quality); got {quality!r}")
        out["quality"] = quality
    if pixel_ratio is not None:
        out["max_pixel_ratio"] = float(_check_number("pixel_ratio", pixel_ratio, 0.25, 4))
    if target_fps is not None:
        out["target_fps"] = check_target_fps(target_fps)
    return out


def check_params(params):
    """``params`` if it is None or a GrassParams; anything else raises GrassTypeError naming ``params``."""
    from ..core.params import GrassParams

    if params is not None and not isinstance(params, GrassParams):
        raise GrassTypeError(f"params must be a GrassParams or None, not {type(params).__name__}")
    return params


def check_backend(backend) -> str:
    """``backend`` if it is one of :data:`BACKENDS`; else GrassValueError naming them."""
    if not isinstance(backend, str) or backend not in BACKENDS:
        raise GrassValueError(f"backend must be one of {', '.join(map(repr, BACKENDS))}; got {backend!r}")
    return backend


class EngineSwitch:
    """The live engine of one widget (see the module docstring).

    Args:
        backend: "kernel", "browser" or "auto" (checked by :func:`check_backend`).
        size: (w, h) of the view, CSS pixels.
        state: the widget's :class:`~grasswidget.notebook.widget_state.WidgetState`.
        streaming_overrides: {max_fps, quality, max_pixel_ratio, target_fps} given by the user.
        preset, function_overrides: as GrassWidget takes them.

    Call :meth:`start` (with the blades and params, once the params exist) to make the first view.
    Attributes: ``view`` (the live view, None before start and after close), ``requested``
    (the ``backend`` asked for), ``auto`` (the AutoEngine for "auto", else None),
    ``max_blades``, ``cpu`` (True/False where the kernel's adapter is known, None before).
    """

    def __init__(self, backend, size, state, *, streaming_overrides, preset=None, function_overrides=None,
                 commands=None):
        from ..core.presets import PRESETS
        from ..core.wgsl_overrides import FunctionOverrides

        self.requested = check_backend(backend)
        if function_overrides is not None and not isinstance(function_overrides, FunctionOverrides):
            raise GrassTypeError("function_overrides must be a FunctionOverrides (e.g. gw.exercise(name).overrides(code)) "
                                 f"or None; got {type(function_overrides).__name__}")
        if preset is not None and preset not in PRESETS:
            raise GrassValueError(f"preset must be None or one of {', '.join(PRESETS)}; got {preset!r}")
        self.size = size
        self.play = state  # the ViewHost's play state: a PlayState (the widget's state)
        self.state = state
        self.preset = preset
        self.function_overrides = function_overrides
        self.commands = commands
        self.view = None
        self.blades = self.params = None
        self._listeners = {name: [] for name in EVENTS}
        self.auto = None
        if backend == "auto":  # the kernel's adapter decides now where it can; else the page's, when shown
            self.auto = engine_auto.AutoEngine(*engine_auto.kernel_adapter(), on_choice=self._on_engine_choice)
            backend = self.auto.engine
        self.first_engine = backend
        self.overrides = dict(streaming_overrides)
        # The kernel's adapter (2 s to open lavapipe) is asked only when the kernel renders.
        self.cpu = engines.kernel_is_cpu() if backend == "kernel" else None
        self.streaming = dict(streaming_defaults(self.cpu if self.cpu is not None else True), **self.overrides)
        if backend == "kernel":
            # The slider's top: the adapter's comfortable maximum, within what memory and the GPU's buffers allow.
            self.max_blades = min(self.streaming["max_blades"], engines.kernel_max_blades())
        else:  # the browser's device decides; the blade state is still built in the kernel's memory
            self.max_blades = engines.browser_max_blades()
        self.streaming["max_blades"] = self.max_blades
        self.sun_default = None

    # ------------------------------------------------------------------ events

    def on(self, event: str, fn) -> None:
        """Call ``fn(value)`` at each ``event`` (one of :data:`EVENTS`)."""
        if event not in self._listeners:
            raise GrassValueError(f"event must be one of {', '.join(EVENTS)}; got {event!r}")
        self._listeners[event].append(fn)

    def _emit(self, event, value):
        for fn in list(self._listeners[event]):
            fn(value)

    # ------------------------------------------------------------------ the ViewHost protocol

    def toggle_play(self):
        self.commands.toggle_play()

    def step(self):
        self.commands.step()

    def reset_camera(self):
        self.commands.reset_camera()

    def inspect(self, ids):
        self.commands.inspect(ids)

    def show_error(self, err):
        self._emit("error", err)

    def show_stats(self, stats):
        self._emit("stats", dict(stats, playing=bool(self.state.playing)))  # the status says "paused"

    def show_inspected(self, rows):
        self._emit("inspected", rows)

    def engine_adapter(self, detail):
        if self.sun_default is not None:
            self.sun_default.apply_engine_adapter(detail)

    def engine_unavailable(self, reason):
        """The browser has no WebGPU adapter: switch to kernel streaming, keep every control."""
        if self.view is None or self.view.closed or self.view.backend != "browser":
            return
        try:
            new = self.new_kernel_view()
        except Exception as err:  # no adapter in the kernel either
            self.show_error(f"WebGPU is not available in this browser ({reason}), and the kernel cannot "
                            f"render either: {err}")
            return
        self.replace(new)
        self.sun_default.apply(cpu_adapter=self.cpu is not False)  # the kernel's adapter draws now
        self.show_error(f"WebGPU is not available in this browser ({reason}): the kernel renders the view "
                        "and streams it instead (use Chrome or Edge, or enable WebGPU, for backend='browser')")

    # ------------------------------------------------------------------ blades

    def check_blades(self, blades):
        """``blades`` (a count or a Blades) if this engine takes it; else GrassTypeError or a
        GrassValueError naming the limit."""
        if isinstance(blades, Blades):
            if len(blades) > self.max_blades:
                raise GrassValueError(f"blades: at most {self.max_blades} blades on this adapter; got {len(blades)}")
            return blades
        if isinstance(blades, bool) or not isinstance(blades, (int, np.integer)):
            raise GrassTypeError(f"blades must be a blade count (int) or a grasswidget.Blades, not {type(blades).__name__}")
        if blades >= 1 and self.cpu is not None:  # the kernel renders (the browser's own limits apply there)
            engines.check_kernel_blades(blades, "blades")  # memory and GPU buffers, as GrassScene and the CLI do
        if not (1 <= int(blades) <= self.max_blades):
            raise GrassValueError(f"blades must be an integer in [1, {self.max_blades}] on this adapter; got {blades!r}")
        return int(blades)

    # ------------------------------------------------------------------ views

    def request_draw(self, _change=None):
        """Ask the live view for a new frame (a parameter or the ball changed); nothing once closed."""
        if self.view is not None and not self.view.closed:
            self.view.request_draw()

    def default_params(self):
        """A new GrassParams for a widget given none: the sunlight's default for the adapter that
        draws (:func:`~grasswidget.core.params.sunlight_defaults`), then the preset's own values
        (the cis565 preset's 40 m distance culling), as GrassScene.preset gives them."""
        from ..core.presets import preset_params
        from ..core.params import GrassParams, sunlight_defaults

        sun = sunlight_defaults(cpu_adapter=self.cpu is not False)
        return GrassParams(**{**sun, **(preset_params(self.preset) if self.preset else {})})

    def start(self, blades, params, own_params: bool):
        """Make the first view for ``blades`` (checked) with ``params``; the sunlight's default
        follows the adapter that draws while ``own_params`` (the widget made them)."""
        self.blades = blades
        self.params = params
        self.sun_default = ShadowsDefault(params, own=own_params)
        self.view = self.new_kernel_view() if self.first_engine == "kernel" else self.new_browser_view()
        self.state.observe(self._on_culling_frozen, names="culling_frozen")
        return self.view

    def announce(self):
        """Say which engine "auto" chose and why (a ``"note"``); nothing for "kernel" and "browser"."""
        if self.auto is not None:
            self._emit("note", self.auto.choice.reason)

    def _on_culling_frozen(self, change):
        if self.view is not None and not self.view.closed:
            self.view.set_options(culling_frozen=bool(change["new"]))

    def new_kernel_view(self):
        """A new kernel view of the field (the kernel's adapter is asked now if it was not)."""
        if self.cpu is None:  # a browser widget falling back: now the kernel's adapter matters
            self.cpu = engines.kernel_is_cpu()
            self.streaming = dict(streaming_defaults(self.cpu), **self.overrides, max_blades=self.max_blades)
        view = KernelView(self.blades, self.size, self.params, host=self, preset=self.preset, streaming=self.streaming)
        if self.function_overrides is not None:
            try:
                view.set_function_overrides(self.function_overrides)
            except BaseException:
                view.close()
                raise
        return view

    def new_browser_view(self):
        """A new browser view of the field."""
        from ..views.browser import BrowserEngineView

        return BrowserEngineView(self.blades, self.size, self.params, host=self, preset=self.preset,
                                 pixel_ratio=self.overrides.get("max_pixel_ratio"),
                                 target_fps=self.streaming["target_fps"], function_overrides=self.function_overrides)

    def set_target_fps(self, value):
        """The frame rate adaptive resolution aims for, in the live view and any later one (1..240;
        else GrassValueError naming ``target_fps`` and the range, and the old value stays)."""
        from ..views.adaptive import check_target_fps

        value = check_target_fps(value)
        if self.view is not None:
            self.view.set_options(target_fps=value)
        self.streaming["target_fps"] = value
        self.overrides["target_fps"] = value

    def replace(self, new):
        """Put ``new`` (the other engine's view) in place of the live view, with the camera, floor,
        ball, play state, frozen culling and inspected blades carried over; the old view closes.
        The ``"view"`` event tells the other parts (the ball, the chart, the stage)."""
        old = self.view
        camera, inspected = old.camera_state, tuple(old.readings.inspected)
        self.view = new
        new.set_options(camera_floor=self.state.camera_floor)
        self._emit("view", new)  # the ball joins the new engine's colliders first, then the view sends them
        try:
            new.camera_state = camera
        except Exception:
            pass
        old.close()
        if self.state.culling_frozen:
            new.set_options(culling_frozen=True)
        if inspected:
            try:
                new.inspect(list(inspected))
            except Exception:
                pass

    def _on_engine_choice(self, choice):
        """The page reported its adapter ("auto"): run the engine the rule chose, say which and why."""
        if self.view is None or self.view.closed:
            return
        try:
            if choice.engine == "browser" and self.view.backend != "browser":
                self.replace(self.new_browser_view())
                self.sun_default.apply(cpu_adapter=False)  # the page's GPU draws now: the sunlight's GPU default
        except Exception as err:  # noqa: BLE001 - never raise into the comm handler; the kernel view stays
            self.show_error(f"{choice.reason}; starting the browser engine failed ({err}): the kernel engine stays")
            return
        self._emit("note", choice.reason)

    def close(self):
        """Close the live view and the "auto" probe."""
        try:
            self.state.unobserve(self._on_culling_frozen, names="culling_frozen")
        except ValueError:
            pass
        if self.view is not None:
            self.view.close()
        if self.auto is not None:
            self.auto.close()
