r"""Compiled pieces of the aggregation multigrid preconditioner (:mod:`.multigrid`).

Level 0 is the implicit system ``A`` itself, in the form of
:mod:`~motes.integrate.implicit_kernels`: a diagonal block per particle, the springs'
blocks ``-C_k = -(α I + β u uᵀ)`` (read row by row from ``row_coef``, the springs' five
numbers copied once per step into each particle's entries, sorted by the other end), and
other forces' blocks in block-CSR form. The coarse levels are block-CSR matrices, all
levels in one set of arrays with a global node numbering: level ``l``'s nodes are
``level_start[l]:level_start[l + 1]``, node ``p``'s off-diagonal blocks
``coff[crow_ptr[p]:crow_ptr[p + 1]]`` at columns ``ccols`` (global numbers).

Constraints (Baraff & Witkin's filter ``S``): the preconditioner works on
``Ã = S A S + (I - S)``, whose diagonal blocks it inverts as ``G_i = Ã_ii⁻¹ S_i``
(``gdiag``; ``A_ii⁻¹`` for a free particle; symmetric, kept as its upper triangle in
float32). A constrained particle (``held``) takes no coarse correction and gives no
residual to the coarse levels, so the coarse matrices are Galerkin products ``Pᵀ Ã P``
over free particles only.

Everything here is serial: it runs inside the serial conjugate gradient loop.
"""

from __future__ import annotations

import numpy as np

from .._jit import called, device, serial_kernel
from .blocks import apply, inverse3, spring_apply

#: Symmetric Gauss-Seidel sweep pairs on the coarsest level: a few nodes (or, where
#: coarsening stalls, unconnected ones, which one sweep solves exactly).
COARSEST_SWEEPS = 4

#: Cycles that solve each coarse level (2: a W-cycle; see :func:`coarse_solve`).
COARSE_CYCLES = 2

#: Scale of the coarse correction on level 0. A piecewise constant interpolation moves an
#: aggregate as one and misses the energy of its smooth bending, so the plain correction
#: falls short; scaling it (Blaheta 1986's over-correction, safe below 2) took 64×64 and
#: 128×128 cloths from 9.7 and 12.3 iterations to 9.1 and 11.2 at a 1e-3 tolerance.
CORRECTION = 1.5


@serial_kernel
def aggregate_kernel(indptr, indices, agg):
    """Greedy aggregation of a graph (Vaněk, Mandel & Brezina 1996, §5), in node order.

    ``indptr``, ``indices``: the graph in CSR form (symmetric, no self loops). Writes
    ``agg[i]``, the aggregate of node ``i``, and returns the number of aggregates.

    1. A node whose neighbours are all free seeds an aggregate of itself and them.
    2. A node left over joins the aggregate of a neighbour seeded in pass 1.
    3. Nodes still left seed aggregates of themselves and their free neighbours.
    """
    n = agg.shape[0]
    for i in range(n):
        agg[i] = -1
    count = 0
    for i in range(n):
        if agg[i] >= 0:
            continue
        alone = True
        for p in range(indptr[i], indptr[i + 1]):
            if agg[indices[p]] >= 0:
                alone = False
                break
        if not alone:
            continue
        agg[i] = count
        for p in range(indptr[i], indptr[i + 1]):
            agg[indices[p]] = count
        count += 1
    seeded = agg.copy()
    for i in range(n):
        if agg[i] >= 0:
            continue
        for p in range(indptr[i], indptr[i + 1]):
            if seeded[indices[p]] >= 0:
                agg[i] = seeded[indices[p]]
                break
    for i in range(n):
        if agg[i] >= 0:
            continue
        agg[i] = count
        for p in range(indptr[i], indptr[i + 1]):
            if agg[indices[p]] < 0:
                agg[indices[p]] = count
        count += 1
    return count


@device
def _fill(a, lo, hi, value):
    """``a[lo:hi] = value`` for ``(n, 3)`` rows, as a loop: a slice assignment compiles
    shape checks and their error messages (seconds per kernel, for nothing)."""
    for p in range(lo, hi):
        a[p, 0] = value
        a[p, 1] = value
        a[p, 2] = value


@device
def _copy(source, target, lo, hi):
    """``target[lo:hi] = source[lo:hi]`` for ``(n, 3)`` rows (see :func:`_fill`)."""
    for p in range(lo, hi):
        target[p, 0] = source[p, 0]
        target[p, 1] = source[p, 1]
        target[p, 2] = source[p, 2]


