"""Compiled kernels on the faces of a staggered (MAC) grid: boundary conditions,
divergence, the pressure gradient, buoyancy and vorticity confinement.

A face grid of axis ``a`` (0 = x, 1 = y, 2 = z) has one more face than cells along
``a``: face ``(k, j, i)`` of the x grid lies between cells ``(k, j, i - 1)`` and
``(k, j, i)``. Arrays are ``(nz, ny, nx)``-shaped, x fastest, and every kernel runs
``prange`` over rows ``(k, j)``.

Boundaries: ``solid`` (nz, ny, nx) uint8 marks obstacle cells, moving at
``solid_velocity`` (3, nz, ny, nx) [m/s]; ``open_faces`` (6,) uint8 marks the open faces
of the domain (-x, +x, -y, +y, -z, +z); ``wall_velocity`` (6, 3) float32 is the velocity
of each closed face's wall [m/s] (its normal component is what the flow may not cross;
its tangential one drags the fluid where the wall has no slip).
"""

from __future__ import annotations

import numpy as np
from numba import prange

from .._jit import device, parallel_kernel


@device
def _neighbours(axis, k, j, i):
    """Cell index of the 'left' cell of face (k, j, i) along ``axis``."""
    if axis == 0:
        return k, j, i - 1
    if axis == 1:
        return k, j - 1, i
    return k - 1, j, i


@parallel_kernel
def enforce_boundaries(face, axis, solid, solid_velocity, open_faces, wall_velocity):
    """Set the faces the flow may not cross: a closed domain face takes its wall's
    normal velocity, a face beside a solid cell the solid's (their mean between two).
    Faces of open domain faces are left to the pressure solve."""
    nz, ny, nx = solid.shape
    fz, fy, fx = face.shape
    n_axis = (nx, ny, nz)[axis]
    for row in prange(fz * fy):
        k = row // fy
        j = row - k * fy
        for i in range(fx):
            index = (i, j, k)[axis]
            if index == 0 or index == n_axis:
                side = 2 * axis + (0 if index == 0 else 1)
                if not open_faces[side]:
                    face[k, j, i] = wall_velocity[side, axis]
                continue
            lk, lj, li = _neighbours(axis, k, j, i)
            left = solid[lk, lj, li]
            right = solid[k, j, i]
            if left and right:
                face[k, j, i] = 0.5 * (
                    solid_velocity[axis, lk, lj, li] + solid_velocity[axis, k, j, i]
                )
            elif left:
                face[k, j, i] = solid_velocity[axis, lk, lj, li]
            elif right:
                face[k, j, i] = solid_velocity[axis, k, j, i]


@parallel_kernel
def divergence(u, v, w, solid, out):
    """``out`` = the net outflow of each fluid cell in cell units (``h`` times the
    divergence [1/s·m]); 0 on solid cells."""
    nz, ny, nx = solid.shape
    for row in prange(nz * ny):
        k = row // ny
        j = row - k * ny
        for i in range(nx):
            if solid[k, j, i]:
                out[k, j, i] = 0.0
            else:
                out[k, j, i] = (
                    u[k, j, i + 1] - u[k, j, i] + v[k, j + 1, i] - v[k, j, i]
                    + w[k + 1, j, i] - w[k, j, i]
                )  # fmt: skip


@parallel_kernel
def subtract_gradient(face, axis, q, solid, open_faces):
    """``face -= q_right - q_left`` across every face between two fluid cells, and across
    open domain faces (``q`` = 0 beyond them). ``q`` is the pressure in velocity units
    (``p dt / (rho h)``) that :class:`motes.gridfluid.pressure.PoissonSolver` returns."""
    nz, ny, nx = solid.shape
    fz, fy, fx = face.shape
    n_axis = (nx, ny, nz)[axis]
    for row in prange(fz * fy):
        k = row // fy
        j = row - k * fy
        for i in range(fx):
            index = (i, j, k)[axis]
            lk, lj, li = _neighbours(axis, k, j, i)
            if index == 0:
                if open_faces[2 * axis] and not solid[k, j, i]:
                    face[k, j, i] -= q[k, j, i]
            elif index == n_axis:
                if open_faces[2 * axis + 1] and not solid[lk, lj, li]:
                    face[k, j, i] += q[lk, lj, li]
            elif not solid[lk, lj, li] and not solid[k, j, i]:
                face[k, j, i] -= q[k, j, i] - q[lk, lj, li]


@parallel_kernel
def add_cell_force(face, axis, force, scale, solid):
    """``face += scale * (mean of force over the two cells beside it)`` on interior faces
    between fluid cells; ``force`` (nz, ny, nx) per cell (an acceleration [m/s²] with
    ``scale = dt``)."""
    nz, ny, nx = solid.shape
    fz, fy, fx = face.shape
    n_axis = (nx, ny, nz)[axis]
    half = 0.5 * scale
    for row in prange(fz * fy):
        k = row // fy
        j = row - k * fy
        for i in range(fx):
            index = (i, j, k)[axis]
            if index == 0 or index == n_axis:
                continue
            lk, lj, li = _neighbours(axis, k, j, i)
            if solid[lk, lj, li] or solid[k, j, i]:
                continue
            face[k, j, i] += half * (force[lk, lj, li] + force[k, j, i])


