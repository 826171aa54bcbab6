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
from ..core.teaching import FROZEN_FRUSTUM_COLOR, frustum_segments

__all__ = ["FrozenCamera"]


class FrozenCamera:
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
        self.view_proj = proj @ np.asarray(camera.world.inverse_matrix, np.float64)
        self.position = np.array(camera.world.position, np.float64)
        self.viewport_size = (float(w), float(h))

    def segments(self, to_local=None) -> np.ndarray:
        """(24, 3) float32 end points of the 12 frustum edges; in world space, or
        mapped by the 4x4 ``to_local`` (e.g. the inverse of a parent's world matrix)."""
        seg = frustum_segments(self.view_proj).astype(np.float64)
        if to_local is not None:
            p = np.concatenate([seg, np.ones((len(seg), 1))], axis=1) @ np.asarray(to_local, np.float64).T
            seg = p[:, :3] / p[:, 3:4]
        return seg.astype(np.float32)

    def make_lines(self, to_local=None, thickness=2.0) -> gfx.Line:
        """A pygfx Line (segments) tracing the frozen view volume."""
        return gfx.Line(
            gfx.Geometry(positions=self.segments(to_local)),
            gfx.LineSegmentMaterial(color=FROZEN_FRUSTUM_COLOR, thickness=thickness),
        )
