"""Plain NumPy twins of the spatial and fluid kernels: slow and obviously correct."""

from __future__ import annotations

import numpy as np


def neighbor_sets(points: np.ndarray, radius: float, queries: np.ndarray | None = None):
    """Brute force: for each query (rows of (m, 3)), the set of points within ``radius``.

    Without ``queries`` the points query themselves and leave themselves out. Distances
    in float64, ``d² <= r²`` as the grid and cKDTree test.
    """
    p = np.asarray(points, np.float64)
    q = p if queries is None else np.asarray(queries, np.float64)
    d2 = ((q[:, None, :] - p[None, :, :]) ** 2).sum(axis=2)
    hits = d2 <= radius * radius
    if queries is None:
        np.fill_diagonal(hits, False)
    return [set(np.flatnonzero(row).tolist()) for row in hits]
