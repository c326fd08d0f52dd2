"""Compiled queries shared by the spatial trees (:class:`~motes.spatial.Octree`,
:class:`~motes.spatial.KDTree`).

Both trees are stored the same way, so one set of kernels serves them:

- the points are sorted so that every node is a run of slots
  ``[start[node], start[node] + count[node])``, their coordinates ``sx, sy, sz`` in slot
  order and ``order[slot]`` the point's original index;
- nodes are numbered breadth first; the children of a node are ``children[node]``
  consecutive nodes from ``child[node]`` (``child`` is -1 for a leaf);
- every node has a tight axis-aligned box ``lo``/``hi`` (3, nodes) [m] around its points
  (:func:`node_boxes`), which prunes better than the node's cell.

Distances are compared in float64 as ``dx² + dy² + dz² <= r²`` (summed in that order, the
test ``scipy.spatial.cKDTree`` makes), so a pair exactly at the radius is found by both or
neither, and the k nearest are the same points.
"""

from __future__ import annotations

import numba
import numpy as np

from .._jit import block_bounds, block_count, device, parallel_kernel
from .kernels import offer_nearest

#: Deepest stack a query needs: a tree of 2^40 points with 8 children per level.
STACK = 8 * 48


@parallel_kernel
def node_boxes(sx, sy, sz, start, count, child, children, level_start, lo, hi):
    """Tight boxes of every node, deepest level first: a leaf's from its points, an
    internal node's from its children's (already computed one level down). An empty leaf
    (a k-d tree of fewer points than leaves) gets an empty box, ``lo = inf``."""
    for level in range(level_start.shape[0] - 2, -1, -1):
        first = level_start[level]
        width = level_start[level + 1] - first
        for t in numba.prange(width):
            node = first + t
            if child[node] < 0 and count[node] == 0:  # an empty leaf: a box nothing is in
                x0 = y0 = z0 = np.inf
                x1 = y1 = z1 = -np.inf
            elif child[node] < 0:
                s0 = start[node]
                x0 = x1 = np.float64(sx[s0])
                y0 = y1 = np.float64(sy[s0])
                z0 = z1 = np.float64(sz[s0])
                for s in range(s0 + 1, s0 + count[node]):
                    x0 = min(x0, sx[s])
                    x1 = max(x1, sx[s])
                    y0 = min(y0, sy[s])
                    y1 = max(y1, sy[s])
                    z0 = min(z0, sz[s])
                    z1 = max(z1, sz[s])
            else:
                c0 = child[node]
                x0, y0, z0 = lo[0, c0], lo[1, c0], lo[2, c0]
                x1, y1, z1 = hi[0, c0], hi[1, c0], hi[2, c0]
                for c in range(c0 + 1, c0 + children[node]):
                    x0 = min(x0, lo[0, c])
                    y0 = min(y0, lo[1, c])
                    z0 = min(z0, lo[2, c])
                    x1 = max(x1, hi[0, c])
                    y1 = max(y1, hi[1, c])
                    z1 = max(z1, hi[2, c])
            lo[0, node], lo[1, node], lo[2, node] = x0, y0, z0
            hi[0, node], hi[1, node], hi[2, node] = x1, y1, z1


@device
def box_distance2(px, py, pz, lo, hi, node):
    """Squared distance [m²] from a point to a node's box (0 inside it)."""
    dx = max(lo[0, node] - px, px - hi[0, node], 0.0)
    dy = max(lo[1, node] - py, py - hi[1, node], 0.0)
    dz = max(lo[2, node] - pz, pz - hi[2, node], 0.0)
    return dx * dx + dy * dy + dz * dz


@parallel_kernel
def knn(
    qx, qy, qz, queries, sx, sy, sz, order, start, count, child, children, lo, hi,
    self_slot, exclude_self, out_d2, out_index,
):  # fmt: skip
    """The ``k`` nearest points of each query, nearest first (``k = out_d2.shape[1]``).

    Best-first descent with a sorted list of the ``k`` nearest so far: a node is skipped
    when its box is farther than the current ``k``-th distance, and children are visited
    nearest box first. ``queries`` is the order to visit the queries in (nearby queries in
    a row descend the same branches). With ``exclude_self`` query ``i`` skips slot
    ``self_slot[i]``. Ties keep the point met first.
    """
    m = qx.shape[0]
    k = out_d2.shape[1]
    for block in numba.prange(block_count(m)):
        first, stop = block_bounds(block, m)
        stack = np.empty(STACK, np.int64)
        near = np.empty(8)
        kids = np.empty(8, np.int64)
        best = np.empty(k)
        slot = np.empty(k, np.int64)
        for t in range(first, stop):
            i = queries[t]
            px, py, pz = np.float64(qx[i]), np.float64(qy[i]), np.float64(qz[i])
            own = self_slot[i] if exclude_self else -1
            for j in range(k):
                best[j] = np.inf
                slot[j] = -1
            top = 1
            stack[0] = 0
            while top > 0:
                top -= 1
                node = stack[top]
                if box_distance2(px, py, pz, lo, hi, node) > best[k - 1]:
                    continue
                if child[node] < 0:
                    first_slot = start[node]
                    offer_nearest(sx, sy, sz, px, py, pz, first_slot, first_slot + count[node],
                                  own, best, slot)  # fmt: skip
                    continue
                # Push the children farthest first, so that the nearest is taken next.
                n_kids = children[node]
                for c in range(n_kids):
                    kid = child[node] + c
                    d = box_distance2(px, py, pz, lo, hi, kid)
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


@parallel_kernel
def within(
    qx, qy, qz, sx, sy, sz, order, start, count, child, children, lo, hi, r2,
    self_slot, exclude_self, fill, offsets, out,
):  # fmt: skip
    """Points within ``sqrt(r2)`` of each query, in two passes straight into CSR form.

    With ``fill`` False, query ``q`` writes its number of neighbours to
    ``offsets[q + 1]`` (the caller then takes the running sum); with ``fill`` True it
    writes its neighbours' point indices to ``out[offsets[q]:offsets[q + 1]]``, in the
    order it meets them (nodes depth first, slots in order). Two traversals rather than
    a fixed-capacity buffer: the middle of a cluster can have a thousand times the
    neighbours of its halo, and a buffer as wide as the busiest row would hold
    ``n × that`` entries. With ``exclude_self`` query ``q`` skips slot ``self_slot[q]``.
    """
    m = qx.shape[0]
    for block in numba.prange(block_count(m)):
        first, stop = block_bounds(block, m)
        stack = np.empty(STACK, np.int64)
        for q in range(first, stop):
            px, py, pz = np.float64(qx[q]), np.float64(qy[q]), np.float64(qz[q])
            own = self_slot[q] if exclude_self else -1
            base = offsets[q] if fill else 0
            found = np.int64(0)
            top = 1
            stack[0] = 0
            while top > 0:
                top -= 1
                node = stack[top]
                if box_distance2(px, py, pz, lo, hi, node) > r2:
                    continue
                if child[node] < 0:
                    for s in range(start[node], start[node] + count[node]):
                        dx = np.float64(sx[s]) - px
                        dy = np.float64(sy[s]) - py
                        dz = np.float64(sz[s]) - pz
                        if dx * dx + dy * dy + dz * dz <= r2 and s != own:
                            if fill:
                                out[base + found] = order[s]
                            found += 1
                    continue
                # Last child pushed first: children are then visited in order.
                for c in range(children[node] - 1, -1, -1):
                    stack[top] = child[node] + c
                    top += 1
            if not fill:
                offsets[q + 1] = found
