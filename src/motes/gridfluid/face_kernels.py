"""Compiled kernels on the faces of a staggered (MAC) grid: boundary conditions,
divergence, the pressure gradient, buoyancy and vorticity confinement.

A face grid of axis ``a`` (0 = x, 1 = y, 2 = z) has one more face than cells along
``a``: face ``(k, j, i)`` of the x grid lies between cells ``(k, j, i - 1)`` and
``(k, j, i)``. Arrays are ``(nz, ny, nx)``-shaped, x fastest, and every kernel runs
``prange`` over rows ``(k, j)``, working along the row in loops that vectorise: the face
kernels at flat offsets (:func:`_face_row`) into views of whole arrays taken once per
call, so that no view is made per row (each costs an atomic reference count update).

Boundaries: ``solid`` (nz, ny, nx) uint8 marks obstacle cells, moving at
``solid_velocity`` (3, nz, ny, nx) [m/s]; ``open_faces`` (6,) uint8 marks the open faces
of the domain (-x, +x, -y, +y, -z, +z); ``wall_velocity`` (6, 3) float32 is the velocity
of each closed face's wall [m/s] (its normal component is what the flow may not cross;
its tangential one drags the fluid where the wall has no slip).
"""

from __future__ import annotations

import numpy as np
from numba import prange

from .._jit import called, device, parallel_kernel


@called
def _face_row(axis, row, fz, fy, ny, nx):
    """Where face row ``row`` (flat index of (k, j)) of the face grid of ``axis`` lies, and
    its interior faces.

    Returns ``where`` (-1 on the domain's lower face, 1 on its upper one, 0 inside; the
    x grid's rows are inside, their first and last face on the domain's faces), then flat
    offsets (uint64): of the row's first interior face, of the cell below it along
    ``axis`` and of the cell above, and the count ``m`` of interior faces. An x face
    ``i`` lies between cells ``i - 1`` and ``i`` of its row, a y or z face between cell
    ``i`` of two rows; at ``where`` -1 the cell offset is that of the row above the
    face, at 1 of the row below.
    """
    k = row // fy
    j = row - k * fy
    face = np.uint64(row * (nx + 1 if axis == 0 else nx))
    if axis == 0:
        cells = np.uint64((k * ny + j) * nx)
        return 0, face + np.uint64(1), cells, cells + np.uint64(1), nx - 1
    index, n = (j, fy - 1) if axis == 1 else (k, fz - 1)
    where = -1 if index == 0 else (1 if index == n else 0)
    above = (k * ny + j) * nx  # the cell row (k, j), above the face along axis
    below = above - (nx if axis == 1 else ny * nx)
    if where < 0:
        below = above
    elif where > 0:
        above = below
    return where, face, np.uint64(below), np.uint64(above), nx


@parallel_kernel
def enforce_boundaries(face, axis, solid, solid_velocity, open_faces, wall_velocity):
    """Set the faces the flow may not cross: a closed domain face takes its wall's
    normal velocity, a face beside a solid cell the solid's (their mean between two).
    Faces of open domain faces are left to the pressure solve."""
    _, ny, nx = solid.shape
    fz, fy, _ = face.shape
    closed_lo, closed_hi = not open_faces[2 * axis], not open_faces[2 * axis + 1]
    wall_lo, wall_hi = wall_velocity[2 * axis, axis], wall_velocity[2 * axis + 1, axis]
    fs, ss, vs = face.ravel(), solid.ravel(), solid_velocity[axis].ravel()
    for row in prange(fz * fy):
        where, f, below, above, m = _face_row(axis, row, fz, fy, ny, nx)
        if axis == 0:  # the row's ends
            if closed_lo:
                fs[f - np.uint64(1)] = wall_lo
            if closed_hi:
                fs[f + np.uint64(m)] = wall_hi
        if where != 0:
            if closed_lo if where < 0 else closed_hi:
                wall = wall_lo if where < 0 else wall_hi
                for i in range(np.uint64(m)):
                    fs[f + i] = wall
            continue
        hit = 0
        for i in range(np.uint64(m)):
            hit |= ss[below + i] | ss[above + i]
        if hit == 0:  # no solid beside the row
            continue
        for i in range(np.uint64(m)):
            a, b = ss[below + i], ss[above + i]
            if a and b:
                fs[f + i] = np.float32(0.5) * (vs[below + i] + vs[above + i])
            elif a:
                fs[f + i] = vs[below + i]
            elif b:
                fs[f + i] = vs[above + i]


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
    _, ny, nx = solid.shape
    fz, fy, _ = face.shape
    open_lo, open_hi = open_faces[2 * axis], open_faces[2 * axis + 1]
    fs, qs, ss = face.ravel(), q.ravel(), solid.ravel()
    for row in prange(fz * fy):
        where, f, below, above, m = _face_row(axis, row, fz, fy, ny, nx)
        if axis == 0:  # the row's ends: q = 0 beyond an open face
            last = below + np.uint64(m)
            if open_lo and not ss[below]:
                fs[f - np.uint64(1)] -= qs[below]
            if open_hi and not ss[last]:
                fs[f + np.uint64(m)] += qs[last]
        if where == 0:
            for i in range(np.uint64(m)):
                g = fs[f + i] - (qs[above + i] - qs[below + i])
                fs[f + i] = g if (ss[below + i] | ss[above + i]) == 0 else fs[f + i]
        elif open_lo if where < 0 else open_hi:
            # the gradient 0 - q across the lower face, q - 0 across the upper one
            sign = np.float32(where)
            for i in range(np.uint64(m)):
                g = fs[f + i] + sign * qs[above + i]
                fs[f + i] = g if ss[above + i] == 0 else fs[f + i]


