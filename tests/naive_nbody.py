"""Slow, obviously correct NumPy twins of the pair-force kernels (float64, O(n²) memory).

Positions are ``(3, n)`` as the kernels take them; each twin returns ``(3, n)``.
"""

from __future__ import annotations

import numpy as np


def inverse_square(position, weight, softening, coupling=1.0, scale=None):
    """``c s_i Σ_{j≠i} w_j (x_j - x_i) / (|x_j - x_i|² + ε²)^{3/2}``."""
    p = np.asarray(position, dtype=np.float64)
    w = np.asarray(weight, dtype=np.float64)
    d = p[:, None, :] - p[:, :, None]  # [component, i, j] = x_j - x_i
    r2 = (d * d).sum(axis=0) + softening**2
    np.fill_diagonal(r2, np.inf)
    field = (w[None, None, :] * d / r2**1.5).sum(axis=2)
    s = np.ones(p.shape[1]) if scale is None else np.asarray(scale, dtype=np.float64)
    return coupling * s * field


def pair_force(position, force, cutoff=None):
    """``Σ_{j≠i, r ≤ r_c} f(r_ij) (x_i - x_j) / r_ij``, ``force`` a NumPy function of r."""
    p = np.asarray(position, dtype=np.float64)
    d = p[:, :, None] - p[:, None, :]  # x_i - x_j
    r = np.sqrt((d * d).sum(axis=0))
    np.fill_diagonal(r, np.inf)
    f = np.where(np.isfinite(r), force(np.where(np.isfinite(r), r, 1.0)), 0.0)
    if cutoff is not None:
        f = np.where(r <= cutoff, f, 0.0)
    return (f / r * d).sum(axis=2)


def morton(q):
    """Morton codes of integer coordinates ``q`` (3, n), 21 bits each, bit by bit."""
    q = np.asarray(q, dtype=np.int64)
    code = np.zeros(q.shape[1], np.int64)
    for b in range(21):
        for axis in range(3):
            code |= ((q[axis] >> b) & 1) << (3 * b + axis)
    return code
