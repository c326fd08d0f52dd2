"""An octree over points, built from Morton codes by a radix sort (for Barnes–Hut).

Construction (every pass compiled, none of them a Python loop over points):

1. **Bounding cube** of the points, padded so that no point lies on its far faces.
2. **Morton codes**: each coordinate quantised to 21 bits and the bits interleaved
   (x lowest), 63 bits per point (Morton 1966; as used for trees by Warren & Salmon 1993).
   Points close in space are close in this order.
3. **Radix sort** of the codes: stable least-significant-digit passes of 8 bits, each a
   counting sort (per-block histograms in parallel, one scan, a parallel scatter); passes
   whose digit is the same for every point are skipped. A stable sort has one result, so
   the order does not depend on the thread count.
4. **Nodes**, breadth first: a node is a run ``[start, start + count)`` of sorted points.
   A node of more than ``leaf_size`` points is split at the highest octal digit in which
   its first and last codes differ (all points share the digits above), into its
   non-empty octants. Runs of a single octant are skipped, so every internal node has at
   least two children and there are fewer than ``2 n`` nodes. Each node's cell is the
   Morton cell of the digits its points share: its edge is ``size`` and its centre
   ``center``. Children of a node are consecutive, found by binary search in the sorted
   codes; each level is split in parallel.

Points with identical codes (closer than ``edge / 2^21``) always share a leaf, which may
then hold more than ``leaf_size`` of them.
"""

from __future__ import annotations

import numba
import numpy as np

from .. import _validate
from .._jit import parallel_kernel, serial_kernel
from .morton import BITS, morton_codes, radix_sort
from .tree import SpatialTree


