"""The kernel engine's side of the pointer rules (:mod:`grasswidget.core.interaction`).

jupyter-rfb sends the canvas's pointer events to the kernel; :class:`KernelPointer` reads each
press with the same :class:`~grasswidget.core.interaction.PointerGesture` the browser engine runs
(as ``rules.js``'s twin), so both engines agree: Ctrl (or Cmd) + click inspects the blade under the
pointer, Ctrl (or Cmd) + drag pans the camera as a right-drag does, Shift + drag moves the ball.

It decides only; the view acts (:meth:`KernelPointer.feed` returns what to do): the camera
controller (pygfx's ``OrbitController``) gets the events it should see (a ctrl drag's events
rewritten as a right-button drag from the press point; a ctrl press that is still a click: none).
"""

from __future__ import annotations

from .. import compat
from ..core.interaction import PointerGesture

__all__ = ["KernelPointer"]


def _as_right_button(event, x=None, y=None) -> dict:
    """The event as a right-button one with no modifier (a pan for the controller), at (x, y) if given."""
    out = dict(event, button=2, buttons=(2,) if compat.event_type(event) != "pointer_up" else (), modifiers=())
    if x is not None:
        out["x"], out["y"] = x, y
    return out


class KernelPointer:
    """The pointer rules for one kernel view's canvas (events as jupyter-rfb sends them: x, y in
    CSS pixels, ``button`` 1 left, 2 right, 3 middle, ``modifiers`` as names).

    ``rules``: :func:`grasswidget.core.interaction.input_rules` (the default)."""

    def __init__(self, rules=None):
        self.gesture = PointerGesture(rules)
        self._press = None  # the pick press's event (a pan starts from it)

    def feed(self, event) -> tuple:
        """``(action, events)`` for one canvas event: ``action`` is ``"inspect"`` (inspect the blade
        at the event's x, y), ``"ball"`` (the ball's: give it the event), or None; ``events`` are
        the events the camera controller should get instead of this one (``[event]``: as it is)."""
        kind = compat.event_type(event)
        if kind not in ("pointer_down", "pointer_move", "pointer_up") or "x" not in event or "y" not in event:
            return None, [event]
        x, y = float(event["x"]), float(event["y"])
        g = self.gesture
        if kind == "pointer_down":
            if g.kind is not None:  # a second button during a press: the press goes on as it was
                return None, [event]
            press = g.down(x, y, event.get("button", 1), tuple(event.get("modifiers") or ()))
            if press == "pick":
                self._press = dict(event)
                return None, []
            if press == "ball":
                return "ball", [event]
            if press == "pan" and set(event.get("modifiers") or ()) & set(g.rules["pick_modifiers"]):
                return None, [_as_right_button(event)]  # ctrl + right-drag pans too
            return None, [event]
        if g.kind is None:  # moves with no press (hover), a release of another button
            return None, [event]
        if kind == "pointer_move":
            act = g.move(x, y)
            if act == "wait":
                return None, []
            if act == "pan_start":
                press = self._press
                return None, [_as_right_button(press, press["x"], press["y"]), event]
            return ("ball" if act == "ball" else None), [event]
        act = g.up(x, y)
        self._press = None
        if act == "inspect":
            return "inspect", []
        if act == "cancel":
            return None, []
        if act == "pan":
            return None, [_as_right_button(event)]
        return ("ball" if act == "ball" else None), [event]
