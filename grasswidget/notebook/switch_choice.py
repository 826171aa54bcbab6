"""The panel's three-way choice for a switch decided by measuring (auto / on / off).

``GrassParams.cull_occlusion`` and ``GrassParams.compute_raster`` are True, False or "auto"
(:mod:`grasswidget.core.auto_switches`). :class:`SwitchChoice` shows one as a dropdown ("auto", "on",
"off") linked both ways to the trait, and beside it what "auto" currently decided, e.g.
"auto (on: removed 41 % of blades, ...)", from the view's stats (``stats["switches"]``).
"""

from __future__ import annotations

import html

import ipywidgets as ipw

from ..core.auto_switches import AUTO, switch_text
from .control_link import ControlLink

__all__ = ["SwitchChoice", "SWITCH_CHOICES"]

#: The panel's three-way choices: (label, GrassParams trait).
SWITCH_CHOICES = (
    ("occlusion culling", "cull_occlusion"),
    ("compute raster", "compute_raster"),
)

_OPTIONS = ("auto", "on", "off")


def _to_control(value) -> str:
    return AUTO if value == AUTO else ("on" if value else "off")


class SwitchChoice:
    """A dropdown (``dropdown``: "auto", "on", "off") for switch ``name`` of ``params`` and a
    line (``decision_line``) with the current decision; ``box`` holds both; ``link`` the
    two-way :class:`ControlLink` (unlink it to stop)."""

    def __init__(self, label, params, name, on_error=None):
        self.name = name
        self.params = params
        self.dropdown = ipw.Dropdown(options=_OPTIONS, value=_to_control(getattr(params, name)), description=label,
                                     style={"description_width": "initial"}, layout=ipw.Layout(width="200px"),
                                     tooltip=params.traits()[name].help)
        self.link = ControlLink(self.dropdown, params, name, on_error, to_obj=str, to_control=_to_control)
        self.decision_line = ipw.HTML(value="", layout=ipw.Layout(margin="0 12px 0 4px"))
        self.box = ipw.HBox([self.dropdown, self.decision_line], layout=ipw.Layout(width="auto", align_items="center"))
        self.show(None)

    def show(self, text):
        """Show the decision ``text`` (a view's ``stats["switches"][name]``), or, with None,
        what the setting alone says ("on", "off", "auto (not decided yet)")."""
        if text is None:
            text = switch_text(getattr(self.params, self.name), None)
        self.decision_line.value = "<small>" + html.escape(text) + "</small>"
