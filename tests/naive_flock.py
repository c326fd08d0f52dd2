"""Brute-force twins of the flock's neighbour search: every pair, no grid."""

from __future__ import annotations

import numpy as np


def neighbor_sets(positions, headings, radius, cos_half_fov):
    """Per boid, the set of boids it sees: ``j != i``, ``|d| <= radius`` and
    ``d · h_i >= cos_half_fov · |d|`` (``d = x_j - x_i``), all in float32 as the kernels
    compute; positions and headings (3, n)."""
    p = np.asarray(positions, np.float32).T
    h = np.asarray(headings, np.float32).T
    d = p[None, :, :] - p[:, None, :]  # d[i, j] = x_j - x_i
    d2 = (d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1]) + d[..., 2] * d[..., 2]
    ahead = (d[..., 0] * h[:, None, 0] + d[..., 1] * h[:, None, 1]) + d[..., 2] * h[:, None, 2]
    seen = (d2 <= np.float32(radius**2)) & (ahead >= np.float32(cos_half_fov) * np.sqrt(d2))
    np.fill_diagonal(seen, False)
    return [set(np.flatnonzero(row).tolist()) for row in seen], seen
