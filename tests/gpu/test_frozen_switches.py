"""Frozen means frozen (issue 37, item 3): while culling is frozen the "auto" switches hold
their values, so the blades drawn under a frozen view do not change when the occlusion
trial would have decided; unfreezing resumes the trial, which then decides."""

import grasswidget as gw
from grasswidget.core.auto_switches import AUTO
from grasswidget.gpu.trial_timing import switches_of


def test_a_trial_in_progress_is_suspended_while_culling_is_frozen_and_resumes_after():
    s = gw.GrassScene(gw.Blades.on_plane(count=8192, size=15.0, seed=2), size=(320, 240))
    try:
        s.params.wind_strength = 0.0
        assert s.params.cull_occlusion == AUTO
        s.step(60)
        inside = ((-3.0, 1.4, 5.0), (2.0, 0.5, -3.0))  # in the grass: near blades hide most of the field
        s.look(*inside)
        for _ in range(3):
            s.render()
        state = switches_of(s.field)
        assert state.measuring and "cull_occlusion" not in state.decisions  # the trial has started
        before = s.visible_count()
        s.freeze_culling()
        s.look((0.0, 32.0, 0.01), (0.0, 0.0, 0.0))  # from above, looking down on the frozen view
        counts = []
        for _ in range(14):  # the whole trial is 11 frames on lavapipe: it would have decided meanwhile
            s.render()
            counts.append(s.visible_count())
        assert counts == [before] * len(counts), counts
        assert state.suspended and not state.decisions
        s.unfreeze_culling()
        s.look(*inside)
        for _ in range(120):  # 11 frames on lavapipe; a GPU's fast frames time more a side (at most 24)
            s.render()
            if not state.measuring:
                break
        assert "cull_occlusion" in state.decisions, "the trial did not resume after unfreezing"
        # Decided (on lavapipe: on, it removes about 95 % of the blades here); the count follows it.
        s.render()
        if state.decisions["cull_occlusion"].on:
            assert s.visible_count() < before
        else:
            assert s.visible_count() == before
    finally:
        s.release()
