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

Every kernel runs ``prange`` over rows ``(k, j)`` and a loop over ``i`` inside; each row's
work is independent of the others (red-black colouring makes a colour's updates
independent), so results do not depend on the thread count. Reductions return one
partial per row, summed in row order by the caller.
"""

from __future__ import annotations

import numpy as np
from numba import prange

from .._jit import device, parallel_kernel


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
def _rows(x, zero, k, j, nz, ny):
    """The four neighbouring rows of row (k, j) in y and z, ``zero`` beyond the domain."""
    down = x[k, j - 1] if j > 0 else zero
    up = x[k, j + 1] if j < ny - 1 else zero
    back = x[k - 1, j] if k > 0 else zero
    front = x[k + 1, j] if k < nz - 1 else zero
    return down, up, back, front


@device
def _row_sum(here, down, up, back, front, i, nx):
    """Sum over the six neighbours of cell ``i`` (unsigned) of a row ``here`` inside the
    domain. Solid cells hold 0 in every vector the operator is applied to, so they need
    no test."""
    s = down[i] + up[i] + back[i] + front[i]
    if i > 0:
        s += here[i - np.uint64(1)]
    if i + np.uint64(1) < nx:
        s += here[i + np.uint64(1)]
    return s


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


@parallel_kernel
def apply_operator(x, diag, inv_diag, zero, out, partial):
    """``out = A x``; ``partial[row]`` = the row's sum of ``x * out`` (for ``d . A d``).

    ``x`` must hold 0 on solid cells.
    """
    nz, ny, nx = x.shape
    for row in prange(nz * ny):
        k = row // ny
        j = row - k * ny
        down, up, back, front = _rows(x, zero, k, j, nz, ny)
        here = x[k, j]
        dg = diag[k, j]
        res = out[k, j]
        acc = 0.0
        for m in range(nx):
            i = np.uint64(m)
            d = dg[i]
            v = d * here[i] - _row_sum(here, down, up, back, front, i, nx)
            v = v if d > 0.0 else np.float32(0.0)
            res[i] = v
            acc += np.float64(v) * np.float64(here[i])
        partial[row] = acc


@parallel_kernel
def residual(x, b, diag, inv_diag, zero, out):
    """``out = b - A x`` (0 on solid cells)."""
    nz, ny, nx = x.shape
    for row in prange(nz * ny):
        k = row // ny
        j = row - k * ny
        down, up, back, front = _rows(x, zero, k, j, nz, ny)
        here = x[k, j]
        dg = diag[k, j]
        rhs = b[k, j]
        res = out[k, j]
        for m in range(nx):
            i = np.uint64(m)
            d = dg[i]
            v = rhs[i] - d * here[i] + _row_sum(here, down, up, back, front, i, nx)
            res[i] = v if d > 0.0 else np.float32(0.0)


@parallel_kernel
def smooth(x, b, diag, inv_diag, zero, color):
    """One Gauss-Seidel half sweep over the cells with ``(i + j + k) % 2 == color``
    (``b`` is 0 on solid cells, whose ``inv_diag`` 0 keeps them at 0)."""
    nz, ny, nx = x.shape
    for row in prange(nz * ny):
        k = row // ny
        j = row - k * ny
        down, up, back, front = _rows(x, zero, k, j, nz, ny)
        here = x[k, j]
        rhs = b[k, j]
        inv = inv_diag[k, j]
        first = (color + j + k) % 2
        if first == 0:  # the row's first cell, which has no left neighbour
            s = down[0] + up[0] + back[0] + front[0] + (here[1] if nx > 1 else 0.0)
            here[0] = (rhs[0] + s) * inv[0]
            first = 2
        last = nx - 1
        # inner cells, both neighbours in the row; unsigned indices spare Numba its
        # negative-index wraparound (4x slower with signed ones)
        for m in range(max(0, (last - first + 1) // 2)):
            i = np.uint64(first + 2 * m)
            s = (
                down[i]
                + up[i]
                + back[i]
                + front[i]
                + here[i - np.uint64(1)]
                + here[i + np.uint64(1)]
            )
            here[i] = (rhs[i] + s) * inv[i]
        if last > 0 and (last - first) % 2 == 0:  # the row's last cell, if of this colour
            s = down[last] + up[last] + back[last] + front[last] + here[last - 1]
            here[last] = (rhs[last] + s) * inv[last]


@parallel_kernel
def prolong_add(coarse, factors, fluid, fine):
    """``fine += P coarse``: each fine cell takes the value of the coarse cell covering it
    (piecewise-constant interpolation; ``factors`` (3,) int64 is 2 along the coarsened
    axes x, y, z, else 1). ``fluid`` (nz, ny, nx) float32 is 0 on solid fine cells, which
    receive nothing."""
    nz, ny, nx = fine.shape
    fx, fy, fz = factors[0], factors[1], factors[2]
    for row in prange(nz * ny):
        k = row // ny
        j = row - k * ny
        src = coarse[k // fz, j // fy]
        if fx == 2:
            for i in range(nx):
                fine[k, j, i] += src[i >> 1] * fluid[k, j, i]
        else:
            for i in range(nx):
                fine[k, j, i] += src[i] * fluid[k, j, i]


@parallel_kernel
def restrict(fine, coarse_solid, factors, scale, coarse):
    """``coarse = scale * P^T fine``: the sum over the fine cells a coarse cell covers,
    times ``scale``: the transpose of :func:`prolong_add`, so that the V-cycle is
    symmetric. Solid coarse cells get 0."""
    nz, ny, nx = fine.shape
    cz, cy, cx = coarse.shape
    fx, fy, fz = factors[0], factors[1], factors[2]
    for row in prange(cz * cy):
        kc = row // cy
        jc = row - kc * cy
        out = coarse[kc, jc]
        out[:] = 0.0
        for k in range(kc * fz, min(kc * fz + fz, nz)):
            for j in range(jc * fy, min(jc * fy + fy, ny)):
                src = fine[k, j]
                if fx == 2:
                    for i in range(nx):
                        out[i >> 1] += src[i]
                else:
                    for i in range(nx):
                        out[i] += src[i]
        for ic in range(cx):
            out[ic] = 0.0 if coarse_solid[kc, jc, ic] else out[ic] * scale


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
    for row in prange(nz * ny):
        k = row // ny
        j = row - k * ny
        acc = 0.0
        for i in range(nx):
            acc += np.float64(a[k, j, i]) * np.float64(b[k, j, i])
        partial[row] = acc


@parallel_kernel
def cg_update(x, r, d, ad, alpha, partial):
    """``x += alpha d``, ``r -= alpha A d``; ``partial[row]`` = the row's max ``|r|``."""
    nz, ny, nx = x.shape
    a = np.float32(alpha)
    for row in prange(nz * ny):
        k = row // ny
        j = row - k * ny
        top = 0.0
        for i in range(nx):
            x[k, j, i] += a * d[k, j, i]
            v = r[k, j, i] - a * ad[k, j, i]
            r[k, j, i] = v
            top = max(top, abs(v))
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
