"""A frozen culling camera: a copy of a camera's pose, projection and viewport.

``GrassField.freeze_culling(camera, viewport_size)`` keeps one of these: from then
on the field culls and picks LOD classes against the copy, whatever camera
renders it, and draws the copy's view volume as white lines (:attr:`FrozenCamera.lines`),
so that a second, outside view shows which blades the frozen view keeps.
"""

from __future__ import annotations

import numpy as np
import pygfx as gfx

from ..errors import GrassValueError
from ..core.teaching import FROZEN_FRUSTUM_COLOR, FrozenView

__all__ = ["FrozenCamera", "frustum_line"]


def frustum_line(frozen: FrozenView, to_local=None, thickness=2.0) -> gfx.Line:
    """A pygfx Line (segments) tracing the view volume of any frozen view."""
    return gfx.Line(
        gfx.Geometry(positions=frozen.segments(to_local)),
        gfx.LineSegmentMaterial(color=FROZEN_FRUSTUM_COLOR, thickness=thickness),
    )


class FrozenCamera(FrozenView):
    """An immutable copy of a pygfx camera as a culling pass sees it.

    Args:
        camera: any pygfx camera (its world pose and projection are copied now).
        viewport_size: (width, height) in physical pixels of the view the camera
            renders; sets the camera's aspect for the copy (as a render would) and
            the pixel scale of the LOD classes.

    Attributes: ``view_proj`` (4x4 float64, world to WebGPU clip space),
    ``position`` (3,) world position, ``viewport_size`` (w, h) pixels.
    """

    def __init__(self, camera, viewport_size):
        w, h = viewport_size
        if not (w > 0 and h > 0):
            raise GrassValueError(f"viewport_size must be (width, height) > 0 pixels; got {viewport_size!r}")
        camera.set_view_size(float(w), float(h))  # what a render of that size does first
        # The same product the render shaders use: projection_transform * cam_transform.
        proj = np.asarray(camera.projection_matrix, np.float64)
        super().__init__(proj @ np.asarray(camera.world.inverse_matrix, np.float64), camera.world.position, (w, h))
        #: A pygfx camera with the same pose and projection (renders the frozen view,
        #: e.g. to capture what it hides for occlusion culling); None if it cannot be copied.
        self.camera = None
        try:
            clone = type(camera)()
            clone.set_state(camera.get_state())
            clone.local.matrix = camera.world.matrix
            self.camera = clone
        except Exception:
            pass

    def make_lines(self, to_local=None, thickness=2.0) -> gfx.Line:
        """A pygfx Line (segments) tracing the frozen view volume."""
        return frustum_line(self, to_local, thickness)
