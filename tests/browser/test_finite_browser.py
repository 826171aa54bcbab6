"""The browser engine's side of "state that stays finite" (issue 37, item 5), without a browser:
step(n) refuses n above MAX_STEPS before anything is sent, and the reset flag that comes back
with read_state's collision buffer warns once per cause. (The WGSL that sets the flag is the
kernel's, tested on lavapipe in tests/gpu/test_finite_state.py.)"""

from __future__ import annotations

import warnings

import pytest

import grasswidget as gw
from grasswidget.browser.engine_widget import BrowserEngineWidget
from grasswidget.core.limits import MAX_STEPS, NonFiniteStateWarning


def test_browser_step_refuses_more_than_max_steps_before_sending():
    view = BrowserEngineWidget(gw.Blades.on_plane(64, seed=1))
    sent = []
    view.send = lambda content, buffers=None: sent.append(content)
    try:
        for n in (MAX_STEPS + 1, 2**40, -3, 1.5):
            with pytest.raises(gw.GrassValueError, match=r"\[0, 1,000,000\].*MAX_STEPS"):
                view.step(n)
        assert sent == []
        view.step(MAX_STEPS)
        assert sent == [{"type": "step", "n": MAX_STEPS}]
    finally:
        view.close()


def test_browser_widget_step_refuses_too():
    w = gw.GrassWidget(64, backend="browser", size=(160, 120))
    try:
        with pytest.raises(ValueError, match="MAX_STEPS"):
            w.step(2**40)
    finally:
        w.close()


def test_the_reset_flag_warns_once_per_cause_until_reset():
    view = BrowserEngineWidget(gw.Blades.on_plane(64, seed=1),
                               params=gw.GrassParams(wind_field="custom", wind_wgsl="return vec3<f32>(1.0);"))
    sent = []
    view.send = lambda content, buffers=None: sent.append(content["type"])
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            assert not view.note_reset_flag(0.0)
            assert sent == []
            assert view.note_reset_flag(1.0) and view.note_reset_flag(1.0)
            assert sent == ["clear_reset_flag", "clear_reset_flag"]  # the page clears it after each read
            view.reset()
            assert view.note_reset_flag(1.0)
        mine = [str(w.message) for w in caught if issubclass(w.category, NonFiniteStateWarning)]
        assert len(mine) == 2 and all("wind WGSL" in m and "at rest" in m for m in mine)
    finally:
        view.close()
