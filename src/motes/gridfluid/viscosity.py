"""Implicit viscosity: backward-Euler diffusion of each velocity component,
``(I - nu dt Laplacian) u_new = u_old``, solved by Jacobi-preconditioned conjugate
gradients (the system is strongly diagonal: a few iterations reach the tolerance)."""

from __future__ import annotations

import numpy as np

from . import pressure_kernels as vec
from . import viscosity_kernels as kern


class Diffusion:
    """Solves the diffusion system of one face grid (axis 0, 1 or 2) in place.

    Parameters
    ----------
    shape : tuple
        The face grid's shape (nz, ny, nx).
    axis : int
        The component: 0 (x faces), 1 (y), 2 (z).
    tolerance : float
        Stop when ``max |r| <= tolerance * max |rhs|``.
    """

    def __init__(self, shape, axis: int, *, tolerance: float = 1e-6, max_iterations: int = 200):
        self.axis = axis
        self.tolerance = tolerance
        self.max_iterations = max_iterations
        self.fixed = np.zeros(shape, np.uint8)
        self.diag = np.empty(shape, np.float32)
        self.rhs = np.empty(shape, np.float32)
        self._r, self._z, self._d, self._ad = (np.empty(shape, np.float32) for _ in range(4))
        self._partial = np.empty(shape[0] * shape[1], np.float64)

    def set_solid(self, solid) -> None:
        kern.fixed_faces(self.axis, solid, self.fixed)

    def solve(self, face, alpha, open_faces, no_slip, wall_velocity) -> int:
        """Diffuse ``face`` in place with ``alpha = nu dt / h^2``; returns the iterations."""
        kern.system(
            face, self.fixed, self.axis, open_faces, no_slip, wall_velocity, alpha,
            self.diag, self.rhs,
        )  # fmt: skip
        r, z, d, ad, partial = self._r, self._z, self._d, self._ad, self._partial
        kern.apply(face, self.fixed, alpha, self.diag, ad, partial)
        np.subtract(self.rhs, ad, out=r)
        target = self.tolerance * float(np.abs(self.rhs).max())
        if float(np.abs(r).max()) <= target:
            return 0
        np.divide(r, self.diag, out=z)
        d[...] = z
        vec.dot_rows(r, z, partial)
        rz = float(partial.sum())
        for it in range(1, self.max_iterations + 1):
            kern.apply(d, self.fixed, alpha, self.diag, ad, partial)
            dad = float(partial.sum())
            if dad <= 0.0:
                return it
            vec.cg_update(face, r, d, ad, rz / dad, partial)
            if float(partial.max()) <= target:
                return it
            np.divide(r, self.diag, out=z)
            vec.dot_rows(r, z, partial)
            rz_new = float(partial.sum())
            vec.cg_direction(d, z, rz_new / rz)
            rz = rz_new
        return self.max_iterations
