"""Compiled kernels of the pressure solve: the Poisson operator on a cell grid with solid
cells and open walls, red-black Gauss-Seidel smoothing, transfers between multigrid
levels, and the vector updates of conjugate gradients.

Arrays are ``(nz, ny, nx)`` (x fastest). ``solid`` is a uint8 grid (1 = solid cell: no
unknown, its pressure held at 0). ``open_faces`` (6,) uint8 says which faces of the
domain (-x, +x, -y, +y, -z, +z) are open: a cell beside an open face sees pressure 0
beyond it (Dirichlet); beside a closed face it sees a wall (Neumann, no coupling).
The operator is the 7-point Laplacian times ``-h^2``: ``(A x)_c = sum over the non-solid
neighbours n of (x_c - x_n) + (open neighbours) x_c``, symmetric positive
(semi-)definite.

Every kernel runs ``prange`` over rows ``(k, j)`` (or fixed blocks of them) and a loop
over ``i`` inside; each row's work is independent of the others (red-black colouring
makes a colour's updates independent), so results do not depend on the thread count.
Reductions return one partial per row, summed in row order by the caller.

The hot kernels index flat views of their arrays, taken once per call, at unsigned
offsets: a view of a row made in the loop costs an atomic reference count increment and
decrement (two threads contend for the array's count; the 3D smoothing sweep ran 20 %
faster without them), and unsigned offsets spare Numba its negative-index wraparound.
"""

from __future__ import annotations

import numpy as np
from numba import prange

from .._jit import called_copy, device, parallel_kernel


@device
def _coupling(solid, open_faces, k, j, i, nz, ny, nx):
    """Diagonal of the operator at cell (k, j, i): its non-solid neighbours and open faces."""
    d = 0.0
    if i > 0:
        d += 1.0 - solid[k, j, i - 1]
    else:
        d += open_faces[0]
    if i < nx - 1:
        d += 1.0 - solid[k, j, i + 1]
    else:
        d += open_faces[1]
    if j > 0:
        d += 1.0 - solid[k, j - 1, i]
    else:
        d += open_faces[2]
    if j < ny - 1:
        d += 1.0 - solid[k, j + 1, i]
    else:
        d += open_faces[3]
    if k > 0:
        d += 1.0 - solid[k - 1, j, i]
    else:
        d += open_faces[4]
    if k < nz - 1:
        d += 1.0 - solid[k + 1, j, i]
    else:
        d += open_faces[5]
    return d


@device
def _row(k, j, nz, ny, nx):
    """Flat offsets (uint64) of row (k, j) and of its neighbouring rows in y and z (down,
    up, back, front), and the weights of those (float32): 1, or 0 beyond the domain,
    where the offset is the row's own (a valid row whose values the 0 cancels)."""
    plane = ny * nx
    base = (k * ny + j) * nx
    one, none = np.float32(1.0), np.float32(0.0)
    down, wd = (base - nx, one) if j > 0 else (base, none)
    up, wu = (base + nx, one) if j < ny - 1 else (base, none)
    back, wb = (base - plane, one) if k > 0 else (base, none)
    front, wf = (base + plane, one) if k < nz - 1 else (base, none)
    return (
        np.uint64(base), np.uint64(down), np.uint64(up), np.uint64(back), np.uint64(front),
        wd, wu, wb, wf,
    )  # fmt: skip


@device
def _neighbour_sum(x, row, nx, out):
    """``out[base + i]`` = the sum of the six neighbours of cell ``i`` of the row of
    ``x`` at ``row`` (from :func:`_row`). Solid cells hold 0 in every vector the operator
    is applied to, so they need no test. The loop vectorises (it stores nothing it
    reads)."""
    base, down, up, back, front, wd, wu, wb, wf = row
    one = np.uint64(1)
    n = np.uint64(nx)
    for i in range(n):
        out[base + i] = (wd * x[down + i] + wu * x[up + i]) + (wb * x[back + i] + wf * x[front + i])
    if n > one:
        last = base + n - one
        out[base] += x[base + one]
        for i in range(one, n - one):
            out[base + i] += x[base + i - one] + x[base + i + one]
        out[last] += x[last - one]


#: :func:`_neighbour_sum` compiled once and called: the smoother inlines it (its loop is
#: the solve's hottest); the residual and the operator call this (2 s less to compile,
#: the solve 1 % slower).
_neighbour_sum_called = called_copy(_neighbour_sum)

#: :func:`_row`, likewise.
_row_called = called_copy(_row)


