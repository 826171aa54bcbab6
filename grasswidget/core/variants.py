"""Checking parameter variants and sweeps before any GPU work (pure: traitlets only).

``gw.compare`` (:mod:`grasswidget.notebook.compare`) shows two to four *variants* of one
meadow side by side, each a mapping of :class:`~grasswidget.core.params.GrassParams`
trait names to values; ``gw.sweep`` (:mod:`grasswidget.tools.sweep`) renders a row or a
grid of settings of one or two parameters. Both validate what they are given here, on
scratch ``GrassParams`` objects, so a misspelt name, a value out of range or a wrong
count raises the project's errors (:class:`~grasswidget.errors.UnknownNameError`,
:class:`~grasswidget.errors.ParameterError`, :class:`~grasswidget.errors.GrassValueError`,
:class:`~grasswidget.errors.GrassTypeError`) naming the parameter and what is allowed,
before a single GPU buffer exists.
"""

from __future__ import annotations

from .params import GrassParams
from ..errors import GrassTypeError, GrassValueError, ParameterError, UnknownNameError

__all__ = ["check_variants", "check_sweep_axes", "apply_changes", "MIN_VARIANTS", "MAX_VARIANTS",
           "MAX_SWEEP_AXES", "MAX_SWEEP_CELLS"]

#: A comparison shows at least this many views ...
MIN_VARIANTS = 2
#: ... and at most this many.
MAX_VARIANTS = 4
#: A sweep varies one parameter (a row) or two (a grid).
MAX_SWEEP_AXES = 2
#: The most settings (cells) one sweep renders.
MAX_SWEEP_CELLS = 64


def apply_changes(params: GrassParams, changes: dict, where: str = "") -> GrassParams:
    """Set each ``name: value`` of ``changes`` on ``params`` (validated by its traits) and
    return ``params``. An unknown name raises UnknownNameError (with the closest name), a
    value out of range ParameterError naming the trait and its range; ``where`` (e.g.
    ``"variant 'soft'"``) starts the message. On error ``params`` may hold the changes
    made before the bad one: pass a scratch copy when that matters."""
    if not isinstance(changes, dict):
        raise GrassTypeError(f"{where + ': ' if where else ''}parameter changes must be a dict of GrassParams "
                             f"trait names to values; got {type(changes).__name__}")
    for name, value in changes.items():
        if not isinstance(name, str) or not params.has_trait(name):
            hint = str(_unknown(params, name))
            raise UnknownNameError(f"{where + ': ' if where else ''}{hint}")
        try:
            setattr(params, name, value)
        except ParameterError as err:
            raise ParameterError(f"{where + ': ' if where else ''}{err}") from None
    return params


def _unknown(params, name):
    try:
        getattr(params, str(name))
    except UnknownNameError as err:
        return err
    return UnknownNameError(f"GrassParams has no trait {name!r}")


def check_variants(variants, base: GrassParams | None = None) -> dict:
    """Validate ``variants`` (label -> dict of GrassParams changes) for a comparison and
    return ``{label: changes}`` as plain dicts, in the given order.

    Two to four variants (:data:`MIN_VARIANTS`..:data:`MAX_VARIANTS`), each label a
    non-empty string, each change valid on a copy of ``base`` (default ``GrassParams()``).
    """
    if not isinstance(variants, dict):
        raise GrassTypeError(f"variants must be a dict mapping a label to parameter changes, e.g. "
                             f"{{'soft': {{'stiffness_scale': 0.5}}, 'stiff': {{'stiffness_scale': 2.0}}}}; "
                             f"got {type(variants).__name__}")
    if not (MIN_VARIANTS <= len(variants) <= MAX_VARIANTS):
        raise GrassValueError(f"variants: a comparison shows {MIN_VARIANTS} to {MAX_VARIANTS} views; "
                              f"got {len(variants)}")
    base = base if base is not None else GrassParams()
    out = {}
    for label, changes in variants.items():
        if not isinstance(label, str) or not label.strip():
            raise GrassValueError(f"variants: each label must be a non-empty string; got {label!r}")
        apply_changes(base.copy(), changes, where=f"variant {label!r}")
        out[label] = dict(changes)
    return out


def check_sweep_axes(axes, base: GrassParams | None = None) -> dict:
    """Validate a sweep's ``axes`` (GrassParams trait name -> list of values) and return
    ``{name: [values]}`` (the values as the trait stores them).

    One parameter (a row) or two (a grid, the first down, the second across), each
    with at least one value, every value valid for its trait, at most
    :data:`MAX_SWEEP_CELLS` settings in all.
    """
    if not isinstance(axes, dict):
        raise GrassTypeError("the sweep must be a dict mapping a GrassParams trait name to a list of values, "
                             f"e.g. {{'stiffness_scale': [0.5, 1, 2]}}; got {type(axes).__name__}")
    if not axes:
        raise GrassValueError(f"the sweep is empty: give 1 or {MAX_SWEEP_AXES} parameters with a list of values "
                              "each, e.g. {'stiffness_scale': [0.5, 1, 2]}")
    if len(axes) > MAX_SWEEP_AXES:
        raise GrassValueError(f"a sweep varies 1 parameter (a row) or {MAX_SWEEP_AXES} (a grid); got {len(axes)}: "
                              f"{', '.join(map(str, axes))}")
    base = base if base is not None else GrassParams()
    out = {}
    for name, values in axes.items():
        if isinstance(values, (str, bytes)) or not hasattr(values, "__iter__"):
            raise GrassTypeError(f"sweep {name!r}: the values must be a list; got {values!r}")
        values = list(values)
        if not values:
            raise GrassValueError(f"sweep {name!r}: the list of values is empty; give at least one value")
        scratch = base.copy()
        stored = []
        for v in values:
            apply_changes(scratch, {name: v}, where="sweep")
            stored.append(getattr(scratch, name))
        out[name] = stored
    cells = 1
    for values in out.values():
        cells *= len(values)
    if cells > MAX_SWEEP_CELLS:
        raise GrassValueError(f"a sweep renders at most {MAX_SWEEP_CELLS} settings; "
                              f"{' x '.join(str(len(v)) for v in out.values())} = {cells}")
    return out
