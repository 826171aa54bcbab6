"""Frame statistics that never stall rendering.

After each render, ``FrameStats.after_render()`` copies the indirect draw
arguments (visible blades per LOD class) and, where the device has timestamp
queries, the GPU times of the simulation pass and of the blade draws into a
small ring of mappable buffers and asks for them asynchronously. Results are
picked up on a later frame when the GPU is done, so values may lag a frame or
two; nothing waits for the GPU. ``counts_frame`` says which frame the counts are of
(``frames`` is the number of renders so far): the counts describe the picture on
screen only when the two are equal, which :meth:`FrameStats.settle` makes so (it
waits for the readbacks in flight: what a paused view and the tests use).
"""

from __future__ import annotations

import threading
import time
from collections import deque

import numpy as np
import wgpu

from .. import compat
from ..core.engine_inputs import counter_layout, read_counters
from ..errors import GrassValueError
from .adapter import ensure_device

__all__ = ["FrameStats", "PassTimer", "read_staging", "write_queries_once"]

RING = 3
#: Frames whose counts :meth:`FrameStats.counts_of` still knows.
HISTORY = 16
# Query slots: sim begin/end, draw begin/end.
Q_SIM, Q_DRAW, N_QUERIES = 0, 2, 4



def read_staging(staging, promise, free: list) -> np.ndarray:
    """The bytes of a mapped-for-read staging buffer (waits for ``promise``, its map_async), as a
    NumPy copy; the buffer is unmapped and put back on ``free`` for reuse, also on an error."""
    try:
        promise.sync_wait()
        return np.frombuffer(staging.read_mapped(), np.uint8).copy()
    finally:
        if staging.map_state == "mapped":
            staging.unmap()
        free.append(staging)

def write_queries_once(device, query_set, count: int):
    """Write every timestamp query of ``query_set`` (``count``, even) once, with empty compute passes.
    Resolving a query that was never written waits for it forever on NVIDIA's Vulkan driver; written once,
    a query stays available."""
    enc = device.create_command_encoder()
    for q in range(0, count, 2):
        enc.begin_compute_pass(timestamp_writes={"query_set": query_set, "beginning_of_pass_write_index": q,
                                                 "end_of_pass_write_index": q + 1}).end()
    device.queue.submit([enc.finish()])


class PassTimer:
    """The GPU time of every compute and render pass begun on this thread between :meth:`start` and
    :meth:`stop`: timestamps at each pass's beginning and end (``timestamp_writes``, added through
    :func:`grasswidget.compat.add_pass_begin_hook`), summed. Other threads' passes, and passes begun
    with ``timestamp_writes`` of their own, are left alone (such a pass makes the reading None: it was
    not timed). ``device`` needs the ``timestamp-query`` feature; ``capacity`` is the passes timed at
    most between a start and a read (integer >= 1, default 32; more make the reading None). Used by
    :mod:`grasswidget.gpu.trial_timing` (an "auto" switch's trial frames on a GPU).
    """

    _running = threading.local()  # .timer: the timer started on each thread, if any
    _hooked = False  # the pass-begin hook added (once, by the first timer made)

    def __init__(self, device, capacity: int = 32):
        if isinstance(capacity, bool) or not isinstance(capacity, int) or capacity < 1:
            raise GrassValueError(f"capacity must be an integer >= 1; got {capacity!r}")
        if "timestamp-query" not in device.features:
            raise GrassValueError("PassTimer needs a device with the 'timestamp-query' feature")
        if not PassTimer._hooked:
            compat.add_pass_begin_hook(_time_running_pass)
            PassTimer._hooked = True
        self.device = device
        self.capacity = capacity
        self.query_set = device.create_query_set(type="timestamp", count=2 * capacity)
        self._resolve = device.create_buffer(size=16 * capacity,
                                             usage=wgpu.BufferUsage.QUERY_RESOLVE | wgpu.BufferUsage.COPY_SRC)
        write_queries_once(device, self.query_set, 2 * capacity)
        self.used = 0       # passes given timestamp writes since start()
        self.missed = 0     # passes begun while running that could not be timed

    def start(self):
        """Time the passes begun on this thread from now on (a running timer of this thread stops)."""
        self.used = self.missed = 0
        PassTimer._running.timer = self

    def stop(self):
        """Stop timing (the passes begun so far stay to be read)."""
        if getattr(PassTimer._running, "timer", None) is self:
            PassTimer._running.timer = None

    def add_writes(self, kwargs):
        """Give the pass about to begin with ``kwargs`` this timer's next timestamp writes (or count it missed)."""
        if kwargs.get("timestamp_writes") is not None or self.used >= self.capacity:
            self.missed += 1
            return
        q = 2 * self.used
        kwargs["timestamp_writes"] = {"query_set": self.query_set, "beginning_of_pass_write_index": q,
                                      "end_of_pass_write_index": q + 1}
        self.used += 1

    def read_ms(self):
        """Milliseconds of GPU time of the passes timed since :meth:`start` (waits for the GPU);
        None when a pass was not timed, or none was begun."""
        if self.missed or not self.used:
            return None
        n = 2 * self.used
        enc = self.device.create_command_encoder()
        enc.resolve_query_set(self.query_set, 0, n, self._resolve, 0)
        self.device.queue.submit([enc.finish()])
        ts = np.frombuffer(self.device.queue.read_buffer(self._resolve, 0, 8 * n), np.uint64).astype(np.int64)
        # wgpu-native reports timestamps in nanoseconds on Vulkan (period 1 ns, as FrameStats reads them).
        return float(np.maximum(ts[1::2] - ts[0::2], 0).sum()) / 1e6


