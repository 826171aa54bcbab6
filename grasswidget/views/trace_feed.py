"""Where the traces' samples come from: one feed per engine, filling a TraceRecorder.

Time: a sample's ``t`` is the field's step count times ``params.dt`` (a new blade
count starts a field at rest, at step 0, and a new trace). Sampling rule (both
engines): a sample is taken when simulated time has advanced
(the step count changed) since the last one, so a paused view that only redraws
adds nothing, and a sample taken again at the same step count replaces the last.

* kernel engine (:class:`KernelTraceFeed`): one sample per ``step(n)`` call, taken when
  the call returns whether or not a frame is ever drawn (a script, a notebook run by
  nbclient, a view scrolled out of sight, a loop of steps in one cell): the inspector's
  compute pass runs alone and its few bytes are read back (queued; :meth:`traces` waits
  for them), with NaN for the culling counts and frame times no frame measured. Then one
  sample per frame the kernel draws while time advances (playing); a frame drawn at the
  step count of a ``step(n)`` sample replaces it (the same ``v2``, plus the frame's
  counts), so there is never a second sample for one step count. The inspected blades'
  numbers of a frame come from :class:`grasswidget.gpu.trace_readback.InspectedReadback`
  a frame or two later (non-blocking while playing; a paused frame waits for its few
  bytes, as no next frame would pick them up), with the frame's time and step count.
* browser engine (:class:`BrowserTraceFeed`): after each ``step(n)`` call (every call:
  the browser steps and answers in order, on screen or at rest) and at each stats message
  of the browser (every 0.5 s; every 0.2 s while a chart is shown; skipped while an
  answer is still on its way): one ``read_inspected`` request answered by the browser with
  the step count it read the blades at (non-blocking for the kernel), so 2 samples a
  second while playing, 5 with a chart.

Culling counts: :class:`grasswidget.core.cull_counts.CullCounter` (GPU counts for distance
and occlusion, the NumPy reference on the rest pose for orientation and frustum). A kernel
sample takes the drawn and GPU counts of its own frame (``FrameStats.counts_of``): while
playing they arrive a frame or two later, so the sample is recorded then (at the latest by
``flush``, which ``traces()`` calls); paused, at once. Frame times: the view's stats (``render_ms``,
``readback_ms``, ``encode_ms`` + ``send_ms`` as one stage, ``encode_send``, ``ack_ms``; the browser: its
frame time as render).
"""

from __future__ import annotations

from collections import deque

from ..core.cull_counts import CullCounter, gpu_kept
from ..core.engine_inputs import STATS_INTERVAL_MS


def _sum_or_none(*values):
    """The sum of the values that are known (None when none is)."""
    known = [v for v in values if v is not None]
    return sum(known) if known else None
from ..core.traces import TraceSample

__all__ = ["KernelTraceFeed", "BrowserTraceFeed", "make_feed", "CHART_STATS_INTERVAL_MS"]


