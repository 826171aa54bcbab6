"""Sphere colliders that push grass blades aside (pure Python, no GPU import).

A :class:`SphereCollider` is a validated traitlets object; a field's colliders are
a :class:`ColliderList` (a ``list`` that checks what goes into it). Collision
follows Jahrmann & Wimmer (2017), section 5.1 "Collision": the tip guide v2 and
the curve midpoint ``m = v0/4 + v1/2 + v2/4`` are pushed out of every sphere, the
squared push lengths add up (times ``params.collision_gain``) in a per-blade
collision strength eta (0..1) that weakens the blade's recovery, and eta fades
over time (``params.collision_fade``).
See :func:`grasswidget.core.reference.collide_spheres` for the exact rule.

Coordinates are the grass field's local space, which is world space for a field
with the default identity transform.
"""

from __future__ import annotations

import math

import numpy as np
import traitlets
from traitlets import TraitError

from ..errors import GrassTypeError, ParameterError
from .params import StrictTraits, Vec3

__all__ = ["SphereCollider", "ColliderList", "MAX_COLLIDERS", "collider_array"]

#: Most sphere colliders one field takes at once (the GPU keeps them in a uniform array).
MAX_COLLIDERS = 16


class _PositiveFloat(traitlets.Float):
    """A finite float > 0 with an error message naming the trait."""

    def validate(self, obj, value):
        bad = ParameterError(f"{self.name} must be a finite number > 0 (metres); got {value!r}")
        if isinstance(value, (bool, str, bytes)):
            raise bad
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise bad from None
        if not (math.isfinite(v) and v > 0):
            raise bad
        return v


class SphereCollider(StrictTraits):
    """A sphere that pushes blades out of its way.

    Args:
        center: (x, y, z) centre in the field's local space (metres), finite.
        radius: radius in metres, finite and > 0.

    Both are traits (observable, linkable); invalid values raise ``TraitError``
    naming ``center`` or ``radius`` and leave the old value; an unknown name
    (``ball.raduis = 2``) raises ``AttributeError`` suggesting the closest trait. Changes apply at the
    field's next ``step()``. Move it between steps to roll it through the field::

        ball = gw.SphereCollider(center=(-8, 1, 0), radius=1)
        field.colliders.append(ball)
        for k in range(200):
            ball.center = (-8 + 0.08 * k, 1, 0)
            field.step(1)
    """

    center = Vec3((0.0, 0.0, 0.0), unit="m", help="Centre (x, y, z) in the field's local space, metres.")
    radius = _PositiveFloat(1.0, help="Radius in metres, > 0.")

    def __init__(self, center=(0.0, 0.0, 0.0), radius=1.0, **kwargs):
        super().__init__(center=center, radius=radius, **kwargs)

    def as_vec4(self):
        """(cx, cy, cz, radius) as a tuple of floats."""
        return (*self.center, self.radius)

    def __repr__(self):
        c = ", ".join(f"{x:g}" for x in self.center)
        return f"SphereCollider(center=({c}), radius={self.radius:g})"


def _check_item(item):
    if not isinstance(item, SphereCollider):
        raise GrassTypeError(
            f"colliders must hold SphereCollider objects (gw.SphereCollider(center=..., radius=...)); "
            f"got {type(item).__name__}"
        )
    return item


def _too_many(n):
    return ValueError(
        f"colliders: at most {MAX_COLLIDERS} sphere colliders are supported per field; got {n}"
    )


class ColliderList(list):
    """A list of :class:`SphereCollider` that refuses other items and more than
    :data:`MAX_COLLIDERS` entries (``TypeError`` / ``ValueError`` naming ``colliders``).

    It is a real ``list``: append, extend, insert, remove, slicing and ``del``
    all work; the field reads it at every ``step()``.
    """

    def __init__(self, items=()):
        items = [_check_item(x) for x in items]
        if len(items) > MAX_COLLIDERS:
            raise _too_many(len(items))
        super().__init__(items)

    def _room(self, extra):
        if len(self) + extra > MAX_COLLIDERS:
            raise _too_many(len(self) + extra)

    def append(self, item):
        _check_item(item)
        self._room(1)
        super().append(item)

    def insert(self, index, item):
        _check_item(item)
        self._room(1)
        super().insert(index, item)

    def extend(self, items):
        items = [_check_item(x) for x in items]
        self._room(len(items))
        super().extend(items)

    def __iadd__(self, items):
        self.extend(items)
        return self

    def __setitem__(self, index, value):
        if isinstance(index, slice):
            value = [_check_item(x) for x in value]
            new = list(self)
            new[index] = value
            if len(new) > MAX_COLLIDERS:
                raise _too_many(len(new))
        else:
            _check_item(value)
        super().__setitem__(index, value)

    def __mul__(self, n):  # a plain list: no validation needed for a copy
        return list(self) * n

    __rmul__ = __mul__

    def __imul__(self, n):
        self._room(len(self) * (int(n) - 1))
        return super().__imul__(n)


def collider_array(colliders) -> np.ndarray:
    """(K, 4) float64 array of (cx, cy, cz, radius) from SphereColliders or
    (center, radius) pairs; validates the count against MAX_COLLIDERS."""
    if colliders is None:
        return np.zeros((0, 4))
    rows = []
    for item in colliders:
        if isinstance(item, SphereCollider):
            rows.append(item.as_vec4())
        else:
            try:
                center, radius = item
                probe = SphereCollider(center=center, radius=radius)
            except TraitError:
                raise
            except (TypeError, ValueError):
                raise GrassTypeError(
                    f"colliders must hold SphereCollider objects or (center, radius) pairs; got {item!r}"
                ) from None
            rows.append(probe.as_vec4())
    if len(rows) > MAX_COLLIDERS:
        raise _too_many(len(rows))
    return np.array(rows, np.float64).reshape(-1, 4)
