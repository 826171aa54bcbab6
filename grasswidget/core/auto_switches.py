"""Whether occlusion culling and the compute rasterizer pay: the rule, decided by measuring.

``GrassParams.cull_occlusion`` and ``GrassParams.compute_raster`` are three-way switches
(:class:`AutoSwitch`): ``True`` forces the feature on, ``False`` off, and ``"auto"`` (the
default of both) lets each view decide from what it measured:

1. a short trial, interleaved off, on, on, off (a block each; a drift of the machine's
   load during the trial weighs on both sides alike): :data:`TRIAL_SETTLE_FRAMES` frames
   dropped after each flip (a pipeline compiles, buffers grow), then the blocks timed by the
   same measure (milliseconds: the engine's, e.g. the kernel's GPU-synchronised render, timed on a GPU
   by its passes' GPU time: ``grasswidget.gpu.trial_timing.trial_clock``); the first block
   lasts until it holds half of :data:`TRIAL_FRAMES` (rounded up) and half of
   :data:`TRIAL_MIN_MS`, or half of :data:`TRIAL_MAX_FRAMES`, and sets the block's length (a
   GPU's 3-10 ms frames jitter more than a few of them can average out; a CPU adapter's
   100 ms frames need only a few);
2. :func:`decide_occlusion` / :func:`decide_compute_raster`: the counts the GPU reported
   first (occlusion that removed under :data:`MIN_OCCLUDED_FRACTION` of the blades it saw,
   or a compute rasterizer that took over no blade, cannot pay: off), then the frame times
   (the faster median kept). Hysteresis: a view that decided before (for another camera,
   field or parameters) keeps its previous choice unless the other one is faster by more
   than :data:`HYSTERESIS` (a fraction of the frame time), so noise does not flip it back
   and forth; while it tries one switch again, the other keeps its previous choice.
   The switches are tried one after the other, the other one running with its current
   value; when the second decision changes the value the first was tried with (the compute
   rasterizer turned on after occlusion was tried with it off), the first is tried again
   once with it (the two interact: occlusion hides the far, thin blades the rasterizer takes);
3. the decision holds until the context changes (:class:`DecisionContext`): the camera
   moves more than :data:`CAMERA_MOVE_FRACTION` of its distance to what it looks at or turns
   more than :data:`CAMERA_TURN_DEG`, the blade count or preset changes, or any parameter
   changes but the two switches themselves (forcing a switch and going back to "auto" in
   the same view keeps the decision).

A view at rest draws no frame, so it runs no trial: a trial advances only with the frames
an engine renders and records (the browser engine starts one only when the browser reports
frames drawn while the widget plays, :mod:`grasswidget.browser.trial_feed`; ``values(...,
start_trial=False)`` makes a decision stale without starting one). ``AutoSwitches.trial_frames_run``
counts the frames recorded in trials, so that a view can tell its frame rate measurements
that include a trial's (GPU-synchronised, first-use compiling) frames from the others.

Frozen culling (a teaching view: ``values(..., frozen=True)``) freezes the switches too: the
context is held (the camera flying around the frozen view is no trigger), no trial starts, a
trial in progress is suspended (its frames are not recorded, its decision is not made) and each
"auto" switch keeps the value it had in the last frame before freezing, so nothing that decides
which blades are drawn changes under the frozen view. A switch forced (True / False) meanwhile
takes that value at once, as the user asked. Unfreezing resumes the trial where it stopped
(after :data:`TRIAL_SETTLE_FRAMES` again), unless the context changed meanwhile.

:class:`AutoSwitches` is the pure state machine an engine drives once per frame: it says
which value each switch has for the next frame and takes the frame's measurements. No GPU,
no widgets: the kernel engine runs it in :mod:`grasswidget.gpu.trial_timing`.
"""

from __future__ import annotations

import math
import numbers
import statistics
from dataclasses import dataclass, field

import traitlets

from ..errors import ParameterError

__all__ = [
    "AUTO", "SWITCHES", "AutoSwitch", "coerce_switch", "Decision", "decide_occlusion", "decide_compute_raster",
    "DecisionContext", "AutoSwitches", "switch_text", "effective",
    "TRIAL_FRAMES", "TRIAL_SETTLE_FRAMES", "MIN_OCCLUDED_FRACTION", "CAMERA_MOVE_FRACTION", "CAMERA_TURN_DEG",
    "HYSTERESIS", "TRIAL_MIN_MS", "TRIAL_MAX_FRAMES", "FRAME_TIMES_KEPT",
]

