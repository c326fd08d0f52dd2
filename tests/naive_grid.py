"""Plain NumPy and SciPy twins of the grid-fluid kernels: slow and obviously correct."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp


def poisson_matrix(solid: np.ndarray, open_faces) -> sp.csr_matrix:
    """The pressure operator of :mod:`motes.gridfluid.pressure_kernels` as a sparse matrix
    over all cells (rows of solid cells are the identity)."""
    nz, ny, nx = solid.shape
    index = np.arange(solid.size).reshape(solid.shape)
    rows, cols, vals = [], [], []
    for k in range(nz):
        for j in range(ny):
            for i in range(nx):
                c = index[k, j, i]
                if solid[k, j, i]:
                    rows.append(c), cols.append(c), vals.append(1.0)
                    continue
                diag = 0.0
                for axis, (dk, dj, di) in enumerate(((0, 0, 1), (0, 1, 0), (1, 0, 0))):
                    for sign in (-1, 1):
                        kk, jj, ii = k + sign * dk, j + sign * dj, i + sign * di
                        if 0 <= kk < nz and 0 <= jj < ny and 0 <= ii < nx:
                            if not solid[kk, jj, ii]:
                                diag += 1.0
                                rows.append(c), cols.append(index[kk, jj, ii]), vals.append(-1.0)
                        else:
                            side = 2 * axis + (sign > 0)  # -x, +x, -y, +y, -z, +z
                            diag += float(open_faces[side])
                rows.append(c), cols.append(c), vals.append(diag)
    return sp.csr_matrix((vals, (rows, cols)), shape=(solid.size, solid.size))


def sample(field: np.ndarray, fx, fy, fz) -> np.ndarray:
    """Trilinear samples of ``field`` (nz, ny, nx) at lattice coordinates, clamped."""
    nz, ny, nx = field.shape

    def axis(f, n):
        f = np.clip(f, 0, n - 1)
        i0 = np.minimum(np.floor(f).astype(int), n - 1)
        i1 = np.minimum(i0 + 1, n - 1)
        return i0, i1, f - i0

    i0, i1, tx = axis(np.asarray(fx, float), nx)
    j0, j1, ty = axis(np.asarray(fy, float), ny)
    k0, k1, tz = axis(np.asarray(fz, float), nz)
    out = 0.0
    for kk, wk in ((k0, 1 - tz), (k1, tz)):
        for jj, wj in ((j0, 1 - ty), (j1, ty)):
            for ii, wi in ((i0, 1 - tx), (i1, tx)):
                out = out + wk * wj * wi * field[kk, jj, ii]
    return out


def velocity(u, v, w, x, y, z):
    return (
        sample(u, x, y - 0.5, z - 0.5),
        sample(v, x - 0.5, y, z - 0.5),
        sample(w, x - 0.5, y - 0.5, z),
    )


def semi_lagrangian(field, offset, u, v, w, scale) -> np.ndarray:
    """One semi-Lagrangian step of ``field`` (nz, ny, nx) on the lattice at ``offset``
    (cells), traced back with the midpoint rule; ``scale = dt / h``."""
    nz, ny, nx = field.shape
    ox, oy, oz = offset
    k, j, i = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
    x, y, z = i + ox, j + oy, k + oz
    ax, ay, az = velocity(u, v, w, x, y, z)
    bx, by, bz = velocity(u, v, w, x - 0.5 * scale * ax, y - 0.5 * scale * ay, z - 0.5 * scale * az)
    return sample(field, x - scale * bx - ox, y - scale * by - oy, z - scale * bz - oz)


def divergence(u, v, w) -> np.ndarray:
    """Net outflow of each cell in cell units (``h`` times the divergence)."""
    return np.diff(u, axis=2) + np.diff(v, axis=1) + np.diff(w, axis=0)