@device
def _add_symmetric(out, p, sign, xx, xy, xz, yy, yz, zz):
    """``out[p] += sign`` times the symmetric 3×3 block of the six given entries."""
    out[p, 0] += sign * xx
    out[p, 1] += sign * xy
    out[p, 2] += sign * xz
    out[p, 3] += sign * xy
    out[p, 4] += sign * yy
    out[p, 5] += sign * yz
    out[p, 6] += sign * xz
    out[p, 7] += sign * yz
    out[p, 8] += sign * zz


@device
def _add_block(out, p, source, s):
    for c in range(9):
        out[p, c] += source[s, c]


@device
def _invert_or_zero(m, out, p):
    """``out[p]`` = inverse of the 3×3 ``m[p]``; zero where ``m[p]`` is zero (a coarse
    node made of constrained particles only, which never receives a residual). Coarse
    diagonal blocks are sums of positive semi-definite blocks: a zero trace means zero."""
    if m[p, 0] + m[p, 4] + m[p, 8] == 0.0:
        for c in range(9):
            out[p, c] = 0.0
    else:
        inverse3(m[p], out, p)


@device
def _product3(a, b, out):
    """``out = a b`` for row-major 3×3 ``a``, ``b`` (flat arrays of 9)."""
    for r in range(3):
        for c in range(3):
            out[3 * r + c] = a[3 * r] * b[c] + a[3 * r + 1] * b[3 + c] + a[3 * r + 2] * b[6 + c]


@device
def _store_symmetric(out, i, xx, xy, xz, yy, yz, zz):
    """``out[i]`` = the upper triangle of a symmetric 3×3 block, as float32."""
    out[i, 0] = xx
    out[i, 1] = xy
    out[i, 2] = xz
    out[i, 3] = yy
    out[i, 4] = yz
    out[i, 5] = zz


@device
def _apply_symmetric(g, i, vx, vy, vz):
    """The symmetric block ``g[i]`` (upper triangle, see :func:`_store_symmetric`) times
    (vx, vy, vz)."""
    xx = np.float64(g[i, 0])
    xy = np.float64(g[i, 1])
    xz = np.float64(g[i, 2])
    yy = np.float64(g[i, 3])
    yz = np.float64(g[i, 4])
    zz = np.float64(g[i, 5])
    return (
        xx * vx + xy * vy + xz * vz,
        xy * vx + yy * vy + yz * vz,
        xz * vx + yz * vy + zz * vz,
    )


@device
def _filtered_inverse(filt, diag, i, gdiag, m, t):
    """``gdiag[i] = Ã_ii⁻¹ S_i`` with ``Ã_ii = S_i A_ii S_i + (I - S_i)``: it inverts
    ``S A S`` on ``S``'s range and maps the constrained directions to 0. ``m`` and ``t``
    are scratch of 9."""
    s = filt[i]
    _product3(s, diag[i], t)
    _product3(t, s, m)
    for c in range(9):
        m[c] -= s[c]
    m[0] += 1.0
    m[4] += 1.0
    m[8] += 1.0
    inverse3(m, t.reshape((1, 9)), 0)
    _product3(t, s, m)
    _store_symmetric(gdiag, i, m[0], m[1], m[2], m[4], m[5], m[8])


