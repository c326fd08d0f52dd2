"""The one swept (a-priori) test: where a particle's path over a step first enters a
collider row.

A path over a step runs from ``x0`` to ``x0 + d``. Under a constant acceleration ``a``
it is the parabola ``x(f) = x0 + (d - b) f + b f²``, ``f`` in [0, 1], with the bend
``b = a h² / 2`` (``h`` the step); without one (``b = 0``) it is the chord. Planes are
met on the parabola itself, solving the quadratic exactly, so a ball dropped on the
ground bounces at its true time of impact; the other shapes are met on the chord (the
two differ by at most ``|a| h² / 8``: 0.2 mm for gravity at 60 steps per second). Shapes
are grown by the particle radius ``r``: exactly for planes, spheres and capsules; a box
grown by slabs keeps square corners (conservative); a triangle mesh is met at its
triangles' planes, and the stand-off returned (``r`` plus its shell thickness) says
how far off the surface to stop.

Tests: the roots of the plane's quadratic in the form that never cancels; ray and
sphere; ray and capsule as a finite cylinder and two balls (the first entry into a
union is the earliest entry into any part); the slab method for boxes (Kay & Kajiya
1986); Möller & Trumbore (1997) for triangles.

Every function returns ``(f, nx, ny, nz)`` (meshes add the stand-off), ``f`` > 1 when
the path enters nothing. The normal points out of the solid at the entry. A path that
starts inside the solid does not enter it: a-posteriori projection handles it. Like
:mod:`.distance`, the inlined functions take every constant from ``one`` so the fused
particle step can run them in float32.
"""

from __future__ import annotations

import numpy as np

from .._jit import device, serial_kernel
from .distance import segment_triangle, triangle_normal
from .layout import G, Kind

_PLANE = int(Kind.PLANE)
_SPHERE = int(Kind.SPHERE)
_BOX = int(Kind.BOX)
_CAPSULE = int(Kind.CAPSULE)


@device
def _plane_entry(table, c, x0, y0, z0, dx, dy, dz, bx, by, bz, r, one):
    """Entry of the parabola into the solid side of a plane grown by ``r``."""
    zero = one - one
    nx = table[c, G]
    ny = table[c, G + 1]
    nz = table[c, G + 2]
    s0 = x0 * nx + y0 * ny + z0 * nz - table[c, G + 3] - r
    bn = bx * nx + by * ny + bz * nz
    un = dx * nx + dy * ny + dz * nz - bn
    s1 = s0 + un + bn
    if s0 >= zero and s1 < zero:
        # The root of bn f² + un f + s0 = 0 in [0, 1]: 2 s0 / (-un + sqrt(un² - 4 bn s0))
        # never subtracts nearly equal numbers when the path comes down (un < 0).
        two = one + one
        root = np.sqrt(max(un * un - two * two * bn * s0, zero))
        denominator = root - un
        f = two * s0 / denominator if denominator > zero else zero
        return min(f, one), nx, ny, nz
    return one + one, zero, zero, zero


@device
def _ball_entry(ox, oy, oz, dx, dy, dz, radius, inside, one):
    """Entry of the chord ``o + f d`` (``o`` relative to the centre) into a ball, or
    with ``inside`` its exit from it (the solid is outside)."""
    zero = one - one
    s0 = ox * ox + oy * oy + oz * oz - radius * radius
    b = ox * dx + oy * dy + oz * dz
    a2 = dx * dx + dy * dy + dz * dz
    f = one + one
    if inside:
        if s0 <= zero and a2 > zero:
            f = (np.sqrt(b * b - a2 * s0) - b) / a2
    elif s0 >= zero and b < zero:
        disc = b * b - a2 * s0
        if disc >= zero:
            f = s0 / (np.sqrt(disc) - b)
    if f > one:
        return one + one, zero, zero, zero
    hx = (ox + f * dx) / radius
    hy = (oy + f * dy) / radius
    hz = (oz + f * dz) / radius
    if inside:
        return f, -hx, -hy, -hz
    return f, hx, hy, hz