#: The third state of a switch: the view decides by measuring.
AUTO = "auto"
#: The switches decided by measuring (GrassParams trait names), in the order they are tried.
SWITCHES = ("cull_occlusion", "compute_raster")
#: Frames timed a side of a trial at least (rounded up to even: two blocks a side).
TRIAL_FRAMES = 3
#: Milliseconds of timed frames each side of a trial lasts at least (more frames where they are fast).
TRIAL_MIN_MS = 50.0
#: Timed frames a side at most, whatever TRIAL_MIN_MS asks (two blocks of half).
TRIAL_MAX_FRAMES = 24
#: The newest frame times (ms) the browser engine keeps between two stats messages, the window
#: that feeds a trial (:mod:`grasswidget.browser.trial_feed`); at least a trial's side
#: (:data:`TRIAL_MAX_FRAMES`), so that one message can carry all of one.
FRAME_TIMES_KEPT = 32
#: Frames dropped after a switch flips, before timing (first use compiles or grows buffers).
TRIAL_SETTLE_FRAMES = 1
#: Occlusion culling that removes less than this fraction (0..1) of the blades reaching it cannot pay.
MIN_OCCLUDED_FRACTION = 0.05
#: The camera moved when its eye travels more than this fraction of its distance to the target.
CAMERA_MOVE_FRACTION = 0.1
#: A view that decided before changes its choice only when the other is faster by more than
#: this fraction of the frame time (0..1; 0.05: 5 %, the margin the issue allows the defaults).
HYSTERESIS = 0.05
#: The camera turned when its view direction changes by more than this (degrees).
CAMERA_TURN_DEG = 10.0

_WORDS = {"on": True, "off": False, "true": True, "false": False, AUTO: AUTO}


def coerce_switch(value, name: str = "switch"):
    """``value`` as a switch state: ``True``, ``False`` or ``"auto"``. Accepts bools (and
    NumPy bools), the integers 0 and 1, and the strings "auto", "on", "off", "true", "false"
    (any case); anything else raises :class:`grasswidget.errors.ParameterError` naming ``name``."""
    if isinstance(value, str):
        word = _WORDS.get(value.strip().lower())
        if word is not None:
            return word
    elif value is True or value is False or _numpy_bool(value):
        return bool(value)
    elif isinstance(value, numbers.Integral) and value in (0, 1):  # NumPy's integers too
        return bool(value)
    raise ParameterError(f"{name} must be True (on), False (off) or 'auto' (decided by measuring); got {value!r}")


def _numpy_bool(value) -> bool:
    # NumPy's boolean scalar: numpy.bool_ (NumPy 1), numpy.bool (NumPy 2); no NumPy import here.
    kind = type(value)
    return kind.__module__ == "numpy" and kind.__name__ in ("bool_", "bool")


class AutoSwitch(traitlets.TraitType):
    """A three-way switch trait: ``True`` (on), ``False`` (off) or ``"auto"`` (decided by
    measuring, :mod:`grasswidget.core.auto_switches`). Set with a bool as before, or "auto"/"on"/"off";
    read back as ``True``, ``False`` or ``"auto"``. Syncs to JavaScript as true/false/"auto"."""

    info_text = "True, False or 'auto'"

    def __init__(self, default_value=AUTO, **kwargs):
        super().__init__(coerce_switch(default_value), **kwargs)

    def validate(self, obj, value):
        return coerce_switch(value, self.name or "switch")


def effective(value, decided) -> bool:
    """The switch's value for a frame: a forced ``True``/``False`` as is; ``"auto"`` follows
    ``decided`` (a bool, or None while undecided: off)."""
    if value == AUTO:
        return bool(decided)
    return bool(value)


@dataclass(frozen=True)
class Decision:
    """What the rule decided: ``on`` (bool) and ``reason`` (a short sentence for people)."""

    on: bool
    reason: str


def _median(values):
    return statistics.median(values) if values else None


def _compare(on_ms, off_ms, what, previous=None):
    """Keep the faster median; ties go to off (nothing to gain). ``previous``: the view's
    earlier choice (bool) or None; it is kept unless the other is faster by more than
    :data:`HYSTERESIS` of its frame time."""
    t_on, t_off = _median(on_ms), _median(off_ms)
    if t_on is None or t_off is None:
        raise ParameterError("frame times: the rule needs at least one frame timed on and one off")
    if previous is None:
        on = t_on < t_off
    elif previous:
        on = not t_off < t_on * (1.0 - HYSTERESIS)
    else:
        on = t_on < t_off * (1.0 - HYSTERESIS)
    close = min(t_on, t_off) >= max(t_on, t_off) * (1.0 - HYSTERESIS)
    kept = f" (kept: within {100 * HYSTERESIS:g} %)" if previous is not None and on == previous and close else ""
    if on:
        return Decision(True, f"{what}, {t_on:.1f} ms a frame against {t_off:.1f} ms off{kept}")
    return Decision(False, f"{what}, but {t_on:.1f} ms a frame against {t_off:.1f} ms off{kept}")


