"""Compiled kernels of advection on a staggered (MAC) grid: semi-Lagrangian back-tracing
(Stam 1999) and the MacCormack correction (Selle, Fedkiw, Kim, Liu & Rossignac 2008).

Positions inside kernels are in *grid units*: ``X = (x - origin) / h``, so cell
``(k, j, i)`` spans ``[i, i + 1] x [j, j + 1] x [k, k + 1]``. A field is sampled on its
own lattice, offset by ``(ox, oy, oz)`` cells: cell centres ``(0.5, 0.5, 0.5)``, the
x faces ``(0, 0.5, 0.5)``, the y faces ``(0.5, 0, 0.5)``, the z faces ``(0.5, 0.5, 0)``.
Samples beyond a lattice are clamped to its edge (constant extension). The trace and
the samplers are compiled once and called, not inlined into each of the kernels (which
cost 10 s of compilation each). Arrays are
``(nz, ny, nx)``-shaped, x fastest; every kernel runs ``prange`` over rows ``(k, j)``.
"""

from __future__ import annotations

from numba import prange

from .._jit import called, device, parallel_kernel


@device
def _axis(f, n):
    """Lower index and fraction of lattice coordinate ``f`` on an axis of ``n`` samples,
    clamped to the lattice."""
    if f <= 0.0:
        return 0, 0, 0.0
    top = n - 1
    if f >= top:
        return top, top, 0.0
    i = int(f)
    return i, i + 1, f - i


@device
def sample(field, fx, fy, fz):
    """Trilinear sample of ``field`` (nz, ny, nx) at lattice coordinates ``(fx, fy, fz)``."""
    nz, ny, nx = field.shape
    i0, i1, tx = _axis(fx, nx)
    j0, j1, ty = _axis(fy, ny)
    k0, k1, tz = _axis(fz, nz)
    c00 = field[k0, j0, i0] + tx * (field[k0, j0, i1] - field[k0, j0, i0])
    c01 = field[k0, j1, i0] + tx * (field[k0, j1, i1] - field[k0, j1, i0])
    c10 = field[k1, j0, i0] + tx * (field[k1, j0, i1] - field[k1, j0, i0])
    c11 = field[k1, j1, i0] + tx * (field[k1, j1, i1] - field[k1, j1, i0])
    c0 = c00 + ty * (c01 - c00)
    c1 = c10 + ty * (c11 - c10)
    return c0 + tz * (c1 - c0)


@called
def sample_of(fields, c, fx, fy, fz):
    """:func:`sample` of ``fields[c]`` for fields (count, nz, ny, nx), without a view."""
    _, nz, ny, nx = fields.shape
    i0, i1, tx = _axis(fx, nx)
    j0, j1, ty = _axis(fy, ny)
    k0, k1, tz = _axis(fz, nz)
    c00 = fields[c, k0, j0, i0] + tx * (fields[c, k0, j0, i1] - fields[c, k0, j0, i0])
    c01 = fields[c, k0, j1, i0] + tx * (fields[c, k0, j1, i1] - fields[c, k0, j1, i0])
    c10 = fields[c, k1, j0, i0] + tx * (fields[c, k1, j0, i1] - fields[c, k1, j0, i0])
    c11 = fields[c, k1, j1, i0] + tx * (fields[c, k1, j1, i1] - fields[c, k1, j1, i0])
    c0 = c00 + ty * (c01 - c00)
    c1 = c10 + ty * (c11 - c10)
    return c0 + tz * (c1 - c0)


@called
def sample_range(fields, n, fx, fy, fz):
    """Trilinear sample of ``fields[n]`` and the least and greatest of the (up to) eight
    values it mixes."""
    _, nz, ny, nx = fields.shape
    i0, i1, tx = _axis(fx, nx)
    j0, j1, ty = _axis(fy, ny)
    k0, k1, tz = _axis(fz, nz)
    a = fields[n, k0, j0, i0]
    b = fields[n, k0, j0, i1]
    c = fields[n, k0, j1, i0]
    d = fields[n, k0, j1, i1]
    e = fields[n, k1, j0, i0]
    f = fields[n, k1, j0, i1]
    g = fields[n, k1, j1, i0]
    h = fields[n, k1, j1, i1]
    lo = min(min(min(a, b), min(c, d)), min(min(e, f), min(g, h)))
    hi = max(max(max(a, b), max(c, d)), max(max(e, f), max(g, h)))
    c00 = a + tx * (b - a)
    c01 = c + tx * (d - c)
    c10 = e + tx * (f - e)
    c11 = g + tx * (h - g)
    c0 = c00 + ty * (c01 - c00)
    c1 = c10 + ty * (c11 - c10)
    return c0 + tz * (c1 - c0), lo, hi