@parallel_kernel
def add_cell_force(face, axis, force, scale, solid):
    """``face += scale * (mean of force over the two cells beside it)`` on interior faces
    between fluid cells; ``force`` (nz, ny, nx) per cell (an acceleration [m/s²] with
    ``scale = dt``)."""
    _, ny, nx = solid.shape
    fz, fy, _ = face.shape
    half = np.float32(0.5 * scale)
    fs, a, ss = face.ravel(), force.ravel(), solid.ravel()
    for row in prange(fz * fy):
        where, f, below, above, m = _face_row(axis, row, fz, fy, ny, nx)
        if where == 0:
            for i in range(np.uint64(m)):
                g = fs[f + i] + half * (a[below + i] + a[above + i])
                fs[f + i] = g if (ss[below + i] | ss[above + i]) == 0 else fs[f + i]


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
def _across(n, index):
    """Neighbours (lower, upper) of ``index`` on an axis of ``n`` cells, clamped, and the
    reciprocal of their distance [1/cells] (0 along an axis of one cell: no derivative):
    central differences inside, one-sided at the domain's edge."""
    lower, upper = max(index - 1, 0), min(index + 1, n - 1)
    return lower, upper, np.float32(1.0 / (upper - lower)) if upper > lower else np.float32(0.0)


@device
def _add_x_derivative(f, scale, out):
    """``out += scale * df/dx`` along a row ``f`` (per cell; central inside, one-sided at
    the ends; ``f`` has at least two cells)."""
    n = f.shape[0]
    half = np.float32(0.5) * scale
    out[0] += scale * (f[1] - f[0])
    for i in range(1, n - 1):
        out[i] += half * (f[i + 1] - f[i - 1])
    out[n - 1] += scale * (f[n - 1] - f[n - 2])


@parallel_kernel
def vorticity(velocity, inv_h, out):
    """Vorticity ``curl u`` [1/s] at cell centres into ``out[0:3]`` and its magnitude into
    ``out[3]``, from cell-centred ``velocity`` (3, nz, ny, nx)."""
    _, nz, ny, nx = velocity.shape
    c = np.float32(inv_h)
    for row in prange(nz * ny):
        k = row // ny
        j = row - k * ny
        jm, jp, cy = _across(ny, j)
        km, kp, cz = _across(nz, k)
        cy *= c
        cz *= c
        vx, vy, vz = velocity[0], velocity[1], velocity[2]
        ox, oy, oz = out[0, k, j], out[1, k, j], out[2, k, j]
        for i in range(nx):
            ox[i] = cy * (vz[k, jp, i] - vz[k, jm, i]) - cz * (vy[kp, j, i] - vy[km, j, i])
            oy[i] = cz * (vx[kp, j, i] - vx[km, j, i])
            oz[i] = -cy * (vx[k, jp, i] - vx[k, jm, i])
        _add_x_derivative(vz[k, j], -c, oy)
        _add_x_derivative(vy[k, j], c, oz)
        magnitude = out[3, k, j]
        for i in range(nx):
            magnitude[i] = np.sqrt(ox[i] * ox[i] + oy[i] * oy[i] + oz[i] * oz[i])


@parallel_kernel
def confinement(omega, strength, h, out):
    """Vorticity confinement acceleration [m/s²] per cell (Fedkiw, Stam & Jensen 2001,
    eq. 9-11): ``strength * h * (N x omega)`` with ``N`` the unit gradient of
    ``|omega|``; ``omega`` (4, nz, ny, nx) from :func:`vorticity`."""
    _, nz, ny, nx = omega.shape
    size = omega[3]
    scale = np.float32(strength * h)
    for row in prange(nz * ny):
        k = row // ny
        j = row - k * ny
        jm, jp, cy = _across(ny, j)
        km, kp, cz = _across(nz, k)
        gx, gy, gz = out[0, k, j], out[1, k, j], out[2, k, j]
        for i in range(nx):  # the gradient of |omega| [per cell], in out for now
            gx[i] = 0.0
            gy[i] = cy * (size[k, jp, i] - size[k, jm, i])
            gz[i] = cz * (size[kp, j, i] - size[km, j, i])
        _add_x_derivative(size[k, j], np.float32(1.0), gx)
        wx, wy, wz = omega[0, k, j], omega[1, k, j], omega[2, k, j]
        for i in range(nx):
            a, b, c = gx[i], gy[i], gz[i]
            norm = np.sqrt(a * a + b * b + c * c)
            s = scale / norm if norm >= 1e-12 else np.float32(0.0)
            gx[i] = s * (b * wz[i] - c * wy[i])
            gy[i] = s * (c * wx[i] - a * wz[i])
            gz[i] = s * (a * wy[i] - b * wx[i])


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
