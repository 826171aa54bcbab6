"""Translucent balls that show a grass field's sphere colliders.

:class:`ColliderBalls` is a pygfx ``Group`` holding one sphere mesh per
:class:`grasswidget.SphereCollider` of a field; :meth:`ColliderBalls.sync` matches
it to the field's collider list (add, move, resize, remove). Make it a child of
the :class:`GrassField` so the balls share the field's transform (colliders live
in the field's local space)::

    balls = ColliderBalls(field)
    field.add(balls)
    ...
    balls.sync()      # before each render (GrassScene does this for you)

It knows nothing of widgets and works in any pygfx scene. Anywhere else than under
the field (GrassScene puts it at the top of the scene, to draw it after the
occlusion culling's second phase), ``sync()`` copies the field's world transform.
"""

from __future__ import annotations

import numpy as np
import pygfx as gfx

__all__ = ["ColliderBalls"]


class ColliderBalls(gfx.Group):
    """One translucent sphere per collider of ``field.colliders``.

    Args:
        field: the :class:`GrassField` whose ``colliders`` are shown.
        color: ball colour (any pygfx colour), default a pale blue-white.
        opacity: 0..1, default 0.35 (alpha-blended, drawn after the grass, no
            depth write, so blades show through and behind it).
    """

    def __init__(self, field, color="#dfe8ff", opacity=0.35):
        super().__init__()
        self._field = field
        # One unit sphere shared by all balls; each ball is scaled to its radius.
        self._geometry = gfx.sphere_geometry(1.0, 32, 16)
        self._ball_material = gfx.MeshPhongMaterial(color=color, opacity=opacity, alpha_mode="blend", shininess=60)
        self._meshes = []
        self._followed = None  # the field's world matrix last copied (sync)

    @property
    def ball_material(self):
        """The balls' shared ``MeshPhongMaterial`` (set color/opacity there)."""
        return self._ball_material

    def sync(self):
        """Make the balls match ``field.colliders`` now (cheap; call before a render)."""
        if self.parent is not self._field:  # elsewhere in the scene: follow the field
            matrix = self._field.world.matrix
            if self._followed is None or not np.array_equal(self._followed, matrix):
                self.local.matrix = matrix  # a decomposition: only when the field moved
                self._followed = np.array(matrix)
        else:
            self._followed = None
        colliders = list(self._field.colliders)
        while len(self._meshes) < len(colliders):
            mesh = gfx.Mesh(self._geometry, self._ball_material)
            self._meshes.append(mesh)
            self.add(mesh)
        while len(self._meshes) > len(colliders):
            self.remove(self._meshes.pop())
        for mesh, col in zip(self._meshes, colliders):
            mesh.local.position = col.center
            mesh.local.scale = (col.radius,) * 3
        return len(colliders)
