"""A two-way link between a control's value and a trait that never raises into the UI."""

from __future__ import annotations

from traitlets import TraitError

__all__ = ["ControlLink"]


class ControlLink:
    """Two-way link between a control's ``value`` and a HasTraits trait.

    Unlike ``ipywidgets.link`` it never lets an error escape into the widget
    machinery: a value the trait refuses (``TraitError``, ``ValueError`` or
    ``TypeError``, also from ``to_obj``) puts the control back to the trait's
    value and is passed to ``on_error``.

    Args:
        control: anything with an observable ``value`` (an ipywidgets control).
        obj, name: the HasTraits object and the trait's name.
        on_error: called with the refused value's exception.
        to_obj, to_control: convert a control value to a trait value and back
            (default: the same value), e.g. one component of a 3-vector trait.
    """

    def __init__(self, control, obj, name, on_error=None, to_obj=None, to_control=None):
        self.control, self.obj, self.name = control, obj, name
        self.on_error = on_error
        self.to_obj = to_obj or (lambda v: v)
        self.to_control = to_control or (lambda v: v)
        self._busy = False
        control.value = self.to_control(getattr(obj, name))
        control.observe(self._from_control, names="value")
        obj.observe(self._from_obj, names=name)

    def _from_control(self, change):
        if self._busy:
            return
        self._busy = True
        try:
            setattr(self.obj, self.name, self.to_obj(change["new"]))
        except (TraitError, ValueError, TypeError) as err:
            self.control.value = self.to_control(getattr(self.obj, self.name))
            if self.on_error:
                self.on_error(err)
        finally:
            self._busy = False

    def _from_obj(self, change):
        if self._busy:
            return
        self._busy = True
        try:
            self.control.value = self.to_control(change["new"])
        finally:
            self._busy = False

    def unlink(self):
        for owner, fn in ((self.control, self._from_control), (self.obj, self._from_obj)):
            try:
                owner.unobserve(fn, names=self.name if owner is self.obj else "value")
            except ValueError:
                pass