@device
def _box_entry(table, c, x0, y0, z0, dx, dy, dz, r, inside, one):
    """Entry of the chord into an oriented box grown by ``r`` (slabs), or with
    ``inside`` its exit from the box shrunk by ``r``."""
    zero = one - one
    # Only entries in [0, 1] count: -1 and 2 stand for "before" and "after" the path.
    enter = -one
    leave = one + one
    fx = fy = fz = zero
    grow = -r if inside else r
    for a in range(3):
        ux = table[c, G + 6 + 3 * a]
        uy = table[c, G + 7 + 3 * a]
        uz = table[c, G + 8 + 3 * a]
        o = (x0 - table[c, G]) * ux + (y0 - table[c, G + 1]) * uy + (z0 - table[c, G + 2]) * uz
        v = dx * ux + dy * uy + dz * uz
        h = table[c, G + 3 + a] + grow
        if v == zero:
            if abs(o) > h and not inside:
                return one + one, zero, zero, zero
            continue
        t0 = (-h - o) / v
        t1 = (h - o) / v
        # Entering through the face toward -v, leaving through the face toward +v.
        sign = one if v < zero else -one
        if t0 > t1:
            t0, t1 = t1, t0
        if inside:
            if t1 < leave:
                leave = t1
                fx, fy, fz = sign * ux, sign * uy, sign * uz
        else:
            if t0 > enter:
                enter = t0
                fx, fy, fz = sign * ux, sign * uy, sign * uz
            leave = min(leave, t1)
    if inside:
        if zero <= leave <= one:
            return leave, fx, fy, fz
    elif enter <= leave and zero <= enter <= one:
        return enter, fx, fy, fz
    return one + one, zero, zero, zero


@device
def _capsule_entry(table, c, x0, y0, z0, dx, dy, dz, r, one):
    """Entry of the chord into a capsule grown by ``r``: its side (a finite cylinder)
    or either end ball, whichever comes first."""
    zero = one - one
    ax = table[c, G]
    ay = table[c, G + 1]
    az = table[c, G + 2]
    ux = table[c, G + 3] - ax
    uy = table[c, G + 4] - ay
    uz = table[c, G + 5] - az
    radius = table[c, G + 6] + r
    best, nx, ny, nz = _ball_entry(x0 - ax, y0 - ay, z0 - az, dx, dy, dz, radius, False, one)
    f, ex, ey, ez = _ball_entry(
        x0 - ax - ux, y0 - ay - uy, z0 - az - uz, dx, dy, dz, radius, False, one
    )
    if f < best:
        best, nx, ny, nz = f, ex, ey, ez
    # Side: |w(f)|² = radius², w the part of (x0 - a + f d) across the axis, times |u|².
    uu = ux * ux + uy * uy + uz * uz
    ox = x0 - ax
    oy = y0 - ay
    oz = z0 - az
    ud = ux * dx + uy * dy + uz * dz
    uo = ux * ox + uy * oy + uz * oz
    qa = uu * (dx * dx + dy * dy + dz * dz) - ud * ud
    qb = uu * (dx * ox + dy * oy + dz * oz) - uo * ud
    qc = uu * (ox * ox + oy * oy + oz * oz) - uo * uo - radius * radius * uu
    disc = qb * qb - qa * qc
    if qa > zero and qc > zero and disc >= zero:
        f = (-qb - np.sqrt(disc)) / qa
        along = uo + f * ud
        if zero <= f < best and zero < along < uu:
            t = along / uu
            best = f
            nx = (ox + f * dx - t * ux) / radius
            ny = (oy + f * dy - t * uy) / radius
            nz = (oz + f * dz - t * uz) / radius
    return best, nx, ny, nz


