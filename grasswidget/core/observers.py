"""Observers of shared traits that do not keep their owner alive.

traitlets keeps every observer it is given; a bound method kept there keeps its object alive
for as long as the observed object lives. A :class:`~grasswidget.core.params.GrassParams` is
often shared: a widget's successive scenes share its params, and a user may pass one
``GrassParams`` to several scenes. A scene or field observing it through a bound method stayed
alive, with its GPU buffers, until the params went, even when nobody held it any more.
:class:`WeakObserver` holds the method weakly: once its object is gone the observer removes
itself at the next change, and :meth:`WeakObserver.stop` removes it at once (a release).
Pure core: stdlib and traitlets only.
"""

from __future__ import annotations

import weakref

from traitlets import All

from ..errors import GrassTypeError

__all__ = ["WeakObserver"]


class WeakObserver:
    """Call ``method`` (a bound method) on every change of ``names`` of ``observed`` (a traitlets
    ``HasTraits``), without keeping ``method``'s object alive.

    Args:
        observed: the object whose traits are observed (e.g. a GrassParams); held strongly
            (it holds this observer anyway).
        method: a bound method ``method(change)``; its object is held weakly.
        names: a trait name, a list of names, or traitlets' ``All`` (the default: every trait).

    Observing starts at construction. :attr:`active` is False after :meth:`stop` or once the
    method's object was collected and a change arrived.
    """

    def __init__(self, observed, method, names=All):
        if not hasattr(method, "__self__") or not hasattr(method, "__func__"):
            raise GrassTypeError(f"method must be a bound method; got {type(method).__name__}")
        self._observed = observed
        self._method = weakref.WeakMethod(method)
        self._names = names
        self.active = True
        observed.observe(self, names=names)

    def __call__(self, change):
        method = self._method()
        if method is None:  # its object is gone: nothing to tell, nothing to keep
            self.stop()
            return
        method(change)

    def stop(self) -> None:
        """Stop observing (idempotent)."""
        if not self.active:
            return
        self.active = False
        try:
            self._observed.unobserve(self, names=self._names)
        except ValueError:  # already removed
            pass
