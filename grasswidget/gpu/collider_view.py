"""Translucent balls that show a grass field's sphere colliders.

:class:`ColliderBalls` is a pygfx ``Group`` holding one sphere mesh per
:class:`grasswidget.SphereCollider` of a field, and one instanced mesh for the rows of
``colliders.set_array`` (a crowd: one draw call for up to MAX_COLLIDERS balls);
:meth:`ColliderBalls.sync` matches it to the field's colliders (add, move, resize, remove). Make it a child of
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

from ..core.colliders import MAX_COLLIDERS

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
        self._crowd = None  # the InstancedMesh of the set_array rows, made when first needed
        self._crowd_key = None

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
        return len(colliders) + self._sync_crowd()

    def _sync_crowd(self):
        rows = getattr(self._field.colliders, "bulk", np.zeros((0, 4)))
        if self._crowd is None and not len(rows):
            return 0
        # Room for the rows in a power of two of instances (16 .. MAX_COLLIDERS): every
        # instance is drawn, the unused ones at scale 0, so the room follows the crowd.
        room = min(MAX_COLLIDERS, max(16, 1 << max(len(rows) - 1, 0).bit_length()))
        if self._crowd is None or self._crowd.instance_buffer.nitems != room:
            if self._crowd is not None:
                self.remove(self._crowd)
            self._crowd = gfx.InstancedMesh(self._geometry, self._ball_material, room)
            self.add(self._crowd)
            self._crowd_key = None
        if self._crowd_key is not rows:  # set_array makes a new array each time
            matrices = np.zeros((room, 4, 4), np.float32)  # unused instances: scale 0, nothing drawn
            k = len(rows)
            matrices[:k, 0, 0] = matrices[:k, 1, 1] = matrices[:k, 2, 2] = rows[:, 3]
            matrices[:k, 3, :3] = rows[:, :3]  # stored transposed: translation in the last row
            matrices[:k, 3, 3] = 1.0
            self._crowd.instance_buffer.data["matrix"] = matrices
            self._crowd.instance_buffer.update_full()
            self._crowd_key = rows
        return len(rows)