@device
def first_hit(kind, inside, table, c, x0, y0, z0, dx, dy, dz, bx, by, bz, r, one):
    """Earliest entry of a particle's path over a step into collider row ``c``.

    Parameters
    ----------
    kind : int
        ``table[c, KIND]``: PLANE, SPHERE, BOX or CAPSULE (meshes:
        :func:`mesh_first_hit`).
    inside : bool
        The row keeps particles inside (spheres and boxes: the path's exit is found).
    table : (k, ROW) array
        Packed rows (:mod:`motes.geometry.layout`).
    x0, y0, z0 : float
        Start of the path [m].
    dx, dy, dz : float
        Displacement over the step [m].
    bx, by, bz : float
        Bend ``a h² / 2`` of the path [m] (zero for a straight one).
    r : float
        Particle radius [m].
    one : float
        1 in the dtype to compute in.

    Returns
    -------
    f, nx, ny, nz : float
        Fraction of the step at the entry (> 1: none) and the unit normal there.
    """
    if kind == _PLANE:
        return _plane_entry(table, c, x0, y0, z0, dx, dy, dz, bx, by, bz, r, one)
    if kind == _SPHERE:
        radius = table[c, G + 3] - r if inside else table[c, G + 3] + r
        return _ball_entry(
            x0 - table[c, G],
            y0 - table[c, G + 1],
            z0 - table[c, G + 2],
            dx,
            dy,
            dz,
            radius,
            inside,
            one,
        )
    if kind == _CAPSULE:
        return _capsule_entry(table, c, x0, y0, z0, dx, dy, dz, r, one)
    return _box_entry(table, c, x0, y0, z0, dx, dy, dz, r, inside, one)


@serial_kernel
def mesh_first_hit(row, tri, cell_start, cell_tris, x0, y0, z0, dx, dy, dz, r):
    """Earliest crossing of the chord ``x0 -> x0 + d`` with a MESH row's triangles.

    ``tri`` (t, 9), ``cell_start`` and ``cell_tris`` as in
    :func:`motes.geometry.distance.mesh_distance`. Returns ``(f, nx, ny, nz, stand_off)``
    with ``f = inf`` for no crossing; the normal faces the side the path came from, and
    ``stand_off`` (``r`` plus the shell's half-thickness [m]) is how far from the
    triangle's plane the particle belongs. float64; called, not inlined (a loop over
    grid cells).
    """
    ox, oy, oz, cell = row[G], row[G + 1], row[G + 2], row[G + 3]
    n0, n1, n2 = int(row[G + 4]), int(row[G + 5]), int(row[G + 6])
    offset = int(row[G + 7])
    grow = r + row[G + 8]
    dims = (n0, n1, n2)
    base = (ox, oy, oz)
    start = (x0, y0, z0)
    step = (dx, dy, dz)
    lo = np.empty(3, dtype=np.int64)
    hi = np.empty(3, dtype=np.int64)
    for a in range(3):
        low = min(start[a], start[a] + step[a]) - grow
        high = max(start[a], start[a] + step[a]) + grow
        lo[a] = min(max(int(np.floor((low - base[a]) / cell)), 0), dims[a] - 1)
        hi[a] = min(max(int(np.floor((high - base[a]) / cell)), 0), dims[a] - 1)
    best = np.inf
    bt = -1
    for i in range(lo[0], hi[0] + 1):
        for j in range(lo[1], hi[1] + 1):
            for k in range(lo[2], hi[2] + 1):
                c = offset + (i * n1 + j) * n2 + k
                for e in range(cell_start[c], cell_start[c + 1]):
                    s = segment_triangle(x0, y0, z0, dx, dy, dz, tri, cell_tris[e])
                    if s < best:
                        best = s
                        bt = cell_tris[e]
    if bt < 0:
        return np.inf, 0.0, 0.0, 0.0, 0.0
    nx, ny, nz = triangle_normal(tri, bt)
    if nx * dx + ny * dy + nz * dz > 0.0:  # face the side the particle came from
        nx, ny, nz = -nx, -ny, -nz
    return best, nx, ny, nz, grow