@numba.njit(inline="always")
def _cell_shift(first, last):
    """Bits below the Morton cell two codes share (a multiple of 3; 0 when equal)."""
    diff = first ^ last
    if diff == 0:
        return 0
    high = 63
    while (diff >> high) & 1 == 0:
        high -= 1
    return (high // 3 + 1) * 3


@numba.njit(inline="always")
def _lower_bound(codes, lo, hi, value):
    while lo < hi:
        mid = (lo + hi) >> 1
        if codes[mid] < value:
            lo = mid + 1
        else:
            hi = mid
    return lo


@parallel_kernel
def _split(codes, start, count, first, stop, leaf_size, bounds, children):
    """Children of nodes ``[first, stop)``: their run bounds and how many (0: a leaf)."""
    for k in numba.prange(first, stop):
        s = start[k]
        e = s + count[k]
        slot = k - first
        shift = _cell_shift(codes[s], codes[e - 1])
        if count[k] <= leaf_size or shift == 0:
            children[slot] = 0
            continue
        shift -= 3
        base = (codes[s] >> (shift + 3)) << (shift + 3)
        made = 0
        lo = s
        for digit in range(1, 9):
            hi = e if digit == 8 else _lower_bound(codes, lo, e, base + (digit << shift))
            if hi > lo:
                bounds[slot, made] = lo
                bounds[slot, made + 1] = hi
                made += 1
                lo = hi
        children[slot] = made


@serial_kernel
def _place(first, stop, bounds, children, next_free, start, count, child):
    """Append the children found by :func:`_split` (in node order); returns the new end."""
    free = next_free
    for k in range(first, stop):
        made = children[k - first]
        if made == 0:
            child[k] = -1
            continue
        child[k] = free
        for c in range(made):
            start[free + c] = bounds[k - first, c]
            count[free + c] = bounds[k - first, c + 1] - bounds[k - first, c]
        free += made
    return free


@parallel_kernel
def _cells(codes, start, count, origin, unit, center, size):
    """Centre and edge of every node's Morton cell."""
    for k in numba.prange(start.shape[0]):
        s = start[k]
        shift = _cell_shift(codes[s], codes[s + count[k] - 1])
        low = (codes[s] >> shift) << shift
        qx = np.int64(0)
        qy = np.int64(0)
        qz = np.int64(0)
        for b in range(BITS):
            qx |= ((low >> (3 * b)) & 1) << b
            qy |= ((low >> (3 * b + 1)) & 1) << b
            qz |= ((low >> (3 * b + 2)) & 1) << b
        edge = unit * (1 << (shift // 3))
        size[k] = edge
        center[0, k] = origin[0] + unit * qx + 0.5 * edge
        center[1, k] = origin[1] + unit * qy + 0.5 * edge
        center[2, k] = origin[2] + unit * qz + 0.5 * edge


class Octree(SpatialTree):
    """An octree over ``n`` points, nodes in breadth-first order (root 0).

    Parameters
    ----------
    leaf_size : int
        Nodes of at most this many points are leaves (>= 1).

    Attributes (after :meth:`build`)
    ----------------------------------
    order : int64 (n,)
        ``order[s]``: the point in sorted slot ``s`` (Morton order).
    codes : int64 (n,)
        Sorted Morton codes.
    node_start, node_count : int64 (nodes,)
        Each node's run of sorted slots.
    node_child : int64 (nodes,)
        First child (children are consecutive), -1 for a leaf.
    node_children : int64 (nodes,)
        Number of children (0 for a leaf).
    node_center : float64 (3, nodes)
        Centre of each node's cell [m].
    node_size : float64 (nodes,)
        Edge of each node's cell [m].
    level_start : int64 (levels + 1,)
        Nodes of breadth-first level ``L`` are ``[level_start[L], level_start[L + 1])``.
    origin : float64 (3,), edge : float
        The bounding cube [m].

    Examples
    --------
    >>> import numpy as np
    >>> points = np.random.default_rng(0).random((3, 1000))
    >>> tree = Octree(leaf_size=16).build(points)
    >>> int(tree.node_count[0]), bool((tree.node_count[tree.leaves()] <= 16).all())
    (1000, True)
    """

    def __init__(self, *, leaf_size: int = 32):
        self.leaf_size = _validate.integer("leaf_size", leaf_size, low=1)

    def build(self, positions) -> Octree:
        """Sort ``positions`` (shape (3, n) [m], n >= 1) into the tree; returns self."""
        pos = np.asarray(positions)
        if pos.ndim != 2 or pos.shape[0] != 3 or pos.shape[1] == 0:
            raise ValueError(f"positions must have shape (3, n) with n >= 1, got {pos.shape}")
        n = pos.shape[1]
        lo = pos.min(axis=1).astype(np.float64)
        hi = pos.max(axis=1).astype(np.float64)
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
            raise ValueError("positions must be finite (no NaN or inf)")
        edge = float((hi - lo).max())
        edge = edge * (1.0 + 1e-6) if edge > 0 else 1.0
        self.origin, self.edge = lo, edge
        unit = edge / (1 << BITS)
        codes = np.empty(n, np.int64)
        x, y, z = (np.ascontiguousarray(row) for row in pos)
        morton_codes(x, y, z, lo, 1.0 / unit, codes)
        self.codes, self.order = radix_sort(codes)
        #: The points in sorted order, shape (3, n), their dtype.
        self.sorted_points = pos[:, self.order]
        self._nodes(n, unit)
        self._built()
        return self

    def _nodes(self, n: int, unit: float) -> None:
        cap = 2 * n + 1
        start = np.zeros(cap, np.int64)
        count = np.zeros(cap, np.int64)
        child = np.full(cap, -1, np.int64)
        count[0] = n
        levels = [0]
        first, stop = 0, 1
        while stop > first:
            width = stop - first
            bounds = np.empty((width, 9), np.int64)
            children = np.empty(width, np.int64)
            _split(self.codes, start, count, first, stop, self.leaf_size, bounds, children)
            free = _place(first, stop, bounds, children, stop, start, count, child)
            first, stop = stop, free
            levels.append(first)
        self.node_start = start[:stop].copy()
        self.node_count = count[:stop].copy()
        self.node_child = child[:stop].copy()
        self.node_children = np.zeros(stop, np.int64)
        inner = self.node_child >= 0
        # Children of consecutive internal nodes are consecutive: the next one's first
        # child ends this node's run (the last internal node's run ends at the last node).
        firsts = self.node_child[inner]
        ends = np.append(firsts[1:], stop)
        self.node_children[inner] = ends - firsts
        self.level_start = np.array(levels, np.int64)
        self.node_center = np.empty((3, stop))
        self.node_size = np.empty(stop)
        _cells(
            self.codes, self.node_start, self.node_count, self.origin, unit,
            self.node_center, self.node_size,
        )  # fmt: skip
