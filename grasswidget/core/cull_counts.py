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

A disabled test keeps what the test before it kept. The reference runs again, on a
worker thread (a frame never waits for it; the numbers then lag the camera by one
count), only when the camera, the culling parameters or the blades change, and while they change
(a camera being dragged) at most every :data:`RECOUNT_INTERVAL_S` seconds or ten
times as long as the last count took, whichever is longer (at most a tenth of a core:
about 0.3 s a count at 2^16 blades on a loaded 2-core machine).
"""

from __future__ import annotations

import threading
import time
import types

import numpy as np

from .reference import cull_reason
from .teaching import camera_view_proj

__all__ = ["CullCounter", "RECOUNT_INTERVAL_S", "gpu_kept"]

#: Least wall-clock time between two reference counts while the camera moves (s).
RECOUNT_INTERVAL_S = 0.25

_CULL_PARAMS = ("cull_orientation", "cull_orientation_threshold", "cull_frustum", "cull_frustum_tolerance",
                "cull_distance", "cull_buckets", "cull_distance_max")


def gpu_kept(visible, occluded, occlusion) -> dict:
    """The GPU's part of the kept counts: ``{"distance": visible + occluded, "occlusion": visible}``
    (None where ``visible`` is None); ``occluded`` counts only while ``occlusion``
    (``params.cull_occlusion``) is on and it is not None (None: occlusion did not run)."""
    if visible is None:
        return {"distance": None, "occlusion": None}
    extra = int(occluded) if occluded is not None and occlusion else 0
    return {"distance": int(visible) + extra, "occlusion": int(visible)}


class CullCounter:
    """Counts of :data:`grasswidget.core.traces.CULL_TESTS` for one field's blades.

    Args:
        blades: the field's :class:`~grasswidget.core.blades.Blades` (field space = world space).
        params: the :class:`GrassParams` (its ``cull_*`` traits are read at each count).
        background: recount on a worker thread (the default), so a frame never waits for it;
            the first count of a field is always done at once.
        clock: the clock (a function returning seconds) that the interval between two recounts
            and a count's duration are measured on; default ``time.perf_counter``.
    """

    def __init__(self, blades, params, background=True, clock=time.perf_counter):
        self.params = params
        self.background = background
        self.clock = clock
        self._lock = threading.Lock()
        self._generation = 0
        self.set_blades(blades)

    def set_blades(self, blades):
        """A new field (the blade count changed): forget the cached counts."""
        with self._lock:
            self._generation += 1
            self._state = blades.rest_state()
            self._key = None
            self._counts = None
            self._started_at = -np.inf
            self._interval = RECOUNT_INTERVAL_S
            self._running = False

    def _count(self, generation, key, state, params, camera, depth_range, size):
        t0 = self.clock()
        near, far = depth_range
        view_proj = camera_view_proj(camera["position"], camera["target"], camera["fov_deg"], near, far,
                                     size[0] / max(size[1], 1))
        reason = cull_reason(state, params, view_proj, np.asarray(camera["position"], np.float64))
        n = len(reason)
        # kept after frustum = culled neither by orientation nor by frustum (distance comes after)
        counts = {"orientation": int(n - np.count_nonzero(reason == 1)),
                  "frustum": int(np.count_nonzero(reason == 0) + np.count_nonzero(reason == 3))}
        with self._lock:
            self._running = False
            if generation == self._generation:
                self._counts = counts
                # A large field's count takes longer: wait 10 times as long as it took (a tenth of a core).
                self._interval = max(RECOUNT_INTERVAL_S, 10.0 * (self.clock() - t0))

    def kept(self, camera: dict, depth_range, size, visible=None, occluded=None, now=False) -> dict:
        """Blades kept after each test (see the module docstring).

        Args:
            camera: the culling camera: ``position``, ``target`` (m), ``fov_deg``.
            depth_range: (near, far) m. size: (width, height) of the view (its aspect).
            visible: the GPU's drawn count (None: unknown). occluded: the GPU's occluded
                count (None: occlusion culling off or unknown).
            now: count for this very camera before returning (on this thread, after any
                count running), whatever the interval; False (default): the newest count,
                which may lag a moving camera. A paused view's sample (a ``step(n)``) uses True.
        """
        p = self.params
        values = {name: getattr(p, name) for name in _CULL_PARAMS}
        camera = {"position": tuple(float(x) for x in camera["position"]),
                  "target": tuple(float(x) for x in camera["target"]), "fov_deg": float(camera["fov_deg"])}
        key = (camera["position"], camera["target"], camera["fov_deg"], tuple(depth_range), tuple(size),
               tuple(values.values()))
        if now:
            self.wait()
        at = self.clock()
        with self._lock:
            first = self._counts is None and not self._running
            due = key != self._key and not self._running and (now or at - self._started_at >= self._interval)
            if first or due:
                self._key, self._started_at, self._running = key, at, True
                job = (self._generation, key, self._state, types.SimpleNamespace(**values), camera,
                       tuple(depth_range), tuple(size))
            else:
                job = None
        if job is not None:
            if first or now or not self.background:
                self._count(*job)
            else:
                threading.Thread(target=self._count, args=job, name="grasswidget-cull-counts", daemon=True).start()
        with self._lock:
            kept = dict(self._counts) if self._counts is not None else {"orientation": None, "frustum": None}
        kept.update(gpu_kept(visible, occluded, p.cull_occlusion))
        return kept

    def wait(self, timeout=10.0):
        """Wait until no count is running (tests)."""
        deadline = time.perf_counter() + timeout
        while time.perf_counter() < deadline:
            with self._lock:
                if not self._running:
                    return
            time.sleep(0.005)
