"""Blade generation (pure NumPy, no GPU import).

A blade is packed, as in Jahrmann & Wimmer (2017), into 4 x vec4 (64 bytes):

=====  ================================  =====================
vec4   xyz                               w
=====  ================================  =====================
0      v0: root on the surface (fixed)   orientation theta (rad)
1      v1: Bezier guide above v0         height h (m)
2      v2: tip guide, simulated          width w (m)
3      up: surface normal at v0          stiffness s (1/s^2)
=====  ================================  =====================
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Blades"]


def _check_range(name, value, lo_min=0.0):
    try:
        lo, hi = (float(value[0]), float(value[1]))
    except (TypeError, IndexError, ValueError):
        raise ValueError(f"{name} must be a (min, max) pair of numbers; got {value!r}") from None
    if not (np.isfinite(lo) and np.isfinite(hi)) or lo <= lo_min or hi < lo:
        raise ValueError(
            f"{name} must be a (min, max) pair with {lo_min:g} < min <= max, finite; got {value!r}"
        )
    return lo, hi


@dataclass
class Blades:
    """A set of N grass blades in their rest pose.

    Attributes (all float32):
        v0: (N, 3) roots, metres.
        up: (N, 3) unit surface normals at the roots.
        orientation: (N,) angle theta (radians) of the width direction in the tangent plane.
        height: (N,) blade heights h, metres.
        width: (N,) blade widths w, metres.
        stiffness: (N,) stiffness s of the recovery force, 1/s^2.
    """

    v0: np.ndarray
    up: np.ndarray
    orientation: np.ndarray
    height: np.ndarray
    width: np.ndarray
    stiffness: np.ndarray

    def __post_init__(self):
        n = len(self.v0)
        self.v0 = np.ascontiguousarray(self.v0, np.float32).reshape(n, 3)
        up = np.asarray(self.up, np.float64).reshape(n, 3)
        norm = np.linalg.norm(up, axis=1, keepdims=True)
        if n and (not np.all(np.isfinite(up)) or np.any(norm < 1e-12)):
            raise ValueError("up vectors must be finite and non-zero")
        self.up = (up / np.maximum(norm, 1e-30)).astype(np.float32)
        for name in ("orientation", "height", "width", "stiffness"):
            arr = np.ascontiguousarray(getattr(self, name), np.float32).reshape(n)
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"{name} must be finite")
            setattr(self, name, arr)
        if not np.all(np.isfinite(self.v0)):
            raise ValueError("v0 (roots) must be finite")
        if n and (self.height.min() <= 0 or self.width.min() <= 0 or self.stiffness.min() <= 0):
            raise ValueError("height, width and stiffness must be > 0")

    def __len__(self):
        return len(self.v0)

    @property
    def count(self) -> int:
        """Number of blades N."""
        return len(self.v0)

    @classmethod
    def on_plane(
        cls,
        count: int,
        size: float = 15.0,
        seed: int = 0,
        height=(1.3, 2.5),
        width=(0.1, 0.14),
        stiffness=(7.0, 13.0),
    ) -> "Blades":
        """Blades on a ``size`` x ``size`` plane centred at the origin, y up.

        Roots are uniform on the plane (jittered-stratified, so the meadow has no
        bald patches), each blade has a uniform random orientation in [0, 2 pi) and
        height, width and stiffness uniform in the given (min, max) ranges. Ids are
        shuffled, so id order carries no spatial pattern (distance culling thins by
        id). The same arguments give the same blades.

        Args:
            count: number of blades N, >= 1.
            size: side of the square plane in metres, > 0 (default 15, the course scene).
            seed: random seed (int).
            height, width, stiffness: (min, max) ranges; metres, metres, 1/s^2.
        """
        if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 1:
            raise ValueError(f"count must be an integer >= 1; got {count!r}")
        count = int(count)
        if isinstance(size, bool) or not isinstance(size, (int, float, np.number)) or not np.isfinite(size) or size <= 0:
            raise ValueError(f"size must be a finite number > 0 (metres); got {size!r}")
        h = _check_range("height", height)
        w = _check_range("width", width)
        s = _check_range("stiffness", stiffness)
        rng = np.random.default_rng(seed)
        # Jittered stratified sampling on a k x k grid (k*k >= count), then a random
        # subset and a random permutation of the ids.
        k = int(np.ceil(np.sqrt(count)))
        cells = rng.permutation(k * k)[:count]
        cx, cz = cells % k, cells // k
        x = (cx + rng.random(count)) / k
        z = (cz + rng.random(count)) / k
        v0 = np.zeros((count, 3), np.float32)
        v0[:, 0] = (x - 0.5) * size
        v0[:, 2] = (z - 0.5) * size
        up = np.tile(np.float32([0, 1, 0]), (count, 1))
        return cls(
            v0=v0,
            up=up,
            orientation=rng.uniform(0.0, 2.0 * np.pi, count),
            height=rng.uniform(*h, count),
            width=rng.uniform(*w, count),
            stiffness=rng.uniform(*s, count),
        )

    def rest_state(self) -> dict:
        """State dict of the rest pose: v1 = v2 = v0 + h * up (the tip guide iv2)."""
        iv2 = self.v0 + self.up * self.height[:, None]
        return dict(
            v0=self.v0.copy(),
            v1=iv2.copy(),
            v2=iv2.copy(),
            up=self.up.copy(),
            height=self.height.copy(),
            width=self.width.copy(),
            orientation=self.orientation.copy(),
            stiffness=self.stiffness.copy(),
        )

    def packed(self) -> np.ndarray:
        """The (N, 4, 4) float32 array of the paper's 4 x vec4 layout, in rest pose."""
        return pack_state(self.rest_state())


def pack_state(state: dict) -> np.ndarray:
    """Pack a state dict into the (N, 4, 4) float32 layout of the GPU buffer."""
    n = len(state["v0"])
    out = np.empty((n, 4, 4), np.float32)
    out[:, 0, :3], out[:, 0, 3] = state["v0"], state["orientation"]
    out[:, 1, :3], out[:, 1, 3] = state["v1"], state["height"]
    out[:, 2, :3], out[:, 2, 3] = state["v2"], state["width"]
    out[:, 3, :3], out[:, 3, 3] = state["up"], state["stiffness"]
    return out


def unpack_state(packed: np.ndarray) -> dict:
    """Inverse of :func:`pack_state`: (N, 4, 4) float32 -> state dict of copies."""
    p = np.asarray(packed, np.float32).reshape(-1, 4, 4)
    return dict(
        v0=p[:, 0, :3].copy(),
        v1=p[:, 1, :3].copy(),
        v2=p[:, 2, :3].copy(),
        up=p[:, 3, :3].copy(),
        orientation=p[:, 0, 3].copy(),
        height=p[:, 1, 3].copy(),
        width=p[:, 2, 3].copy(),
        stiffness=p[:, 3, 3].copy(),
    )
