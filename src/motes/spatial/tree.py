"""What the spatial trees share: sorted points, nodes with tight boxes, and the queries
(radius neighbours, k nearest, pairs) that :mod:`.tree_kernels` answers for both."""

from __future__ import annotations

import numpy as np

from .. import _validate
from . import tree_kernels
from .morton import BITS, morton_codes, radix_sort
from .neighbors import Neighbors, points_rows, sorted_pairs


class SpatialTree:
    """Base of :class:`~motes.spatial.Octree` and :class:`~motes.spatial.KDTree`.

    A subclass's ``build`` sets, for ``n`` points and ``nodes`` nodes numbered breadth
    first:

    - ``order`` int64 (n,): ``order[s]`` is the point in sorted slot ``s``;
    - ``sorted_points`` (3, n): the points in slot order, their dtype;
    - ``node_start``, ``node_count`` int64 (nodes,): each node's run of slots;
    - ``node_child`` int64 (nodes,): first child (children are consecutive), -1 for a leaf;
    - ``node_children`` int64 (nodes,): number of children (0 for a leaf);
    - ``level_start`` int64 (levels + 1,): level ``L`` is nodes
      ``[level_start[L], level_start[L + 1])``;

    then calls :meth:`_built`. The tight node boxes (``node_lo``, ``node_hi``, float64
    (3, nodes) [m]) are computed on the first query, so a build for Barnes–Hut alone does
    not pay for them.
    """

    def _built(self) -> None:
        self._rows = None
        self._boxes = None

    @property
    def count(self) -> int:
        """Number of points."""
        return int(self.node_count[0])

    def leaves(self) -> np.ndarray:
        """Indices of the leaf nodes, in breadth-first order (int64)."""
        return np.flatnonzero(self.node_child < 0)

    # -- queries ---------------------------------------------------------------------
    def knn(self, points, k: int, *, exclude_self: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """The ``k`` nearest tree points of each query point, nearest first.

        Parameters
        ----------
        points : array of shape (3, m)
            Query points [m].
        k : int
            Neighbours per query, 1 <= k <= number of tree points (less one with
            ``exclude_self``).
        exclude_self : bool
            The queries are the tree's own points, in their original order: leave each
            point out of its own list.

        Returns
        -------
        distance : float64 (m, k)
            Euclidean distances [m], ascending (computed in float64).
        index : int64 (m, k)
            Indices of the neighbours among the points given to ``build``.
        """
        most = self.count - (1 if exclude_self else 0)
        k = _validate.integer("k", k, low=1)
        if k > most:
            raise ValueError(f"k must be <= {most} (the points available), got {k}")
        q = self._queries(points, exclude_self)
        qx, qy, qz = (np.ascontiguousarray(r, dtype=np.float64) for r in q)
        distance = np.empty((q.shape[1], k))
        index = np.empty((q.shape[1], k), np.int64)
        lo, hi = self._node_boxes()
        tree_kernels.knn(
            qx, qy, qz, self._morton_order(qx, qy, qz), *self._sorted_rows(), self.order,
            self.node_start, self.node_count, self.node_child, self.node_children, lo, hi,
            self._self_slots(exclude_self), exclude_self, distance, index,
        )  # fmt: skip
        np.sqrt(distance, out=distance)
        return distance, index

    def neighbors(self, radius: float) -> Neighbors:
        """Every point's neighbours within ``radius`` [m] (itself excluded), in CSR form,
        by point index; a pair exactly at the radius is in."""
        own = self.sorted_points[:, self._self_slots(True)]  # the points in their own order
        return self._within(own, radius, True)

    def query(self, points, radius: float) -> Neighbors:
        """Tree points within ``radius`` [m] of other ``points`` (3, m), in CSR form."""
        return self._within(self._queries(points, False), radius, False)

    def pairs(self, distance: float) -> np.ndarray:
        """Every unordered pair of tree points at most ``distance`` [m] apart, as
        ``(i, j)`` rows with ``i < j``, sorted; shape (pairs, 2), int64."""
        return sorted_pairs(self.neighbors(distance))

    # -- internals -------------------------------------------------------------------
    def _queries(self, points, exclude_self: bool) -> np.ndarray:
        q = points_rows("points", points)
        if exclude_self and q.shape[1] != self.count:
            raise ValueError("exclude_self needs the tree's own points as the queries")
        return q

    def _sorted_rows(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if self._rows is None:
            self._rows = tuple(np.ascontiguousarray(r, np.float64) for r in self.sorted_points)
        return self._rows

    def _node_boxes(self) -> tuple[np.ndarray, np.ndarray]:
        if self._boxes is None:
            nodes = self.node_start.shape[0]
            lo, hi = np.empty((3, nodes)), np.empty((3, nodes))
            tree_kernels.node_boxes(
                *self._sorted_rows(), self.node_start, self.node_count, self.node_child,
                self.node_children, self.level_start, lo, hi,
            )  # fmt: skip
            self._boxes = lo, hi
        return self._boxes

    def _self_slots(self, exclude_self: bool) -> np.ndarray:
        if not exclude_self:
            return np.full(1, -1, np.int64)
        slot_of = np.empty(self.count, np.int64)
        slot_of[self.order] = np.arange(self.count)
        return slot_of

    def _morton_order(self, qx, qy, qz) -> np.ndarray:
        """Queries in Morton order over the tree's box: consecutive queries then descend
        the same branches."""
        lo, hi = self._node_boxes()
        edge = max(float((hi[:, 0] - lo[:, 0]).max()), 1e-300)
        codes = np.empty(qx.shape[0], np.int64)
        morton_codes(qx, qy, qz, lo[:, 0].copy(), (1 << BITS) / edge, codes)
        return radix_sort(codes)[1]

    def _within(self, q, radius, exclude_self) -> Neighbors:
        radius = _validate.positive("radius", radius)
        m = q.shape[1]
        qx, qy, qz = (np.ascontiguousarray(r, dtype=np.float64) for r in q)
        lo, hi = self._node_boxes()
        offsets = np.zeros(m + 1, np.int64)
        indices = np.empty(0, np.int32)
        for fill in (False, True):
            tree_kernels.within(
                qx, qy, qz, *self._sorted_rows(), self.order, self.node_start,
                self.node_count, self.node_child, self.node_children, lo, hi,
                radius * radius, self._self_slots(exclude_self), exclude_self, fill,
                offsets, indices,
            )  # fmt: skip
            if not fill:
                np.cumsum(offsets, out=offsets)
                indices = np.empty(int(offsets[-1]), np.int32)
        return Neighbors(offsets, indices)
