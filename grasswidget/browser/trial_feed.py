"""The browser engine's side of the "auto" switches (occlusion culling, the compute rasterizer).

The rule and the trial are the kernel engine's: one :class:`grasswidget.core.auto_switches.AutoSwitches`
per :class:`~grasswidget.browser.engine_widget.BrowserEngineWidget`, here fed by the browser's stats
messages instead of by a render loop. engine.js only executes and measures:

* Python sends the switch state to execute as the two ``u_cull`` words it already reads each
  frame (``occlusion_phase``, ``compute_raster``: :func:`grasswidget.browser.uniforms.cull_uniform`
  with ``decided``), the trial's value while a switch is tried, then the decision.
* Each stats message (every ``stats_interval_ms``) carries ``frame_times``: the times (ms, from
  the frame's start to the queue's ``onSubmittedWorkDone``, i.e. the frame's GPU work) of the
  frames drawn since the previous message with the switch state ``timed_switches``
  (``[occlusion, raster]`` as executed; the list restarts when that state changes), and
  ``counts_switches``: the state of the frame whose counts (``visible``, ``occluded``,
  ``rastered``) the message carries.

:meth:`BrowserAutoSwitches.on_stats` records the message's frame times as the trial's frames
when the browser ran them with the state the trial asked for (and its counts are of such a
frame), one by one until the trial asks for another state; then it writes the new state. The
decision is made again on the kernel's triggers (:class:`grasswidget.core.auto_switches.DecisionContext`):
the camera moved or turned, the blade field or any parameter but the two switches changed.
While culling is frozen the switches hold their values and a trial in progress is suspended until
culling is unfrozen (as in the kernel engine; :mod:`grasswidget.core.auto_switches`, "Frozen culling"). A trial starts and advances
only on stats messages that report frames drawn while the widget plays: a view at rest (off
screen, nothing drawn; or paused, drawing only on demand) runs none, and is never woken by one.
"""

from __future__ import annotations

from ..core.auto_switches import SWITCHES, AutoSwitches, DecisionContext

__all__ = ["BrowserAutoSwitches"]


class BrowserAutoSwitches:
    """The "auto" switches of one BrowserEngineWidget (see the module docstring).

    ``state`` is the :class:`~grasswidget.core.auto_switches.AutoSwitches`; ``values`` the switch values
    (``{"cull_occlusion": bool, "compute_raster": bool}``) last sent to the browser, or None
    before :meth:`refresh` ran; ``write`` is called with the new values when they change."""

    def __init__(self, widget, write):
        self._widget = widget
        self._write = write
        self.state = AutoSwitches()
        self.values: dict | None = None
        self._params_version = 0
        self._field_version = 0

    def params_changed(self, name: str):
        """Parameter ``name`` changed: any but the two switches makes the decision stale."""
        if name not in SWITCHES:
            self._params_version += 1

    def field_changed(self):
        """The blades were replaced: decide again."""
        self._field_version += 1

    def settings(self) -> dict:
        """{switch: True / False / "auto"} as the params say."""
        return {name: getattr(self._widget.params, name) for name in SWITCHES}

    def context(self) -> DecisionContext:
        """The :class:`DecisionContext` of the widget's camera, field and parameters."""
        cam = self._widget.camera or {}
        eye = tuple(float(x) for x in cam.get("position", (0.0, 0.0, 0.0)))
        target = tuple(float(x) for x in cam.get("target", (0.0, 0.0, 0.0)))
        return DecisionContext(eye, target, int(len(self._widget.blades)), None,
                               (self._params_version, self._field_version))

    def _next_values(self, start_trial: bool) -> dict:
        frozen = self._widget.frozen_camera is not None
        return self.state.values(self.settings(), self.state.context if frozen else self.context(), start_trial,
                                 frozen=frozen)

    def refresh(self) -> dict:
        """Work out the values for the next frames and send them if they changed; returns
        them. A trigger (camera, field, parameters) makes the decision stale here, but starts
        no trial: only frames the browser reports drawn do (:meth:`on_stats`), so that a view
        at rest is not woken by a trial (a new ``u_cull`` makes the browser draw a frame)."""
        return self._send(self._next_values(start_trial=False))

    def _send(self, values) -> dict:
        if values != self.values:
            self.values = values
            self._write(values)
        return values

    def on_stats(self, msg: dict):
        """Feed a browser stats message (see the module docstring) to the trial, then send
        the values for the next frames; a message with frames drawn may start a trial."""
        # Only a playing view's frames measure: a paused one draws on demand (a camera move, a
        # new u_cull), and a trial fed by them would wake it with each state it sends.
        drew = bool(msg.get("frame_times")) and bool(getattr(self._widget, "playing", True))
        values = self._next_values(start_trial=drew)
        if drew and self.state.measuring and self.values == values:
            asked = [bool(values[name]) for name in SWITCHES]
            timed = msg.get("timed_switches")
            counted = msg.get("counts_switches")
            if timed is not None and [bool(x) for x in timed] == asked and counted is not None \
                    and [bool(x) for x in counted] == asked:
                per_class = msg.get("visible") or []
                rastered = int(msg.get("rastered") or 0)
                counts = {"visible": int(sum(per_class)) + rastered if per_class else None,
                          "rastered": rastered,
                          "occluded": msg.get("occluded") if values["cull_occlusion"] else 0}
                for ms in msg.get("frame_times") or ():
                    self.state.record(float(ms), counts)
                    if not self.state.measuring or self._next_values(start_trial=False) != values:
                        break
        self._send(self._next_values(start_trial=drew))

    def texts(self) -> dict:
        """{switch: words} for the panel: "on", "off", "auto (measuring)", "auto (on: removed
        41 % of blades, ...)" (:func:`grasswidget.core.auto_switches.switch_text`)."""
        settings = self.settings()
        return {name: self.state.text(name, settings[name]) for name in SWITCHES}
