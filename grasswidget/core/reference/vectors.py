"""Small vector helpers every part of the reference uses (float64, vectorised over the
last axis)."""

from __future__ import annotations

import numpy as np

__all__ = ["safe_normalize", "dot", "U32_MASK"]

#: The low 32 bits: the reference's hashes wrap like the WGSL's u32 arithmetic.
U32_MASK = np.uint64(0xFFFFFFFF)


def safe_normalize(v, eps=1e-12):
    """v / |v| along the last axis; a zero vector stays zero (no NaN)."""
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.maximum(n, eps)


def dot(a, b):
    """The dot product along the last axis."""
    return np.sum(a * b, axis=-1)
