"""The "auto" switches' rule (grasswidget.core.auto_switches): each outcome of the decision, the
trial's schedule, re-deciding when the context changes, and the three-way trait."""

import pytest

from grasswidget.core.params import GrassParams
from grasswidget.core.auto_switches import (AUTO, AutoSwitches, DecisionContext, decide_compute_raster, decide_occlusion,
                                            MIN_OCCLUDED_FRACTION, switch_text)
from grasswidget.errors import GrassError


def test_occlusion_that_hides_nothing_is_off_whatever_the_times():
    d = decide_occlusion([1.0], [9.0], occluded=10, reaching=1000)  # 1 %: under MIN_OCCLUDED_FRACTION
    assert MIN_OCCLUDED_FRACTION > 0.01 and not d.on and "1 %" in d.reason and "too few" in d.reason
    assert not decide_occlusion([1.0], [9.0], 0, 0).on


def test_occlusion_that_hides_many_is_kept_when_faster_dropped_when_slower():
    on = decide_occlusion([10.0, 11.0, 30.0], [20.0, 21.0, 19.0], occluded=410, reaching=1000)
    assert on.on and on.reason.startswith("removed 41 % of blades") and "11.0 ms" in on.reason and "20.0 ms off" in on.reason
    off = decide_occlusion([22.0, 23.0], [20.0, 21.0], occluded=410, reaching=1000)
    assert not off.on and "but" in off.reason
    assert not decide_occlusion([20.0], [20.0], 410, 1000).on  # a tie gains nothing: off


def test_compute_raster_without_thin_blades_is_off_else_the_faster():
    assert not decide_compute_raster([1.0], [5.0], rastered=0, drawn=500).on
    assert decide_compute_raster([4.0], [5.0], rastered=250, drawn=500).on
    slower = decide_compute_raster([6.0], [5.0], rastered=250, drawn=500)
    assert not slower.on and "drew 50 % of blades" in slower.reason


def _ctx(eye=(0.0, 2.0, 10.0), target=(0.0, 0.0, 0.0), blades=1024, params=("a",)):
    return DecisionContext(eye, target, blades, None, params)


def _run_trial(state, settings, ctx, ms_of, counts_of):
    """Drive ``state`` until nothing is measured; returns the values of each frame."""
    seen = []
    for _ in range(100):
        values = state.values(settings, ctx)
        seen.append(values)
        if not state.measuring:
            return seen
        state.record(ms_of(values), counts_of(values))
    raise AssertionError("the trial never ended")


def test_trial_times_off_then_on_and_keeps_the_faster():
    state = AutoSwitches(trial_frames=2, settle_frames=1, min_ms=0)
    settings = {"cull_occlusion": AUTO, "compute_raster": False}
    seen = _run_trial(state, settings, _ctx(), lambda v: 5.0 if v["cull_occlusion"] else 9.0,
                      lambda v: dict(occluded=600 if v["cull_occlusion"] else 0, visible=400, rastered=0))
    occl = [v["cull_occlusion"] for v in seen]
    # off, on, on, off: a settling frame after each flip, then a block of 1 frame (2 timed a side)
    assert occl[:7] == [False, False] + [True] * 3 + [False, False]
    assert all(v["compute_raster"] is False for v in seen)  # forced off: never tried
    assert state.decisions["cull_occlusion"].on and seen[-1]["cull_occlusion"] is True
    assert "compute_raster" not in state.decisions
    assert state.text("cull_occlusion", AUTO).startswith("auto (on: removed 60 % of blades")


def test_decision_holds_until_camera_field_or_params_change():
    state = AutoSwitches(trial_frames=1, settle_frames=0, min_ms=0)
    settings = {"cull_occlusion": AUTO}
    run = lambda ctx: _run_trial(state, settings, ctx, lambda v: 1.0, lambda v: dict(occluded=0, visible=100))
    run(_ctx())
    assert not state.decisions["cull_occlusion"].on
    state.values(settings, _ctx(eye=(0.0, 2.0, 10.3)))  # 3 % of the distance: same view
    assert "cull_occlusion" in state.decisions and not state.measuring
    for ctx, why in ((_ctx(eye=(0.0, 2.0, 14.0)), "the camera moved"), (_ctx(target=(8.0, 0.0, 0.0)), "the camera turned"),
                     (_ctx(blades=2048), "the blade count changed"), (_ctx(params=("b",)), "the parameters changed")):
        run(_ctx())
        state.values(settings, ctx)
        assert state.measuring and state.redecided_because == why
        run(ctx)


def test_forcing_a_switch_stops_its_trial_and_auto_again_keeps_the_decision():
    state = AutoSwitches(trial_frames=1, settle_frames=0, min_ms=0)
    ctx = _ctx()
    state.values({"compute_raster": AUTO}, ctx)
    assert state.trial == "compute_raster"
    assert state.values({"compute_raster": True}, ctx) == {"compute_raster": True} and not state.measuring
    _run_trial(state, {"compute_raster": AUTO}, ctx, lambda v: 1.0, lambda v: dict(rastered=0, visible=10))
    assert state.values({"compute_raster": False}, ctx) == {"compute_raster": False}
    assert state.values({"compute_raster": AUTO}, ctx) == {"compute_raster": False} and not state.measuring


