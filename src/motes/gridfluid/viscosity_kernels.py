"""Compiled kernels of implicit viscosity: backward-Euler diffusion of one face grid,
``(I - nu dt Laplacian) u_new = u_old``, a symmetric positive definite system solved by
Jacobi-preconditioned conjugate gradients (:mod:`motes.gridfluid.viscosity`).

``alpha = nu dt / h^2``. Faces the flow may not cross (closed domain faces, faces beside
solid cells; ``fixed`` = 1) keep their value: their rows are the identity and their
neighbours take them on the right-hand side, which keeps the matrix symmetric. Beyond the
domain, along an axis other than the face's own, a closed wall without slip holds the
fluid at its velocity (the ghost value ``2 u_wall - u``: twice the coupling), a slipping
or open one exerts no shear (the ghost value ``u``: no coupling).
"""

from __future__ import annotations

import numpy as np
from numba import prange

from .._jit import device, parallel_kernel


@device
def _step(axis, b, k, j, i, sign):
    """Face (k, j, i) moved by ``sign`` along axis ``b``."""
    if b == 0:
        return k, j, i + sign
    if b == 1:
        return k, j + sign, i
    return k + sign, j, i


@parallel_kernel
def fixed_faces(axis, solid, fixed):
    """``fixed`` = 1 on domain faces normal to ``axis`` and faces beside a solid cell."""
    nz, ny, nx = solid.shape
    fz, fy, fx = fixed.shape
    n_axis = (nx, ny, nz)[axis]
    for row in prange(fz * fy):
        k = row // fy
        j = row - k * fy
        for i in range(fx):
            index = (i, j, k)[axis]
            if index == 0 or index == n_axis:
                fixed[k, j, i] = 1
                continue
            lk, lj, li = _step(axis, axis, k, j, i, -1)
            fixed[k, j, i] = 1 if (solid[lk, lj, li] or solid[k, j, i]) else 0


@parallel_kernel
def system(face, fixed, axis, open_faces, no_slip, wall_velocity, alpha, diag, rhs):
    """The diagonal and right-hand side of the diffusion system of one face grid."""
    fz, fy, fx = face.shape
    shape = (fx, fy, fz)
    for row in prange(fz * fy):
        k = row // fy
        j = row - k * fy
        for i in range(fx):
            if fixed[k, j, i]:
                diag[k, j, i] = 1.0
                rhs[k, j, i] = face[k, j, i]
                continue
            d = 1.0
            r = face[k, j, i]
            for b in range(3):
                n = shape[b]
                index = (i, j, k)[b]
                for sign in (-1, 1):
                    inside = index + sign
                    if 0 <= inside < n:
                        if n > 1:
                            d += alpha
                            nk, nj, ni = _step(axis, b, k, j, i, sign)
                            if fixed[nk, nj, ni]:
                                r += alpha * face[nk, nj, ni]
                    else:
                        side = 2 * b + (0 if sign < 0 else 1)
                        if n > 1 and b != axis and no_slip[side] and not open_faces[side]:
                            d += 2.0 * alpha
                            r += 2.0 * alpha * wall_velocity[side, axis]
            diag[k, j, i] = d
            rhs[k, j, i] = r


@parallel_kernel
def apply(x, fixed, alpha, diag, out, partial):
    """``out = M x`` over the free faces (fixed faces: ``out = x``, and no coupling);
    ``partial[row]`` = the row's sum of ``x * out``."""
    fz, fy, fx = x.shape
    shape = (fx, fy, fz)
    for row in prange(fz * fy):
        k = row // fy
        j = row - k * fy
        acc = 0.0
        for i in range(fx):
            if fixed[k, j, i]:
                v = x[k, j, i]
            else:
                s = 0.0
                for b in range(3):
                    n = shape[b]
                    index = (i, j, k)[b]
                    for sign in (-1, 1):
                        inside = index + sign
                        if 0 <= inside < n:
                            nk, nj, ni = _step(0, b, k, j, i, sign)
                            if not fixed[nk, nj, ni]:
                                s += x[nk, nj, ni]
                v = diag[k, j, i] * x[k, j, i] - alpha * s
            out[k, j, i] = v
            acc += np.float64(v) * np.float64(x[k, j, i])
        partial[row] = acc