@parallel_kernel
def buoyancy(scalars, density_weight, heat_weight, ambient, out):
    """Buoyant acceleration per cell [m/s²] along "up" (Fedkiw, Stam & Jensen 2001,
    eq. 8): ``-density_weight * density + heat_weight * (temperature - ambient)``;
    ``scalars[0]`` is density, ``scalars[1]`` temperature [K]."""
    _, nz, ny, nx = scalars.shape
    for row in prange(nz * ny):
        k = row // ny
        j = row - k * ny
        for i in range(nx):
            out[k, j, i] = (
                heat_weight * (scalars[1, k, j, i] - ambient) - density_weight * scalars[0, k, j, i]
            )


@parallel_kernel
def cell_velocity(u, v, w, out):
    """Velocity at cell centres [m/s], (3, nz, ny, nx): the mean of opposite faces."""
    _, nz, ny, nx = out.shape
    for row in prange(nz * ny):
        k = row // ny
        j = row - k * ny
        for i in range(nx):
            out[0, k, j, i] = 0.5 * (u[k, j, i] + u[k, j, i + 1])
            out[1, k, j, i] = 0.5 * (v[k, j, i] + v[k, j + 1, i])
            out[2, k, j, i] = 0.5 * (w[k, j, i] + w[k + 1, j, i])


@device
def _difference(f, c, k, j, i, axis, nz, ny, nx):
    """Derivative of component ``c`` of ``f`` along ``axis`` at a cell, per cell:
    central inside, one-sided at the domain's edge (0 along an axis of one cell)."""
    n = (nx, ny, nz)[axis]
    index = (i, j, k)[axis]
    if n == 1:
        return 0.0
    lo = max(index - 1, 0)
    hi = min(index + 1, n - 1)
    if axis == 0:
        a, b = f[c, k, j, lo], f[c, k, j, hi]
    elif axis == 1:
        a, b = f[c, k, lo, i], f[c, k, hi, i]
    else:
        a, b = f[c, lo, j, i], f[c, hi, j, i]
    return (b - a) / (hi - lo)


@parallel_kernel
def vorticity(velocity, inv_h, out):
    """Vorticity ``curl u`` [1/s] at cell centres into ``out[0:3]`` and its magnitude into
    ``out[3]``, from cell-centred ``velocity`` (3, nz, ny, nx)."""
    _, nz, ny, nx = velocity.shape
    for row in prange(nz * ny):
        k = row // ny
        j = row - k * ny
        for i in range(nx):
            wx = _difference(velocity, 2, k, j, i, 1, nz, ny, nx) - _difference(
                velocity, 1, k, j, i, 2, nz, ny, nx
            )
            wy = _difference(velocity, 0, k, j, i, 2, nz, ny, nx) - _difference(
                velocity, 2, k, j, i, 0, nz, ny, nx
            )
            wz = _difference(velocity, 1, k, j, i, 0, nz, ny, nx) - _difference(
                velocity, 0, k, j, i, 1, nz, ny, nx
            )
            out[0, k, j, i] = wx * inv_h
            out[1, k, j, i] = wy * inv_h
            out[2, k, j, i] = wz * inv_h
            out[3, k, j, i] = np.sqrt(wx * wx + wy * wy + wz * wz) * inv_h


@parallel_kernel
def confinement(omega, strength, h, out):
    """Vorticity confinement acceleration [m/s²] per cell (Fedkiw, Stam & Jensen 2001,
    eq. 9-11): ``strength * h * (N x omega)`` with ``N`` the unit gradient of
    ``|omega|``; ``omega`` (4, nz, ny, nx) from :func:`vorticity`."""
    _, nz, ny, nx = omega.shape
    for row in prange(nz * ny):
        k = row // ny
        j = row - k * ny
        for i in range(nx):
            gx = _difference(omega, 3, k, j, i, 0, nz, ny, nx)
            gy = _difference(omega, 3, k, j, i, 1, nz, ny, nx)
            gz = _difference(omega, 3, k, j, i, 2, nz, ny, nx)
            norm = np.sqrt(gx * gx + gy * gy + gz * gz)
            if norm < 1e-12:
                out[0, k, j, i] = 0.0
                out[1, k, j, i] = 0.0
                out[2, k, j, i] = 0.0
                continue
            s = strength * h / norm
            wx, wy, wz = omega[0, k, j, i], omega[1, k, j, i], omega[2, k, j, i]
            out[0, k, j, i] = s * (gy * wz - gz * wy)
            out[1, k, j, i] = s * (gz * wx - gx * wz)
            out[2, k, j, i] = s * (gx * wy - gy * wx)


@parallel_kernel
def decay(values, factor, target):
    """``values = target + factor * (values - target)`` for each field ``c`` of
    (c, nz, ny, nx), with ``factor[c]`` and ``target[c]`` (dissipation toward a rest
    value: 0 for density, the ambient temperature for temperature)."""
    count, nz, ny, nx = values.shape
    for row in prange(nz * ny):
        k = row // ny
        j = row - k * ny
        for c in range(count):
            f = factor[c]
            t = target[c]
            if f != 1.0:
                for i in range(nx):
                    values[c, k, j, i] = t + f * (values[c, k, j, i] - t)


@parallel_kernel
def clear_solids(scalars, solid, rest):
    """Set each field ``c`` of (c, nz, ny, nx) to ``rest[c]`` inside solid cells (smoke
    carried into an obstacle by interpolation does not stay there)."""
    count, nz, ny, nx = scalars.shape
    for row in prange(nz * ny):
        k = row // ny
        j = row - k * ny
        for i in range(nx):
            if solid[k, j, i]:
                for c in range(count):
                    scalars[c, k, j, i] = rest[c]
