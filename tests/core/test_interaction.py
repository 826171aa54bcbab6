"""The pointer, key and display rules both engines follow (grasswidget.core.interaction), pure."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from grasswidget.core import interaction as ia
from grasswidget.errors import GrassValueError


def _press(events, rules=None):
    g = ia.PointerGesture(rules)
    out = []
    for kind, *args in events:
        out.append(getattr(g, kind)(*args))
    return out, g


def test_a_ctrl_press_is_a_click_until_it_moves_the_slop_then_a_pan():
    slop = ia.CLICK_SLOP_PX
    for mods in (("Control",), ("Meta",), ("Control", "Shift")):  # ctrl wins over the ball's shift
        got, g = _press([("down", 50, 50, ia.LEFT, mods), ("move", 51, 52), ("move", 50 + 0.7 * slop, 50),
                         ("up", 50, 50 + 0.9 * slop)])
        assert got == ["pick", "wait", "wait", "inspect"] and g.kind is None
    # the slop reached on the way (even back at the press point after): a pan, never an inspect
    got, _ = _press([("down", 0, 0, ia.LEFT, ("Control",)), ("move", 0, slop), ("move", 1, 0), ("up", 0, 0)])
    assert got == ["pick", "pan_start", "pan", "pan"]
    # released past the slop with no move between: nothing to pan, nothing inspected
    got, _ = _press([("down", 0, 0, ia.LEFT, ("Meta",)), ("up", 3 * slop, 0)])
    assert got == ["pick", "cancel"]


def test_the_other_presses_keep_their_kind_from_press_to_release():
    cases = {(ia.LEFT, ("Shift",)): "ball", (ia.RIGHT, ()): "pan", (ia.RIGHT, ("Control",)): "pan",
             (ia.LEFT, ()): "orbit", (ia.LEFT, ("Alt",)): "orbit", (ia.MIDDLE, ()): "orbit"}
    for (button, mods), kind in cases.items():
        got, _ = _press([("down", 5, 5, button, mods), ("move", 6, 5), ("move", 90, 40), ("up", 90, 40)])
        assert got == [kind] * 4, (button, mods)
    g = ia.PointerGesture()
    assert g.move(1, 1) is None and g.up(1, 1) is None  # no press: nothing
    assert [ia.DOM_BUTTONS[b] for b in (0, 1, 2)] == [ia.LEFT, ia.MIDDLE, ia.RIGHT]


def test_the_rules_data_decides_the_gesture():
    """The numbers travel as data: a gesture built on changed rules follows them (what the JS twin runs)."""
    rules = json.loads(json.dumps(ia.input_rules()))  # JSON-able, as frame_rules carries it
    assert rules == ia.input_rules() and rules["click_slop_px"] == 4.0 and rules["steps_report_ms"] == 60
    events = [("down", 0, 0, 1, ("Control",)), ("move", 6, 0), ("up", 6, 0)]
    assert _press(events)[0] == ["pick", "pan_start", "pan"]
    assert _press(events, dict(rules, click_slop_px=10.0))[0] == ["pick", "wait", "inspect"]


def test_keys_ball_reach_and_pixel_ratio():
    assert [ia.key_action(k) for k in (" ", "Space", "S", "r", "x")] == ["toggle_play", "toggle_play", "step",
                                                                          "reset_camera", None]
    assert ia.key_action("s", ("Shift",)) is None and ia.key_action(" ", ["Control"]) is None
    # the field's box plus a tenth of its extent (the larger side, at least 1 m) on each side
    assert np.allclose(ia.ball_reach((-2, 0, -1, ), (2, 0.5, 1)), (-2.4, 2.4, -1.4, 1.4))
    assert np.allclose(ia.ball_reach((0, 0, 0), (0.2, 0, 0.1)), (-0.1, 0.3, -0.1, 0.2))
    with pytest.raises(GrassValueError, match="margin.*0 to 1"):
        ia.ball_reach((0, 0, 0), (1, 0, 1), margin=2)
    with pytest.raises(GrassValueError, match="finite"):
        ia.ball_reach((0, 0, math.nan), (1, 0, 1))
    assert [ia.display_ratio(d) for d in (0, None, 1, 1.5, 2, 3)] == [1.0, 1.0, 1.0, 1.5, 2.0, ia.MAX_PIXEL_RATIO]
    assert ia.display_ratio(3, asked=3.0) == 3.0  # a widget's pixel_ratio is not capped
