"""Compiled kernels of advection on a staggered (MAC) grid: semi-Lagrangian back-tracing
(Stam 1999), the MacCormack correction (Selle, Fedkiw, Kim, Liu & Rossignac 2008) and
BFECC (Kim, Liu, Llamas & Rossignac 2005).

Positions inside kernels are in *grid units*: ``X = (x - origin) / h``, so cell
``(k, j, i)`` spans ``[i, i + 1] x [j, j + 1] x [k, k + 1]``. A field is sampled on its
own lattice, offset by ``(ox, oy, oz)`` cells: cell centres ``(0.5, 0.5, 0.5)``, the
x faces ``(0, 0.5, 0.5)``, the y faces ``(0.5, 0, 0.5)``, the z faces ``(0.5, 0.5, 0)``.
Samples beyond a lattice are clamped to its edge (constant extension). Arrays are
``(nz, ny, nx)``-shaped, x fastest; every kernel runs ``prange`` over rows.

A point is traced with the midpoint rule (RK2). Its first velocity is taken at the
lattice point itself, where trilinear interpolation of the face grids reduces to the
mean of one, two or four faces (:func:`_start_3d`); the midpoint's is trilinear. A 2D
fluid (one cell thick, ``w`` unused: its fields' samples do not depend on z) has a
kernel of its own, bilinear, that never reads ``w``.

The passes of the schemes share one kernel per dimension (:func:`_carry_2d`,
:func:`_carry_3d`), compiled once, and differ in what is done with the traced sample
(``mode``). Each kernel works a row at a time in loops over the row's points, most of
which vectorise; only the interpolations gather. Indices are unsigned in the hot loops
(Numba wraps a signed index that may be negative with a select per access), and the
arithmetic stays in float32: together, on one thread, 10 times faster in 2D and 6 times
in 3D than a trace per point through compiled functions called in float64.
"""

from __future__ import annotations

import numpy as np
from numba import prange

from .._jit import device, fma, parallel_kernel

#: What a carry kernel does with the value sampled at the traced point.
SEMI_LAGRANGIAN = 0  # out = sample
FORWARD = 1  # out = sample; lo, hi = the range of the values it mixed
CORRECT = 2  # out = clamp(forward + (fields - sample) / 2, lo, hi)
ESTIMATE = 3  # out = fields + (fields - sample) / 2

#: The lattices a field may live on, by offset (ox, oy, oz) in cells.
LATTICES = {(0.5, 0.5, 0.5): 0, (0.0, 0.5, 0.5): 1, (0.5, 0.0, 0.5): 2, (0.5, 0.5, 0.0): 3}


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


@device
def velocity(u, v, w, x, y, z):
    """Velocity [m/s] at grid position ``(x, y, z)`` from the three face grids."""
    return (
        sample(u, x, y - 0.5, z - 0.5),
        sample(v, x - 0.5, y, z - 0.5),
        sample(w, x - 0.5, y - 0.5, z),
    )


# -- the hot path: float32, unsigned indices ----------------------------------------------


@device
def _extent(n):
    """The largest coordinate (float32) and lower index (float32) on an axis of ``n``
    samples."""
    return np.float32(n - 1), np.float32(max(n - 2, 0))


@device
def _locate(f, top, cap):
    """Lower index (uint64) and fraction (float32) of lattice coordinate ``f`` (float32)
    clamped to ``[0, top]``, the index at most ``cap`` (from :func:`_extent`): branch-free,
    so a loop of them vectorises."""
    g = min(max(f, np.float32(0.0)), top)
    lower = np.floor(min(g, cap))
    return np.uint64(lower), g - lower


@device
def _lerp(a, b, t):
    return fma(t, b - a, a)


@device
def _strides(grid):
    """Flat strides (uint64) of the y and z axes of ``grid`` (..., nz, ny, nx), 0 along an
    axis of one sample (its clamped corners coincide)."""
    nz, ny, nx = grid.shape[-3], grid.shape[-2], grid.shape[-1]
    return np.uint64(nx if ny > 1 else 0), np.uint64(nx * ny if nz > 1 else 0)


@device
def _gather_2d(g, at, sy, tx, ty):
    """Bilinear sample of the flat grid ``g`` from corner ``at`` (row stride ``sy``)."""
    one = np.uint64(1)
    return _lerp(_lerp(g[at], g[at + one], tx), _lerp(g[at + sy], g[at + sy + one], tx), ty)