@serial_kernel
def galerkin_kernel(
    filt,
    inv_diag,
    gdiag,
    diag,
    off,
    row_ptr,
    cols,
    pairs,
    coef,
    held,
    agg,
    spring_slot,
    off_slot,
    level_start,
    crow_ptr,
    cagg,
    cslot,
    entry_spring,
    row_coef,
    cdiag,
    coff,
    cinv,
):
    """This step's level-0 rows and coarse matrices ``Pᵀ Ã P`` (piecewise constant ``P``).

    Level 0's spring entries, row by row, take their springs' five numbers
    (``row_coef[e] = coef[entry_spring[e]]``, float32: the preconditioner needs no more,
    and the sweeps then read half the bytes).

    With ``P`` summing each aggregate, a coarse block is the sum of the fine blocks
    between the two aggregates: an aggregate's diagonal block gathers its particles'
    diagonal blocks and the blocks between them (a spring inside an aggregate adds
    ``-2 C_k``), and a block between two aggregates lands in the coarse entry listed for
    it (``spring_slot`` (m, 2) for both directions of a spring, ``off_slot`` for the fine
    block-CSR entries, ``cslot`` for a coarse level's entries in the next; -1: inside an
    aggregate). Blocks touching a constrained particle are left out (Galerkin over free
    particles). Also inverts every coarse diagonal block, and writes level 0's
    ``G_i = Ã_ii⁻¹ S_i`` (``inv_diag[i]`` where free).
    """
    m = np.empty(9)
    t = np.empty(9)
    for i in range(diag.shape[0]):
        if held[i]:
            _filtered_inverse(filt, diag, i, gdiag, m, t)
        else:
            g = inv_diag[i]
            _store_symmetric(gdiag, i, g[0], g[1], g[2], g[4], g[5], g[8])
    for e in range(entry_spring.shape[0]):
        k = entry_spring[e]
        for c in range(5):
            row_coef[e, c] = coef[k, c]
    levels = level_start.shape[0] - 1
    if levels == 0:
        return
    n = diag.shape[0]
    cdiag[:] = 0.0
    coff[:] = 0.0
    for i in range(n):
        if not held[i]:
            _add_block(cdiag, agg[i], diag, i)
    for k in range(pairs.shape[0]):
        if held[pairs[k, 0]] or held[pairs[k, 1]]:
            continue
        alpha = coef[k, 0]
        beta = coef[k, 1]
        ux = coef[k, 2]
        uy = coef[k, 3]
        uz = coef[k, 4]
        xx = alpha + beta * ux * ux
        xy = beta * ux * uy
        xz = beta * ux * uz
        yy = alpha + beta * uy * uy
        yz = beta * uy * uz
        zz = alpha + beta * uz * uz
        s = spring_slot[k, 0]
        if s < 0:
            _add_symmetric(cdiag, agg[pairs[k, 0]], -2.0, xx, xy, xz, yy, yz, zz)
        else:
            _add_symmetric(coff, s, -1.0, xx, xy, xz, yy, yz, zz)
            _add_symmetric(coff, spring_slot[k, 1], -1.0, xx, xy, xz, yy, yz, zz)
    for i in range(n):
        if held[i]:
            continue
        for slot in range(row_ptr[i], row_ptr[i + 1]):
            if held[cols[slot]]:
                continue
            s = off_slot[slot]
            if s < 0:
                _add_block(cdiag, agg[i], off, slot)
            else:
                _add_block(coff, s, off, slot)
    for level in range(levels - 1):
        for p in range(level_start[level], level_start[level + 1]):
            parent = cagg[p]
            _add_block(cdiag, parent, cdiag, p)
            for e in range(crow_ptr[p], crow_ptr[p + 1]):
                s = cslot[e]
                if s < 0:
                    _add_block(cdiag, parent, coff, e)
                else:
                    _add_block(coff, s, coff, e)
    for p in range(cdiag.shape[0]):
        _invert_or_zero(cdiag, cinv, p)


@device
def _fine_rest(i, lo, hi, part, row_other, row_coef, row_ptr, cols, off, x):
    """``-Σ_j A_ij x_j`` on level 0 over the springs' entries ``lo:hi`` of particle ``i``
    (blocks ``-C_k``) and its block-CSR entries: all of them (``part`` 0), those with
    ``j < i`` (1) or ``j > i`` (2)."""
    sx = 0.0
    sy = 0.0
    sz = 0.0
    for e in range(lo, hi):
        cx, cy, cz = spring_apply(row_coef, e, x, row_other[e])
        sx += cx
        sy += cy
        sz += cz
    for slot in range(row_ptr[i], row_ptr[i + 1]):
        j = cols[slot]
        if (part == 1 and j > i) or (part == 2 and j < i):
            continue
        ax, ay, az = apply(off, slot, x[j, 0], x[j, 1], x[j, 2])
        sx -= ax
        sy -= ay
        sz -= az
    return sx, sy, sz


@device
def _coarse_rest(p, crow_ptr, ccols, coff, x):
    """``-Σ_{q≠p} A_pq x_q`` on a coarse level."""
    sx = 0.0
    sy = 0.0
    sz = 0.0
    for e in range(crow_ptr[p], crow_ptr[p + 1]):
        q = ccols[e]
        ax, ay, az = apply(coff, e, x[q, 0], x[q, 1], x[q, 2])
        sx -= ax
        sy -= ay
        sz -= az
    return sx, sy, sz


