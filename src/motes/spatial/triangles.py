"""A uniform grid over moving triangles, rebuilt every step by a compiled counting sort.

Static meshes bin their triangles once (``collide.mesh``); a cloth moves, so its grid is
rebuilt each step. Each triangle is listed in every cell its bounding box (grown by a
pad) overlaps, in triangle order: two serial O(t) passes (count, then fill) and a scan,
so the lists are the same on any thread count. Cells are about one triangle's bounding
box across and never more than ``MAX_CELLS_PER_TRIANGLE`` times the triangle count, so a
triangle touches a handful of cells and a far-flung mesh cannot allocate a huge grid.
"""

from __future__ import annotations

import numpy as np

from .._jit import serial_kernel

#: Bound on the number of cells, per triangle.
MAX_CELLS_PER_TRIANGLE = 64


@serial_kernel
def _cell_ranges(tri, pad, origin, inv_cell, dims, first, last):
    """Per triangle, the first and last cell (i, j, k) its padded box overlaps."""
    for t in range(tri.shape[0]):
        for a in range(3):
            lo = min(tri[t, a], min(tri[t, 3 + a], tri[t, 6 + a])) - pad
            hi = max(tri[t, a], max(tri[t, 3 + a], tri[t, 6 + a])) + pad
            first[t, a] = min(max(int((lo - origin[a]) * inv_cell), 0), dims[a] - 1)
            last[t, a] = min(max(int((hi - origin[a]) * inv_cell), 0), dims[a] - 1)


@serial_kernel
def _bin(first, last, dims, cell_start, cell_tris):
    """Counting sort of (cell, triangle) pairs into CSR rows, triangle order kept."""
    cell_start[:] = 0
    for t in range(first.shape[0]):
        for i in range(first[t, 0], last[t, 0] + 1):
            for j in range(first[t, 1], last[t, 1] + 1):
                for k in range(first[t, 2], last[t, 2] + 1):
                    cell_start[(i * dims[1] + j) * dims[2] + k + 1] += 1
    for c in range(cell_start.shape[0] - 1):
        cell_start[c + 1] += cell_start[c]
    cursor = cell_start[:-1].copy()
    for t in range(first.shape[0]):
        for i in range(first[t, 0], last[t, 0] + 1):
            for j in range(first[t, 1], last[t, 1] + 1):
                for k in range(first[t, 2], last[t, 2] + 1):
                    c = (i * dims[1] + j) * dims[2] + k
                    cell_tris[cursor[c]] = t
                    cursor[c] += 1


class TriangleGrid:
    """Cells listing the triangles that may lie within ``pad`` of a point in them.

    Attributes (after :meth:`build`)
    --------------------------------
    origin : (3,) float64
        Lower corner of the grid [m].
    inv_cell : float
        1 / cell edge [1/m].
    dims : (3,) int64
        Cells along x, y, z (cell ``(i, j, k)`` is row ``(i·dims[1] + j)·dims[2] + k``).
    cell_start, cell_tris : int64 arrays
        CSR rows: the triangles of cell ``c`` are ``cell_tris[cell_start[c]:cell_start[c+1]]``.
    """

    def __init__(self):
        self.origin = np.zeros(3)
        self.inv_cell = 1.0
        self.dims = np.ones(3, np.int64)
        self.cell_start = np.zeros(2, np.int64)
        self.cell_tris = np.zeros(0, np.int64)

    def build(self, tri: np.ndarray, pad: float) -> TriangleGrid:
        """Bin triangles ``tri`` ((t, 9) float64: corners a, b, c) grown by ``pad`` [m]."""
        t = len(tri)
        corners = tri.reshape(t, 3, 3)
        lo = corners.min(axis=(0, 1)) - pad
        hi = corners.max(axis=(0, 1)) + pad
        extent = np.maximum(hi - lo, 1e-9)
        # About one triangle box per cell, but never more than the bound in total.
        mean_box = float(np.mean(corners.max(axis=1) - corners.min(axis=1))) + 2 * pad
        cell = max(mean_box, float(np.cbrt(np.prod(extent) / (MAX_CELLS_PER_TRIANGLE * t))))
        self.origin = lo
        self.inv_cell = 1.0 / cell
        self.dims = np.maximum(np.ceil(extent / cell).astype(np.int64), 1)
        first = np.empty((t, 3), np.int64)
        last = np.empty((t, 3), np.int64)
        _cell_ranges(tri, pad, self.origin, self.inv_cell, self.dims, first, last)
        spans = np.prod(last - first + 1, axis=1)
        cells = int(np.prod(self.dims))
        if self.cell_start.shape[0] != cells + 1:
            self.cell_start = np.empty(cells + 1, np.int64)
        self.cell_tris = np.empty(int(spans.sum()), np.int64)
        _bin(first, last, self.dims, self.cell_start, self.cell_tris)
        return self