def _time_running_pass(kind, kwargs):
    """compat's pass-begin hook: the pass about to begin gets this thread's running PassTimer's writes."""
    timer = getattr(PassTimer._running, "timer", None)
    if timer is not None:
        timer.add_writes(kwargs)


class FrameStats:
    """Live statistics of one GrassField: visible blades and GPU milliseconds.

    Attributes (None until known):
        visible_per_class: list of visible blades per LOD class (nearest first), both
            occlusion phases.
        visible: total visible blades (drawn by the hardware rasterizer or in compute).
        rastered: of those, the blades the compute rasterizer drew (0 while it is off;
            GrassParams.compute_raster); ``visible - rastered`` were drawn as ribbons.
        occluded: blades culled by occlusion in the counted frame; None when occlusion
            culling did not run in it (off, or "auto" deciding off), as the browser engine's.
        gpu_ms: dict with "simulation" and "draw" GPU milliseconds (timestamp queries; "simulation"
            only where :attr:`simulation_timed`).
        render_ms: CPU milliseconds of the last render call.
        fps: frames per second over the last second of renders.
        frames: renders so far (1 after the first; :meth:`after_render` counts them).
        counts_frame: the render (1-based, as ``frames``) whose counts ``visible``,
            ``visible_per_class``, ``rastered`` and ``occluded`` are; None before the first
            arrives. Equal to ``frames`` after :meth:`settle`.
    """

    def __init__(self, field):
        self.field = field
        self.device = device = ensure_device()
        self.n_classes = field.args_buffer.nitems // 4
        self.timestamps = "timestamp-query" in device.features
        self.inside_passes = "timestamp-query-inside-passes" in device.features
        from .adapter import is_cpu_adapter

        #: Whether ``gpu_ms["simulation"]`` is measured: timestamp queries on a GPU adapter. Not on a CPU
        #: adapter: lavapipe's timestamps around a compute pass stop bracketing its dispatches once frames have
        #: rendered (the cis565 view's 2^16 step, 4.4 ms on the wall, read as 0.02-0.13 ms in most frames and
        #: 3.0 ms in one; tests/gpu/test_trial_clock.py's docstring: the same for a dispatch of known length).
        self.simulation_timed = self.timestamps and not is_cpu_adapter()
        self.visible_per_class = None
        self.visible = None
        self.rastered = None
        self.occluded = None
        self.gpu_ms = {}
        self.render_ms = None
        self.fps = None
        self.frames = 0
        self.counts_frame = None
        self._history = deque(maxlen=HISTORY)  # (frame, counts) of the last frames read
        self._times = deque(maxlen=120)
        self._free = deque()
        self._pending = deque()
        # Staging layout: first-phase args, second-phase args (+ occluded count), and
        # the compute rasterizer's counters (16 bytes) in self._second bytes; timestamps.
        self._second = 16 * (self.n_classes + 1) + 16
        # Last, 4 bytes: the simulation's reset flag (GrassField.note_reset_flag), so a blade put
        # back at rest for going non-finite is noticed without a readback of its own.
        self._flag_at = 16 * self.n_classes + self._second + (8 * N_QUERIES if self.timestamps else 0)
        size = self._flag_at + 4
        for _ in range(RING):
            self._free.append(device.create_buffer(size=size, usage=wgpu.BufferUsage.COPY_DST | wgpu.BufferUsage.MAP_READ))
        if self.timestamps:
            self.query_set = device.create_query_set(type="timestamp", count=N_QUERIES)
            self._resolve = device.create_buffer(
                size=8 * N_QUERIES, usage=wgpu.BufferUsage.QUERY_RESOLVE | wgpu.BufferUsage.COPY_SRC
            )
            # wgpu-native reports timestamps in nanoseconds on Vulkan (period 1 ns).
            self._period_ns = 1.0
            # a render before the first step() hung NVIDIA's driver before the queries were written once
            write_queries_once(device, self.query_set, N_QUERIES)
        else:
            self.query_set = None
        self._written = set()  # timestamp pairs written by real work: "simulation", "draw"

    # ------------------------------------------------------------------ hooks

    def sim_timestamp_writes(self):
        """timestamp_writes for the simulation's compute pass, or None (see :attr:`simulation_timed`)."""
        if not self.simulation_timed:
            return None
        self._written.add("simulation")
        return {"query_set": self.query_set, "beginning_of_pass_write_index": Q_SIM, "end_of_pass_write_index": Q_SIM + 1}

    def draw_timestamp(self, render_pass, when):
        """Write the draw begin/end timestamp inside pygfx's render pass."""
        if self.timestamps and self.inside_passes:
            compat.write_timestamp(render_pass, self.query_set, Q_DRAW + (0 if when == "before" else 1))
            if when == "after":
                self._written.add("draw")

    def after_render(self, render_ms=None):
        """Queue the copies for this frame and pick up finished earlier ones."""
        now = time.perf_counter()
        self.frames += 1
        self._times.append(now)
        while self._times and now - self._times[0] > 1.0:
            self._times.popleft()
        if len(self._times) > 1:
            self.fps = (len(self._times) - 1) / max(self._times[-1] - self._times[0], 1e-9)
        if render_ms is not None:
            self.render_ms = render_ms
        self.poll()
        args = compat.gpu_buffer(self.field.args_buffer)
        if not self._free or args is None:
            return
        staging = self._free.popleft()
        enc = self.device.create_command_encoder()
        nargs = 16 * self.n_classes
        enc.copy_buffer_to_buffer(args, 0, staging, 0, nargs)
        enc.copy_buffer_to_buffer(compat.sync_buffer(self.field.occlusion_args_buffer), 0, staging, nargs,
                                  self._second - 16)
        enc.copy_buffer_to_buffer(compat.sync_buffer(self.field.raster_args_buffer), 0, staging,
                                  nargs + self._second - 16, 16)
        if self.timestamps:
            enc.resolve_query_set(self.query_set, 0, N_QUERIES, self._resolve, 0)
            enc.copy_buffer_to_buffer(self._resolve, 0, staging, nargs + self._second, 8 * N_QUERIES)
        enc.copy_buffer_to_buffer(compat.sync_buffer(self.field.collision_buffer), self.field.reset_flag_offset,
                                  staging, self._flag_at, 4)
        self.device.queue.submit([enc.finish()])
        switches = dict(self.field.frame_switches or {})  # the frame's occlusion and compute rasterizer
        self._pending.append((staging, staging.map_async("READ"), (self.frames, switches)))

    def poll(self):
        """Read every finished frame's numbers (non-blocking)."""
        compat.poll_device(self.device)
        while self._pending and compat.promise_settled(self._pending[0][1]):
            self._take()

    def settle(self):
        """Wait for every readback in flight and read it: afterwards the counts are those
        of the last render (``counts_frame == frames``), unless that render's copy was
        skipped because all RING staging buffers were busy (then the newest before it).
        Blocks for the GPU's work queued so far (a paused view, the tests); a playing
        view uses :meth:`poll`."""
        compat.poll_device(self.device)
        while self._pending:
            self._take()

    def _take(self):
        staging, promise, (frame, switches) = self._pending.popleft()
        raw = read_staging(staging, promise, self._free)
        self._apply(raw, switches)
        self.counts_frame = frame
        self._history.append((frame, {"visible": self.visible, "rastered": self.rastered, "occluded": self.occluded}))

    def counts_of(self, frame):
        """The counts of render ``frame`` (as :attr:`frames` numbered it): {"visible",
        "rastered", "occluded"} once read (:meth:`poll`, :meth:`settle`); None before, for a
        frame whose copy was skipped (the staging ring full) and for one older than the last
        :data:`HISTORY` read."""
        for f, counts in reversed(self._history):
            if f == frame:
                return dict(counts)
        return None

    def _apply(self, raw, switches=None):
        """Take one read-back; ``switches``: the frame's ``GrassField.frame_switches`` (a pass
        that did not run counted nothing that frame: occluded None, rastered 0, as the browser
        engine's stats; unknown ({}, a frame drawn without render_frame): taken as counted)."""
        switches = switches or {}
        nargs = 16 * self.n_classes
        layout = counter_layout(self.n_classes)  # the staging layout above, both engines' (core.engine_inputs)
        counts = read_counters(raw[: 4 * layout["words"]].view(np.uint32), layout)
        self.visible_per_class = counts["visible_per_class"]
        self.rastered = counts["rastered"] if switches.get("compute_raster", True) else 0
        self.visible = int(sum(self.visible_per_class)) + self.rastered
        self.occluded = counts["occluded"] if switches.get("cull_occlusion", True) else None
        self.field.note_reset_flag(float(raw[self._flag_at:self._flag_at + 4].view(np.float32)[0]))
        if self.timestamps:
            ts = raw[nargs + self._second:self._flag_at].view(np.uint64).astype(np.float64)
            for name, q in (("simulation", Q_SIM), ("draw", Q_DRAW)):
                if name in self._written and ts[q + 1] > ts[q] > 0:
                    self.gpu_ms[name] = float((ts[q + 1] - ts[q]) * self._period_ns / 1e6)

    def release(self):
        """Destroy the staging buffers and the query set (the stats stop working)."""
        # Settle outstanding map requests first: an unsettled promise stays referenced
        # by the event loop (if one is set) and keeps its buffer alive.
        for staging, promise, _frame in self._pending:
            try:
                promise.sync_wait()
            except Exception:
                pass
        buffers = list(self._free) + [staging for staging, _p, _f in self._pending]
        if self.timestamps:
            buffers.append(self._resolve)
            self.query_set.destroy()
        for buf in buffers:
            if buf.map_state == "mapped":
                buf.unmap()
            buf.destroy()
        self._free.clear()
        self._pending.clear()

    def as_dict(self) -> dict:
        return dict(
            visible=self.visible,
            rastered=self.rastered,
            visible_per_class=self.visible_per_class,
            occluded=self.occluded,
            gpu_ms=dict(self.gpu_ms),
            render_ms=self.render_ms,
            fps=self.fps,
            frames=self.frames,
            counts_frame=self.counts_frame,
        )

    def __repr__(self):
        return f"FrameStats({self.as_dict()})"
