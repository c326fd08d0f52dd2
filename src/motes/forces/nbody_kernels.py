r"""Kernels of the inverse-square pair forces: direct summation and Barnes–Hut.

Both add, for each target ``i``, the softened field of sources ``j`` with weights
``w_j`` (masses, charges):

.. math:: f_i \mathrel{+}= c \, p_i \sum_j w_j (x_j - x_i) / (|x_j - x_i|^2 + ε^2)^{3/2}

``c p_i`` scales it to a force (``G m_i`` for gravity, ``-k q_i`` for Coulomb's law). A
pair at distance 0 with ``ε = 0`` (a particle and itself) adds nothing.

**Tiles.** The sum over sources is a reduction, and a float reduction in a loop does not
vectorise without reassociation (``_jit.FASTMATH`` forbids it, for bit-stable results).
So a tile of ``TILE`` targets is held in small arrays and each source is applied to the
whole tile: the loop over the tile's targets carries no reduction and vectorises, and
each target's sum is taken over the sources in one fixed order (bit-identical for any
thread count). Tiles are padded with copies of their first target.

**Barnes–Hut** (Barnes & Hut 1986, Nature 324, 446) walks the octree once per group of
targets (a leaf of the tree, in tiles; Barnes 1990, J. Comput. Phys. 87, 161): a node is
accepted as one pseudo-particle when the distance from its centre of mass to the group's
bounding box exceeds ``size / θ + δ``, ``δ`` the offset of the centre of mass from the
cell's centre (the ``b_max`` criterion of Salmon & Warren 1994, J. Comput. Phys. 111,
136), and the node does not hold the group itself; else its children are visited, and
an opened leaf's points are summed directly. Accepted nodes add their monopole and,
optionally, their traceless quadrupole ``Q = Σ w (3 s sᵀ - |s|² I)`` about the centre
of mass, with the softened distance in place of ``r``:

.. math:: a = M d / r^3 - Q d / r^5 + \tfrac{5}{2} (dᵀ Q d) \, d / r^7

with ``d`` from the target to the centre of mass.
"""

from __future__ import annotations

import numba
import numpy as np

from .._jit import block_bounds, block_count, device, parallel_kernel

#: Targets per tile of direct summation.
TILE = 64
#: Targets per tile of a Barnes–Hut group (a leaf is walked in tiles of this many).
GROUP = 32
#: Depth of the walk's stack: a Morton octree has at most 21 levels of up to 8 children.
STACK = 8 * 22


@device
def _sources(tx, ty, tz, ax, ay, az, sx, sy, sz, sw, start, stop, eps2):
    """Add the field of sources ``[start, stop)`` to every target of a tile."""
    zero = tx.dtype.type(0)
    one = tx.dtype.type(1)
    for j in range(start, stop):
        xj = sx[j]
        yj = sy[j]
        zj = sz[j]
        wj = sw[j]
        for t in range(tx.shape[0]):
            dx = xj - tx[t]
            dy = yj - ty[t]
            dz = zj - tz[t]
            r2 = dx * dx + dy * dy + dz * dz + eps2
            inv = one / np.sqrt(r2) if r2 > zero else zero
            s = wj * (inv * inv * inv)
            ax[t] += s * dx
            ay[t] += s * dy
            az[t] += s * dz


@device
def _node(tx, ty, tz, ax, ay, az, cx, cy, cz, mass, q, eps2, quadrupole):
    """Add the monopole (and quadrupole ``q``: xx, yy, zz, xy, xz, yz) of one node."""
    one = tx.dtype.type(1)
    half5 = tx.dtype.type(2.5)
    qxx, qyy, qzz, qxy, qxz, qyz = q[0], q[1], q[2], q[3], q[4], q[5]
    for t in range(tx.shape[0]):
        dx = cx - tx[t]
        dy = cy - ty[t]
        dz = cz - tz[t]
        r2 = dx * dx + dy * dy + dz * dz + eps2
        inv = one / np.sqrt(r2)
        inv2 = inv * inv
        inv3 = inv * inv2
        s = mass * inv3
        if quadrupole:
            qx = qxx * dx + qxy * dy + qxz * dz
            qy = qxy * dx + qyy * dy + qyz * dz
            qz = qxz * dx + qyz * dy + qzz * dz
            inv5 = inv3 * inv2
            s += half5 * (dx * qx + dy * qy + dz * qz) * (inv5 * inv2)
            ax[t] += s * dx - inv5 * qx
            ay[t] += s * dy - inv5 * qy
            az[t] += s * dz - inv5 * qz
        else:
            ax[t] += s * dx
            ay[t] += s * dy
            az[t] += s * dz


