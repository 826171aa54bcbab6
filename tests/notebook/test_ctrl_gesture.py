"""The ctrl gesture in the kernel engine, with synthetic jupyter-rfb events (the browser engine's
side runs the same rule under node: tests/browser/test_engine_rules.py). Ctrl + click inspects,
ctrl + drag pans the camera exactly as a right-drag along the same path does."""

from __future__ import annotations

import numpy as np
import pytest

import grasswidget as gw
from grasswidget.core.interaction import CLICK_SLOP_PX

SIZE = (160, 120)


def _pointer(kind, x, y, modifiers=(), button=1):
    return dict(type=kind, x=x, y=y, button=button, buttons=(button,) if kind != "pointer_up" else (),
                modifiers=modifiers, ntouches=0, touches={}, timestamp=0)


def _drag(w, path, modifiers=(), button=1):
    w.view.events(_pointer("pointer_down", *path[0], modifiers, button))
    for x, y in path[1:]:
        w.view.events(_pointer("pointer_move", x, y, modifiers, button))
    w.view.events(_pointer("pointer_up", *path[-1], modifiers, button))
    for _ in range(40):
        w.controller.tick()
    return w.camera_state


@pytest.fixture(scope="module")
def kernel_widget():
    w = gw.GrassWidget(blades=256, size=SIZE, backend="kernel")
    w.canvas.handle_event({"event_type": "resize", "width": SIZE[0], "height": SIZE[1], "pixel_ratio": 1.0})
    w.pause()
    w.view.draw()
    w.controller.damping = 0  # each drag lands at once (pygfx eases it over ticks otherwise)
    yield w
    w.close()


def test_ctrl_drag_pans_as_a_right_drag_and_ctrl_click_inspects(kernel_widget, monkeypatch):
    w = kernel_widget
    home = w.camera_state
    path = [(80, 60)] + [(80 + 6 * i, 60 - 2 * i) for i in range(1, 8)]
    right = _drag(w, path, button=2)
    moved = np.subtract(right["position"], home["position"])
    assert np.linalg.norm(moved) > 0.05  # a right-drag pans: camera and target move together
    assert np.allclose(np.subtract(right["target"], home["target"]), moved, atol=1e-6)
    picks = []  # where the view was asked to pick a blade
    monkeypatch.setattr(w.view, "pick_blade", lambda x, y: picks.append((x, y)))
    for mods in (("Control",), ("Meta",)):
        w.camera_state = home
        assert np.allclose(w.camera_state["position"], home["position"])
        ctrl = _drag(w, path, mods)
        assert picks == []  # a drag inspects nothing
        for key in ("position", "target"):
            assert np.allclose(ctrl[key], right[key], atol=1e-6), (mods, key)
    # a press released less than the slop away is a click: it inspects there, the camera stays
    w.camera_state = home
    near = (80 + 0.6 * CLICK_SLOP_PX, 60 + 0.5 * CLICK_SLOP_PX)
    assert np.hypot(near[0] - 80, near[1] - 60) < CLICK_SLOP_PX
    after = _drag(w, [(80, 60), (81, 61), near], ("Control",))
    assert picks == [near]
    assert np.allclose(after["position"], home["position"]) and np.allclose(after["target"], home["target"])
    # a plain left drag along the same path still orbits: the distance kept, the target still
    w.camera_state = home
    orbit = _drag(w, path)
    assert np.allclose(orbit["target"], home["target"], atol=1e-6)
    assert not np.allclose(orbit["position"], home["position"], atol=1e-3)