@parallel_kernel
def diagonal(solid, open_faces, diag, inv_diag):
    """The operator's diagonal and its inverse (both 0 on solid cells, and the inverse 0
    on a fluid cell walled in on every side) into (nz, ny, nx) float32 arrays."""
    nz, ny, nx = solid.shape
    for row in prange(nz * ny):
        k = row // ny
        j = row - k * ny
        for i in range(nx):
            d = 0.0 if solid[k, j, i] else _coupling(solid, open_faces, k, j, i, nz, ny, nx)
            diag[k, j, i] = d
            inv_diag[k, j, i] = 1.0 / d if d > 0.0 else 0.0


@device
def _dot(p, q, base, nx):
    """The sum of ``p[base + i] * q[base + i]`` over a row, in float64, in four running
    sums (a float sum keeps its order, so one sum would wait on each addition)."""
    s0 = s1 = s2 = s3 = 0.0
    one, two, three, four = np.uint64(1), np.uint64(2), np.uint64(3), np.uint64(4)
    whole = np.uint64(nx) // four * four
    for i in range(np.uint64(0), whole, four):
        at = base + i
        s0 += np.float64(p[at]) * np.float64(q[at])
        s1 += np.float64(p[at + one]) * np.float64(q[at + one])
        s2 += np.float64(p[at + two]) * np.float64(q[at + two])
        s3 += np.float64(p[at + three]) * np.float64(q[at + three])
    total = (s0 + s1) + (s2 + s3)
    for i in range(whole, np.uint64(nx)):
        total += np.float64(p[base + i]) * np.float64(q[base + i])
    return total


#: :func:`_dot` compiled once and called (the viscosity solve's operator).
_dot_called = called_copy(_dot)


