"""Tools on top of the package: the command line (:mod:`.cli`, also
``python -m grasswidget``), benchmarks (:mod:`.bench`) and animation export
(:mod:`.export`)."""