class _Feed:
    """What both feeds share: the recorder, the culling camera, the counts of a sample."""

    def __init__(self, view, recorder, on_sample=None):
        self.view = view
        self.recorder = recorder
        self.on_sample = on_sample or (lambda: None)
        self.counter = CullCounter(view.blades, view.params)
        self._blades = view.blades
        self.frozen_camera = None
        self._last_step = None
        self._generation = 0  # reset_blades() calls so far: an answer asked for before one is dropped
        view.frame_hooks.append(self.after_frame)

    def set_culling_frozen(self, frozen: bool):
        """Count culling against the camera of now (frozen) or the live camera (not frozen)."""
        self.frozen_camera = self.view.camera_state if frozen else None

    def _check_blades(self):
        # A new field (another count, or other blades of the same count): new rest pose, new ids,
        # and a step count from 0 again.
        if self.view.blades is not self._blades:
            self._blades = self.view.blades
            self.counter.set_blades(self.view.blades)
            self.recorder.clear()
            self._last_step = None

    def _counts(self, stats):
        camera = self.frozen_camera or self.view.camera_state
        visible = stats.get("visible")
        occluded = stats.get("occluded")
        rastered = stats.get("rastered")
        # Paused (a step(n)): the reference counts this very camera before the sample is taken.
        kept = self.counter.kept(camera, self.view.readings.depth_range, self.view.size, visible=visible,
                                 occluded=occluded, now=not self.view.play.playing)
        drawn = {"ribbons": None if visible is None else visible - (rastered or 0), "compute": rastered}
        return kept, drawn

    @staticmethod
    def _frame_ms(stats):
        return {"render": stats.get("render_ms", stats.get("draw_ms")), "readback": stats.get("readback_ms"),
                "encode_send": _sum_or_none(stats.get("encode_ms"), stats.get("send_ms")), "ack": stats.get("ack_ms")}

    def _record(self, t, step_count, kept, drawn, frame_ms, rows):
        up = self.view.blades.up
        if rows and max(int(r["id"]) for r in rows) >= len(up):
            rows = []  # the answer of a field replaced meanwhile
        self.recorder.record(TraceSample.from_inspected(t, step_count, rows, up, kept, drawn, frame_ms))
        self.on_sample()

    def detach(self):
        try:
            self.view.frame_hooks.remove(self.after_frame)
        except ValueError:
            pass

    def after_frame(self):
        """Take this frame's sample (each engine's feed)."""

    def after_step(self):
        """Take the sample of a ``step(n)`` call (each engine's feed)."""

    def after_reset(self):
        """The blades went back to rest (step 0): forget every sample, and any still on its way."""
        self.flush()
        self._generation += 1
        self._last_step = None
        self.recorder.clear()

    def flush(self):
        """Record what is still on its way (each engine's feed)."""