@device
def velocity(u, v, w, x, y, z):
    """Velocity [m/s] at grid position ``(x, y, z)`` from the three face grids."""
    return (
        sample(u, x, y - 0.5, z - 0.5),
        sample(v, x - 0.5, y, z - 0.5),
        sample(w, x - 0.5, y - 0.5, z),
    )


@called
def trace(u, v, w, x, y, z, scale):
    """Where the flow carries grid position ``(x, y, z)`` in time ``scale * h`` [s]
    (``scale = dt / h``; negative to trace back): the midpoint rule (RK2)."""
    ax, ay, az = velocity(u, v, w, x, y, z)
    half = 0.5 * scale
    bx, by, bz = velocity(u, v, w, x + half * ax, y + half * ay, z + half * az)
    return x + scale * bx, y + scale * by, z + scale * bz


@parallel_kernel
def advect_semi_lagrangian(fields, ox, oy, oz, u, v, w, scale, out):
    """``out[c] = fields[c]`` sampled where each lattice point was ``dt`` ago.

    ``fields`` (c, nz, ny, nx): one or more fields on the same lattice (offset
    ``ox, oy, oz``), traced once per point; ``scale = dt / h``.
    """
    count, nz, ny, nx = fields.shape
    for row in prange(nz * ny):
        k = row // ny
        j = row - k * ny
        for i in range(nx):
            x, y, z = trace(u, v, w, i + ox, j + oy, k + oz, -scale)
            for c in range(count):
                out[c, k, j, i] = sample_of(fields, c, x - ox, y - oy, z - oz)


@parallel_kernel
def advect_forward(fields, ox, oy, oz, u, v, w, scale, out, lo, hi):
    """First pass of MacCormack: the semi-Lagrangian ``out`` and, for each point, the
    range ``[lo, hi]`` of the values the sample mixed (the clamp of the second pass)."""
    count, nz, ny, nx = fields.shape
    for row in prange(nz * ny):
        k = row // ny
        j = row - k * ny
        for i in range(nx):
            x, y, z = trace(u, v, w, i + ox, j + oy, k + oz, -scale)
            for c in range(count):
                s, a, b = sample_range(fields, c, x - ox, y - oy, z - oz)
                out[c, k, j, i] = s
                lo[c, k, j, i] = a
                hi[c, k, j, i] = b


@parallel_kernel
def maccormack_correct(fields, forward, ox, oy, oz, u, v, w, scale, lo, hi, out):
    """Second pass of MacCormack: ``out = forward + (fields - back) / 2``, where ``back``
    is ``forward`` carried back the other way (traced forward in time), clamped to
    ``[lo, hi]`` so the correction makes no new extrema (Selle et al. 2008, eq. 7-8)."""
    count, nz, ny, nx = fields.shape
    for row in prange(nz * ny):
        k = row // ny
        j = row - k * ny
        for i in range(nx):
            x, y, z = trace(u, v, w, i + ox, j + oy, k + oz, scale)
            for c in range(count):
                back = sample_of(forward, c, x - ox, y - oy, z - oz)
                value = forward[c, k, j, i] + 0.5 * (fields[c, k, j, i] - back)
                out[c, k, j, i] = min(max(value, lo[c, k, j, i]), hi[c, k, j, i])


@parallel_kernel
def bfecc_estimate(fields, forward, ox, oy, oz, u, v, w, scale, out):
    """Middle pass of BFECC (Kim, Liu, Llamas & Rossignac 2005): ``out = fields +
    (fields - back) / 2``, ``back`` being ``forward`` carried back the other way; the
    final value is ``out`` advected once more (then clamped)."""
    count, nz, ny, nx = fields.shape
    for row in prange(nz * ny):
        k = row // ny
        j = row - k * ny
        for i in range(nx):
            x, y, z = trace(u, v, w, i + ox, j + oy, k + oz, scale)
            for c in range(count):
                back = sample_of(forward, c, x - ox, y - oy, z - oz)
                out[c, k, j, i] = fields[c, k, j, i] + 0.5 * (fields[c, k, j, i] - back)


@parallel_kernel
def clamp_to(values, lo, hi):
    """``values = clip(values, lo, hi)`` in place."""
    count, nz, ny, nx = values.shape
    for row in prange(nz * ny):
        k = row // ny
        j = row - k * ny
        for c in range(count):
            for i in range(nx):
                values[c, k, j, i] = min(max(values[c, k, j, i], lo[c, k, j, i]), hi[c, k, j, i])


@parallel_kernel
def sample_velocity(u, v, w, origin, inv_h, positions, out):
    """Grid velocity [m/s] at world ``positions`` (3, n) into ``out`` (3, n)."""
    n = positions.shape[1]
    for p in prange(n):
        x = (positions[0, p] - origin[0]) * inv_h
        y = (positions[1, p] - origin[1]) * inv_h
        z = (positions[2, p] - origin[2]) * inv_h
        a, b, c = velocity(u, v, w, x, y, z)
        out[0, p] = a
        out[1, p] = b
        out[2, p] = c