@device
def _gather(g, at, sy, sz, tx, ty, tz):
    """Trilinear sample of the flat grid ``g`` from corner ``at`` (strides ``sy``,
    ``sz``)."""
    one = np.uint64(1)
    near = _lerp(_lerp(g[at], g[at + one], tx), _lerp(g[at + sy], g[at + sy + one], tx), ty)
    at = at + sz
    far = _lerp(_lerp(g[at], g[at + one], tx), _lerp(g[at + sy], g[at + sy + one], tx), ty)
    return _lerp(near, far, tz)


@device
def _mean4(a, b, c, d):
    return np.float32(0.25) * ((a + b) + (c + d))


@device
def _start_3d(lattice, u, v, w, k, j, i):
    """Velocity at lattice point (k, j, i) (uint64) of ``lattice`` (0: centres, 1-3: x,
    y, z faces): trilinear interpolation at a lattice point is the mean of the one, two
    or four faces around it (clamped at the domain's edge)."""
    nz, ny, nx = u.shape[0], u.shape[1], v.shape[2]
    one = np.uint64(1)
    half = np.float32(0.5)
    if lattice == 0:
        return (
            half * (u[k, j, i] + u[k, j, i + one]),
            half * (v[k, j, i] + v[k, j + one, i]),
            half * (w[k, j, i] + w[k + one, j, i]),
        )
    if lattice == 1:
        i0, i1 = max(i, one) - one, min(i, np.uint64(nx - 1))
        return (
            u[k, j, i],
            _mean4(v[k, j, i0], v[k, j, i1], v[k, j + one, i0], v[k, j + one, i1]),
            _mean4(w[k, j, i0], w[k, j, i1], w[k + one, j, i0], w[k + one, j, i1]),
        )
    if lattice == 2:
        j0, j1 = max(j, one) - one, min(j, np.uint64(ny - 1))
        return (
            _mean4(u[k, j0, i], u[k, j0, i + one], u[k, j1, i], u[k, j1, i + one]),
            v[k, j, i],
            _mean4(w[k, j0, i], w[k, j1, i], w[k + one, j0, i], w[k + one, j1, i]),
        )
    k0, k1 = max(k, one) - one, min(k, np.uint64(nz - 1))
    return (
        _mean4(u[k0, j, i], u[k0, j, i + one], u[k1, j, i], u[k1, j, i + one]),
        _mean4(v[k0, j, i], v[k0, j + one, i], v[k1, j, i], v[k1, j + one, i]),
        w[k, j, i],
    )


@device
def _start_2d(lattice, u, v, j, i):
    """:func:`_start_3d` of a 2D fluid: ``u``, ``v`` (ny, nx + 1), (ny + 1, nx)."""
    ny, nx = u.shape[0], v.shape[1]
    one = np.uint64(1)
    half = np.float32(0.5)
    if lattice == 0:
        return half * (u[j, i] + u[j, i + one]), half * (v[j, i] + v[j + one, i])
    if lattice == 1:
        i0, i1 = max(i, one) - one, min(i, np.uint64(nx - 1))
        return u[j, i], _mean4(v[j, i0], v[j, i1], v[j + one, i0], v[j + one, i1])
    j0, j1 = max(j, one) - one, min(j, np.uint64(ny - 1))
    return _mean4(u[j0, i], u[j0, i + one], u[j1, i], u[j1, i + one]), v[j, i]


#: Rows of a work item: its scratch rows are allocated once per item.
ROWS = 8


@device
def _finish(mode, fields, sampled, lo, hi, out, at, value, low, high):
    """Store what ``mode`` makes of ``value``, the sample at the point traced from flat
    index ``at``, and the range [low, high] of the values it mixed."""
    if mode == SEMI_LAGRANGIAN:
        out[at] = value
    elif mode == FORWARD:
        out[at] = value
        lo[at] = low
        hi[at] = high
    elif mode == CORRECT:
        corrected = fma(np.float32(0.5), fields[at] - value, sampled[at])
        out[at] = min(max(corrected, lo[at]), hi[at])
    else:
        here = fields[at]
        out[at] = fma(np.float32(0.5), here - value, here)


