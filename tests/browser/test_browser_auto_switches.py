"""The browser engine's "auto" switches without a browser: recorded stats messages fed to
the view, the switch state it sends back (the two ``u_cull`` words engine.js executes), the
decision (grasswidget.core.auto_switches's rule, the kernel's) and the panel's words.

Not marked ``browser``: the messages are what engine.js sends (js/messages.js's protocol comment).
"""

from __future__ import annotations

import numpy as np

import grasswidget as gw
from grasswidget.core.auto_switches import TRIAL_MAX_FRAMES, TRIAL_SETTLE_FRAMES
from grasswidget.core.uniform_layouts import CULL_LAYOUT, offsets

_AT = offsets(CULL_LAYOUT)


def _executed(engine_widget) -> list:
    """[occlusion, compute raster] as engine.js reads them from the u_cull bytes it was sent."""
    data = engine_widget.cull_uniform
    return [bool(np.frombuffer(data, np.int32, 1, _AT[name][0])[0]) for name in ("occlusion_phase", "compute_raster")]


def _stats(switches, ms, visible=(600, 200, 100, 100), occluded=None, rastered=0):
    """A stats message as engine.js sends it: frames timed and counted with ``switches``."""
    n = 2 * TRIAL_MAX_FRAMES + TRIAL_SETTLE_FRAMES  # enough for any block of a trial
    return {"type": "stats", "fps": 30.0, "visible": list(visible), "occluded": occluded, "rastered": rastered,
            "steps": 15, "step_count": 15, "frame_ms": ms, "frame_size": [320, 240],
            "frame_times": [ms] * n, "timed_switches": list(switches), "counts_switches": list(switches)}


def test_browser_auto_switches_decide_from_the_browsers_frames():
    w = gw.GrassWidget(1024, backend="browser", size=(320, 240))
    ew = w.view.engine_widget
    try:
        assert w.params.cull_occlusion == "auto" and w.params.compute_raster == "auto"
        # The trial starts with occlusion culling off.
        assert _executed(ew) == [False, False]
        assert "auto (" in w.panel.switch_choices["cull_occlusion"].decision_line.value
        # A message of frames drawn with another state than asked (still in flight) is not used.
        ew.handle_message(_stats([True, False], 9.0, occluded=500))
        assert _executed(ew) == [False, False] and ew.auto_switches.state.decisions == {}
        # Off: 10 ms a frame; then the browser is asked for the on half.
        ew.handle_message(_stats([False, False], 10.0))
        assert _executed(ew) == [True, False]
        # Counts of a frame drawn off (a read-back in flight) with on-frames: waits for the next message.
        msg = _stats([True, False], 6.0, occluded=500)
        msg["counts_switches"] = [False, False]
        ew.handle_message(msg)
        assert "cull_occlusion" not in ew.auto_switches.state.decisions
        # On: 6 ms, 500 of 1500 blades occluded; then off again (the trial runs off, on, on, off).
        ew.handle_message(_stats([True, False], 6.0, occluded=500))
        assert _executed(ew) == [False, False] and "cull_occlusion" not in ew.auto_switches.state.decisions
        # Off, 10 ms: on, and the compute rasterizer is tried next (off first).
        ew.handle_message(_stats([False, False], 10.0))
        decision = ew.auto_switches.state.decisions["cull_occlusion"]
        assert decision.on and "removed 33 % of blades" in decision.reason and "6.0 ms" in decision.reason
        assert _executed(ew) == [True, False]
        assert w.stats["switches"]["cull_occlusion"].startswith("auto (on: removed 33 % of blades")
        assert "auto (on: removed 33 % of blades" in w.panel.switch_choices["cull_occlusion"].decision_line.value
        ew.handle_message(_stats([True, False], 6.0, occluded=500))
        assert _executed(ew) == [True, True]
        ew.handle_message(_stats([True, True], 5.0, occluded=500, rastered=0))
        assert _executed(ew) == [True, False]
        ew.handle_message(_stats([True, False], 6.0, occluded=500))
        assert ew.auto_switches.state.decisions["compute_raster"] == gw.core.auto_switches.Decision(
            False, "took over no blade (none thin enough)")
        assert _executed(ew) == [True, False]
        assert w.stats["switches"] == {"cull_occlusion": w.stats["switches"]["cull_occlusion"],
                                       "compute_raster": "auto (off: took over no blade (none thin enough))"}
        # Forcing a switch is executed at once; back to auto keeps the decision.
        w.params.cull_occlusion = False
        assert _executed(ew) == [False, False]
        w.params.cull_occlusion = "auto"
        assert _executed(ew) == [True, False]
        # The camera moves far: decided again, from a view where occlusion hides almost nothing: off.
        # The move itself starts no trial (a view at rest is not woken): the previous choice runs
        # until the browser reports frames drawn, which start the trial.
        cam = ew.camera
        ew.camera = dict(cam, position=[0.0, 30.0, 0.01])
        assert ew.auto_switches.state.redecided_because == "the camera moved"
        assert _executed(ew) == [True, False] and ew.auto_switches.state.decisions == {}
        assert not ew.auto_switches.state.measuring
        assert ew.auto_switches.texts()["cull_occlusion"] == "auto (on until measured again)"
        ew.handle_message(_stats([True, False], 6.0, occluded=10))  # frames drawn: the trial starts, off first
        assert _executed(ew) == [False, False] and ew.auto_switches.state.trial == "cull_occlusion"
        ew.handle_message(_stats([False, False], 5.0))
        ew.handle_message(_stats([True, False], 4.0, occluded=10))
        ew.handle_message(_stats([False, False], 5.0))
        decision = ew.auto_switches.state.decisions["cull_occlusion"]
        assert not decision.on and decision.reason == "removed 1 % of blades: too few to pay"
        # A parameter change decides again too.
        w.params.cull_distance_max = w.params.cull_distance_max * 0.9
        assert ew.auto_switches.state.redecided_because == "the parameters changed"
        assert ew.auto_switches.texts()["cull_occlusion"] == "auto (off until measured again)"
        assert _executed(ew) == [False, False]  # the previous choice, until frames are reported
        ew.handle_message(_stats([False, False], 5.0))
        assert ew.auto_switches.texts()["cull_occlusion"] == "auto (off, measuring again)"
    finally:
        w.close()