def test_switch_trait_keeps_bools_and_takes_auto():
    p = GrassParams()
    assert p.cull_occlusion == AUTO and p.compute_raster == AUTO  # the defaults
    p.cull_occlusion = False
    p.compute_raster = True
    assert p.cull_occlusion is False and p.compute_raster is True
    p.cull_occlusion = "on"
    p.compute_raster = "OFF"
    assert p.cull_occlusion is True and p.compute_raster is False
    assert GrassParams(cull_occlusion=0).cull_occlusion is False
    for bad in ("maybe", 2, None, 0.5):
        with pytest.raises(GrassError, match="cull_occlusion must be True"):
            p.cull_occlusion = bad
    assert p.cull_occlusion is True  # kept
    assert switch_text(True, None) == "on" and switch_text(AUTO, None, measuring=True) == "auto (measuring)"


def test_a_decision_made_again_changes_only_past_the_hysteresis():
    from grasswidget.core.auto_switches import HYSTERESIS

    assert 0 < HYSTERESIS <= 0.05
    # first decision: the faster wins, however close
    assert decide_occlusion([9.9], [10.0], 500, 1000).on
    # made again with the previous choice on: kept unless off is faster by more than HYSTERESIS
    kept = decide_occlusion([10.3], [10.0], 500, 1000, previous=True)
    assert kept.on and "kept: within 5 %" in kept.reason
    assert not decide_occlusion([10.0], [10.0 * (1 - HYSTERESIS) - 0.01], 500, 1000, previous=True).on
    # previous choice off: on only when faster by more than HYSTERESIS
    assert not decide_compute_raster([9.7], [10.0], 100, 500, previous=False).on
    assert decide_compute_raster([10.0 * (1 - HYSTERESIS) - 0.01], [10.0], 100, 500, previous=False).on
    # the counts still rule first: nothing hidden is off whatever was chosen before
    assert not decide_occlusion([1.0], [10.0], 0, 1000, previous=True).on


def test_noise_does_not_flip_a_decision_back_and_forth():
    """A view whose two choices cost the same (noise of +-3 %) re-decides after every camera
    move: after the first decision it never flips."""
    import random

    rng = random.Random(4)
    state = AutoSwitches(trial_frames=3, settle_frames=1, min_ms=0)
    settings = {"cull_occlusion": AUTO, "compute_raster": False}
    chosen = []
    for k in range(40):
        ctx = _ctx(eye=(0.0, 2.0, 10.0 + 2.0 * (k % 2)))  # each move 20 % of the distance: re-decide
        _run_trial(state, settings, ctx, lambda v: 10.0 * (1 + rng.uniform(-0.03, 0.03)),
                   lambda v: dict(occluded=300 if v["cull_occlusion"] else 0, visible=700, rastered=0))
        chosen.append(state.decisions["cull_occlusion"].on)
    assert len(set(chosen)) == 1, chosen


def test_without_frames_no_trial_starts_and_the_previous_choice_runs():
    state = AutoSwitches(trial_frames=1, settle_frames=0, min_ms=0)
    settings = {"cull_occlusion": AUTO, "compute_raster": AUTO}
    # never decided, no frame drawn for it: off, nothing measured
    assert state.values(settings, _ctx(), start_trial=False) == {"cull_occlusion": False, "compute_raster": False}
    assert not state.measuring and state.trial_frames_run == 0
    _run_trial(state, settings, _ctx(), lambda v: 5.0 if v["cull_occlusion"] else 9.0,
               lambda v: dict(occluded=600 if v["cull_occlusion"] else 0, visible=400, rastered=0))
    assert state.decisions["cull_occlusion"].on and state.trial_frames_run == 8  # 2 switches x (off, on, on, off)
    moved = _ctx(eye=(0.0, 2.0, 14.0))
    assert state.values(settings, moved, start_trial=False)["cull_occlusion"] is True  # the previous choice
    assert not state.measuring and state.text("cull_occlusion", AUTO) == "auto (on until measured again)"
    # frames again: the trial of occlusion runs; meanwhile the compute rasterizer keeps its previous choice
    values = state.values(settings, moved)
    assert state.trial == "cull_occlusion" and values == {"cull_occlusion": False, "compute_raster": False}
    assert state.text("cull_occlusion", AUTO) == "auto (on, measuring again)"


def test_trial_sizes_are_checked():
    for bad in (dict(trial_frames=0), dict(trial_frames=True), dict(settle_frames=-1), dict(settle_frames=1.5),
                dict(max_frames=2), dict(min_ms=-1.0), dict(min_ms="5")):
        with pytest.raises(GrassError, match="must be"):
            AutoSwitches(**bad)


