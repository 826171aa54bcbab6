"""The blade count control (powers of two, asks before a slow count) and the status line's words.

No GPU here: the control is driven with a stand-in ``apply`` that records what it
is asked; the widget's own use of it runs in tests/notebook/test_widget.py and,
with the keyboard in JupyterLab, in tests/e2e/test_lecture_controls.py.
"""

from __future__ import annotations

import pytest

from grasswidget.notebook.blade_count_control import (BladeCountControl, blade_stops, count_words, estimate_fps,
                                                      needs_confirmation)
from grasswidget.notebook.panel import format_status


def test_stops_are_powers_of_two_up_to_the_top_and_never_more_than_double():
    stops = blade_stops(1 << 18)
    assert stops == [1 << k for k in range(19)]
    odd = blade_stops(300_000, current=5000)  # a top that is no power of two, a count set from code
    assert odd[-1] == 300_000 and 5000 in odd and 1 << 18 in odd
    assert all(b <= 2 * a for a, b in zip(odd, odd[1:]))  # one step at most doubles
    assert blade_stops(1 << 18, current=10**9) == stops  # out of range: not offered


def test_counts_in_words():
    assert count_words(4096) == "4,096" and count_words(262144) == "262,144"
    assert count_words(1) == "1" and count_words(5000) == "5,000"


def test_estimate_scales_the_measured_frame_time_by_the_blade_count():
    assert estimate_fps(262144, 24.0, 4096) == pytest.approx(24.0 * 4096 / 262144)
    assert estimate_fps(8192, None, 4096) is None and estimate_fps(8192, 0.0, 4096) is None
    # fewer blades never ask; more ask when the estimate falls below the target or nothing is measured
    assert not needs_confirmation(2048, 4096, None, None, 24)
    assert not needs_confirmation(8192, 4096, 60.0, 4096, 24)      # about 30 frames/s: fine
    assert needs_confirmation(16384, 4096, 60.0, 4096, 24)         # about 15 frames/s
    assert needs_confirmation(8192, 4096, None, None, 24)          # not measured yet


class _Actions:
    def __init__(self, fail_above=None):
        self.applied = []
        self.fail_above = fail_above

    def apply(self, n):
        if self.fail_above is not None and n > self.fail_above:
            raise MemoryError(f"blades: {n} do not fit")
        self.applied.append(n)


def _control(count=4096, top=1 << 18, **kw):
    actions, errors = _Actions(**kw), []
    return BladeCountControl(count, top, actions.apply, errors.append), actions, errors


def test_a_fast_count_applies_at_once_a_slow_one_asks_and_cancel_goes_back():
    c, actions, _errors = _control()
    c.note_stats({"fps": 60.0, "blades": 4096, "target_fps": 24.0, "playing": True})
    c.slider.value = 8192  # estimate 30 frames/s >= 24: applied
    assert actions.applied == [8192] and c.count == 8192 and c.pending is None
    assert c.confirm_row.layout.display == "none"
    c.slider.value = 1 << 18  # estimate 60 * 4096 / 262144 = 0.94 frames/s: asks, nothing applied
    assert actions.applied == [8192] and c.pending == 1 << 18
    assert c.confirm_row.layout.display != "none"
    assert "Apply 262,144 blades? about 0.94 frames/s here (target 24)" in c.question.value, c.question.value
    c.cancel()
    assert c.slider.value == 8192 and c.pending is None and actions.applied == [8192]
    assert c.confirm_row.layout.display == "none"
    c.slider.value = 1 << 16
    c.confirm()  # Apply
    assert actions.applied == [8192, 1 << 16] and c.count == 1 << 16 and c.slider.value == 1 << 16


def test_paused_stats_keep_the_last_measurement_and_unknown_rate_asks():
    c, actions, _errors = _control()
    c.slider.value = 8192  # nothing measured yet: asks
    assert c.pending == 8192 and "not measured yet" in c.question.value and not actions.applied
    c.cancel()
    c.note_stats({"fps": 48.0, "blades": 4096, "target_fps": 24.0, "playing": True})
    c.note_stats({"fps": 0.0, "blades": 4096, "target_fps": 24.0, "playing": False})  # paused: kept
    assert c.measured == (48.0, 4096)
    c.slider.value = 8192
    assert actions.applied == [8192]


def test_a_window_with_a_trial_of_the_auto_switches_is_not_the_frame_rate():
    """The "auto" switches' trial (GPU-synchronised frames, a first use compiling) made the test
    lecture's 256-blade view measure 1.96 frames/s once: 512 blades then asked (estimate 0.98,
    target 1) where 9.6 frames/s was the view's rate."""
    c, actions, _errors = _control()
    c.note_stats({"fps": 9.6, "blades": 256, "target_fps": 1.0, "playing": True, "trial": False})
    c.note_stats({"fps": 1.96, "blades": 256, "target_fps": 1.0, "playing": True, "trial": True})  # not kept
    assert c.measured == (9.6, 256)
    c.slider.value = 512
    assert actions.applied == [512] and c.pending is None


