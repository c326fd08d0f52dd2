"""Light reaching the voxels of a volume: one transmittance volume per light and frame,
and the empty-space bricks the rays leap over.

A volume's voxels are packed with their light in one float32 array ``grid`` of shape
``(nx, ny, nz, C)`` (see :func:`.volume.light_volume`): channel 0 the density, one
channel per light (the fraction of it that reaches the voxel centre), two for the
ambient light (the fraction arriving from straight above and from straight below), the
temperature. Voxel ``(i, j, k)`` is centred at ``origin + (i + 0.5, j + 0.5, k + 0.5)
* cell``.

- **Directional lights**: :func:`sweep` goes slice by slice along the axis the light
  travels most along, from the face the light enters by. Each voxel reads the optical
  depth of the previous slice (one cell nearer the light) bilinearly where the ray
  toward the light crosses it and adds the segment's ``σ h (ρ + ρ_prev) / 2``
  (trapezoidal rule over the segment of length ``h = cell / |l_a|``): O(N³) for the
  whole volume, exact for a uniform medium whose rays stay inside the box. A ray that
  leaves the box through a side within the segment counts half the segment, at the
  voxel's density. The caller takes ``exp(-τ)``.
- **Ambient light**: :func:`columns`, the same along +y and -y, column by column.
- **Point lights**: :func:`march_point`, each cell of a grid at most ``POINT_GRID``
  cells a side marches to the light (or out of the box) with midpoint samples of the
  trilinear density; :func:`upsample` interpolates the fine channel from that grid.
- **Opaque geometry and particles** shadowing a directional light:
  :func:`shadow_voxels` multiplies the voxel's transmittance by
  :func:`.lighting.light_reaching` at its centre (shadow map and opacity map), for the
  voxels a sample can read.
- **Empty space**: :func:`brick_maxima` and :func:`brick_distances` give each brick of
  ``BRICK³`` voxels its Chebyshev distance to the nearest brick holding medium.

Every kernel writes each voxel once from values fixed before (the previous slice, the
density), in parallel over rows of fixed length: the result does not depend on the
number of threads.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from .._jit import device, parallel_kernel, serial_kernel
from .lighting import light_reaching
from .shading import LIGHT_DIRECTION

#: Voxels of each side of an empty-space brick.
BRICK = 4
#: Largest side [cells] of the grid on which point lights' transmittance is marched.
POINT_GRID = 64


@device
def axis_weights(u, n):
    """Lower index, upper index and weight of the upper one for a linear interpolation at
    voxel coordinate ``u`` (voxel ``i`` centred at ``u = i``) along an axis of ``n``
    voxels, clamped to the edge voxels."""
    u = min(max(u, 0.0), n - 1.0)
    i0 = min(int(u), max(n - 2, 0))
    i1 = min(i0 + 1, n - 1)
    return i0, i1, u - i0


@device
def trilinear(grid, ch, i0, i1, j0, j1, k0, k1, fx, fy, fz):
    """Channel ``ch`` of ``grid`` interpolated between the eight voxels given."""
    c00 = grid[i0, j0, k0, ch] + fz * (grid[i0, j0, k1, ch] - grid[i0, j0, k0, ch])
    c01 = grid[i0, j1, k0, ch] + fz * (grid[i0, j1, k1, ch] - grid[i0, j1, k0, ch])
    c10 = grid[i1, j0, k0, ch] + fz * (grid[i1, j0, k1, ch] - grid[i1, j0, k0, ch])
    c11 = grid[i1, j1, k0, ch] + fz * (grid[i1, j1, k1, ch] - grid[i1, j1, k0, ch])
    c0 = c00 + fy * (c01 - c00)
    c1 = c10 + fy * (c11 - c10)
    return c0 + fx * (c1 - c0)


@device
def density_at(grid, x, y, z, ox, oy, oz, inv_cell):
    """Trilinear density (channel 0) at the world point ``(x, y, z)`` [m]."""
    nx, ny, nz = grid.shape[0], grid.shape[1], grid.shape[2]
    i0, i1, fx = axis_weights((x - ox) * inv_cell - 0.5, nx)
    j0, j1, fy = axis_weights((y - oy) * inv_cell - 0.5, ny)
    k0, k1, fz = axis_weights((z - oz) * inv_cell - 0.5, nz)
    return trilinear(grid, 0, i0, i1, j0, j1, k0, k1, fx, fy, fz)


@parallel_kernel
def brick_maxima(rho, size, out):
    """``out[b]``: the largest density of the voxels a sample inside brick ``b`` (voxels
    ``[b size, (b + 1) size)`` per axis) interpolates between, i.e. the brick's voxels
    and one more on each side. A brick whose maximum is 0 holds no medium anywhere."""
    nx, ny, nz = rho.shape
    bx, by, bz = out.shape
    for bi in numba.prange(bx):
        i0, i1 = max(bi * size - 1, 0), min((bi + 1) * size + 1, nx)
        for bj in range(by):
            j0, j1 = max(bj * size - 1, 0), min((bj + 1) * size + 1, ny)
            for bk in range(bz):
                k0, k1 = max(bk * size - 1, 0), min((bk + 1) * size + 1, nz)
                most = np.float32(0.0)
                for i in range(i0, i1):
                    for j in range(j0, j1):
                        for k in range(k0, k1):
                            most = max(most, rho[i, j, k])
                out[bi, bj, bk] = most


@serial_kernel
def brick_distances(maxima, cap, out):
    """``out[b]``: the Chebyshev distance [bricks] from brick ``b`` to the nearest brick
    whose maximum is above 0 (0 for such a brick), at most ``cap``. Two raster passes,
    each taking the 13 neighbours already visited plus one (Rosenfeld & Pfaltz 1966's
    sequential distance transform, with the 26-neighbourhood: exact for this metric).
    A ray in brick ``b`` may leap across the cube of bricks within ``out[b] - 1``."""
    bx, by, bz = maxima.shape
    for i in range(bx):
        for j in range(by):
            for k in range(bz):
                out[i, j, k] = 0 if maxima[i, j, k] > 0.0 else cap
    for sweep_back in range(2):
        for a in range(bx):
            i = bx - 1 - a if sweep_back else a
            for b in range(by):
                j = by - 1 - b if sweep_back else b
                for c in range(bz):
                    k = bz - 1 - c if sweep_back else c
                    best = out[i, j, k]
                    for di in range(-1, 2):
                        for dj in range(-1, 2):
                            for dk in range(-1, 2):
                                # only the neighbours visited before (i, j, k) in this pass
                                order = di * 9 + dj * 3 + dk
                                if (order <= 0) if sweep_back else (order >= 0):
                                    continue
                                ni, nj, nk = i + di, j + dj, k + dk
                                if 0 <= ni < bx and 0 <= nj < by and 0 <= nk < bz:
                                    best = min(best, out[ni, nj, nk] + 1)
                    out[i, j, k] = best


@device
def slice_weights(u, n):
    """Bilinear lookup along one axis of a slice at voxel coordinate ``u``: ``(inside,
    i0, i1, f)``; ``inside`` is False beyond the box (half a voxel past the edge
    centres), where the light arrives unobstructed."""
    if u < -0.5 or u > n - 0.5:
        return False, 0, 0, 0.0
    i0, i1, f = axis_weights(u, n)
    return True, i0, i1, f


@parallel_kernel
def sweep(rho, counts, strides, first, step, du, dv, half, tau):
    """Optical depth toward a directional light, slice by slice (see the module docstring).

    ``rho`` and ``tau`` are the density and the output, raveled (nx, ny, nz) float32;
    ``counts`` and ``strides`` (3,) the voxels and voxel strides along the sweep axis
    ``a`` and the two slice axes ``p``, ``q``; ``first`` the index along ``a`` of the
    slice facing the light and ``step`` (±1) the way away from it; ``(du, dv)`` the
    offset [voxels] along ``p``, ``q`` of the point one slice nearer the light; ``half``
    half the optical depth per unit density of one slice step (extinction times the
    segment length [m], halved: the trapezoidal rule).
    """
    na, n_p, nq = counts[0], counts[1], counts[2]
    sa, sp, sq = strides[0], strides[1], strides[2]
    for s in range(na):
        a = first + s * step
        base = a * sa
        previous = (a - step) * sa
        for row in numba.prange(n_p):
            inside_u, u0, u1, fu = slice_weights(row + du, n_p)
            for col in range(nq):
                v = base + row * sp + col * sq
                here = rho[v]
                if s == 0:
                    tau[v] = half * here
                    continue
                inside_v, v0, v1, fv = slice_weights(col + dv, nq)
                if not (inside_u and inside_v):
                    tau[v] = half * here
                    continue
                w00 = previous + u0 * sp + v0 * sq
                w01 = previous + u0 * sp + v1 * sq
                w10 = previous + u1 * sp + v0 * sq
                w11 = previous + u1 * sp + v1 * sq
                r0 = rho[w00] + fv * (rho[w01] - rho[w00])
                r1 = rho[w10] + fv * (rho[w11] - rho[w10])
                t0 = tau[w00] + fv * (tau[w01] - tau[w00])
                t1 = tau[w10] + fv * (tau[w11] - tau[w10])
                tau[v] = t0 + fu * (t1 - t0) + half * (here + r0 + fu * (r1 - r0))


@parallel_kernel
def columns(rho, half, above, below):
    """Optical depth from each voxel centre straight up and straight down to the box's
    top and bottom faces (the ambient light's two directions): the sweep along ±y, each
    column of voxels on its own (trapezoidal rule, ``half`` as in :func:`sweep`)."""
    nx, ny, nz = rho.shape
    for i in numba.prange(nx):
        for k in range(nz):
            above[i, ny - 1, k] = half * rho[i, ny - 1, k]
            below[i, 0, k] = half * rho[i, 0, k]
        for j in range(ny - 2, -1, -1):
            for k in range(nz):
                above[i, j, k] = above[i, j + 1, k] + half * (rho[i, j, k] + rho[i, j + 1, k])
        for j in range(1, ny):
            for k in range(nz):
                below[i, j, k] = below[i, j - 1, k] + half * (rho[i, j, k] + rho[i, j - 1, k])


@parallel_kernel
def blur_xz(values, radius, scratch):
    """Box-filter ``values`` (nx, ny, nz) along x, then z, in each horizontal plane
    (``2 radius + 1`` voxels, clamped at the edges; ``scratch`` of the same shape). Run
    twice it approaches a Gaussian: the sky seen through a cone, not one column."""
    nx, ny, nz = values.shape
    width = 1.0 / (2 * radius + 1)
    for j in numba.prange(ny):
        for k in range(nz):  # a sliding sum along x: two terms a voxel
            acc = 0.0
            for d in range(-radius, radius + 1):
                acc += values[min(max(d, 0), nx - 1), j, k]
            for i in range(nx):
                scratch[i, j, k] = acc * width
                acc += values[min(i + radius + 1, nx - 1), j, k]
                acc -= values[max(i - radius, 0), j, k]
        for i in range(nx):  # then along z
            acc = 0.0
            for d in range(-radius, radius + 1):
                acc += scratch[i, j, min(max(d, 0), nz - 1)]
            for k in range(nz):
                values[i, j, k] = acc * width
                acc += scratch[i, j, min(k + radius + 1, nz - 1)]
                acc -= scratch[i, j, max(k - radius, 0)]


@device
def needed(bricks, size, i, j, k):
    """Whether a sample in a non-empty brick may read voxel ``(i, j, k)``: one of the
    bricks holding voxels ``i - 1 .. i + 1`` (per axis) is not empty (distance 0 in
    :func:`brick_distances`)."""
    bx, by, bz = bricks.shape
    for bi in range(max((i - 1) // size, 0), min((i + 1) // size, bx - 1) + 1):
        for bj in range(max((j - 1) // size, 0), min((j + 1) // size, by - 1) + 1):
            for bk in range(max((k - 1) // size, 0), min((k + 1) // size, bz - 1) + 1):
                if bricks[bi, bj, bk] == 0:
                    return True
    return False


@parallel_kernel
def shadow_voxels(grid, ch, bricks, size, ox, oy, oz, cell, lights, k, shadowing):
    """Multiply channel ``ch`` by the fraction of directional light ``k`` that opaque
    geometry and particles let reach each voxel centre (:func:`light_reaching`), where a
    sample may read the voxel and some light is left."""
    nx, ny, nz = grid.shape[0], grid.shape[1], grid.shape[2]
    lx = lights[k, LIGHT_DIRECTION]
    ly = lights[k, LIGHT_DIRECTION + 1]
    lz = lights[k, LIGHT_DIRECTION + 2]
    for i in numba.prange(nx):
        x = ox + (i + 0.5) * cell
        for j in range(ny):
            y = oy + (j + 0.5) * cell
            for kk in range(nz):
                if grid[i, j, kk, ch] < 1e-4 or not needed(bricks, size, i, j, kk):
                    continue
                z = oz + (kk + 0.5) * cell
                seen = light_reaching(lights, k, shadowing, lx, ly, lz, x, y, z)
                grid[i, j, kk, ch] = grid[i, j, kk, ch] * seen


@device
def box_exit(x, y, z, dx, dy, dz, lo, hi):
    """Distance along the unit direction ``d`` from the point ``(x, y, z)`` inside the
    box ``[lo, hi]`` to where it leaves the box."""
    t = math.inf
    if dx > 0.0:
        t = min(t, (hi[0] - x) / dx)
    elif dx < 0.0:
        t = min(t, (lo[0] - x) / dx)
    if dy > 0.0:
        t = min(t, (hi[1] - y) / dy)
    elif dy < 0.0:
        t = min(t, (lo[1] - y) / dy)
    if dz > 0.0:
        t = min(t, (hi[2] - z) / dz)
    elif dz < 0.0:
        t = min(t, (lo[2] - z) / dz)
    return max(t, 0.0)


@parallel_kernel
def march_point(grid, bricks, size, lo, hi, cell, tau_unit, px, py, pz, h, factor, out):
    """Transmittance from the centres of a coarse grid (``factor`` voxels a cell, ``out``
    its shape) to a point light at ``(px, py, pz)`` [m], marched with midpoint samples at
    most ``h`` [m] apart to the light or out of the box. ``tau_unit``: extinction [1/m
    per unit density]. ``bricks``: the distances of :func:`brick_distances`; cells further
    from the medium than the fine voxels they are interpolated into reach are left at
    1."""
    nx, ny, nz = grid.shape[0], grid.shape[1], grid.shape[2]
    reach = 1 + (int(factor) + 1 + size - 1) // size
    cx, cy, cz = out.shape
    inv_cell = 1.0 / cell
    for ci in numba.prange(cx):
        bi = min(int((ci + 0.5) * factor), nx - 1)
        x = lo[0] + min((ci + 0.5) * factor, nx) * cell
        for cj in range(cy):
            bj = min(int((cj + 0.5) * factor), ny - 1)
            y = lo[1] + min((cj + 0.5) * factor, ny) * cell
            for ck in range(cz):
                bk = min(int((ck + 0.5) * factor), nz - 1)
                z = lo[2] + min((ck + 0.5) * factor, nz) * cell
                out[ci, cj, ck] = 1.0
                if bricks[bi // size, bj // size, bk // size] > reach:
                    continue  # no sample reads the fine voxels this cell is spread over
                dx, dy, dz = px - x, py - y, pz - z
                dist = math.sqrt(dx * dx + dy * dy + dz * dz)
                if dist <= 0.0:
                    continue
                dx, dy, dz = dx / dist, dy / dist, dz / dist
                length = min(dist, box_exit(x, y, z, dx, dy, dz, lo, hi))
                steps = max(math.ceil(length / h), 1)
                hh = length / steps
                tau = 0.0
                for s in range(steps):
                    t = (s + 0.5) * hh
                    tau += density_at(
                        grid, x + t * dx, y + t * dy, z + t * dz, lo[0], lo[1], lo[2], inv_cell
                    )
                out[ci, cj, ck] = math.exp(-tau_unit * hh * tau)


@parallel_kernel
def upsample(coarse, factor, grid, ch):
    """Channel ``ch`` of ``grid`` interpolated trilinearly from ``coarse`` (cells of
    ``factor`` voxels, centred at voxel coordinate ``(c + 0.5) factor - 0.5``)."""
    nx, ny, nz = grid.shape[0], grid.shape[1], grid.shape[2]
    cx, cy, cz = coarse.shape
    inv = 1.0 / factor
    for i in numba.prange(nx):
        i0, i1, fx = axis_weights((i + 0.5) * inv - 0.5, cx)
        for j in range(ny):
            j0, j1, fy = axis_weights((j + 0.5) * inv - 0.5, cy)
            for k in range(nz):
                k0, k1, fz = axis_weights((k + 0.5) * inv - 0.5, cz)
                c00 = coarse[i0, j0, k0] + fz * (coarse[i0, j0, k1] - coarse[i0, j0, k0])
                c01 = coarse[i0, j1, k0] + fz * (coarse[i0, j1, k1] - coarse[i0, j1, k0])
                c10 = coarse[i1, j0, k0] + fz * (coarse[i1, j0, k1] - coarse[i1, j0, k0])
                c11 = coarse[i1, j1, k0] + fz * (coarse[i1, j1, k1] - coarse[i1, j1, k0])
                c0 = c00 + fy * (c01 - c00)
                c1 = c10 + fy * (c11 - c10)
                grid[i, j, k, ch] = c0 + fx * (c1 - c0)