def test_fast_frames_are_timed_for_at_least_min_ms_a_side_and_at_most_max_frames():
    from grasswidget.core.auto_switches import TRIAL_MAX_FRAMES, TRIAL_MIN_MS

    assert TRIAL_MIN_MS >= 3 * 10 and TRIAL_MAX_FRAMES >= 10
    # blocks of 2 (3 a side at least, rounded up to two blocks); of 7 (25 ms: half of 50 ms a side); of 12 at most
    for ms, block in ((100.0, 2), (4.0, 7), (0.5, 12)):
        state = AutoSwitches(trial_frames=3, settle_frames=0, min_ms=50.0, max_frames=24)
        seen = _run_trial(state, {"cull_occlusion": AUTO}, _ctx(), lambda v: ms,
                          lambda v: dict(occluded=500 if v["cull_occlusion"] else 0, visible=500))
        assert [v["cull_occlusion"] for v in seen[:-1]] == [False] * block + [True] * 2 * block + [False] * block, \
            (ms, len(seen))


def test_the_first_switch_is_tried_again_when_the_second_changes_what_it_was_tried_with():
    """Occlusion tried with the rasterizer off (its provisional value) pays; the rasterizer then
    pays too, and with it on occlusion no longer does (it hid the far, thin blades the
    rasterizer now draws cheaply): occlusion is tried again once, with the rasterizer on."""
    cost = {(False, False): 16.4, (True, False): 13.8, (False, True): 9.1, (True, True): 10.0}  # the H100's meadow 2^22
    state = AutoSwitches(trial_frames=3, settle_frames=0, min_ms=0)
    settings = {"cull_occlusion": AUTO, "compute_raster": AUTO}
    seen = _run_trial(state, settings, _ctx(), lambda v: cost[(v["cull_occlusion"], v["compute_raster"])],
                      lambda v: dict(occluded=300 if v["cull_occlusion"] else 0, visible=700,
                                     rastered=200 if v["compute_raster"] else 0))
    assert seen[-1] == {"cull_occlusion": False, "compute_raster": True}
    assert not state.decisions["cull_occlusion"].on and state.decisions["compute_raster"].on
    # occlusion, the rasterizer, occlusion again with it on, the rasterizer again with occlusion off
    # (each tried again at most once per context): 4 trials of 2 + 4 + 2 frames, then the choice
    assert len(seen) == 1 + 4 * 8
    assert state.values(settings, _ctx()) == seen[-1] and not state.measuring  # settled: no more trials


def test_frozen_culling_suspends_a_trial_and_holds_the_values_until_unfrozen():
    """Issue 37, item 3: while culling is frozen no "auto" decision lands and no switch changes
    (the would-be decision needs frames the frozen view does not record); unfreezing resumes the
    trial where it stopped, and it then decides as an unfrozen run would."""
    settings = {"cull_occlusion": AUTO, "compute_raster": False}
    ms_of = lambda v: 5.0 if v["cull_occlusion"] else 9.0  # noqa: E731  occlusion pays
    counts_of = lambda v: dict(occluded=600 if v["cull_occlusion"] else 0, visible=400, rastered=0)  # noqa: E731
    reference = _run_trial(AutoSwitches(trial_frames=2, settle_frames=1, min_ms=0), settings, _ctx(), ms_of, counts_of)

    state = AutoSwitches(trial_frames=2, settle_frames=1, min_ms=0)
    for _ in range(1):  # the trial's first (settling) frame, occlusion off; then freeze
        v = state.values(settings, _ctx())
        state.record(ms_of(v), counts_of(v))
    before = state.values(settings, _ctx())
    assert state.measuring and before["cull_occlusion"] is False
    runs = state.trial_frames_run
    moved = _ctx(eye=(0.0, 40.0, 0.01))  # the camera flies off the frozen view
    for _ in range(3 * len(reference)):  # far more frames than the whole trial needs
        v = state.values(settings, moved, frozen=True)
        assert v == before  # nothing that decides which blades are drawn changes
        assert not state.measuring and state.suspended
        state.record(ms_of(v), counts_of(v))  # a frozen frame is not one of the trial's
    assert "cull_occlusion" not in state.decisions and state.trial_frames_run == runs
    assert state.text("cull_occlusion", AUTO) == "auto (measuring; paused while culling is frozen)"
    # forcing a switch while frozen takes effect at once (the user asked), and "auto" again holds
    assert state.values({**settings, "cull_occlusion": True}, moved, frozen=True)["cull_occlusion"] is True
    assert state.values(settings, moved, frozen=True) == before
    # unfrozen at the view of before: the trial resumes (a settling frame first) and decides
    seen = _run_trial(state, settings, _ctx(), ms_of, counts_of)
    assert not state.suspended and state.decisions["cull_occlusion"].on and seen[-1]["cull_occlusion"] is True
    assert state.trial_frames_run > runs
    # decided, then frozen: the decision holds whatever the camera does, no new trial starts
    state.values(settings, _ctx())
    for eye in ((30.0, 5.0, 0.0), (0.0, 40.0, 0.01)):
        assert state.values(settings, _ctx(eye=eye), frozen=True)["cull_occlusion"] is True
        assert not state.measuring