@called
def fine_sweep(backward, part, fine, r, x):
    """One block Gauss-Seidel sweep on level 0 (``fine``: see :func:`vcycle`), in particle
    order or its reverse: ``x_i = G_i (r_i - Σ_{j≠i} A_ij x_j)``, over all of a row's
    entries (``part`` 0) or those with ``j < i`` (1: a forward sweep from ``x = 0``, where
    the others are 0)."""
    entry_ptr, row_mid, row_other, row_coef, row_ptr, cols, off, gdiag, _, _ = fine
    n = r.shape[0]
    for t in range(n):
        i = n - 1 - t if backward else t
        stop = row_mid[i] if part == 1 else entry_ptr[i + 1]
        sx, sy, sz = _fine_rest(
            i, entry_ptr[i], stop, part, row_other, row_coef, row_ptr, cols, off, x
        )
        x[i, 0], x[i, 1], x[i, 2] = _apply_symmetric(
            gdiag, i, r[i, 0] + sx, r[i, 1] + sy, r[i, 2] + sz
        )


@called
def fine_down(fine, r, x, crhs):
    """The forward sweep from ``x = 0`` and the residual ``r - A x`` summed into the
    aggregates' right-hand sides ``crhs``.

    From zero, row ``i`` needs only its entries ``j < i`` (``entry_ptr[i]:row_mid[i]``:
    the others are still 0), and after the sweep a free particle's residual is
    ``-Σ_{j>i} A_ij x_j``: its other entries cancel by the sweep's own equation. So the
    two take one pass over the entries between them, not two.
    """
    entry_ptr, row_mid, row_other, row_coef, row_ptr, cols, off, _, held, agg = fine
    n = r.shape[0]
    _fill(x, 0, x.shape[0], 0.0)
    fine_sweep(False, 1, fine, r, x)
    for i in range(n):
        if held[i]:
            continue
        sx, sy, sz = _fine_rest(
            i, row_mid[i], entry_ptr[i + 1], 2, row_other, row_coef, row_ptr, cols, off, x
        )
        a = agg[i]
        crhs[a, 0] += sx
        crhs[a, 1] += sy
        crhs[a, 2] += sz


@called
def coarse_sweep(backward, lo, hi, crow_ptr, ccols, coff, cinv, r, x):
    """One block Gauss-Seidel sweep over coarse nodes ``lo:hi``."""
    for t in range(hi - lo):
        p = hi - 1 - t if backward else lo + t
        sx, sy, sz = _coarse_rest(p, crow_ptr, ccols, coff, x)
        x[p, 0], x[p, 1], x[p, 2] = apply(cinv, p, r[p, 0] + sx, r[p, 1] + sy, r[p, 2] + sz)


@device
def _restrict(lo, hi, crow_ptr, ccols, coff, cdiag, cagg, crhs, cx):
    """Residuals of nodes ``lo:hi`` summed into their aggregates' right-hand sides."""
    for p in range(lo, hi):
        sx, sy, sz = _coarse_rest(p, crow_ptr, ccols, coff, cx)
        ax, ay, az = apply(cdiag, p, cx[p, 0], cx[p, 1], cx[p, 2])
        a = cagg[p]
        crhs[a, 0] += crhs[p, 0] + sx - ax
        crhs[a, 1] += crhs[p, 1] + sy - ay
        crhs[a, 2] += crhs[p, 2] + sz - az