class KernelTraceFeed(_Feed):
    """Samples of the kernel engine: after each ``step(n)`` call and after each drawn frame in
    which time advanced."""

    def __init__(self, view, recorder, on_sample=None):
        super().__init__(view, recorder, on_sample)
        from ..gpu.trace_readback import InspectedReadback

        self._readback_field = view.scene.field
        self.readback = InspectedReadback(self._readback_field)
        #: Samples of frames drawn while playing, with nothing inspected, waiting for their
        #: frame's counts (FrameStats.counts_of): (frame, tag), oldest first.
        self._waiting = deque()
        self._step_sample = False  # the newest sample is a step(n)'s, of no drawn frame

    def _follow_field(self, scene):
        if scene.field is not self._readback_field:  # the blade count changed: a new field
            self.readback.release()
            self._readback_field = scene.field
            from ..gpu.trace_readback import InspectedReadback

            self.readback = InspectedReadback(scene.field)
            self._waiting.clear()  # frames of the field before (its stats numbered them)
        self._check_blades()
        for (frame, tag), rows in self.readback.poll():
            self._record(*self._of_frame(frame, tag), rows)
        self._record_waiting()

    def after_step(self):
        """A ``step(n)`` call: sample the state it left, whether or not a frame is drawn (a
        script, nbclient, a view at rest, several calls in one cell). The inspector's compute
        pass runs alone (no render) and its few bytes are queued for readback; the culling
        and frame-time numbers of a sample no frame was drawn for are unknown (NaN). A frame
        drawn later at the same step count replaces this sample with its own (same ``v2``,
        plus the frame's counts)."""
        view = self.view
        scene = view.scene
        if scene is None or view.closed:
            return
        with view.lock:  # the canvas may draw on another thread (kernel_view: "Threads")
            self._follow_field(scene)
            step = int(scene.field.step_count)
            if step == self._last_step:
                return
            kept, drawn = self._counts({})  # no frame drawn: the GPU's counts are unknown
            tag = (step * float(view.params.dt), step, kept, drawn, self._frame_ms({}))
            self._last_step, self._step_sample = step, True
            inspector = scene.field.inspector
            if not view.readings.inspected or inspector is None:
                self._record(*tag, rows=[])
                return
            try:
                inspector.compute_now()
                queued = self.readback.after_render((None, tag))  # no frame: no frame's counts
                if not queued:  # every ring buffer in flight: wait for them
                    self.flush()
                    queued = self.readback.after_render((None, tag))
            except Exception as err:  # noqa: BLE001 - e.g. user WGSL the inspector cannot compile
                view.host.show_error(f"traces: the inspected blades could not be read: {err}")
                queued = False
            if not queued:
                self._record(*tag, rows=[])

    def after_frame(self):
        view = self.view
        scene = view.scene
        if scene is None:
            return
        self._follow_field(scene)
        step = int(scene.field.step_count)
        if step == self._last_step and not self._step_sample:
            return
        self._last_step, self._step_sample = step, False
        stats = dict(view.stats)
        if scene.stats is not None and not view.play.playing:
            # Paused (a step(n)): the counts of this very frame, read now (nothing to stall); while
            # playing the newest that arrived (a frame or two before this one: FrameStats.counts_frame).
            scene.stats.settle()
        live = scene.stats.as_dict() if scene.stats is not None else {}
        for key in ("visible", "rastered"):
            if live.get(key) is not None:
                stats[key] = live[key]
        if "occluded" in live:  # None when occlusion culling did not run in the counted frame
            stats["occluded"] = live["occluded"]
        kept, drawn = self._counts(stats)
        tag = (step * float(view.params.dt), step, kept, drawn, self._frame_ms(stats))
        # The frame's own counts replace the newest ones when they arrive (while playing, a frame or
        # two later; paused, they are here already): the sample says what this frame drew.
        frame = scene.stats.frames if scene.stats is not None else None
        if not view.readings.inspected or not self.readback.after_render((frame, tag)):
            if view.readings.inspected:  # the ring is full: the frame is skipped
                return
            self._waiting.append((frame, tag))
            self._record_waiting()
        elif not view.play.playing:
            self.flush()  # paused (a step(n)): no next frame will come to pick it up; nothing to stall

    def set_charting(self, charting: bool):
        """Nothing to change: the kernel samples every frame."""

    def flush(self):
        """Wait for the frames in flight and record them (tests, and before reading the traces)."""
        stats = self.view.scene.stats if self.view.scene is not None else None
        if stats is not None:
            stats.settle()
        for (frame, tag), rows in self.readback.flush():
            self._record(*self._of_frame(frame, tag), rows)
        self._record_waiting(final=True)

    def _of_frame(self, frame, tag):
        """``tag`` with the drawn and GPU-kept counts of its own ``frame`` where they were read;
        as it was (the newest counts when it was taken) where they were not (a copy skipped)."""
        stats = self.view.scene.stats if self.view.scene is not None else None
        counts = stats.counts_of(frame) if stats is not None and frame is not None else None
        if counts is None or counts["visible"] is None:
            return tag
        t, step, kept, drawn, frame_ms = tag
        kept = {**kept, **gpu_kept(counts["visible"], counts["occluded"], self.view.params.cull_occlusion)}
        rastered = counts["rastered"] or 0
        drawn = {"ribbons": counts["visible"] - rastered, "compute": counts["rastered"]}
        return t, step, kept, drawn, frame_ms

    def _record_waiting(self, final=False):
        """Record the waiting samples whose frame's counts were read (all of them when ``final``,
        or once the stats have moved past a frame whose copy was skipped)."""
        stats = self.view.scene.stats if self.view.scene is not None else None
        while self._waiting:
            frame, tag = self._waiting[0]
            known = stats is not None and frame is not None and stats.counts_of(frame) is not None
            passed = stats is None or frame is None or (stats.counts_frame or 0) >= frame
            if not (known or passed or final):
                return
            self._waiting.popleft()
            self._record(*self._of_frame(frame, tag), rows=[])

    def detach(self):
        super().detach()
        self.readback.release()