@parallel_kernel
def apply_operator(x, diag, inv_diag, zero, out, partial):
    """``out = A x``; ``partial[row]`` = the row's sum of ``x * out`` (for ``d . A d``).

    ``x`` must hold 0 on solid cells.
    """
    nz, ny, nx = x.shape
    xs, ds, res = x.ravel(), diag.ravel(), out.ravel()
    for r in prange(nz * ny):
        row = _row_called(r // ny, r % ny, nz, ny, nx)
        _neighbour_sum_called(xs, row, nx, res)
        base = row[0]
        for i in range(np.uint64(nx)):
            d = ds[base + i]
            v = d * xs[base + i] - res[base + i]
            res[base + i] = v if d > 0.0 else np.float32(0.0)
        partial[r] = _dot(xs, res, base, nx)


@device
def _residual_row(x, b, diag, out, r, nz, ny, nx):
    """``out = b - A x`` on row ``r`` of flat (nz, ny, nx) arrays (0 on solid cells)."""
    row = _row_called(r // ny, r % ny, nz, ny, nx)
    _neighbour_sum_called(x, row, nx, out)
    base = row[0]
    for i in range(np.uint64(nx)):
        d = diag[base + i]
        v = (b[base + i] - d * x[base + i]) + out[base + i]
        out[base + i] = v if d > 0.0 else np.float32(0.0)


@device
def _smooth_slab(x, b, inv, work, nz, ny, nx, slab, color):
    """Gauss-Seidel update of the cells with ``(i + j + k) % 2 == color`` in slab
    ``slab`` (a plane ``k`` of a grid more than one cell thick, else a row ``j``) of the
    flat ``x`` (nz, ny, nx) (``b`` is 0 on solid cells, whose ``inv`` 0 keeps them at 0).

    Each row's new values are computed for all its cells (a loop that vectorises) and
    those of the colour kept: twice the arithmetic of a loop over every other cell, in
    a fraction of its time; cells of the other colour are written back unchanged.
    """
    one = np.uint64(1)
    k, start, stop = (slab, 0, ny) if nz > 1 else (0, slab, slab + 1)
    for j in range(start, stop):
        row = _row(k, j, nz, ny, nx)
        _neighbour_sum(x, row, nx, work)
        base = row[0]
        first = np.uint64((color + j + k) % 2)
        for i in range(np.uint64(nx)):
            v = (b[base + i] + work[base + i]) * inv[base + i]
            x[base + i] = v if (i & one) == first else x[base + i]


#: Slabs (planes, or rows of a 2D grid) of a work item of the smoothing sweeps (the last
#: item takes the remainder too): at least twice the half sweeps done in one pass.
SLABS = 32


@device
def _block_bounds(block, blocks, slabs):
    """Slabs ``[start, stop)`` of work item ``block`` of ``blocks``."""
    start = block * SLABS
    return start, slabs if block == blocks - 1 else start + SLABS


@device
def _sweep_block(x, b, inv, work, nz, ny, nx, block, blocks, color, stages, phase):
    """Work item ``block`` of ``stages`` red-black Gauss-Seidel half sweeps (colour
    ``color`` first, then alternating) done in one pass over memory, in two phases.

    Half sweep ``q`` of slab ``s`` needs half sweep ``q - 1`` of the slabs beside it
    done, and ``q + 1`` not yet (it reads their cells of the other colour), so the pairs
    ``(s, q)`` are taken in the order of ``s + q``, then ``q``: a wave through the slabs,
    ``stages`` deep. ``phase`` 0: each item does the pairs whose slabs' neighbours, down
    to half sweep 0, are its own (or beyond the domain); ``phase`` 1: the rest, around
    the boundary at the end of the item, which reach into the next. Every cell sees the
    neighbour values of the half sweeps done one after the other, so the result is
    theirs, whatever the thread count."""
    slabs = nz if nz > 1 else ny
    start, stop = _block_bounds(block, blocks, slabs)
    if phase == 0:
        low, high = start, stop
    elif stop == slabs:
        return
    else:
        low, high = max(stop - stages + 1, 0), min(stop + stages - 1, slabs)
    for wave in range(low, high + stages - 1):
        for q in range(stages):
            slab = wave - q
            if slab < low or slab >= high:
                continue
            first, last = _block_bounds(min(slab // SLABS, blocks - 1), blocks, slabs)
            own = (slab >= first + q or first == 0) and (slab < last - q or last == slabs)
            if own == (phase == 0):
                _smooth_slab(x, b, inv, work, nz, ny, nx, slab, color ^ (q & 1))


@device
def _prolong_row(coarse, cy, cx, factors, fluid, fine, r, ny, nx):
    """``fine += P coarse`` on fine row ``r``: each fine cell takes the value of the
    coarse cell covering it (piecewise-constant interpolation; ``factors`` (3,) int64 is
    2 along the coarsened axes x, y, z, else 1); ``fluid`` is 0 on solid fine cells,
    which receive nothing. Flat arrays, fine (nz, ny, nx), coarse (cz, cy, cx)."""
    k = r // ny
    j = r - k * ny
    base = np.uint64(r * nx)
    cbase = np.uint64(((k // factors[2]) * cy + j // factors[1]) * cx)
    one = np.uint64(1)
    if factors[0] == 2:
        for i in range(np.uint64(nx)):
            fine[base + i] += coarse[cbase + (i >> one)] * fluid[base + i]
    else:
        for i in range(np.uint64(nx)):
            fine[base + i] += coarse[cbase + i] * fluid[base + i]


@device
def _restrict_row(fine, nz, ny, nx, coarse_solid, factors, scale, coarse, r, cy, cx):
    """``coarse = scale * P^T fine`` on coarse row ``r``: the sum over the fine cells a
    coarse cell covers, times ``scale``: the transpose of :func:`_prolong_row`, so that
    the V-cycle is symmetric. Solid coarse cells get 0."""
    fx, fy, fz = factors[0], factors[1], factors[2]
    kc = r // cy
    jc = r - kc * cy
    cbase = np.uint64(r * cx)
    shift = np.uint64(1 if fx == 2 else 0)
    for i in range(np.uint64(cx)):
        coarse[cbase + i] = 0.0
    for k in range(kc * fz, min(kc * fz + fz, nz)):
        for j in range(jc * fy, min(jc * fy + fy, ny)):
            base = np.uint64((k * ny + j) * nx)
            for i in range(np.uint64(nx)):
                coarse[cbase + (i >> shift)] += fine[base + i]
    for i in range(np.uint64(cx)):
        coarse[cbase + i] = 0.0 if coarse_solid[cbase + i] else coarse[cbase + i] * scale


@parallel_kernel
def sweep(x, b, inv_diag, color, work, count):
    """``count`` red-black Gauss-Seidel sweeps, colour ``color`` first, in one pass over
    memory (:func:`_sweep_block`); ``work`` is scratch of the shape of ``x``."""
    nz, ny, nx = x.shape
    xs, bs, inv, ws = x.ravel(), b.ravel(), inv_diag.ravel(), work.ravel()
    slabs = nz if nz > 1 else ny
    blocks = max(slabs // SLABS, 1)
    for phase in range(2):
        for block in prange(blocks):
            _sweep_block(xs, bs, inv, ws, nz, ny, nx, block, blocks, color, 2 * count, phase)


@parallel_kernel
def restrict_residual(x, b, diag, work, coarse_solid, factors, scale, coarse_b, coarse_x):
    """The way down a V-cycle: ``coarse_b = scale * P^T (b - A x)`` and ``coarse_x = 0``.
    Each coarse row's work item computes the residual of the fine rows it covers (into
    ``work``) before restricting it: no fine row is shared, so no pass of its own."""
    nz, ny, nx = x.shape
    cz, cy, cx = coarse_b.shape
    fy, fz = factors[1], factors[2]
    xs, bs, ds, ws = x.ravel(), b.ravel(), diag.ravel(), work.ravel()
    cs, cb, cxs = coarse_solid.ravel(), coarse_b.ravel(), coarse_x.ravel()
    for r in prange(cz * cy):
        kc = r // cy
        jc = r - kc * cy
        for k in range(kc * fz, min(kc * fz + fz, nz)):
            for j in range(jc * fy, min(jc * fy + fy, ny)):
                _residual_row(xs, bs, ds, ws, k * ny + j, nz, ny, nx)
        _restrict_row(ws, nz, ny, nx, cs, factors, scale, cb, r, cy, cx)
        base = np.uint64(r * cx)
        for i in range(np.uint64(cx)):
            cxs[base + i] = 0.0


@parallel_kernel
def prolong_add(coarse, factors, fluid, fine):
    """``fine += P coarse`` (:func:`_prolong_row`), the way up a V-cycle."""
    nz, ny, nx = fine.shape
    _, cy, cx = coarse.shape
    src, mask, dst = coarse.ravel(), fluid.ravel(), fine.ravel()
    for r in prange(nz * ny):
        _prolong_row(src, cy, cx, factors, mask, dst, r, ny, nx)


@parallel_kernel
def coarsen_solid(fine, factors, coarse):
    """A coarse cell is solid when every fine cell it covers is."""
    nz, ny, nx = fine.shape
    cz, cy, cx = coarse.shape
    for row in prange(cz * cy):
        kc = row // cy
        jc = row - kc * cy
        for ic in range(cx):
            s = 1
            for k in range(kc * factors[2], min((kc + 1) * factors[2], nz)):
                for j in range(jc * factors[1], min((jc + 1) * factors[1], ny)):
                    for i in range(ic * factors[0], min((ic + 1) * factors[0], nx)):
                        s = s & fine[k, j, i]
            coarse[kc, jc, ic] = s


@parallel_kernel
def dot_rows(a, b, partial):
    """``partial[row]`` = the row's sum of ``a * b`` (float64)."""
    nz, ny, nx = a.shape
    p, q = a.ravel(), b.ravel()
    for r in prange(nz * ny):
        partial[r] = _dot(p, q, np.uint64(r * nx), nx)


@parallel_kernel
def cg_update(x, r, d, ad, alpha, partial):
    """``x += alpha d``, ``r -= alpha A d``; ``partial[row]`` = the row's max ``|r|``
    (four running maxima: the order of a max does not change it)."""
    nz, ny, nx = x.shape
    a = np.float32(alpha)
    xs, rs, ds, ads = x.ravel(), r.ravel(), d.ravel(), ad.ravel()
    one, two, three, four = np.uint64(1), np.uint64(2), np.uint64(3), np.uint64(4)
    whole = np.uint64(nx) // four * four
    for row in prange(nz * ny):
        base = np.uint64(row * nx)
        for i in range(np.uint64(nx)):
            xs[base + i] += a * ds[base + i]
            rs[base + i] -= a * ads[base + i]
        m0 = m1 = m2 = m3 = np.float32(0.0)
        for i in range(np.uint64(0), whole, four):
            at = base + i
            m0 = max(m0, abs(rs[at]))
            m1 = max(m1, abs(rs[at + one]))
            m2 = max(m2, abs(rs[at + two]))
            m3 = max(m3, abs(rs[at + three]))
        top = max(max(m0, m1), max(m2, m3))
        for i in range(whole, np.uint64(nx)):
            top = max(top, abs(rs[base + i]))
        partial[row] = top


@parallel_kernel
def cg_direction(d, z, beta):
    """``d = z + beta d``."""
    nz, ny, nx = d.shape
    b = np.float32(beta)
    for row in prange(nz * ny):
        k = row // ny
        j = row - k * ny
        for i in range(nx):
            d[k, j, i] = z[k, j, i] + b * d[k, j, i]


@parallel_kernel
def add_constant(x, solid, value):
    """``x += value`` on the non-solid cells (removing a mean: the all-closed domain's
    constant null space)."""
    nz, ny, nx = x.shape
    v = np.float32(value)
    for row in prange(nz * ny):
        k = row // ny
        j = row - k * ny
        for i in range(nx):
            if not solid[k, j, i]:
                x[k, j, i] += v
