"""A k-d tree (a binary space partition) over points, built by median splits.

Construction (Bentley 1975; Friedman, Bentley & Finkel 1977), every pass compiled:

1. The tree's shape follows from ``n`` alone: every leaf sits at depth ``D``, the least
   depth whose leaves hold at most ``leaf_size`` points, and a node of ``c`` points hands
   ``c // 2`` to its first child and the rest to the second. Nodes are numbered as a
   heap (children of ``i`` are ``2i + 1`` and ``2i + 2``), which is breadth first.
2. Level by level, every node of the level in parallel: the axis along which its points
   spread most is chosen, and a quickselect (Hoare 1961, median-of-three pivot) puts its
   median point in place, the lesser coordinates before it and the greater after it. The
   coordinates move with the point indices, so the sorted coordinates are a by-product.

Unlike the octree's cells, a median split adapts to any distribution: the leaves hold
the same number of points in a dense cluster and in its sparse halo, and the depth is
``log2(n / leaf_size)`` whatever the clustering. Queries (radius, k nearest, pairs) are
those every :class:`~motes.spatial.tree.SpatialTree` answers, on tight node boxes.
"""

from __future__ import annotations

import numba
import numpy as np

from .. import _validate
from .._jit import device, parallel_kernel
from .neighbors import points_rows
from .tree import SpatialTree


@device
def _swap(key, a, b, order, i, j):
    key[i], key[j] = key[j], key[i]
    a[i], a[j] = a[j], a[i]
    b[i], b[j] = b[j], b[i]
    order[i], order[j] = order[j], order[i]


@device
def _select(key, a, b, order, lo, hi, kth):
    """Rearrange slots ``[lo, hi]`` so that slot ``kth`` holds the point it would hold
    sorted by ``key``, with no greater key before it and no lesser after; ``a``, ``b``
    (the other coordinates) and ``order`` move with it."""
    while hi > lo:
        x, y, z = key[lo], key[(lo + hi) // 2], key[hi]
        pivot = max(min(x, y), min(max(x, y), z))  # the median of the three
        i, j = lo, hi
        while i <= j:
            while key[i] < pivot:
                i += 1
            while key[j] > pivot:
                j -= 1
            if i <= j:
                _swap(key, a, b, order, i, j)
                i += 1
                j -= 1
        # Now [lo, j] <= pivot, [i, hi] >= pivot, and anything between equals it.
        if kth <= j:
            hi = j
        elif kth >= i:
            lo = i
        else:
            return


@parallel_kernel
def _split_level(sx, sy, sz, order, start, count, first, width):
    """Median split of nodes ``[first, first + width)`` along their widest axis."""
    for t in numba.prange(width):
        node = first + t
        s0 = start[node]
        c = count[node]
        if c < 2:
            continue
        x0 = x1 = sx[s0]
        y0 = y1 = sy[s0]
        z0 = z1 = sz[s0]
        for s in range(s0 + 1, s0 + c):
            x0 = min(x0, sx[s])
            x1 = max(x1, sx[s])
            y0 = min(y0, sy[s])
            y1 = max(y1, sy[s])
            z0 = min(z0, sz[s])
            z1 = max(z1, sz[s])
        ex, ey, ez = x1 - x0, y1 - y0, z1 - z0
        last, kth = s0 + c - 1, s0 + c // 2
        # The key array passed first, so the selection's inner loops read one array.
        if ex >= ey and ex >= ez:
            _select(sx, sy, sz, order, s0, last, kth)
        elif ey >= ez:
            _select(sy, sx, sz, order, s0, last, kth)
        else:
            _select(sz, sx, sy, order, s0, last, kth)


class KDTree(SpatialTree):
    """A balanced k-d tree over ``n`` points (a binary space partition).

    Parameters
    ----------
    leaf_size : int
        Leaves hold at most this many points (>= 1); every leaf is at the same depth.

    Attributes (after :meth:`build`)
    ----------------------------------
    order : int64 (n,)
        ``order[s]``: the point in sorted slot ``s``.
    sorted_points : float64 (3, n)
        The points in slot order [m].
    node_start, node_count : int64 (nodes,)
        Each node's run of slots.
    node_child : int64 (nodes,)
        First child ``2i + 1``, or -1 for a leaf.
    node_children : int64 (nodes,)
        2, or 0 for a leaf.
    level_start : int64 (levels + 1,)
        Depth ``L`` is nodes ``[2^L - 1, 2^(L+1) - 1)``.

    Examples
    --------
    >>> import numpy as np
    >>> points = np.random.default_rng(0).random((3, 1000))
    >>> tree = KDTree(leaf_size=16).build(points)
    >>> distance, index = tree.knn(points[:, :2], 3)
    >>> index[:, 0].tolist()
    [0, 1]
    """

    def __init__(self, *, leaf_size: int = 16):
        self.leaf_size = _validate.integer("leaf_size", leaf_size, low=1)

    def build(self, positions) -> KDTree:
        """Sort ``positions`` (shape (3, n) [m], n >= 1) into the tree; returns self."""
        pos = points_rows("positions", positions)
        n = pos.shape[1]
        if n == 0:
            raise ValueError("positions must hold at least one point, got shape (3, 0)")
        depth = 0
        while -(-n // (1 << depth)) > self.leaf_size:
            depth += 1
        nodes = (1 << (depth + 1)) - 1
        start = np.zeros(nodes, np.int64)
        count = np.zeros(nodes, np.int64)
        count[0] = n
        for level in range(depth):  # each node hands c // 2 to its first child
            parents = np.arange((1 << level) - 1, (1 << (level + 1)) - 1)
            half = count[parents] // 2
            start[2 * parents + 1], count[2 * parents + 1] = start[parents], half
            start[2 * parents + 2] = start[parents] + half
            count[2 * parents + 2] = count[parents] - half
        sx, sy, sz = (np.array(row, dtype=np.float64) for row in pos)
        order = np.arange(n, dtype=np.int64)
        for level in range(depth):
            first = (1 << level) - 1
            _split_level(sx, sy, sz, order, start, count, first, 1 << level)
        self.order = order
        self.sorted_points = np.stack([sx, sy, sz])
        self.node_start, self.node_count = start, count
        inner = np.arange(nodes) < (1 << depth) - 1
        self.node_child = np.where(inner, 2 * np.arange(nodes) + 1, -1).astype(np.int64)
        self.node_children = np.where(inner, 2, 0).astype(np.int64)
        self.level_start = (1 << np.arange(depth + 2, dtype=np.int64)) - 1
        self._built()
        self._rows = (sx, sy, sz)
        return self

    @property
    def depth(self) -> int:
        """Depth of the leaves (0: the root is the only node)."""
        return self.level_start.shape[0] - 2

    def __repr__(self) -> str:
        return f"KDTree({self.count} points, depth {self.depth}, leaf_size={self.leaf_size})"