@parallel_kernel
def _carry_2d(mode, lattice, fields, sampled, ox, oy, u, v, scale, lo, hi, out):
    """One pass (``mode``) of advection of a 2D fluid's ``fields`` (count, 1, ny, nx) on
    ``lattice`` (offset ``ox, oy``): each point traced by ``scale = +-dt / h`` (negative:
    back in time) through ``u``, ``v`` (1, ...), and ``sampled`` (count, 1, ny, nx)
    sampled there.

    A row at a time, in loops over its points: the midpoints of the traces; where they
    fall on the u and v grids (vectorised); the velocity there and the traced points
    (gathers); where those fall on the field's lattice (vectorised); then field by field,
    the samples."""
    count, _, ny, nx = fields.shape
    u2, v2 = u[0], v[0]
    uf, vf = u.ravel(), v.ravel()
    f_, s_, lo_, hi_, out_ = fields.ravel(), sampled.ravel(), lo.ravel(), hi.ravel(), out.ravel()
    sy = np.uint64(nx)
    plane = np.uint64(nx * ny)
    usy, vsy = np.uint64(u.shape[2]), np.uint64(v.shape[2])
    ux_top, ux_cap = _extent(u.shape[2])
    uy_top, uy_cap = _extent(u.shape[1])
    vx_top, vx_cap = _extent(v.shape[2])
    vy_top, vy_cap = _extent(v.shape[1])
    fx_top, fx_cap = _extent(nx)
    fy_top, fy_cap = _extent(ny)
    s = np.float32(scale)
    half = np.float32(0.5) * s
    h = np.float32(0.5)
    fox, foy = np.float32(ox), np.float32(oy)
    for block in prange((ny + ROWS - 1) // ROWS):
        px = np.empty(nx, np.float32)
        py = np.empty(nx, np.float32)
        cu = np.empty(nx, np.uint64)
        cv = np.empty(nx, np.uint64)
        t = np.empty((4, nx), np.float32)
        for row in range(block * ROWS, min(ny, block * ROWS + ROWS)):
            j = np.uint64(row)
            y = np.float32(row) + foy
            for m in range(nx):
                ax, ay = _start_2d(lattice, u2, v2, j, np.uint64(m))
                px[m] = fma(half, ax, np.float32(m) + fox)
                py[m] = fma(half, ay, y)
            for m in range(nx):
                i0, tx = _locate(px[m], ux_top, ux_cap)
                j0, ty = _locate(py[m] - h, uy_top, uy_cap)
                cu[m] = j0 * usy + i0
                t[0, m] = tx
                t[1, m] = ty
                i0, tx = _locate(px[m] - h, vx_top, vx_cap)
                j0, ty = _locate(py[m], vy_top, vy_cap)
                cv[m] = j0 * vsy + i0
                t[2, m] = tx
                t[3, m] = ty
            for m in range(nx):
                bx = _gather_2d(uf, cu[m], usy, t[0, m], t[1, m])
                by = _gather_2d(vf, cv[m], vsy, t[2, m], t[3, m])
                px[m] = fma(s, bx, np.float32(m))
                py[m] = fma(s, by, y) - foy
            for m in range(nx):
                i0, tx = _locate(px[m], fx_top, fx_cap)
                j0, ty = _locate(py[m], fy_top, fy_cap)
                cu[m] = j0 * sy + i0
                t[0, m] = tx
                t[1, m] = ty
            at = j * sy
            for c in range(np.uint64(count)):
                first = c * plane
                _samples_2d(mode, f_, s_, lo_, hi_, out_, first, at, cu, t, sy, nx)


@device
def _samples_2d(mode, fields, sampled, lo, hi, out, first, at, corner, t, sy, nx):
    """The last loop of :func:`_carry_2d`: a row of one field."""
    one = np.uint64(1)
    for m in range(nx):
        b = first + corner[m]
        tx, ty = t[0, m], t[1, m]
        p, q = sampled[b], sampled[b + one]
        r, w = sampled[b + sy], sampled[b + sy + one]
        value = _lerp(_lerp(p, q, tx), _lerp(r, w, tx), ty)
        low = min(min(p, q), min(r, w))
        high = max(max(p, q), max(r, w))
        _finish(mode, fields, sampled, lo, hi, out, first + at + np.uint64(m), value, low, high)


@parallel_kernel
def _carry_3d(mode, lattice, fields, sampled, ox, oy, oz, u, v, w, scale, lo, hi, out):
    """:func:`_carry_2d` in 3D: ``fields`` and ``sampled`` (count, nz, ny, nx).

    The three velocity samples at a midpoint share their fractions: along x, ``u`` is
    sampled at the point's coordinate on a lattice of ``nx + 1`` faces, ``v`` and ``w``
    half a cell lower on one of ``nx`` (likewise along y and z), so each axis is
    located twice, not three times."""
    count, nz, ny, nx = fields.shape
    f_, s_, lo_, hi_, out_ = fields.ravel(), sampled.ravel(), lo.ravel(), hi.ravel(), out.ravel()
    grids = (u.ravel(), v.ravel(), w.ravel())
    sy, sz = _strides(fields)
    plane = np.uint64(nx * ny * nz)
    usy, usz = _strides(u)
    vsy, vsz = _strides(v)
    wsy, wsz = _strides(w)
    # (top, cap) of each axis: on the faces normal to it, and on the other two grids
    x_face, x_mid = _extent(u.shape[2]), _extent(v.shape[2])
    y_face, y_mid = _extent(v.shape[1]), _extent(u.shape[1])
    z_face, z_mid = _extent(w.shape[0]), _extent(u.shape[0])
    fx, fy, fz = _extent(nx), _extent(ny), _extent(nz)
    s = np.float32(scale)
    half = np.float32(0.5) * s
    h = np.float32(0.5)
    fox, foy, foz = np.float32(ox), np.float32(oy), np.float32(oz)
    rows = nz * ny
    for block in prange((rows + ROWS - 1) // ROWS):
        p = np.empty((3, nx), np.float32)
        corner = np.empty((3, nx), np.uint64)
        t = np.empty((6, nx), np.float32)  # fractions: x face, x mid, y face, ...
        for row in range(block * ROWS, min(rows, block * ROWS + ROWS)):
            k = np.uint64(row // ny)
            j = np.uint64(row % ny)
            y = np.float32(j) + foy
            z = np.float32(k) + foz
            for m in range(nx):
                ax, ay, az = _start_3d(lattice, u, v, w, k, j, np.uint64(m))
                p[0, m] = fma(half, ax, np.float32(m) + fox)
                p[1, m] = fma(half, ay, y)
                p[2, m] = fma(half, az, z)
            for m in range(nx):  # these three loops vectorise
                on_face, t[0, m] = _locate(p[0, m], x_face[0], x_face[1])
                mid, t[1, m] = _locate(p[0, m] - h, x_mid[0], x_mid[1])
                corner[0, m] = on_face
                corner[1, m] = mid
                corner[2, m] = mid
            for m in range(nx):
                on_face, t[2, m] = _locate(p[1, m], y_face[0], y_face[1])
                mid, t[3, m] = _locate(p[1, m] - h, y_mid[0], y_mid[1])
                corner[0, m] += mid * usy
                corner[1, m] += on_face * vsy
                corner[2, m] += mid * wsy
            for m in range(nx):
                on_face, t[4, m] = _locate(p[2, m], z_face[0], z_face[1])
                mid, t[5, m] = _locate(p[2, m] - h, z_mid[0], z_mid[1])
                corner[0, m] += mid * usz
                corner[1, m] += mid * vsz
                corner[2, m] += on_face * wsz
            for m in range(nx):
                xf, xm, yf, ym, zf, zm = t[0, m], t[1, m], t[2, m], t[3, m], t[4, m], t[5, m]
                bx = _gather(grids[0], corner[0, m], usy, usz, xf, ym, zm)
                by = _gather(grids[1], corner[1, m], vsy, vsz, xm, yf, zm)
                bz = _gather(grids[2], corner[2, m], wsy, wsz, xm, ym, zf)
                p[0, m] = fma(s, bx, np.float32(m))
                p[1, m] = fma(s, by, y) - foy
                p[2, m] = fma(s, bz, z) - foz
            for m in range(nx):
                i0, t[0, m] = _locate(p[0, m], fx[0], fx[1])
                j0, t[1, m] = _locate(p[1, m], fy[0], fy[1])
                k0, t[2, m] = _locate(p[2, m], fz[0], fz[1])
                corner[0, m] = k0 * sz + j0 * sy + i0
            at = np.uint64(row) * np.uint64(nx)
            for c in range(np.uint64(count)):
                first = c * plane
                _samples_3d(mode, f_, s_, lo_, hi_, out_, first, at, corner, t, sy, sz, nx)


@device
def _samples_3d(mode, fields, sampled, lo, hi, out, first, at, corner, t, sy, sz, nx):
    """The last loop of :func:`_carry_3d`: a row of one field."""
    one = np.uint64(1)
    for m in range(nx):
        b = first + corner[0, m]
        tx, ty, tz = t[0, m], t[1, m], t[2, m]
        p0, p1 = sampled[b], sampled[b + one]
        p2, p3 = sampled[b + sy], sampled[b + sy + one]
        b = b + sz
        p4, p5 = sampled[b], sampled[b + one]
        p6, p7 = sampled[b + sy], sampled[b + sy + one]
        near = _lerp(_lerp(p0, p1, tx), _lerp(p2, p3, tx), ty)
        far = _lerp(_lerp(p4, p5, tx), _lerp(p6, p7, tx), ty)
        low = min(min(min(p0, p1), min(p2, p3)), min(min(p4, p5), min(p6, p7)))
        high = max(max(max(p0, p1), max(p2, p3)), max(max(p4, p5), max(p6, p7)))
        value = _lerp(near, far, tz)
        _finish(mode, fields, sampled, lo, hi, out, first + at + np.uint64(m), value, low, high)


def _carry(mode, fields, sampled, ox, oy, oz, u, v, w, scale, lo, hi, out) -> None:
    """Run one pass: the 2D kernel where the fluid is one cell thick (and so are the
    fields), else the 3D one."""
    lattice = LATTICES.get((float(ox), float(oy), float(oz)))
    if lattice is None:
        raise ValueError(f"no lattice at offset {(ox, oy, oz)}; the lattices are {list(LATTICES)}")
    for name, array in (("sampled", sampled), ("lo", lo), ("hi", hi), ("out", out)):
        if array.shape != fields.shape:
            raise ValueError(f"{name} has shape {array.shape}, the fields {fields.shape}")
    flat = u.shape[0] == 1
    if flat and fields.shape[1] > 1 and not (fields.any() or sampled.any()):
        # a 2D fluid's w faces, zero but where a source pulls the flow along z
        for array in {id(a): a for a in (out, lo, hi)}.values():
            array[...] = 0.0
        return
    if flat and fields.shape[1] == 1:
        _carry_2d(mode, lattice, fields, sampled, ox, oy, u, v, scale, lo, hi, out)
    else:
        _carry_3d(mode, lattice, fields, sampled, ox, oy, oz, u, v, w, scale, lo, hi, out)


def advect_semi_lagrangian(fields, ox, oy, oz, u, v, w, scale, out) -> None:
    """``out[c] = fields[c]`` sampled where each lattice point was ``dt`` ago.

    ``fields`` (c, nz, ny, nx): one or more fields on the same lattice (offset
    ``ox, oy, oz``), traced once per point; ``scale = dt / h``.
    """
    _carry(SEMI_LAGRANGIAN, fields, fields, ox, oy, oz, u, v, w, -scale, out, out, out)


def advect_forward(fields, ox, oy, oz, u, v, w, scale, out, lo, hi) -> None:
    """First pass of MacCormack: the semi-Lagrangian ``out`` and, for each point, the
    range ``[lo, hi]`` of the values the sample mixed (the clamp of the second pass)."""
    _carry(FORWARD, fields, fields, ox, oy, oz, u, v, w, -scale, lo, hi, out)


def maccormack_correct(fields, forward, ox, oy, oz, u, v, w, scale, lo, hi, out) -> None:
    """Second pass of MacCormack: ``out = forward + (fields - back) / 2``, where ``back``
    is ``forward`` carried back the other way (traced forward in time), clamped to
    ``[lo, hi]`` so the correction makes no new extrema (Selle et al. 2008, eq. 7-8)."""
    _carry(CORRECT, fields, forward, ox, oy, oz, u, v, w, scale, lo, hi, out)


def bfecc_estimate(fields, forward, ox, oy, oz, u, v, w, scale, out) -> None:
    """Middle pass of BFECC (Kim, Liu, Llamas & Rossignac 2005): ``out = fields +
    (fields - back) / 2``, ``back`` being ``forward`` carried back the other way; the
    final value is ``out`` advected once more (then clamped)."""
    _carry(ESTIMATE, fields, forward, ox, oy, oz, u, v, w, scale, out, out, out)


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
