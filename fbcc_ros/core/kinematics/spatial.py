"""Small 3-vector helpers for the per-sample paths.

``np.cross`` costs about 30 µs per call on 3-vectors (it moves axes and broadcasts); the
compensation calls it several times per 1 kHz sample, so the component formula is used instead.
"""

from __future__ import annotations

import numpy as np

from fbcc_ros.core.arrays import FloatArray


def cross(a: FloatArray, b: FloatArray) -> FloatArray:
    """``a x b`` of two 3-vectors."""
    return np.array(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


def skew(v: FloatArray) -> FloatArray:
    """Cross-product matrices of the rows of v, (..., 3, 3): ``skew(v) @ u = v x u``."""
    out = np.zeros((*v.shape[:-1], 3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out