def decide_occlusion(on_ms, off_ms, occluded: int, reaching: int, previous=None) -> Decision:
    """Whether occlusion culling pays. ``on_ms``/``off_ms``: frame times (ms) measured with it
    on / off, same measure; ``occluded``: blades it removed in a frame with it on (the GPU's
    count); ``reaching``: the blades that reached it that frame (drawn + occluded). Off when it
    removed under :data:`MIN_OCCLUDED_FRACTION` (nothing hidden: it cannot pay), else the
    faster of the two; ``previous``: the view's earlier choice (bool) or None, kept unless
    the other is faster by more than :data:`HYSTERESIS`."""
    occluded, reaching = int(occluded), int(reaching)
    if reaching <= 0:
        return Decision(False, "no blade reached occlusion culling")
    fraction = occluded / reaching
    what = f"removed {100 * fraction:.0f} % of blades"
    if fraction < MIN_OCCLUDED_FRACTION:
        return Decision(False, f"{what}: too few to pay")
    return _compare(on_ms, off_ms, what, previous)


def decide_compute_raster(on_ms, off_ms, rastered: int, drawn: int, previous=None) -> Decision:
    """Whether the compute rasterizer pays. ``rastered``: blades it drew in a frame with it on
    (the GPU's count); ``drawn``: all blades drawn that frame (both paths). Off when it took
    over no blade (none thinner than compute_raster_max_px), else the faster of the two
    (``previous``: as :func:`decide_occlusion`'s)."""
    rastered, drawn = int(rastered), int(drawn)
    if rastered <= 0:
        return Decision(False, "took over no blade (none thin enough)")
    what = f"drew {100 * rastered / max(drawn, rastered):.0f} % of blades"
    return _compare(on_ms, off_ms, what, previous)


_RULES = {"cull_occlusion": decide_occlusion, "compute_raster": decide_compute_raster}


@dataclass(frozen=True)
class DecisionContext:
    """What a decision was made for: the camera's ``eye`` and ``target`` (world units), the
    blade count, the preset's name (or None) and the other parameters (a hashable summary,
    e.g. a tuple of (name, value) pairs without the switches)."""

    eye: tuple
    target: tuple
    blades: int
    preset: object = None
    params: object = None

    def differs(self, other: "DecisionContext") -> str | None:
        """Why a decision made for ``self`` no longer holds in ``other`` (a short phrase), or None."""
        if self.blades != other.blades:
            return "the blade count changed"
        if self.preset != other.preset:
            return "the preset changed"
        if self.params != other.params:
            return "the parameters changed"
        d0 = [t - e for e, t in zip(self.eye, self.target)]
        d1 = [t - e for e, t in zip(other.eye, other.target)]
        dist = math.sqrt(sum(v * v for v in d0)) or 1.0
        moved = math.sqrt(sum((a - b) ** 2 for a, b in zip(self.eye, other.eye)))
        if moved > CAMERA_MOVE_FRACTION * dist:
            return "the camera moved"
        n1 = math.sqrt(sum(v * v for v in d1)) or 1.0
        cos = sum(a * b for a, b in zip(d0, d1)) / (dist * n1)
        if math.degrees(math.acos(max(-1.0, min(1.0, cos)))) > CAMERA_TURN_DEG:
            return "the camera turned"
        return None


@dataclass
class _Trial:
    name: str
    stage: int = 0  # 0: off (its length sets the block), 1: on for two blocks, 2: off for one block
    settle: int = TRIAL_SETTLE_FRAMES
    block: int = 0  # frames of the first block (0 until it ends)
    times: dict = field(default_factory=lambda: {"off": [], "on": []})
    counts: list = field(default_factory=list)  # (occluded, reaching) or (rastered, drawn) of on-frames
    others: dict = field(default_factory=dict)  # the other switches' values while it ran

    @property
    def phase(self) -> str:
        return "on" if self.stage == 1 else "off"


