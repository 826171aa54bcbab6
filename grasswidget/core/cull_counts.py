"""Blades kept after each culling test, for the traces (pure NumPy).

The GPU counts what survives every test (``visible``, the drawn blades) and, with
occlusion culling, the occluded ones, in the views' non-blocking stats; it does not
count per test. :class:`CullCounter` fills in the first two tests with the NumPy
reference (:func:`grasswidget.core.reference.cull_reason`) on the blades' rest pose
for the culling camera:

* ``kept["orientation"]``: exact (the test reads only the root, ``up``, the
  orientation and the camera);
* ``kept["frustum"]``: the rest pose's (a blade swaying across the frustum's edge by
  its sway, a few centimetres, may count differently from the GPU's live test);
* ``kept["distance"]`` = visible + occluded and ``kept["occlusion"]`` = visible: the
  GPU's own counts (as the stats line shows them).

A disabled test keeps what the test before it kept. The reference runs again only
when the camera, the culling parameters or the blades change, and while they change
(a camera being dragged) at most every :data:`RECOUNT_INTERVAL_S` seconds or ten
times as long as the last count took, whichever is longer (at most a tenth of a core:
about 15 ms a count at 2^16 blades on this machine's CPU).
"""

from __future__ import annotations

import time

import numpy as np

from .reference import cull_reason
from .teaching import camera_view_proj

__all__ = ["CullCounter", "RECOUNT_INTERVAL_S"]

#: Least wall-clock time between two reference counts while the camera moves (s).
RECOUNT_INTERVAL_S = 0.25

_CULL_PARAMS = ("cull_orientation", "cull_orientation_threshold", "cull_frustum", "cull_frustum_tolerance",
                "cull_distance", "cull_buckets", "cull_distance_max")


class CullCounter:
    """Counts of :data:`grasswidget.core.traces.CULL_TESTS` for one field's blades.

    Args:
        blades: the field's :class:`~grasswidget.core.blades.Blades` (field space = world space).
        params: the :class:`GrassParams` (its ``cull_*`` traits are read at each count).
    """

    def __init__(self, blades, params):
        self.params = params
        self.set_blades(blades)

    def set_blades(self, blades):
        """A new field (the blade count changed): forget the cached counts."""
        self._state = blades.rest_state()
        self._key = None
        self._counts = None
        self._counted_at = -np.inf
        self._interval = RECOUNT_INTERVAL_S

    def kept(self, camera: dict, depth_range, size, visible=None, occluded=None) -> dict:
        """Blades kept after each test (see the module docstring).

        Args:
            camera: the culling camera: ``position``, ``target`` (m), ``fov_deg``.
            depth_range: (near, far) m. size: (width, height) of the view (its aspect).
            visible: the GPU's drawn count (None: unknown). occluded: the GPU's occluded
                count (None: occlusion culling off or unknown).
        """
        p = self.params
        key = (tuple(camera["position"]), tuple(camera["target"]), float(camera["fov_deg"]), tuple(depth_range),
               tuple(size)) + tuple(getattr(p, name) for name in _CULL_PARAMS)
        now = time.perf_counter()
        if self._counts is None or (key != self._key and now - self._counted_at >= self._interval):
            near, far = depth_range
            view_proj = camera_view_proj(camera["position"], camera["target"], camera["fov_deg"], near, far,
                                         size[0] / max(size[1], 1))
            reason = cull_reason(self._state, p, view_proj, np.asarray(camera["position"], np.float64))
            n = len(reason)
            self._counts = {"orientation": int(n - np.count_nonzero(reason == 1)),
                            "frustum": int(np.count_nonzero(reason == 0) + np.count_nonzero(reason == 3))}
            # kept after frustum = not culled by orientation or frustum (distance comes after).
            self._key, self._counted_at = key, now
            # A large field's count takes longer: wait 10 times as long as it took (at most 10 % of a core).
            self._interval = max(RECOUNT_INTERVAL_S, 10.0 * (time.perf_counter() - now))
        kept = dict(self._counts)
        if visible is None:
            kept["distance"] = kept["occlusion"] = None
        else:
            kept["occlusion"] = int(visible)
            kept["distance"] = int(visible) + (int(occluded) if occluded is not None and p.cull_occlusion else 0)
        return kept
