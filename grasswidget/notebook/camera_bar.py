"""A widget's camera: its start and named views (:class:`CameraHome`), and the camera bar.

:class:`CameraBar` is the first line of a GrassWidget's panel, in both layouts
(see :mod:`grasswidget.notebook.layout`):

* a Play/Pause button, in the bar only while the panel is folded (the full panel has its own);
* "home", "top" and "low" (``GrassWidget.look_from``: the start camera, straight down
  over the whole field, a student's eye just above the grass looking across it);
* "above the grass" (the widget's ``camera_floor``: ticked = "grass", the orbit keeps the
  camera above the tallest blade's tip; unticked = "ground", down among the blades);
* "more" / "less": unfolds and folds the rest of the panel (the widget's ``panel_folded``).

It knows no widget: it observes and sets a state's traits (``playing``, ``camera_floor``,
``panel_folded``: a GrassWidget's :class:`~grasswidget.notebook.widget_state.WidgetState`, or a
comparison) and its buttons call two actions (``look_from(name)``, ``toggle_play()``); an error
from a button goes to ``on_error`` (the panel's message line), never into the notebook.

:class:`CameraHome` remembers the start camera of the first view, moves the live view's
camera to a named view (:func:`grasswidget.core.camera_presets.camera_preset`) and follows the
state's ``camera_floor``: a new floor gives the view new orbit limits and lifts a camera now below
them; a camera lower than the "grass" floor allows lowers it to "ground", nothing raises it.
:func:`grasswidget.core.camera_presets.floor_for` says which floor a camera needs.
"""

from __future__ import annotations

import ipywidgets as ipw
import numpy as np

from ..core.camera_presets import camera_preset, check_camera_preset, floor_for
from ..core.orbit_limits import clamp_orbit
from .layout import close_widgets

__all__ = ["CameraBar", "CameraHome", "PRESET_BUTTONS", "floor_for"]

#: The preset buttons: (preset name, icon, tooltip), one per core.camera_presets.CAMERA_PRESETS.
PRESET_BUTTONS = (
    ("home", "home", "Back to the start camera (r)"),
    ("top", "arrow-down", "Straight down over the whole field (the freeze-culling view)"),
    ("low", "eye", "A student's eye just above the grass, looking across the field"),
)