def test_a_count_from_code_is_shown_exactly_and_a_refused_count_goes_back():
    c, actions, errors = _control(fail_above=4096)
    c.show_count(5000)  # from code: any integer in range
    assert c.slider.value == 5000 and "5,000" in c.slider.label and not actions.applied
    values = [v for _l, v in c.slider.options]
    assert 4096 in values and 8192 in values and values == sorted(values)
    c.show_count(4096)
    assert 5000 not in [v for _l, v in c.slider.options]
    c.note_stats({"fps": 240.0, "blades": 4096, "target_fps": 24.0})
    c.slider.value = 8192  # applying fails: the message goes to the panel, the slider back
    assert errors and "do not fit" in str(errors[0]) and c.slider.value == 4096 and c.count == 4096


@pytest.mark.parametrize("stats, want, never", [
    ({"fps": None, "blades": 4096, "playing": True}, "starting…", "real time"),
    ({"fps": 0.0, "blades": 4096, "playing": True, "sim_speed": 0.0, "slow_motion": True},
     "waiting for frames", "0.0"),
    ({"fps": 0.01, "visible": 10, "blades": 4096, "playing": True}, "waiting for frames · 10 of 4,096 blades drawn",
     "real time"),
    ({"fps": 12.0, "blades": 4096, "playing": False}, "paused · 4,096 blades", "frames/s"),
    ({"fps": 30.04, "visible": 3000, "blades": 4096, "playing": True, "sim_speed": 1.0},
     "30.0 frames/s · 3,000 of 4,096 blades drawn · real time", "slow"),
    ({"fps": 0.6, "blades": 88116, "playing": True, "slow_motion": True, "sim_speed": 0.3},
     "0.6 frames/s · 88,116 blades · slow motion 0.3x", "real time"),
    ({"fps": 0.1, "blades": 434281, "playing": True, "slow_motion": True, "sim_speed": 0.04},
     "slow motion 0.04x", "0.0x"),
    ({"fps": 0.1, "blades": 434281, "playing": True, "slow_motion": True, "sim_speed": 0.001},
     "slow motion under 0.01x", "0.0x"),
    ({"fps": 0.1, "blades": 256, "playing": True, "sim_speed": None}, "0.1 frames/s · 256 blades", "real time"),
    ({"fps": 11.9, "blades": 1024, "playing": True, "slow_motion": True, "sim_speed": 0.958},
     "slow motion 0.96x", "1.0x"),
    ({"fps": 11.9, "blades": 1024, "playing": True, "slow_motion": True, "sim_speed": 0.9999},
     "slow motion 0.99x", "1.0x"),
    # how old the stats are (issue 37, item 4): a frame that arrived is never "waiting for frames"
    ({"fps": 0.0, "visible": 10, "blades": 4096, "playing": True, "frame_age_s": 0.4, "stale": False,
      "waiting": False, "at_rest": False}, "starting… · 10 of 4,096 blades drawn", "waiting"),
    ({"fps": 3.9, "visible": 10, "blades": 4096, "playing": True, "frame_age_s": 0.8, "stale": True,
      "waiting": False, "at_rest": False}, "3.9 frames/s · 10 of 4,096 blades drawn · last frame 0.8 s ago",
     "real time"),
    ({"fps": 3.9, "blades": 4096, "playing": True, "frame_age_s": 5.0, "stale": True, "waiting": True,
      "at_rest": False}, "waiting for frames · 4,096 blades · last frame 5.0 s ago", "real time"),
    ({"fps": 24.0, "visible": 2756, "blades": 4096, "playing": True, "frame_age_s": 42.3, "stale": True,
      "waiting": False, "at_rest": True},
     "at rest (out of sight) · 2,756 of 4,096 blades drawn · last frame 42 s ago", "frames/s"),
    ({"fps": 24.0, "blades": 4096, "playing": False, "frame_age_s": 600.0, "stale": True, "waiting": False,
      "at_rest": False}, "paused · 4,096 blades · last frame 10 min ago", "real time"),
    ({"fps": 24.0, "blades": 4096, "playing": False, "frame_age_s": 600.0, "stale": False, "waiting": False,
      "at_rest": False}, "paused · 4,096 blades", "ago"),
])
def test_status_says_only_what_it_knows(stats, want, never):
    line = format_status(stats)
    assert want in line and never not in line, line


def test_the_target_is_read_when_choosing():
    """The widget's target_fps as it is now (set a moment ago), not as of the last stats."""
    target = [1.0]
    applied = []
    c = BladeCountControl(256, 1 << 18, applied.append, print, target_fps=lambda: target[0])
    c.note_stats({"fps": 4.0, "blades": 256, "target_fps": 1.0, "playing": True})
    c.slider.value = 512  # about 2 frames/s >= 1: applied
    assert applied == [512]
    target[0] = 240.0
    c.slider.value = 1024  # about 1 frame/s < 240: asks, naming the target in force
    assert c.pending == 1024 and "(target 240)" in c.question.value and applied == [512]
