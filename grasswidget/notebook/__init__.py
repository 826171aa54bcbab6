"""The notebook front end: :class:`~.widget.GrassWidget` and the parts it is made of.

The engine switch (:mod:`.engine_switch`, with the "auto" rule in :mod:`.engine_auto`), the state
the parts share (:mod:`.widget_state`), the control panel (:mod:`.panel`, :mod:`.control_link`,
:mod:`.blade_control`, :mod:`.switch_choice`), the camera and its bar (:mod:`.camera_bar`), the
draggable ball (:mod:`.ball`), the lab bench (:mod:`.lab_bench`), the layout (:mod:`.layout`), the
files (:mod:`.saving`) and marimo's face (:mod:`.marimo_face`, :mod:`.control_mirror`); beside
them, comparisons (:mod:`.compare`), exercises (:mod:`.exercise`) and cell re-runs
(:mod:`.cell_rerun`). The engines' views are in :mod:`grasswidget.views`, the only way from here
to an engine.
"""
