"""The state a GrassWidget's parts share: play state, teaching switches, camera floor, folding.

:class:`WidgetState` holds the traits that more than one part of a
:class:`~grasswidget.GrassWidget` reads or sets: the view follows ``playing`` and
``time_scale`` (it is the views' :class:`~grasswidget.views.api.PlayState`), the engine
switch ``culling_frozen`` and ``camera_floor``, the lab bench ``chart``, the camera bar
``playing``, ``camera_floor`` and ``panel_folded``, the layout ``panel_folded``. The parts
observe these traits and set them; none of them holds the widget. The widget's traits of
the same names (its public API) are linked to these both ways (:func:`link_state`).
"""

from __future__ import annotations

from traitlets import Any, link, validate

from ..core.orbit_limits import FLOORS
from ..core.params import CheckedBool, ChoiceTrait
from ..views.api import PlayState
from .lab_bench import check_chart

__all__ = ["SharedTraits", "WidgetState", "WidgetActions", "STATE_TRAITS", "link_state"]

#: The traits a GrassWidget shares with its state, by name.
STATE_TRAITS = ("playing", "time_scale", "culling_frozen", "chart", "camera_floor", "panel_folded")


class SharedTraits(PlayState):
    """The traits a GrassWidget and its :class:`WidgetState` both have (:data:`STATE_TRAITS`),
    defined once: the widget's are its public API, the state's what its parts observe and set;
    :func:`link_state` keeps the two alike. ``playing`` and ``time_scale`` are the views'
    :class:`~grasswidget.views.api.PlayState`."""

    playing = CheckedBool(True, help="Animate (continuous drawing) or pause (draw on demand).")
    culling_frozen = CheckedBool(False, help="Cull against a copy of the camera taken when this was set "
                                 "(see GrassScene.freeze_culling).")
    chart = Any(None, allow_none=True,
                help='The live chart under the view: None (hidden), "tip" (tip offset of each inspected blade), '
                     '"bend" (bend angle), "culling" (blades kept after each culling test) or "frame" (where '
                     "a frame's time goes), against simulated time (see grasswidget.notebook.lab_bench).")
    camera_floor = ChoiceTrait("grass", FLOORS, help='What the orbit keeps the camera above: "grass" (0.3 m above '
                               'the tallest blade\'s tip, so never inside the field) or "ground" (0.3 m above the '
                               'ground, down among the blades). A widget whose start camera is lower than the grass '
                               'starts with "ground".')
    panel_folded = CheckedBool(False, help="Show only the camera bar (play/pause, camera presets, more) under or "
                               "beside the view; True from the start with layout='lecture'.")

    @validate("chart")
    def _valid_chart(self, proposal):
        return check_chart(proposal["value"])


class WidgetState(SharedTraits):
    """What a GrassWidget's parts share (see the module docstring): the widget's traits of the same
    names, in an object the parts may hold (they never hold the widget)."""


def link_state(owner, state: WidgetState) -> list:
    """Link ``owner``'s traits named in :data:`STATE_TRAITS` to ``state``'s both ways (``state``
    takes ``owner``'s values first); returns the links (``unlink()`` each when closing)."""
    return [link((owner, name), (state, name)) for name in STATE_TRAITS]


class WidgetActions:
    """What the parts' buttons, keys and clicks may ask of a widget: its public actions, each a
    callable given by name (``toggle_play``, ``step``, ``reset_blades``, ``reset_camera``,
    ``look_from``, ``set_blades``, ``inspect``, ``save_png_later``), and ``target_fps`` (read
    through the callable given for it). Nothing else of the widget is reachable from here."""

    def __init__(self, *, target_fps, **actions):
        self._target_fps = target_fps
        for name, fn in actions.items():
            setattr(self, name, fn)

    @property
    def target_fps(self) -> float:
        """The frame rate adaptive resolution aims for now."""
        return self._target_fps()
