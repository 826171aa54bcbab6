"""A widget's camera: its start ("home"), the named views, and the floor the orbit keeps.

:class:`CameraHome` remembers the start camera of the first view, moves the live view's
camera to a named view (:func:`grasswidget.core.camera_presets.camera_preset`: "home",
"top", "low") and follows the state's ``camera_floor``: a new floor gives the view new
orbit limits and lifts a camera now below them. A camera lower than the "grass" floor
allows lowers ``camera_floor`` to "ground"; nothing raises it. It reads the live view
from the engine switch (:class:`~grasswidget.notebook.engine_switch.EngineSwitch`).
"""

from __future__ import annotations

import numpy as np

from ..core.camera_presets import camera_preset, check_camera_preset, floor_for
from ..core.orbit_limits import clamp_orbit

__all__ = ["CameraHome"]


class CameraHome:
    """The camera part of a GrassWidget (see the module docstring).

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
        state.camera_floor = floor_for(view.blades, self.home, view.depth_range[1])
        view.set_camera_floor(state.camera_floor)
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
                                              limits=view.orbit_limits, horizon=blades.horizon)
        if self.state.camera_floor == "grass" and floor_for(view.blades, view.camera_state,
                                                            view.depth_range[1]) == "ground":
            self.state.camera_floor = "ground"

    def _on_floor(self, change):
        """A new floor: new orbit limits in the view; a camera now below them rises at once."""
        view = self.engine.view
        if view is None or view.closed:
            return
        view.set_camera_floor(change["new"])
        cam = view.camera_state
        position, target = clamp_orbit(cam["position"], cam["target"], view.orbit_limits)
        if not (np.allclose(position, cam["position"]) and np.allclose(target, cam["target"])):
            view.camera_state = {"position": tuple(position), "target": tuple(target)}

    def close(self):
        """Stop following the state."""
        try:
            self.state.unobserve(self._on_floor, names="camera_floor")
        except ValueError:
            pass
