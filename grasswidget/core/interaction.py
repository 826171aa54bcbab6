"""How a user's pointer, keys and display act on a view, decided once for both engines (pure Python).

The kernel engine applies these rules to jupyter-rfb's canvas events in the kernel
(:mod:`grasswidget.views.kernel`, :mod:`grasswidget.notebook.ball`); the browser engine
gets them as data (``frame_rules["input"]``, :func:`input_rules`) and its JS twins in
``grasswidget/browser/js/rules.js`` execute them (``tests/browser/test_engine_rules.py`` runs the
twins under Node.js against these functions). The live page (``browser/page.js``) reads the same
data from its data block.

* :class:`PointerGesture`: what one press of a pointer button does, from press to release. Ctrl
  (or Cmd) + left button: a *click* (released less than :data:`CLICK_SLOP_PX` CSS pixels from
  where it was pressed, never further on the way) inspects the blade under the pointer; a *drag*
  (it went that far) pans the camera, as a right-drag does. Both engines follow this rule (see
  docs/design.md, "The ctrl gesture"). Shift + left-drag moves the ball; a right-drag pans; any
  other press orbits.
* :func:`key_action`: what a key pressed in a view does (space: play/pause, ``s``: one step,
  ``r``: the home camera); a key with a modifier held is the notebook's.
* :func:`ball_reach`: how far past the field the ball may be moved (:data:`BALL_MARGIN` of the
  field's extent).
* :func:`display_ratio`: rendered pixels per CSS pixel that follow the display's
  devicePixelRatio, at most :data:`MAX_PIXEL_RATIO`.
* :data:`STEPS_REPORT_MS`: while a ball rolls in the browser engine, how often the page tells
  Python how many steps passed.
"""

from __future__ import annotations

import math

from ..errors import GrassValueError

__all__ = ["CLICK_SLOP_PX", "PICK_MODIFIERS", "BALL_MODIFIER", "LEFT", "RIGHT", "MIDDLE", "DOM_BUTTONS",
           "MAX_PIXEL_RATIO", "STEPS_REPORT_MS", "BALL_MARGIN", "KEY_ACTIONS", "input_rules", "key_action",
           "ball_reach", "display_ratio", "PointerGesture"]

#: A press released less than this many CSS pixels from where it was pressed (and never that far
#: on the way) is a click; from this far on it is a drag. Both engines; 4 px.
CLICK_SLOP_PX = 4.0
#: Modifier names (jupyter-rfb's, the DOM's key names) that make a left press the ctrl gesture:
#: Ctrl, or Cmd on a Mac.
PICK_MODIFIERS = ("Control", "Meta")
#: The modifier that makes a left press move the ball.
BALL_MODIFIER = "Shift"
#: Pointer buttons as jupyter-rfb numbers them (the rules' numbering): 1 left, 2 right, 3 middle.
LEFT, RIGHT, MIDDLE = 1, 2, 3
#: The rules' number of each DOM ``PointerEvent.button`` (0 left, 1 middle, 2 right, 3 back, 4 forward).
DOM_BUTTONS = (LEFT, MIDDLE, RIGHT, 4, 5)
#: The most rendered pixels per CSS pixel when a view follows the display's devicePixelRatio
#: (a 3x phone screen renders at 2x); a widget's ``pixel_ratio`` may ask otherwise.
MAX_PIXEL_RATIO = 2.0
#: While a ball rolls in the browser engine, the page tells Python the steps simulated at most
#: this often (milliseconds): Python moves the ball by them.
STEPS_REPORT_MS = 60
#: The ball's centre may go this fraction of the field's extent past the field's edges.
BALL_MARGIN = 0.1
#: What each key (the DOM's ``key``, lower case) does in a view, as the name of an action.
KEY_ACTIONS = {" ": "toggle_play", "space": "toggle_play", "spacebar": "toggle_play", "s": "step",
               "r": "reset_camera"}


def input_rules() -> dict:
    """The rules above as data (JSON-able), sent to the browser as ``frame_rules["input"]``:
    ``click_slop_px``, ``pick_modifiers``, ``ball_modifier``, ``buttons`` ({left, right, middle}),
    ``dom_buttons``, ``max_pixel_ratio``, ``steps_report_ms``, ``ball_margin``, ``keys``."""
    return {"click_slop_px": CLICK_SLOP_PX, "pick_modifiers": list(PICK_MODIFIERS), "ball_modifier": BALL_MODIFIER,
            "buttons": {"left": LEFT, "right": RIGHT, "middle": MIDDLE}, "dom_buttons": list(DOM_BUTTONS),
            "max_pixel_ratio": MAX_PIXEL_RATIO, "steps_report_ms": STEPS_REPORT_MS, "ball_margin": BALL_MARGIN,
            "keys": dict(KEY_ACTIONS)}


