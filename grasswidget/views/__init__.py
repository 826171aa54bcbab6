"""The views: the one interface between a GrassWidget and the engine that shows its meadow
(:mod:`.api`: :class:`~grasswidget.views.api.EngineView`, its host and play state), and both
engines' views side by side: the kernel engine's (:mod:`.kernel`, with its clock :mod:`.clock`,
resolution governor :mod:`.adaptive` and orbit controller :mod:`.orbit`) and the browser
engine's (:mod:`.browser`). :mod:`.trace_feed` samples either for the lab bench,
:mod:`.engines` answers what the widget asks of an engine before it has a view, and
:mod:`.front_end` makes a view's anywidgets fit the front end (Jupyter or marimo).

The notebook front end imports this package only, never ``grasswidget.gpu`` or
``grasswidget.browser`` (tests/test_architecture.py).
"""
