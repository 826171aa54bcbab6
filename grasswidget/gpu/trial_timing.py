"""The kernel engine's side of the "auto" switches (occlusion culling, the compute rasterizer).

:func:`grasswidget.gpu.render_frame` asks :func:`begin_frame` which value each GrassField's
switches have for this frame and calls :meth:`FrameSwitches.end` after it rendered. The rule
and the trial are :class:`grasswidget.core.auto_switches.AutoSwitches` (pure Python, one per field);
this module only times the frames and reads the GPU's counts for it: while a field is being
tried, the frame is GPU-synchronised before and after the render (a 16-byte readback waits for
the queue), so its time is the render's, and the blades drawn, occluded and drawn in compute
are read back right after it. Frames outside a trial are not synchronised. The time
(:func:`trial_clock`) is, on a GPU adapter with timestamp queries, the GPU time of the frame's
passes (:class:`grasswidget.gpu.stats.PassTimer`: every compute and render pass of the render, summed):
a synchronised frame's wall time there is mostly the host's work, which moves by more than the
switches change (an H200's 2^20 meadow: frames of 6-17 ms on the wall for 3.5-4 ms of GPU work,
and a trial that decided the compute rasterizer differently from run to run). On a GPU adapter
without them it is wall time; on a CPU adapter the process's CPU time (lavapipe renders in this
process's threads: its CPU time is the render's work, and moves far less than wall time when
other processes load the machine). While a field's culling is frozen its switches hold the values
of the last frame before freezing (the camera flying around a frozen view starts no trial, and a
trial in progress is suspended until culling is unfrozen: :mod:`grasswidget.core.auto_switches`).
"""

from __future__ import annotations

import time
import weakref

import numpy as np
import wgpu

from ..core.auto_switches import SWITCHES, AutoSwitches, DecisionContext
from .adapter import ensure_device

__all__ = ["begin_frame", "switches_of", "FrameSwitches", "wait_for_queue", "switch_texts", "trial_mark",
           "trial_clock"]

_STATE: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()
_SYNC = {}
_TIMERS = {}  # id(device) -> (device, PassTimer): the trial frames' GPU timer of each device


def switches_of(field) -> AutoSwitches:
    """The :class:`grasswidget.core.auto_switches.AutoSwitches` of ``field`` (made on first use)."""
    state = _STATE.get(field)
    if state is None:
        state = _STATE[field] = AutoSwitches()
    return state


def wait_for_queue(device=None):
    """Block until the GPU finished everything submitted so far (a 16-byte readback)."""
    _sync(device or ensure_device())


def trial_clock(device=None) -> str:
    """What a trial frame's time is on ``device`` (default: grasswidget's): "cpu" (the process's CPU
    time: a CPU adapter), "gpu" (the GPU time of the frame's passes: a GPU adapter with the
    timestamp-query feature) or "wall" (wall time: a GPU adapter without it). See the module docstring."""
    from .adapter import is_cpu_adapter

    if is_cpu_adapter():
        return "cpu"
    device = device or ensure_device()
    return "gpu" if "timestamp-query" in device.features else "wall"


def _clock() -> float:
    """Seconds: the process's CPU time on a CPU adapter, else wall time (see the module docstring)."""
    from .adapter import is_cpu_adapter

    return time.process_time() if is_cpu_adapter() else time.perf_counter()


def _pass_timer(device):
    """The trial frames' :class:`grasswidget.gpu.stats.PassTimer` of ``device`` when :func:`trial_clock`
    is "gpu", else None."""
    if trial_clock(device) != "gpu":
        return None
    entry = _TIMERS.get(id(device))
    if entry is None or entry[0] is not device:
        from .stats import PassTimer

        entry = _TIMERS[id(device)] = (device, PassTimer(device))
    return entry[1]


def _sync(device):
    buf = _SYNC.get(id(device))
    if buf is None:
        buf = _SYNC[id(device)] = device.create_buffer(size=16, usage=wgpu.BufferUsage.COPY_SRC | wgpu.BufferUsage.COPY_DST)
    device.queue.read_buffer(buf)