def key_action(key, modifiers=()) -> str | None:
    """The action of ``key`` (a DOM key name, any case) pressed with ``modifiers`` held: one of
    ``"toggle_play"``, ``"step"``, ``"reset_camera"``, or None (not ours: another key, or any
    modifier held, so the notebook's shortcuts keep working)."""
    if modifiers:
        return None
    return KEY_ACTIONS.get(str(key).lower())


def ball_reach(lo, hi, margin=BALL_MARGIN) -> tuple:
    """``(x_min, x_max, z_min, z_max)`` (m) where the ball's centre may go over a field whose blade
    roots span ``lo`` .. ``hi`` (x, y, z): the field's box widened on each side by ``margin``
    (0 .. 1, default :data:`BALL_MARGIN`) times its extent (the larger of its x and z sizes, at
    least 1 m)."""
    margin = float(margin)
    if not 0.0 <= margin <= 1.0:
        raise GrassValueError(f"margin must be a fraction of the field's extent from 0 to 1; got {margin!r}")
    lo, hi = [float(v) for v in lo], [float(v) for v in hi]
    if not all(math.isfinite(v) for v in lo + hi):
        raise GrassValueError(f"ball_reach needs finite field bounds; got lo={lo!r}, hi={hi!r}")
    extent = max(hi[0] - lo[0], hi[2] - lo[2], 1.0)
    pad = margin * extent
    return (lo[0] - pad, hi[0] + pad, lo[2] - pad, hi[2] + pad)


def display_ratio(device_ratio, asked=0.0) -> float:
    """Rendered pixels per CSS pixel: ``asked`` when it is positive (a widget's ``pixel_ratio``),
    else the display's ``device_ratio`` (missing or not positive: 1) held to at most
    :data:`MAX_PIXEL_RATIO`."""
    if asked and asked > 0:
        return float(asked)
    ratio = float(device_ratio) if device_ratio and device_ratio > 0 else 1.0
    return min(ratio, MAX_PIXEL_RATIO)


class PointerGesture:
    """One press of a pointer button, press to release, as both engines read it.

    Feed it the press (:meth:`down`), each move (:meth:`move`) and the release (:meth:`up`),
    with positions in CSS pixels; each returns what the event does:

    * ``down`` returns the press's kind: ``"pick"`` (left + Ctrl/Cmd: a click inspects, a drag
      pans; this wins over Shift), ``"ball"`` (left + Shift), ``"pan"`` (right button), or
      ``"orbit"`` (any other press).
    * ``move`` returns ``"wait"`` while a pick press is still a click (moved less than
      ``click_slop_px`` from the press), ``"pan_start"`` on the move that makes it a drag (the
      pan then starts from the press point), then ``"pan"``; for other kinds their kind; None
      with no press.
    * ``up`` returns ``"inspect"`` for a pick press that stayed a click (released less than
      ``click_slop_px`` from the press), ``"pan"`` for one whose pan started, ``"cancel"`` for one
      released that far away with no move in between (nothing to do); for other kinds their kind;
      None with no press. The press is over then.

    ``rules``: :func:`input_rules` (the default) or the same dict as the browser gets.
    """

    def __init__(self, rules=None):
        self.rules = rules or input_rules()
        self.kind = None
        self.start = None
        self.dragging = False

    def down(self, x, y, button, modifiers=()) -> str:
        """A press at (x, y) of ``button`` (1 left, 2 right, 3 middle) with ``modifiers`` held."""
        r, mods = self.rules, set(modifiers or ())
        left = button == r["buttons"]["left"]
        if left and mods & set(r["pick_modifiers"]):
            kind = "pick"
        elif left and r["ball_modifier"] in mods:
            kind = "ball"
        elif button == r["buttons"]["right"]:
            kind = "pan"
        else:
            kind = "orbit"
        self.kind, self.start, self.dragging = kind, (float(x), float(y)), kind != "pick"
        return kind

    def _far(self, x, y) -> bool:
        return math.hypot(float(x) - self.start[0], float(y) - self.start[1]) >= self.rules["click_slop_px"]

    def move(self, x, y) -> str | None:
        """The pointer moved to (x, y) with the button held."""
        if self.kind is None:
            return None
        if self.kind != "pick":
            return self.kind
        if self.dragging:
            return "pan"
        if self._far(x, y):
            self.dragging = True
            return "pan_start"
        return "wait"

    def up(self, x, y) -> str | None:
        """The button was released at (x, y): the press is over."""
        kind = self.kind
        if kind is None:
            return None
        click = kind == "pick" and not self.dragging and not self._far(x, y)
        started = self.dragging
        self.kind, self.start, self.dragging = None, None, False
        if kind != "pick":
            return kind
        if click:
            return "inspect"
        return "pan" if started else "cancel"
