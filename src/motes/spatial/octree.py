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
from .._jit import block_bounds, block_count, parallel_kernel, serial_kernel

#: Bits per coordinate in a Morton code (3 x 21 = 63 bits: a positive int64).
BITS = 21
#: Keys per block of the radix sort's histograms and scatter.
SORT_BLOCK = 1 << 16
_RADIX = 8
_DIGITS = 1 << _RADIX


@numba.njit(inline="always")
def _spread(v):
    """The 21 low bits of ``v`` moved to bits 0, 3, 6, ... 60."""
    v &= 0x1FFFFF
    v = (v | (v << 32)) & 0x1F00000000FFFF
    v = (v | (v << 16)) & 0x1F0000FF0000FF
    v = (v | (v << 8)) & 0x100F00F00F00F00F
    v = (v | (v << 4)) & 0x10C30C30C30C30C3
    v = (v | (v << 2)) & 0x1249249249249249
    return v


@parallel_kernel
def morton_codes(x, y, z, origin, scale, out):
    """``out[i]``: Morton code of point ``i`` quantised as ``(p - origin) * scale``.

    ``scale`` maps the bounding cube onto ``[0, 2^21)``; coordinates are clamped into it.
    """
    n = x.shape[0]
    top = (1 << BITS) - 1
    for i in numba.prange(n):
        qx = min(max(np.int64((x[i] - origin[0]) * scale), 0), top)
        qy = min(max(np.int64((y[i] - origin[1]) * scale), 0), top)
        qz = min(max(np.int64((z[i] - origin[2]) * scale), 0), top)
        out[i] = _spread(qx) | (_spread(qy) << 1) | (_spread(qz) << 2)


@parallel_kernel
def _histograms(keys, shift, counts):
    n = keys.shape[0]
    for block in numba.prange(counts.shape[0]):
        row = counts[block]
        row[:] = 0
        for i in range(block * SORT_BLOCK, min(n, (block + 1) * SORT_BLOCK)):
            row[(keys[i] >> shift) & (_DIGITS - 1)] += 1


@serial_kernel
def _offsets(counts, n):
    """Exclusive scan, digit-major then block; returns whether the pass can be skipped."""
    total = 0
    for d in range(_DIGITS):
        for block in range(counts.shape[0]):
            c = counts[block, d]
            counts[block, d] = total
            total += c
            if c == n:
                return True
    return False


@parallel_kernel
def _scatter(keys, index, shift, offsets, keys_out, index_out):
    n = keys.shape[0]
    for block in numba.prange(offsets.shape[0]):
        row = offsets[block]
        for i in range(block * SORT_BLOCK, min(n, (block + 1) * SORT_BLOCK)):
            d = (keys[i] >> shift) & (_DIGITS - 1)
            slot = row[d]
            row[d] = slot + 1
            keys_out[slot] = keys[i]
            index_out[slot] = index[i]