@parallel_kernel
def direct_kernel(x, y, z, w, scale, coupling, eps2, out_x, out_y, out_z):
    """``out[:, i] += coupling scale_i Σ_j w_j (x_j - x_i) / (r² + ε²)^{3/2}`` (all j)."""
    n = x.shape[0]
    dtype = x.dtype
    for tile in numba.prange((n + TILE - 1) // TILE):
        first = tile * TILE
        live = min(TILE, n - first)
        tx = np.empty(TILE, dtype)
        ty = np.empty(TILE, dtype)
        tz = np.empty(TILE, dtype)
        for t in range(TILE):
            k = first + t if t < live else first
            tx[t] = x[k]
            ty[t] = y[k]
            tz[t] = z[k]
        ax = np.zeros(TILE, dtype)
        ay = np.zeros(TILE, dtype)
        az = np.zeros(TILE, dtype)
        _sources(tx, ty, tz, ax, ay, az, x, y, z, w, np.uint64(0), np.uint64(n), eps2)
        for t in range(live):
            c = coupling * scale[first + t]
            out_x[first + t] += c * ax[t]
            out_y[first + t] += c * ay[t]
            out_z[first + t] += c * az[t]


@parallel_kernel
def moments_kernel(
    first, stop, start, count, child, children, sx, sy, sz, sw, center, com, mass, quad
):
    """Weight, centre of weight and quadrupole of nodes ``[first, stop)`` (float64).

    Leaves sum their points; internal nodes combine their children's moments (already
    computed: levels are done deepest first), the quadrupoles by the parallel-axis rule
    ``Q = Σ_c Q_c + M_c (3 d dᵀ - |d|² I)``, ``d`` the child's offset. A node of zero
    weight keeps its cell centre as centre.
    """
    for k in numba.prange(first, stop):
        m = 0.0
        mx = 0.0
        my = 0.0
        mz = 0.0
        leaf = child[k] < 0
        if leaf:
            for j in range(start[k], start[k] + count[k]):
                wj = np.float64(sw[j])
                m += wj
                mx += wj * sx[j]
                my += wj * sy[j]
                mz += wj * sz[j]
        else:
            for c in range(child[k], child[k] + children[k]):
                m += mass[c]
                mx += mass[c] * com[0, c]
                my += mass[c] * com[1, c]
                mz += mass[c] * com[2, c]
        if m != 0.0:
            cx, cy, cz = mx / m, my / m, mz / m
        else:
            cx, cy, cz = center[0, k], center[1, k], center[2, k]
        mass[k] = m
        com[0, k] = cx
        com[1, k] = cy
        com[2, k] = cz
        qxx = qyy = qzz = qxy = qxz = qyz = 0.0
        if leaf:
            for j in range(start[k], start[k] + count[k]):
                wj = np.float64(sw[j])
                dx = sx[j] - cx
                dy = sy[j] - cy
                dz = sz[j] - cz
                d2 = dx * dx + dy * dy + dz * dz
                qxx += wj * (3.0 * dx * dx - d2)
                qyy += wj * (3.0 * dy * dy - d2)
                qzz += wj * (3.0 * dz * dz - d2)
                qxy += wj * 3.0 * dx * dy
                qxz += wj * 3.0 * dx * dz
                qyz += wj * 3.0 * dy * dz
        else:
            for c in range(child[k], child[k] + children[k]):
                wc = mass[c]
                dx = com[0, c] - cx
                dy = com[1, c] - cy
                dz = com[2, c] - cz
                d2 = dx * dx + dy * dy + dz * dz
                qxx += quad[0, c] + wc * (3.0 * dx * dx - d2)
                qyy += quad[1, c] + wc * (3.0 * dy * dy - d2)
                qzz += quad[2, c] + wc * (3.0 * dz * dz - d2)
                qxy += quad[3, c] + wc * 3.0 * dx * dy
                qxz += quad[4, c] + wc * 3.0 * dx * dz
                qyz += quad[5, c] + wc * 3.0 * dy * dz
        quad[0, k] = qxx
        quad[1, k] = qyy
        quad[2, k] = qzz
        quad[3, k] = qxy
        quad[4, k] = qxz
        quad[5, k] = qyz


@parallel_kernel
def barnes_hut_kernel(
    sx, sy, sz, sw, order, leaves, start, count, child, children,
    com, mass, quad, accept2, eps2, quadrupole, scale, coupling, out_x, out_y, out_z,
):  # fmt: skip
    """Barnes–Hut field on every sorted point, added to ``out`` at ``order[slot]``.

    ``sx, sy, sz, sw``: points and weights in Morton order; ``com`` (3, nodes), ``mass``,
    ``quad`` (6, nodes) in the points' precision; ``accept2``: squared acceptance
    distance ``(size / θ + δ)^2`` per node; ``scale``: per-point factor by original index.
    """
    dtype = sx.dtype
    zero = dtype.type(0)
    for g in numba.prange(leaves.shape[0]):
        leaf = leaves[g]
        tx = np.empty(GROUP, dtype)
        ty = np.empty(GROUP, dtype)
        tz = np.empty(GROUP, dtype)
        ax = np.empty(GROUP, dtype)
        ay = np.empty(GROUP, dtype)
        az = np.empty(GROUP, dtype)
        stack = np.empty(STACK, np.int64)
        q = np.empty(6, dtype)
        end = start[leaf] + count[leaf]
        for first in range(start[leaf], end, GROUP):
            live = min(GROUP, end - first)
            for t in range(GROUP):
                k = first + t if t < live else first
                tx[t] = sx[k]
                ty[t] = sy[k]
                tz[t] = sz[k]
                ax[t] = zero
                ay[t] = zero
                az[t] = zero
            lox, hix = tx.min(), tx.max()
            loy, hiy = ty.min(), ty.max()
            loz, hiz = tz.min(), tz.max()
            top = 1
            stack[0] = 0
            while top > 0:
                top -= 1
                k = stack[top]
                cx, cy, cz = com[0, k], com[1, k], com[2, k]
                dx = max(lox - cx, cx - hix, zero)
                dy = max(loy - cy, cy - hiy, zero)
                dz = max(loz - cz, cz - hiz, zero)
                inside = start[k] <= first < start[k] + count[k]
                if not inside and dx * dx + dy * dy + dz * dz > accept2[k]:
                    for c in range(6):
                        q[c] = quad[c, k]
                    _node(tx, ty, tz, ax, ay, az, cx, cy, cz, mass[k], q, eps2, quadrupole)
                elif child[k] < 0:
                    s = np.uint64(start[k])
                    _sources(tx, ty, tz, ax, ay, az, sx, sy, sz, sw, s, s + count[k], eps2)
                else:
                    for c in range(child[k] + children[k] - 1, child[k] - 1, -1):
                        stack[top] = c
                        top += 1
            for t in range(live):
                i = order[first + t]
                c = coupling * scale[i]
                out_x[i] += c * ax[t]
                out_y[i] += c * ay[t]
                out_z[i] += c * az[t]


@parallel_kernel
def gather_kernel(x, y, z, w, order, sx, sy, sz, sw):
    """Points and weights in sorted order: ``sx[s] = x[order[s]]``..."""
    n = order.shape[0]
    for block in numba.prange(block_count(n)):
        lo, hi = block_bounds(block, n)
        for s in range(lo, hi):
            i = order[s]
            sx[s] = x[i]
            sy[s] = y[i]
            sz[s] = z[i]
            sw[s] = w[i]