class AutoSwitches:
    """The per-view state of the "auto" switches: one trial at a time, then decisions.

    Per frame the engine calls :meth:`values` (the switch values for that frame, given the
    params' settings and the frame's :class:`DecisionContext`), renders, then :meth:`record`
    with the frame's time (ms) and the latest counts the GPU reported
    (``{"occluded", "visible", "rastered"}``, any may be None). ``decisions`` maps each
    decided switch to its :class:`Decision`; ``trial`` is the switch being tried (or None).
    ``trial_frames``: frames timed with a switch off, then as many on (integer >= 1);
    ``settle_frames``: frames dropped after each flip (integer >= 0); ``min_ms``: timed
    milliseconds a side at least (0..1e6); ``max_frames``: timed frames a side at most
    (integer >= ``trial_frames``).
    """

    def __init__(self, trial_frames: int = TRIAL_FRAMES, settle_frames: int = TRIAL_SETTLE_FRAMES,
                 min_ms: float = TRIAL_MIN_MS, max_frames: int = TRIAL_MAX_FRAMES):
        if isinstance(trial_frames, bool) or not isinstance(trial_frames, int) or trial_frames < 1:
            raise ParameterError(f"trial_frames must be an integer >= 1; got {trial_frames!r}")
        if isinstance(settle_frames, bool) or not isinstance(settle_frames, int) or settle_frames < 0:
            raise ParameterError(f"settle_frames must be an integer >= 0; got {settle_frames!r}")
        if not isinstance(min_ms, (int, float)) or isinstance(min_ms, bool) or not 0 <= min_ms < 1e6:
            raise ParameterError(f"min_ms must be a number of milliseconds in [0, 1e6); got {min_ms!r}")
        if isinstance(max_frames, bool) or not isinstance(max_frames, int) or max_frames < trial_frames:
            raise ParameterError(f"max_frames must be an integer >= trial_frames ({trial_frames}); got {max_frames!r}")
        self.trial_frames = trial_frames
        self.settle_frames = settle_frames
        self.min_ms = float(min_ms)
        self.max_frames = max_frames
        self._retried: set = set()  # switches tried again in this context (at most once each)
        self._tried_with: dict = {}  # switch -> the other switches' values during its last trial
        self.decisions: dict = {}
        #: The decisions made for the previous context (kept for hysteresis, and as the
        #: provisional values while they are made again).
        self.previous: dict = {}
        self.context: DecisionContext | None = None
        self.redecided_because: str | None = None
        #: Frames recorded in trials so far (settling frames included): a view compares it
        #: between two frame rate measurements to tell whether a trial ran in between.
        self.trial_frames_run = 0
        self._trial: _Trial | None = None
        #: True while culling is frozen (the last :meth:`values` call said ``frozen``).
        self.frozen = False
        self._held: dict = {}  # the values of the last frame before freezing

    @property
    def suspended(self) -> bool:
        """True while a trial waits for culling to be unfrozen (see the module docstring)."""
        return self.frozen and self._trial is not None

    @property
    def trial(self) -> str | None:
        return self._trial.name if self._trial else None

    @property
    def measuring(self) -> bool:
        """True while a trial runs and is not suspended (the engine should time this frame)."""
        return self._trial is not None and not self.frozen

    def values(self, settings: dict, context: DecisionContext, start_trial: bool = True,
               frozen: bool = False) -> dict:
        """The value (bool) of each switch of ``settings`` ({name: True/False/"auto"}) for the
        next frame in ``context``; starts a trial where an "auto" switch is undecided, unless
        ``start_trial`` is False (the caller draws no frame for it: the value is then the
        previous context's decision, or off). An undecided switch not being tried runs with
        its previous decision (off when it has none). ``frozen``: culling is frozen; the
        context is not looked at, no trial starts or advances and each "auto" switch keeps its
        value of the last frame before freezing (see the module docstring)."""
        if frozen:
            if not self.frozen:
                self.frozen = True
            out = {}
            for name in SWITCHES:
                if name not in settings:
                    continue
                if settings[name] != AUTO:
                    out[name] = bool(settings[name])
                elif name in self._held:
                    out[name] = self._held[name]
                else:
                    out[name] = self._value(settings, name)
            return out
        if self.frozen:  # unfrozen: a suspended trial resumes, settling first (its state flips back)
            self.frozen = False
            if self._trial is not None:
                self._trial.settle = self.settle_frames
        out = self._values(settings, context, start_trial)
        self._held = {name: out[name] for name in out}
        return out

    def _values(self, settings, context, start_trial) -> dict:
        if self.context is not None:
            why = self.context.differs(context)
            if why:
                self.previous.update(self.decisions)
                self.decisions.clear()
                self._retried.clear()
                self._tried_with.clear()
                self._trial = None
                self.redecided_because = why
                self.context = context
        else:
            self.context = context
        if self._trial is not None and settings.get(self._trial.name) != AUTO:
            self._trial = None  # forced meanwhile: the trial stops, nothing decided
        if self._trial is None and start_trial:
            for name in SWITCHES:
                if settings.get(name) == AUTO and name not in self.decisions:
                    self._trial = _Trial(name, settle=self.settle_frames,
                                         others={k: self._value(settings, k) for k in SWITCHES if k != name and k in settings})
                    break
        out = {}
        for name in SWITCHES:
            if name not in settings:
                continue
            if self._trial is not None and self._trial.name == name:
                out[name] = self._trial.phase == "on"
            else:
                out[name] = self._value(settings, name)
        return out

    def _value(self, settings, name) -> bool:
        """Switch ``name``'s value outside its trial: forced, decided, previously decided, or off."""
        d = self.decisions.get(name) or self.previous.get(name)
        return effective(settings[name], d.on if d else None)

    def record(self, frame_ms: float, counts: dict | None = None):
        """The frame rendered with the last :meth:`values` took ``frame_ms`` milliseconds;
        ``counts``: the GPU's latest ``occluded``, ``visible`` (drawn, both paths) and
        ``rastered`` (values may lag a frame; only counts of on-frames are used)."""
        t = self._trial
        if t is None or self.frozen:  # no trial, or one suspended while culling is frozen
            return
        self.trial_frames_run += 1
        if t.settle > 0:
            t.settle -= 1
            return
        t.times[t.phase].append(float(frame_ms))
        if t.phase == "on" and counts:
            if t.name == "cull_occlusion" and counts.get("occluded") is not None and counts.get("visible") is not None:
                t.counts.append((int(counts["occluded"]), int(counts["occluded"]) + int(counts["visible"])))
            if t.name == "compute_raster" and counts.get("rastered") is not None and counts.get("visible") is not None:
                t.counts.append((int(counts["rastered"]), int(counts["visible"])))
        off, on = t.times["off"], t.times["on"]
        if t.stage == 0:  # the first block: half the frames and half the time a side asks
            half = -(-self.trial_frames // 2)
            if (len(off) >= half and sum(off) >= self.min_ms / 2) or len(off) >= -(-self.max_frames // 2):
                t.block, t.stage, t.settle = len(off), 1, self.settle_frames
            return
        if t.stage == 1:
            if len(on) >= 2 * t.block:
                t.stage, t.settle = 2, self.settle_frames
            return
        if len(off) >= 2 * t.block:
            # The counts of the last on-frame that reported any (earlier ones may be of an off-frame).
            removed, seen = max(t.counts, key=lambda c: c[0]) if t.counts else (0, 0)
            before = self.previous.get(t.name)
            decision = self.decisions[t.name] = _RULES[t.name](t.times["on"], t.times["off"], removed, seen,
                                                               before.on if before else None)
            self._trial = None
            # A switch decided with this one at another value is tried again (once per context).
            for name, trial in list(self._tried_with.items()):
                if name != t.name and name not in self._retried and trial.get(t.name, decision.on) != decision.on:
                    self.decisions.pop(name, None)
                    self._retried.add(name)
            self._tried_with[t.name] = dict(t.others)

    def text(self, name: str, setting) -> str:
        """The panel's words for switch ``name`` set to ``setting``: see :func:`switch_text`."""
        measuring = self._trial is not None and self._trial.name == name
        text = switch_text(setting, self.decisions.get(name), measuring, self.previous.get(name))
        if measuring and self.frozen and setting == AUTO:
            text = text[:-1] + "; paused while culling is frozen)"
        return text


def switch_text(setting, decision: Decision | None, measuring: bool = False, previous: Decision | None = None) -> str:
    """How a switch reads: "on", "off", "auto (measuring)", "auto (on: removed 41 % of blades, ...)";
    undecided with a ``previous`` decision (the camera, field or parameters changed):
    "auto (on until measured again)" / "auto (on, measuring again)"."""
    if setting != AUTO:
        return "on" if setting else "off"
    if decision is None:
        if previous is not None:
            state = "on" if previous.on else "off"
            return f"auto ({state}, measuring again)" if measuring else f"auto ({state} until measured again)"
        return "auto (measuring)" if measuring else "auto (not decided yet)"
    return f"auto ({'on' if decision.on else 'off'}: {decision.reason})"
