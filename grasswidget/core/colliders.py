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

A crowd (hundreds of balls) is cheapest as one array: ``colliders.set_array(a)``
with ``a`` (K, 4) rows (cx, cy, cz, radius) holds K spheres beside the list's
SphereCollider objects, replaced in one call (NumPy speed, no traitlets per ball).
The GPU keeps the spheres in a storage buffer and finds the ones near each blade
through a grid (:mod:`grasswidget.core.collider_grid`), so a blade pays for the
spheres near it, not for all of them.
"""

from __future__ import annotations

import math

import numpy as np
import traitlets
from traitlets import TraitError

from ..errors import GrassTypeError, GrassValueError, ParameterError
from .limits import MAX_COORDINATE
from .params import StrictTraits, Vec3

__all__ = ["SphereCollider", "ColliderList", "MAX_COLLIDERS", "collider_array", "check_sphere_array"]

#: Most sphere colliders one field takes at once (list items plus ``set_array`` rows).
#: The GPU keeps them in a storage buffer of this many vec4 (16 KiB).
MAX_COLLIDERS = 1024


class _PositiveFloat(traitlets.Float):
    """A finite float in (0, MAX_COORDINATE] with an error message naming the trait and the range."""

    def validate(self, obj, value):
        bad = ParameterError(f"{self.name} must be a finite number in (0, {MAX_COORDINATE:g}] (metres); got {value!r}")
        if isinstance(value, (bool, str, bytes)):
            raise bad
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise bad from None
        if not (math.isfinite(v) and 0 < v <= MAX_COORDINATE):
            raise bad
        return v


class SphereCollider(StrictTraits):
    """A sphere that pushes blades out of its way.

    Args:
        center: (x, y, z) centre in the field's local space (metres), each coordinate in
            [-1e7, 1e7] (:data:`grasswidget.core.limits.MAX_COORDINATE`).
        radius: radius in metres, in (0, 1e7] (the same limit: the pushes of a larger
            sphere, squared into the collision strength, would overflow float32).

    Both are traits (observable, linkable); invalid values raise ``TraitError``
    naming ``center`` or ``radius`` and leave the old value; an unknown name
    (``ball.raduis = 2``) raises ``AttributeError`` suggesting the closest trait. Changes apply at the
    field's next ``step()``. Move it between steps to roll it through the field::

        ball = gw.SphereCollider(center=(-8, 1, 0), radius=1)
        field.colliders.append(ball)
        for k in range(200):
            ball.center = (-8 + 0.08 * k, 1, 0)
            field.step(1)

    Setting a trait costs about 0.1 ms; for hundreds of moving balls use
    :meth:`ColliderList.set_array` instead.
    """

    center = Vec3((0.0, 0.0, 0.0), unit="m", limit=MAX_COORDINATE,
                  help="Centre (x, y, z) in the field's local space, metres, each in [-1e7, 1e7].")
    radius = _PositiveFloat(1.0, help="Radius in metres, in (0, 1e7].")

    def __init__(self, center=(0.0, 0.0, 0.0), radius=1.0, **kwargs):
        self._edits = 0  # counts changes, so a ColliderList re-reads only the balls that moved
        super().__init__(center=center, radius=radius, **kwargs)

    @traitlets.observe("center", "radius")
    def _count_edit(self, change):
        self._edits += 1

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
    return GrassValueError(
        f"colliders: at most {MAX_COLLIDERS} sphere colliders are supported per field "
        f"(SphereCollider items plus set_array rows); got {n}"
    )


def check_sphere_array(spheres, name="spheres") -> np.ndarray:
    """``spheres`` as a (K, 4) float64 array of (cx, cy, cz, radius) rows (metres), checked:
    finite values, centres within +-MAX_COORDINATE, radius in (0, MAX_COORDINATE] (metres),
    0 <= K <= MAX_COLLIDERS; a GrassValueError naming ``name`` and the range otherwise.
    A single row (4,) is taken as (1, 4)."""
    try:
        a = np.array(spheres, dtype=np.float64, copy=True)
    except (TypeError, ValueError):
        raise GrassValueError(f"{name} must be a (K, 4) array of (cx, cy, cz, radius) rows; got {spheres!r:.80}") from None
    if a.ndim == 1 and a.shape == (4,):
        a = a[None]
    if a.size == 0:
        return np.zeros((0, 4))
    if a.ndim != 2 or a.shape[1] != 4:
        raise GrassValueError(f"{name} must be a (K, 4) array of (cx, cy, cz, radius) rows; got shape {a.shape}")
    if not np.isfinite(a).all():
        row = int(np.flatnonzero(~np.isfinite(a).all(axis=1))[0])
        raise GrassValueError(f"{name} must be finite (metres); row {row} is {a[row].tolist()}")
    if not (a[:, 3] > 0).all():
        row = int(np.flatnonzero(a[:, 3] <= 0)[0])
        raise GrassValueError(f"{name}: every radius (column 3) must be > 0 metres; row {row} has {a[row, 3]!r}")
    far = np.abs(a) > MAX_COORDINATE
    if far.any():
        row = int(np.flatnonzero(far.any(axis=1))[0])
        raise GrassValueError(f"{name}: every centre coordinate must be in [{-MAX_COORDINATE:g}, {MAX_COORDINATE:g}] "
                              f"and every radius in (0, {MAX_COORDINATE:g}] metres (MAX_COORDINATE); "
                              f"row {row} is {a[row].tolist()}")
    if len(a) > MAX_COLLIDERS:
        raise _too_many(len(a))
    return a


class ColliderList(list):
    """A list of :class:`SphereCollider`, plus an optional block of array spheres.

    It is a real ``list`` of SphereCollider objects: append, extend, insert,
    remove, slicing and ``del`` all work; other items raise ``TypeError`` naming
    ``colliders``. Beside them it holds the rows of :meth:`set_array` (a crowd
    moved by NumPy). Items and rows together are at most :data:`MAX_COLLIDERS`
    (1024); more raise ``ValueError`` naming ``colliders``. The field reads
    :meth:`array` (both, items first) at every ``step()``; ``len()`` counts the
    items only, :attr:`count` both. ``clear()`` removes both.
    """

    def __init__(self, items=()):
        items = [_check_item(x) for x in items]
        self._bulk = np.zeros((0, 4))
        self._bulk_version = 0
        self._cache_key = None
        self._cache = np.zeros((0, 4))
        if len(items) > MAX_COLLIDERS:
            raise _too_many(len(items))
        super().__init__(items)

    # ------------------------------------------------------------------ the array block

    def set_array(self, spheres):
        """Replace the array spheres by ``spheres``: (K, 4) rows (cx, cy, cz, radius), metres
        in the field's local space (any array-like; K = 0 removes them). One NumPy copy, no
        per-ball objects: moving 1024 balls costs well under a millisecond. Checked with
        :func:`check_sphere_array` (finite, radius > 0) and against MAX_COLLIDERS together
        with the SphereCollider items; on error nothing changes. Applies at the next step."""
        a = check_sphere_array(spheres, "colliders.set_array(spheres)")
        if len(self) + len(a) > MAX_COLLIDERS:
            raise _too_many(len(self) + len(a))
        a.setflags(write=False)
        self._bulk = a
        self._bulk_version += 1

    @property
    def bulk(self) -> np.ndarray:
        """The rows of the last :meth:`set_array`, (K, 4) float64, read-only."""
        return self._bulk

    @property
    def count(self) -> int:
        """All spheres: SphereCollider items plus set_array rows."""
        return len(self) + len(self._bulk)

    def array(self) -> np.ndarray:
        """All spheres as a (K, 4) float64 array (items' (cx, cy, cz, radius) first, then the
        set_array rows), read-only. Cached: re-read only when an item was added, removed or
        changed, or set_array was called. ValueError past MAX_COLLIDERS (a list grown past
        its checks, e.g. by ``list.extend``)."""
        key = (tuple(map(id, self)), tuple(b._edits for b in self), self._bulk_version)
        if key != self._cache_key:
            if self.count > MAX_COLLIDERS:
                raise _too_many(self.count)
            rows = np.array([_check_item(b).as_vec4() for b in self], np.float64).reshape(-1, 4)
            out = np.concatenate([rows, self._bulk]) if len(self._bulk) else rows
            out.setflags(write=False)
            self._cache, self._cache_key = out, key
        return self._cache

    @property
    def version(self):
        """A value that changes whenever :meth:`array` would change (for caches of derived data)."""
        return (tuple(map(id, self)), tuple(b._edits for b in self), self._bulk_version)

    # ------------------------------------------------------------------ list methods, checked

    def _room(self, extra):
        if self.count + extra > MAX_COLLIDERS:
            raise _too_many(self.count + extra)

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
            if len(new) + len(self._bulk) > MAX_COLLIDERS:
                raise _too_many(len(new) + len(self._bulk))
        else:
            _check_item(value)
        super().__setitem__(index, value)

    def clear(self):
        """Remove every SphereCollider item and the set_array rows."""
        super().clear()
        self.set_array(np.zeros((0, 4)))

    def __mul__(self, n):  # a plain list: no validation needed for a copy
        return list(self) * n

    __rmul__ = __mul__

    def __imul__(self, n):
        self._room(len(self) * (int(n) - 1))
        return super().__imul__(n)

    def __repr__(self):
        extra = f" + {len(self._bulk)} array spheres" if len(self._bulk) else ""
        return f"ColliderList({list.__repr__(self)}{extra})"


def collider_array(colliders) -> np.ndarray:
    """(K, 4) float64 array of (cx, cy, cz, radius) from a ColliderList (its :meth:`~ColliderList.array`),
    a (K, 4) array, or an iterable of SphereColliders or (center, radius) pairs; validates
    the values and the count against MAX_COLLIDERS (ValueError naming ``colliders``)."""
    if colliders is None:
        return np.zeros((0, 4))
    if isinstance(colliders, ColliderList):
        return colliders.array()
    if isinstance(colliders, np.ndarray):
        return check_sphere_array(colliders, "colliders")
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