def test_a_paused_browser_view_runs_no_trial_and_is_not_woken():
    """Paused, the browser draws only on demand (a camera move, a new u_cull): the frames it
    reports start no trial and feed none, and no new switch state is sent (each would draw a
    frame). Played again, the next frames start the trial."""
    w = gw.GrassWidget(1024, backend="browser", size=(320, 240))
    ew = w.view.engine_widget
    try:
        w.pause()
        sent = ew.cull_uniform
        for _ in range(3):
            ew.handle_message(_stats([False, False], 10.0))
        assert not ew.auto_switches.state.measuring and ew.auto_switches.state.decisions == {}
        assert ew.cull_uniform == sent and _executed(ew) == [False, False]
        assert ew.auto_switches.state.trial_frames_run == 0 and w.stats["trial"] is False
        w.play()
        ew.handle_message(_stats([False, False], 10.0))  # off frames of a playing view: the trial's first half
        assert ew.auto_switches.state.trial == "cull_occlusion" and _executed(ew) == [True, False]
        assert w.stats["trial"] is True  # this window's frame rate is a trial's
    finally:
        w.close()


def test_frozen_culling_suspends_the_browser_trial_until_unfrozen():
    """Issue 37, item 3, browser engine: frozen, the frames the browser reports do not advance the
    trial, the switch state sent (u_cull) does not change, nothing is decided; unfrozen, the
    trial resumes and decides."""
    w = gw.GrassWidget(1024, backend="browser", size=(320, 240))
    ew = w.view.engine_widget
    try:
        w.play()
        ew.handle_message(_stats([False, False], 10.0))  # the trial's off half: the browser is asked for on
        assert _executed(ew) == [True, False] and ew.auto_switches.state.trial == "cull_occlusion"
        w.culling_frozen = True
        cam = ew.camera
        ew.camera = dict(cam, position=[0.0, 30.0, 0.01])  # flying around the frozen view
        for _ in range(4):  # far more frames than the rest of the trial needs, with either state
            ew.handle_message(_stats([True, False], 6.0, occluded=500))
            ew.handle_message(_stats([False, False], 10.0))
            assert _executed(ew) == [True, False]
        state = ew.auto_switches.state
        assert state.suspended and state.decisions == {}
        assert ew.auto_switches.texts()["cull_occlusion"] == "auto (measuring; paused while culling is frozen)"
        ew.camera = cam
        w.culling_frozen = False
        assert not state.suspended and state.trial == "cull_occlusion"
        for switches, ms in (([True, False], 6.0), ([True, False], 6.0), ([False, False], 10.0)):
            ew.handle_message(_stats(switches, ms, occluded=500 if switches[0] else None))
        assert state.decisions["cull_occlusion"].on
    finally:
        w.close()