class CameraBar:
    """One line: [Play] home top low [x] above the grass   more.

    Args:
        owner: the state: a HasTraits with ``playing``, ``camera_floor`` and ``panel_folded``.
        actions: an object with ``look_from(name)`` and ``toggle_play()`` (default: ``owner``).
        on_error: called with an exception a button raised.

    Attributes: ``play_button``, ``preset_buttons`` (dict name -> Button),
    ``floor_checkbox``, ``more_button`` (ToggleButton, down = unfolded), ``row`` (the HBox).
    """

    def __init__(self, owner, actions=None, *, on_error):
        self._owner = owner
        actions = owner if actions is None else actions
        self._on_error = on_error
        self.play_button = ipw.Button(description="Pause", icon="pause", layout=ipw.Layout(width="90px"),
                                      tooltip="Play / pause the animation (space)")
        self.play_button.on_click(lambda _b: self._run(actions.toggle_play))
        self.preset_buttons = {}
        for name, icon, tip in PRESET_BUTTONS:
            b = ipw.Button(description=name, icon=icon, tooltip=tip, layout=ipw.Layout(width="76px"))
            b.on_click(lambda _b, name=name: self._run(actions.look_from, name))
            self.preset_buttons[name] = b
        self.floor_checkbox = ipw.Checkbox(value=owner.camera_floor == "grass", description="above the grass",
                                           indent=False, layout=ipw.Layout(width="auto", margin="2px 8px"),
                                           tooltip="Keep the camera above the tallest blade (untick to go down "
                                                   "among the blades)")
        self.more_button = ipw.ToggleButton(value=not owner.panel_folded, layout=ipw.Layout(width="80px"),
                                            tooltip="Show / hide the rest of the controls")
        self.floor_checkbox.observe(self._on_checkbox, names="value")
        self.more_button.observe(self._on_more, names="value")
        owner.observe(self._on_floor, names="camera_floor")
        owner.observe(self._on_folded, names="panel_folded")
        owner.observe(self._on_playing, names="playing")
        self.row = ipw.HBox([self.play_button, *self.preset_buttons.values(), self.floor_checkbox, self.more_button],
                            layout=ipw.Layout(width="100%", flex_flow="row wrap", align_items="center"))
        self.row.add_class("grasswidget-camera-bar")
        self._show_playing(bool(owner.playing))
        self._show_folded(bool(owner.panel_folded))

    def _run(self, fn, *args):
        try:
            fn(*args)
        except Exception as err:  # noqa: BLE001 - a button never raises into the notebook
            self._on_error(err)

    # ------------------------------------------------------------------ both ways

    def _on_checkbox(self, change):
        floor = "grass" if change["new"] else "ground"
        if self._owner.camera_floor != floor:
            self._run(setattr, self._owner, "camera_floor", floor)

    def _on_floor(self, change):
        self.floor_checkbox.value = change["new"] == "grass"

    def _on_more(self, change):
        if self._owner.panel_folded == bool(change["new"]):
            self._owner.panel_folded = not change["new"]
        self._show_folded(not change["new"])

    def _on_folded(self, change):
        self.more_button.value = not change["new"]
        self._show_folded(bool(change["new"]))

    def _on_playing(self, change):
        self._show_playing(bool(change["new"]))

    def _show_playing(self, playing):
        self.play_button.description = "Pause" if playing else "Play"
        self.play_button.icon = "pause" if playing else "play"

    def _show_folded(self, folded):
        # The full panel has its own Play/Pause: the bar's is on the page only while folded
        # (not merely hidden, so the page holds one visible "Pause" either way).
        rest = [self.preset_buttons[name] for name, _i, _t in PRESET_BUTTONS]
        self.row.children = ([self.play_button] if folded else []) + rest + [self.floor_checkbox, self.more_button]
        self.more_button.description = "more" if folded else "less"
        self.more_button.icon = "chevron-down" if folded else "chevron-up"

    def close(self):
        """Stop following the widget's traits and close the bar's widgets."""
        for name, fn in (("camera_floor", self._on_floor), ("panel_folded", self._on_folded),
                         ("playing", self._on_playing)):
            try:
                self._owner.unobserve(fn, names=name)
            except ValueError:
                pass
        close_widgets(self.play_button, *self.preset_buttons.values(), self.floor_checkbox, self.more_button, self.row)


class CameraHome:
    """The camera of a GrassWidget: start, named views, floor (see the module docstring).

    Args:
        engine: the EngineSwitch (its ``view`` is the live view).
        state: the WidgetState (``camera_floor`` is observed and set here).
        size: (w, h) CSS pixels of the view (the presets' aspect).
    """

    def __init__(self, engine, state, size):
        self.engine = engine
        self.state = state
        self.size = size
        view = engine.view
        #: The start camera (a camera_state dict): "home".
        self.home = dict(view.camera_state)
        state.camera_floor = floor_for(view.blades, self.home, view.readings.depth_range[1])
        view.set_options(camera_floor=state.camera_floor)
        state.observe(self._on_floor, names="camera_floor")

    def look_from(self, name):
        """Move the live camera to the named view ``name`` (see ``GrassWidget.look_from``)."""
        check_camera_preset(name)
        view = self.engine.view
        if name == "home":
            view.reset_camera()
        else:
            blades = view.blades
            view.camera_state = camera_preset(name, blades.v0, blades.height, home=self.home,
                                              aspect=self.size[0] / self.size[1], fov_deg=view.camera_state["fov_deg"],
                                              limits=view.readings.orbit_limits, horizon=blades.horizon)
        if self.state.camera_floor == "grass" and floor_for(view.blades, view.camera_state,
                                                            view.readings.depth_range[1]) == "ground":
            self.state.camera_floor = "ground"

    def _on_floor(self, change):
        """A new floor: new orbit limits in the view; a camera now below them rises at once."""
        view = self.engine.view
        if view is None or view.closed:
            return
        view.set_options(camera_floor=change["new"])
        cam = view.camera_state
        position, target = clamp_orbit(cam["position"], cam["target"], view.readings.orbit_limits)
        if not (np.allclose(position, cam["position"]) and np.allclose(target, cam["target"])):
            view.camera_state = {"position": tuple(position), "target": tuple(target)}

    def close(self):
        """Stop following the state."""
        try:
            self.state.unobserve(self._on_floor, names="camera_floor")
        except ValueError:
            pass
