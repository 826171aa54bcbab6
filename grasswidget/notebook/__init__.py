"""The notebook front end: :class:`~.widget.GrassWidget` and what it is made of.

The kernel engine's live view (:mod:`.kernel_view`) with its clock
(:mod:`.clock`), resolution governor (:mod:`.adaptive`) and camera limits
(:mod:`.orbit`); the control panel (:mod:`.panel`, :mod:`.control_link`) and
the draggable ball (:mod:`.ball`).
"""