#: Milliseconds between the browser's stats messages while a chart is shown (5 samples a second).
CHART_STATS_INTERVAL_MS = 200


class BrowserTraceFeed(_Feed):
    """Samples of the browser engine: at each stats message and after each step(n)."""

    def __init__(self, view, recorder, on_sample=None):
        super().__init__(view, recorder, on_sample)
        self._in_flight = 0  # read_inspected requests not answered yet

    def set_charting(self, charting: bool):
        """A chart is shown: ask the browser for a stats message (a sample) every 200 ms instead of 500."""
        self.view.engine_widget.stats_interval_ms = CHART_STATS_INTERVAL_MS if charting else STATS_INTERVAL_MS

    def after_frame(self):
        self._check_blades()
        step = self.view.stats.get("step_count")
        if step is None or step == self._last_step or self._in_flight:
            return  # nothing new, or a sample on its way (a slow browser is not flooded)
        self.sample_now()

    def after_step(self):
        """A ``step(n)`` call: one sample of the state it leaves, whatever else is on its way
        (the browser steps and answers in order, on screen or at rest)."""
        self.sample_now()

    def sample_now(self):
        """Ask the browser for the inspected blades' numbers now (answered after what it was
        asked before, e.g. a step(n)); the sample is recorded when the answer comes, with the
        step count the browser had when it read them."""
        view = self.view
        if view.closed:
            return
        ids = list(view.readings.inspected)
        stats = dict(view.stats)
        kept, drawn = self._counts(stats)
        frame_ms = self._frame_ms(stats)
        bview = view.engine_widget
        generation = self._generation

        def answered(msg, buffers):
            if generation != self._generation:
                return  # asked before a reset_blades() or a flush that gave up: not counted, dropped
            self._in_flight = max(0, self._in_flight - 1)
            if msg.get("type") != "inspected" or msg.get("step_count") is None:
                return
            step = int(msg["step_count"])
            rows = bview.inspected_from_answer(msg, buffers, ids) if ids else []
            self._last_step = step
            self._record(step * view.params.dt, step, kept, drawn, frame_ms, rows)

        self._in_flight += 1
        bview.request_async({"type": "read_inspected"}, answered)

    def flush(self):
        """Wait for the samples asked of the browser and not answered yet (a loop of ``step(n)``
        calls in one cell, then ``traces()``: the answers come while this handles the notebook's
        messages), at most ``ANSWER_TIMEOUT`` seconds. None can come with no notebook kernel (a
        script) or no page that answers: then :class:`~grasswidget.browser.kernel_pump.BrowserTimeoutError`
        (a TimeoutError) says how many are missing, instead of traces that silently lack them;
        they are given up (dropped should they come later), so the next call returns what was
        recorded."""
        if not self._in_flight or self.view.closed:
            return
        from ..browser.kernel_pump import BrowserTimeoutError, wait_for
        from ..browser.engine_widget import ANSWER_TIMEOUT

        missing = self._in_flight
        try:
            wait_for(lambda: True if not self._in_flight else None, ANSWER_TIMEOUT,
                     f"traces(): {missing} sample(s) of step(n) calls or frames asked of the browser engine's view")
        except BrowserTimeoutError:
            self._in_flight = 0  # given up: an answer that still comes is dropped
            self._generation += 1
            raise

    def after_reset(self):
        """As every feed's, without waiting for the answers on their way: they are dropped."""
        self._in_flight = 0
        self._generation += 1
        self._last_step = None
        self.recorder.clear()


def make_feed(view, recorder, on_sample=None):
    """The feed for ``view``'s engine."""
    cls = KernelTraceFeed if view.backend == "kernel" else BrowserTraceFeed
    return cls(view, recorder, on_sample)
