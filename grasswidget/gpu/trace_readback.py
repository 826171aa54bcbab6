"""The inspected blades' numbers of each rendered frame, read back without stalling.

The blade inspector's compute pass runs in every render and writes the inspected
blades' control points and forces (:mod:`grasswidget.gpu.inspector`). After a frame,
:meth:`InspectedReadback.after_render` copies those two small buffers (at most 64
blades: 5 KB) into one of a small ring of mappable buffers and asks for it
asynchronously, as :class:`grasswidget.gpu.stats.FrameStats` does; :meth:`poll`
returns the frames the GPU has finished, each with the tag it was queued with
(e.g. its simulated time), as ``read_inspected()``-style rows. Nothing waits for the
GPU; when every ring buffer is still in flight a frame is skipped (counted in
``skipped``).
"""

from __future__ import annotations

from collections import deque

import numpy as np
import wgpu

from .. import compat
from ..core.reference import FORCE_NAMES
from ..core.teaching import MAX_INSPECTED, inspected_rows
from .adapter import ensure_device
from .stats import read_staging

__all__ = ["InspectedReadback", "RING"]

#: Frames that may be in flight at once.
RING = 4
_FORCE_BYTES = MAX_INSPECTED * len(FORCE_NAMES) * 16
_POINT_BYTES = MAX_INSPECTED * 3 * 12


class InspectedReadback:
    """Non-blocking readback of one field's inspector, frame by frame (see the module docstring)."""

    def __init__(self, field):
        self.field = field
        self.device = ensure_device()
        self._free = deque(self.device.create_buffer(size=_FORCE_BYTES + _POINT_BYTES,
                                                     usage=wgpu.BufferUsage.COPY_DST | wgpu.BufferUsage.MAP_READ)
                           for _ in range(RING))
        self._pending = deque()
        self.skipped = 0

    def after_render(self, tag) -> bool:
        """Queue the copy of this frame's inspector numbers with ``tag``; False when nothing is
        inspected or the ring is full (the frame is skipped)."""
        inspector = self.field.inspector
        if inspector is None or not inspector.ids:
            return False
        forces, points = compat.gpu_buffer(inspector.forces_buffer), compat.gpu_buffer(inspector.points_buffer)
        if forces is None or points is None:  # not uploaded yet (no render since inspect())
            return False
        if not self._free:
            self.skipped += 1
            return False
        n = len(inspector.ids)
        staging = self._free.popleft()
        enc = self.device.create_command_encoder()
        enc.copy_buffer_to_buffer(forces, 0, staging, 0, n * len(FORCE_NAMES) * 16)
        enc.copy_buffer_to_buffer(points, 0, staging, _FORCE_BYTES, _padded(n * 36))
        self.device.queue.submit([enc.finish()])
        self._pending.append((staging, staging.map_async("READ"), tag, inspector.ids))
        return True

    def poll(self) -> list:
        """``[(tag, rows), ...]`` of the frames the GPU has finished, oldest first (non-blocking)."""
        compat.poll_device(self.device)
        out = []
        while self._pending and compat.promise_settled(self._pending[0][1]):
            staging, promise, tag, ids = self._pending.popleft()
            raw = read_staging(staging, promise, self._free)
            n = len(ids)
            forces = raw[: n * len(FORCE_NAMES) * 16].view(np.float32).reshape(n, len(FORCE_NAMES), 4)
            points = raw[_FORCE_BYTES: _FORCE_BYTES + n * 36].view(np.float32).reshape(n, 3, 3)
            blades = self.field.blades
            if max(ids) < len(blades):
                out.append((tag, inspected_rows(ids, blades.height, blades.stiffness,
                                                self.field.params.stiffness_scale, points, forces)))
        return out

    def flush(self) -> list:
        """Wait for every frame in flight and return them as :meth:`poll` does (for tests and
        before a blade-count change)."""
        for _staging, promise, _tag, _ids in self._pending:
            try:
                promise.sync_wait()
            except Exception:
                pass
        return self.poll()

    def release(self):
        """Settle what is in flight and destroy the ring buffers."""
        for _staging, promise, _tag, _ids in self._pending:
            try:
                promise.sync_wait()
            except Exception:
                pass
        for buf in list(self._free) + [p[0] for p in self._pending]:
            if buf.map_state == "mapped":
                buf.unmap()
            buf.destroy()
        self._free.clear()
        self._pending.clear()


def _padded(nbytes: int) -> int:
    return (nbytes + 3) // 4 * 4