_VERSIONS: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def _params_key(params) -> tuple:
    """(id, changes so far) of ``params``: any change of a trait but the switches bumps it
    (an observer; cheaper per frame than comparing every value)."""
    count = _VERSIONS.get(params)
    if count is None:
        count = _VERSIONS[params] = [0]

        def bump(change, count=count):
            if change["name"] not in SWITCHES:
                count[0] += 1

        params.observe(bump)
    return (id(params), count[0])


def context_of(field, camera) -> DecisionContext:
    """The :class:`DecisionContext` of ``field`` seen by ``camera`` (a pygfx camera)."""
    eye = np.asarray(camera.world.position, np.float64)
    forward = np.asarray(camera.world.forward, np.float64)
    reach = max(float(np.linalg.norm(eye)), 1.0)  # fields sit around the origin: distance to it
    target = eye + forward * reach
    return DecisionContext(tuple(map(float, eye)), tuple(map(float, target)), int(field.count), None,
                           _params_key(field.params))


class FrameSwitches:
    """The switch values of one frame's fields, and the timing of a trial frame."""

    def __init__(self, fields, camera):
        self.values = {}
        self.measured = []
        for field in fields:
            state = switches_of(field)
            settings = {name: getattr(field.params, name) for name in SWITCHES}
            # Culling frozen (a teaching view): the switches hold their values while the camera flies
            # around it, and a trial in progress is suspended (core.auto_switches: "Frozen culling").
            frozen = bool(getattr(field, "culling_frozen", False))
            self.values[field] = state.values(settings, state.context if frozen else context_of(field, camera),
                                              frozen=frozen)
            if state.measuring:
                self.measured.append((field, state))
        self._t0 = None
        self._timer = None
        if self.measured:
            device = ensure_device()
            _sync(device)
            self._timer = _pass_timer(device)
            if self._timer is not None:
                self._timer.start()
            self._t0 = _clock()

    def value(self, field, name) -> bool:
        """This frame's value (bool) of switch ``name`` for ``field``."""
        return self.values[field][name]

    def end(self):
        """After the frame's render: time it (GPU-synchronised) and feed the trials."""
        if self._t0 is None:
            return
        timer, self._timer = self._timer, None
        if timer is not None:
            timer.stop()  # every pass of the frame is begun
        _sync(ensure_device())
        ms = (_clock() - self._t0) * 1e3
        if timer is not None:  # the GPU time of the frame's passes, where every pass was timed
            gpu_ms = timer.read_ms()
            if gpu_ms is not None:
                ms = gpu_ms
        for field, state in self.measured:
            rastered = field.read_raster_count() if field.compute_raster_active else 0
            visible = int(field.read_draw_args()[:, 1].sum()) + rastered
            counts = dict(visible=visible, rastered=rastered,
                          occluded=field.read_occluded_count() if self.value(field, "cull_occlusion") else 0)
            state.record(ms, counts)
        self._t0 = None


def switch_texts(field) -> dict:
    """{switch name: words} for ``field``'s switches: "on", "off", "auto (measuring)",
    "auto (on: removed 41 % of blades, ...)" (:func:`grasswidget.core.auto_switches.switch_text`)."""
    state = switches_of(field)
    return {name: state.text(name, getattr(field.params, name)) for name in SWITCHES}


def trial_mark(field) -> tuple:
    """(frames recorded in trials so far, a trial running now) for ``field``: a view that
    measures its frame rate compares two marks to tell whether a trial ran in between (its
    frames are GPU-synchronised and the first after a flip compiles: not the view's rate)."""
    state = switches_of(field)
    return state.trial_frames_run, state.measuring


def begin_frame(fields, camera) -> FrameSwitches:
    """The switch values of ``fields`` for a frame seen by ``camera``; call ``end()`` after it."""
    return FrameSwitches(fields, camera)
