"""Uniform grid neighbour search, built by counting sort.

Why a dense grid over the bounding box and not a hashed one: with a hash, two of the 27
cells around a point can share a bucket and the bucket would be visited twice (a
duplicate neighbour) unless every query de-duplicates buckets; a dense grid has no
collisions, and its x-fastest numbering makes the three cells of a row one run of the
sorted points (9 runs per query instead of 27). Its cost is memory per cell, so the
number of cells is bounded: when the bounding box would need more than
``cells_per_point * n`` cells (a few far-flung points), the cells grow until it fits.
Larger cells only add candidates that the distance test rejects, so results never
change, only the time.

The sorted order is a by-product worth keeping: a solver that permutes its particles
into it (:attr:`UniformGrid.order`) reads neighbours from nearby memory.
"""

from __future__ import annotations

import numpy as np

from .. import _validate
from . import kernels
from .neighbors import NeighborOverflow, Neighbors, sorted_pairs

#: Cells are enlarged by this relative margin so that two points at most ``cell_size``
#: apart never fall two cells apart through the round-off of ``(x - origin) / cell``.
_MARGIN = 1e-6


class UniformGrid:
    """A uniform grid over a set of points for fixed-radius neighbour queries.

    Parameters
    ----------
    cell_size : float
        Edge of a cell [m]; queries take any radius up to it.
    capacity : int
        Initial neighbours per point in the query buffer; see :meth:`neighbors`.
    cells_per_point : float
        Bound on the number of cells, per point (at least 64 cells in all).

    Examples
    --------
    >>> import numpy as np
    >>> pts = np.random.default_rng(0).random((3, 1000), dtype=np.float32)
    >>> grid = UniformGrid(0.1).build(pts)
    >>> lists = grid.neighbors(0.1)
    >>> lists.offsets.shape
    (1001,)
    """

    def __init__(self, cell_size: float, *, capacity: int = 64, cells_per_point: float = 4.0):
        self.cell_size = _validate.positive("cell_size", cell_size)
        self.capacity = _validate.integer("capacity", capacity, low=1)
        self.cells_per_point = _validate.positive("cells_per_point", cells_per_point)
        self.count = 0
        #: Sorted slot -> point index, int64, shape (n,).
        self.order = np.zeros(0, np.int64)
        #: Point coordinates in sorted order, float32, shape (3, n).
        self.sorted_positions = np.zeros((3, 0), np.float32)
        #: First slot of each cell, int64, shape (cells + 1,).
        self.cell_start = np.zeros(2, np.int64)
        self.origin = np.zeros(3)
        self.dims = np.ones(3, np.int64)
        self.cell = self.cell_size
        self._keys = np.zeros(0, np.int64)
        self._buffer = np.zeros((0, self.capacity + 1), np.int32)
        self._found = np.zeros(0, np.int64)

    def build(self, positions) -> UniformGrid:
        """Sort ``positions`` (shape (3, n) [m], rows x, y, z) into the grid; returns self."""
        pos = _rows("positions", positions)
        n = pos.shape[1]
        self.count = n
        if n == 0:
            self.order = np.zeros(0, np.int64)
            self.sorted_positions = np.zeros((3, 0), np.float32)
            self.dims = np.ones(3, np.int64)
            self.cell_start = np.zeros(2, np.int64)
            return self
        x, y, z = pos
        lo = pos.min(axis=1).astype(np.float64)
        hi = pos.max(axis=1).astype(np.float64)
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
            raise ValueError("positions must be finite (no NaN or inf)")
        cell = self.cell_size * (1.0 + _MARGIN)
        limit = max(64.0, self.cells_per_point * n)
        extent = hi - lo
        while True:
            dims = np.floor(extent / cell).astype(np.int64) + 1
            if float(np.prod(dims.astype(np.float64))) <= limit:
                break
            cell *= max(1.01, (float(np.prod(dims.astype(np.float64))) / limit) ** (1 / 3))
        self.cell, self.origin, self.dims = cell, lo, dims
        cells = int(np.prod(dims))
        if self._keys.shape[0] != n:
            self._keys = np.empty(n, np.int64)
            self.order = np.empty(n, np.int64)
            self.sorted_positions = np.empty((3, n), np.float32)
        if self.cell_start.shape[0] != cells + 1:
            self.cell_start = np.empty(cells + 1, np.int64)
        kernels.cell_keys(x, y, z, lo, 1.0 / cell, dims, self._keys)
        kernels.counting_sort(self._keys, self.cell_start, self.order)
        np.take(pos, self.order, axis=1, out=self.sorted_positions)
        return self

    def neighbors(self, radius: float, *, slots: bool = False, grow: bool = True) -> Neighbors:
        """Every point's neighbours within ``radius`` [m] (itself excluded), in CSR form.

        Parameters
        ----------
        radius : float
            Query radius [m], at most ``cell_size``; a pair exactly at the radius is in.
        slots : bool
            False: row ``i`` lists the neighbours of point ``i`` by point index. True:
            rows and entries are sorted slots (point ``order[s]`` is slot ``s``), for a
            caller that keeps its particles in the grid's order.
        grow : bool
            When a point has more neighbours than :attr:`capacity`: True grows the
            buffer and runs the query again; False raises :class:`NeighborOverflow`.
        """
        s = self.sorted_positions
        return self._query(s, radius, True, slots, grow)

    def neighbor_rows(self, radius: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Every point's neighbours within ``radius`` [m] as sorted slots, in rows that are
        not packed together: ``(begin, end, entries)``, row ``s`` (slot ``s``) being
        ``entries[begin[s]:end[s]]``, the same entries in the same order as
        ``neighbors(radius, slots=True)``.

        It skips the copy into CSR form (6 ms of a 100,000-particle fluid step): the rows
        stay where the search wrote them, in the grid's buffer, valid until its next
        query. ``begin``, ``end``: int64 (n,); ``entries``: int32.
        """
        self._query(self.sorted_positions, radius, True, True, True, pack=False)
        n = self.count
        stride = self._buffer.shape[1]
        begin = np.arange(n, dtype=np.int64) * stride
        return begin, begin + self._found[:n], self._buffer[:n].reshape(-1)

    def query(self, points, radius: float, *, grow: bool = True) -> Neighbors:
        """Neighbours (point indices) within ``radius`` [m] of other ``points`` (3, m)."""
        q = _rows("points", points)
        return self._query(q, radius, False, False, grow)

    def knn(self, points, k: int, *, exclude_self: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """The ``k`` nearest grid points of each query point, nearest first.

        Any ``k`` works whatever the cell size; the search grows shells of cells until
        the ``k``-th distance is settled, so it is fast when a few cells hold ``k``
        points and slow on strongly clustered points (use a tree there).

        Parameters
        ----------
        points : array of shape (3, m)
            Query points [m] (compared in the grid's float32 coordinates).
        k : int
            1 <= k <= number of points (less one with ``exclude_self``).
        exclude_self : bool
            The queries are the grid's own points, in their original order: leave each
            point out of its own list.

        Returns
        -------
        distance : float64 (m, k)
            Distances [m], ascending.
        index : int64 (m, k)
            Point indices.
        """
        q = _rows("points", points)
        most = self.count - (1 if exclude_self else 0)
        k = _validate.integer("k", k, low=1)
        if k > most:
            raise ValueError(f"k must be <= {most} (the points available), got {k}")
        if exclude_self and q.shape[1] != self.count:
            raise ValueError("exclude_self needs the grid's own points as the queries")
        self_slot = np.full(1, -1, np.int64)
        if exclude_self:
            self_slot = np.empty(self.count, np.int64)
            self_slot[self.order] = np.arange(self.count)
        distance = np.empty((q.shape[1], k))
        index = np.empty((q.shape[1], k), np.int64)
        kernels.knn_shells(
            *q, *self.sorted_positions, self.order, self.cell_start, self.origin,
            1.0 / self.cell, self.dims, self_slot, exclude_self, distance, index,
        )  # fmt: skip
        np.sqrt(distance, out=distance)
        return distance, index

    def pairs(self, distance: float) -> np.ndarray:
        """Every unordered pair of points at most ``distance`` [m] apart (any distance;
        fastest up to ``cell_size``), as ``(i, j)`` rows with ``i < j``, sorted; shape
        (pairs, 2), int64."""
        return sorted_pairs(self.neighbors(distance))

    # -- internals -------------------------------------------------------------------
    def _query(self, q, radius, exclude_self, slots, grow, pack=True) -> Neighbors | None:
        """Search into the buffer; with ``pack``, return the rows in CSR form."""
        radius = _validate.positive("radius", radius)
        nq = q.shape[1]
        if nq == 0 or self.count == 0:
            return Neighbors(np.zeros(nq + 1, np.int64), np.zeros(0, np.int32))
        while True:
            if self._buffer.shape[0] < nq or self._buffer.shape[1] != self.capacity + 1:
                self._buffer = np.empty(
                    (max(nq, self._buffer.shape[0]), self.capacity + 1), np.int32
                )
                self._found = np.empty(self._buffer.shape[0], np.int64)
            buffer, found = self._buffer[:nq], self._found[:nq]
            sx, sy, sz = self.sorted_positions
            kernels.query_radius(
                *q, sx, sy, sz, self.cell_start, self.origin, 1.0 / self.cell, self.dims,
                radius * radius, exclude_self, buffer, found,
            )  # fmt: skip
            most = int(found.max())
            if most <= self.capacity:
                break
            if not grow:
                raise NeighborOverflow(most, self.capacity)
            self.capacity = most + most // 4
        if not pack:
            return None
        if exclude_self and not slots:
            row_of = np.empty(nq, np.int64)
            row_of[self.order] = np.arange(nq)
        else:
            row_of = np.arange(nq, dtype=np.int64)
        entry_map = np.arange(self.count, dtype=np.int32) if slots else self.order.astype(np.int32)
        offsets = np.zeros(nq + 1, np.int64)
        np.cumsum(found[row_of], out=offsets[1:])
        indices = np.empty(int(offsets[-1]), np.int32)
        kernels.compact_rows(buffer, found, row_of, entry_map, offsets, indices)
        return Neighbors(offsets, indices)


def _rows(name: str, value) -> np.ndarray:
    arr = np.asarray(value)
    if arr.ndim != 2 or arr.shape[0] != 3:
        raise ValueError(f"{name} must have shape (3, n), got shape {arr.shape}")
    return np.ascontiguousarray(arr, dtype=np.float32)