@called
def coarse_solve(coarse, crhs, cx):
    """``cx`` on level 1 ≈ its matrix's inverse times its right-hand side in ``crhs``.

    A W-cycle: each level is solved by :data:`COARSE_CYCLES` cycles from zero (the
    second for what the first left; one where the next level is more than a quarter of
    this one), each a forward sweep, the next level solved the same way, and a backward
    sweep; the coarsest level by symmetric sweeps (one sweep, exact, where its nodes are
    unconnected). Symmetric
    positive definite, as conjugate gradients need. Written as a loop over an explicit
    stack of levels (Numba's disk cache cannot hold a recursive function).
    """
    level_start, crow_ptr, ccols, coff, cdiag, cinv, cagg = coarse
    last = level_start.shape[0] - 2
    saved = np.empty(cx.shape)  # each level's right-hand side
    done = np.empty(cx.shape)  # each level's sum of finished cycles
    count = np.zeros(last + 1, dtype=np.int64)
    level = 0
    _fill(cx, level_start[0], level_start[1], 0.0)
    _fill(done, level_start[0], level_start[1], 0.0)
    _copy(crhs, saved, level_start[0], level_start[1])
    down = True
    while True:
        lo = level_start[level]
        hi = level_start[level + 1]
        if down and level == last:
            _fill(cx, lo, hi, 0.0)
            if crow_ptr[lo] == crow_ptr[hi]:  # unconnected nodes: one sweep is exact
                coarse_sweep(False, lo, hi, crow_ptr, ccols, coff, cinv, crhs, cx)
            else:
                for _ in range(COARSEST_SWEEPS):
                    coarse_sweep(False, lo, hi, crow_ptr, ccols, coff, cinv, crhs, cx)
                    coarse_sweep(True, lo, hi, crow_ptr, ccols, coff, cinv, crhs, cx)
            down = False
        elif down:
            if count[level] > 0:  # the next cycle solves for what the last ones left
                for p in range(lo, hi):
                    sx, sy, sz = _coarse_rest(p, crow_ptr, ccols, coff, cx)
                    ax, ay, az = apply(cdiag, p, cx[p, 0], cx[p, 1], cx[p, 2])
                    crhs[p, 0] = saved[p, 0] + sx - ax
                    crhs[p, 1] = saved[p, 1] + sy - ay
                    crhs[p, 2] = saved[p, 2] + sz - az
                for p in range(lo, hi):
                    for d in range(3):
                        done[p, d] += cx[p, d]
                        cx[p, d] = 0.0
            coarse_sweep(False, lo, hi, crow_ptr, ccols, coff, cinv, crhs, cx)
            nhi = level_start[level + 2]
            _fill(crhs, hi, nhi, 0.0)
            _restrict(lo, hi, crow_ptr, ccols, coff, cdiag, cagg, crhs, cx)
            level += 1
            if level < last:
                _fill(cx, hi, nhi, 0.0)
                _copy(crhs, saved, hi, nhi)
                _fill(done, hi, nhi, 0.0)
                count[level] = 0
            continue
        # Back from the level below: prolong its correction, sweep back, and either run
        # this level's next cycle or hand its sum up.
        if level == last:
            if level == 0:
                return
            level -= 1
            lo = level_start[level]
            hi = level_start[level + 1]
        else:
            # A second cycle only where the next level is at most a quarter of this one
            # (a cloth's levels shrink 7-9x); chains of hair halve per level, and a
            # W-cycle's cost would grow with every level.
            shrink = 4 * (level_start[level + 2] - hi) <= hi - lo
            if count[level] < (COARSE_CYCLES if shrink else 1):
                down = True
                continue
            for p in range(lo, hi):
                for d in range(3):
                    cx[p, d] += done[p, d]
                    crhs[p, d] = saved[p, d]
            if level == 0:
                return
            level -= 1
            lo = level_start[level]
            hi = level_start[level + 1]
        for p in range(lo, hi):
            a = cagg[p]
            for d in range(3):
                cx[p, d] += cx[a, d]
        coarse_sweep(True, lo, hi, crow_ptr, ccols, coff, cinv, crhs, cx)
        count[level] += 1


@called
def vcycle(fine, coarse, r, x, crhs, cx):
    """``x = V r``: one symmetric cycle from ``x = 0`` (Gauss-Seidel forward before the
    coarse correction, backward after, so that ``V`` is symmetric positive definite).

    The coarse levels are solved by a W-cycle (:func:`coarse_solve`): cheap, since level
    1 has about a tenth of level 0's entries, and it keeps the iteration count from
    growing with the number of levels (a 64×64 cloth 3.95 -> 2.9 iterations per step, a
    128×128 one 5.2 -> 3.4, against one plain V-cycle).

    ``fine`` = ``(entry_ptr, row_mid, row_other, row_coef, row_ptr, cols, off, gdiag,
    held, agg)``, ``coarse`` = ``(level_start, crow_ptr, ccols, coff, cdiag, cinv,
    cagg)``; ``crhs`` and ``cx`` (coarse nodes, 3) are scratch: each level's right-hand
    side (the residual of the level above, summed over aggregates) and correction.
    """
    held = fine[8]
    agg = fine[9]
    level_start = coarse[0]
    n = r.shape[0]
    levels = level_start.shape[0] - 1
    if levels == 0:  # too few particles to coarsen: one symmetric Gauss-Seidel sweep
        _fill(x, 0, x.shape[0], 0.0)
        fine_sweep(False, 0, fine, r, x)
        fine_sweep(True, 0, fine, r, x)
        return
    _fill(crhs, level_start[0], level_start[1], 0.0)
    fine_down(fine, r, x, crhs)
    coarse_solve(coarse, crhs, cx)
    for i in range(n):
        if held[i]:
            continue
        a = agg[i]
        for d in range(3):
            x[i, d] += CORRECTION * cx[a, d]
    fine_sweep(True, 0, fine, r, x)


__all__ = ["aggregate_kernel", "galerkin_kernel", "vcycle"]