def radix_sort(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Stable sort of non-negative int64 ``keys`` (n,): ``(sorted keys, order)``.

    ``order[s]`` is the index of the key in slot ``s`` (int64).
    """
    n = keys.shape[0]
    keys = np.array(keys, dtype=np.int64)  # a copy: the passes reuse it
    index = np.arange(n, dtype=np.int64)
    if n < 2:
        return keys, index
    counts = np.empty(((n + SORT_BLOCK - 1) // SORT_BLOCK, _DIGITS), np.int64)
    keys_out, index_out = np.empty_like(keys), np.empty_like(index)
    top = int(keys.max()).bit_length()
    for shift in range(0, top, _RADIX):
        _histograms(keys, shift, counts)
        if _offsets(counts, n):
            continue
        _scatter(keys, index, shift, counts, keys_out, index_out)
        keys, keys_out = keys_out, keys
        index, index_out = index_out, index
    return keys, index


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


class Octree:
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

    @property
    def count(self) -> int:
        """Number of points."""
        return int(self.node_count[0])

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
            Indices of the neighbours among the points given to :meth:`build`.
        """
        q = np.asarray(points)
        if q.ndim != 2 or q.shape[0] != 3:
            raise ValueError(f"points must have shape (3, m), got {q.shape}")
        most = self.count - (1 if exclude_self else 0)
        k = _validate.integer("k", k, low=1)
        if k > most:
            raise ValueError(f"k must be <= {most} (the points available), got {k}")
        if exclude_self and q.shape[1] != self.count:
            raise ValueError("exclude_self needs the tree's own points as the queries")
        qx, qy, qz = (np.ascontiguousarray(r, dtype=np.float64) for r in q)
        sx, sy, sz = (np.ascontiguousarray(r, dtype=np.float64) for r in self.sorted_points)
        slot_of = np.empty(self.count, np.int64)
        slot_of[self.order] = np.arange(self.count)
        self_slot = slot_of if exclude_self else np.full(1, -1, np.int64)
        distance = np.empty((q.shape[1], k))
        index = np.empty((q.shape[1], k), np.int64)
        slack = self.edge / (1 << BITS)
        # Queries in Morton order: consecutive queries descend the same branches.
        codes = np.empty(q.shape[1], np.int64)
        morton_codes(qx, qy, qz, self.origin, 1.0 / slack, codes)
        queries = radix_sort(codes)[1]
        _knn_kernel(
            qx, qy, qz, queries, sx, sy, sz, self.order, self.node_start, self.node_count,
            self.node_child, self.node_children, self.node_center, self.node_size / 2 + slack,
            self_slot, exclude_self, distance, index,
        )  # fmt: skip
        np.sqrt(distance, out=distance)
        return distance, index

    def leaves(self) -> np.ndarray:
        """Indices of the leaf nodes, in breadth-first order (int64)."""
        return np.flatnonzero(self.node_child < 0)


@numba.njit(inline="always")
def _box_distance2(px, py, pz, center, half, k):
    dx = max(abs(px - center[0, k]) - half[k], 0.0)
    dy = max(abs(py - center[1, k]) - half[k], 0.0)
    dz = max(abs(pz - center[2, k]) - half[k], 0.0)
    return dx * dx + dy * dy + dz * dz


@parallel_kernel
def _knn_kernel(
    qx, qy, qz, queries, sx, sy, sz, order, start, count, child, children, center, half,
    self_slot, exclude_self, out_d2, out_index,
):  # fmt: skip
    """Best-first descent with a sorted list of the ``k`` nearest so far.

    A node is skipped when its cell (grown by the codes' quantum) is farther than the
    current ``k``-th distance; children are visited nearest cell first. Squared
    distances in float64; ties keep the point met first.
    """
    m = qx.shape[0]
    k = out_d2.shape[1]
    for block in numba.prange(block_count(m)):
        lo, hi = block_bounds(block, m)
        stack = np.empty(8 * 22, np.int64)
        near = np.empty(8)
        kids = np.empty(8, np.int64)
        best = np.empty(k)
        slot = np.empty(k, np.int64)
        for t in range(lo, hi):
            i = queries[t]
            px, py, pz = qx[i], qy[i], qz[i]
            own = self_slot[i] if exclude_self else -1
            for j in range(k):
                best[j] = np.inf
                slot[j] = -1
            top = 1
            stack[0] = 0
            while top > 0:
                top -= 1
                node = stack[top]
                if _box_distance2(px, py, pz, center, half, node) > best[k - 1]:
                    continue
                if child[node] < 0:
                    for s in range(start[node], start[node] + count[node]):
                        if s == own:
                            continue
                        dx = sx[s] - px
                        dy = sy[s] - py
                        dz = sz[s] - pz
                        d2 = dx * dx + dy * dy + dz * dz
                        if d2 < best[k - 1]:
                            j = k - 1
                            while j > 0 and best[j - 1] > d2:
                                best[j] = best[j - 1]
                                slot[j] = slot[j - 1]
                                j -= 1
                            best[j] = d2
                            slot[j] = s
                    continue
                # Push the children farthest first, so the nearest is taken next.
                n_kids = children[node]
                for c in range(n_kids):
                    kid = child[node] + c
                    d = _box_distance2(px, py, pz, center, half, kid)
                    j = c
                    while j > 0 and near[j - 1] < d:
                        near[j] = near[j - 1]
                        kids[j] = kids[j - 1]
                        j -= 1
                    near[j] = d
                    kids[j] = kid
                for c in range(n_kids):
                    stack[top] = kids[c]
                    top += 1
            for j in range(k):
                out_d2[i, j] = best[j]
                out_index[i, j] = order[slot[j]]
