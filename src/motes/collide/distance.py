"""Signed distances from a point to packed collider shapes.

The shape distances are inlined device functions; the mesh query, a loop over grid
cells and triangles, is a compiled function of its own (called, not inlined: it costs
far more than a call, and inlining it into every caller tripled their compile time).

Rows are packed by :mod:`.contact` (:data:`~.contact.ROW`): column 0 the shape kind,
columns 4.. its geometry. Each function returns the signed distance [m] (negative
inside the solid) and the unit normal pointing out of it.
"""

from __future__ import annotations

import numpy as np

from .._jit import device, serial_kernel

PLANE, SPHERE, BOX, CAPSULE, MESH = 0, 1, 2, 3, 4
G = 4  # first geometry column


@device
def shape_distance(kind, row, px, py, pz):
    """Signed distance and outward normal for a plane, sphere, box or capsule row."""
    if kind == PLANE:
        nx, ny, nz = row[G], row[G + 1], row[G + 2]
        return px * nx + py * ny + pz * nz - row[G + 3], nx, ny, nz
    if kind == SPHERE or kind == CAPSULE:  # noqa: SIM109 (plain compares compile to two ints)
        if kind == SPHERE:
            cx, cy, cz, radius = row[G], row[G + 1], row[G + 2], row[G + 3]
        else:
            ax, ay, az = row[G], row[G + 1], row[G + 2]
            ux, uy, uz = row[G + 3] - ax, row[G + 4] - ay, row[G + 5] - az
            uu = ux * ux + uy * uy + uz * uz
            t = ((px - ax) * ux + (py - ay) * uy + (pz - az) * uz) / max(uu, 1e-300)
            t = min(max(t, 0.0), 1.0)
            cx, cy, cz, radius = ax + t * ux, ay + t * uy, az + t * uz, row[G + 6]
        dx, dy, dz = px - cx, py - cy, pz - cz
        dist = np.sqrt(dx * dx + dy * dy + dz * dz)
        if dist == 0.0:
            return -radius, 0.0, 1.0, 0.0  # at the centre: out along +y
        return dist - radius, dx / dist, dy / dist, dz / dist
    # Oriented box: centre G..G+2, half extents G+3..G+5, axes (rows) G+6..G+14.
    dx, dy, dz = px - row[G], py - row[G + 1], pz - row[G + 2]
    l0 = dx * row[G + 6] + dy * row[G + 7] + dz * row[G + 8]
    l1 = dx * row[G + 9] + dy * row[G + 10] + dz * row[G + 11]
    l2 = dx * row[G + 12] + dy * row[G + 13] + dz * row[G + 14]
    q0 = abs(l0) - row[G + 3]
    q1 = abs(l1) - row[G + 4]
    q2 = abs(l2) - row[G + 5]
    o0 = max(q0, 0.0) * (1.0 if l0 >= 0 else -1.0)
    o1 = max(q1, 0.0) * (1.0 if l1 >= 0 else -1.0)
    o2 = max(q2, 0.0) * (1.0 if l2 >= 0 else -1.0)
    out2 = o0 * o0 + o1 * o1 + o2 * o2
    if out2 > 0.0:
        # Outside: Euclidean distance to the box (faces, edges and corners alike).
        dist = np.sqrt(out2)
        o0 /= dist
        o1 /= dist
        o2 /= dist
    else:
        # Inside: leave through the face of least penetration.
        dist = max(q0, max(q1, q2))
        o0 = (1.0 if l0 >= 0 else -1.0) if q0 == dist else 0.0
        o1 = (1.0 if l1 >= 0 else -1.0) if (q1 == dist and o0 == 0.0) else 0.0
        o2 = (1.0 if l2 >= 0 else -1.0) if (o0 == 0.0 and o1 == 0.0) else 0.0
    nx = o0 * row[G + 6] + o1 * row[G + 9] + o2 * row[G + 12]
    ny = o0 * row[G + 7] + o1 * row[G + 10] + o2 * row[G + 13]
    nz = o0 * row[G + 8] + o1 * row[G + 11] + o2 * row[G + 14]
    return dist, nx, ny, nz


@device
def closest_on_triangle(px, py, pz, tri, t):
    """Closest point to p on triangle ``tri[t]`` (a, b, c flattened), Ericson 2005 §5.1.5."""
    ax, ay, az = tri[t, 0], tri[t, 1], tri[t, 2]
    abx, aby, abz = tri[t, 3] - ax, tri[t, 4] - ay, tri[t, 5] - az
    acx, acy, acz = tri[t, 6] - ax, tri[t, 7] - ay, tri[t, 8] - az
    apx, apy, apz = px - ax, py - ay, pz - az
    d1 = abx * apx + aby * apy + abz * apz
    d2 = acx * apx + acy * apy + acz * apz
    if d1 <= 0.0 and d2 <= 0.0:
        return ax, ay, az
    bpx, bpy, bpz = px - tri[t, 3], py - tri[t, 4], pz - tri[t, 5]
    d3 = abx * bpx + aby * bpy + abz * bpz
    d4 = acx * bpx + acy * bpy + acz * bpz
    if d3 >= 0.0 and d4 <= d3:
        return tri[t, 3], tri[t, 4], tri[t, 5]
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        v = d1 / (d1 - d3)
        return ax + v * abx, ay + v * aby, az + v * abz
    cpx, cpy, cpz = px - tri[t, 6], py - tri[t, 7], pz - tri[t, 8]
    d5 = abx * cpx + aby * cpy + abz * cpz
    d6 = acx * cpx + acy * cpy + acz * cpz
    if d6 >= 0.0 and d5 <= d6:
        return tri[t, 6], tri[t, 7], tri[t, 8]
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        w = d2 / (d2 - d6)
        return ax + w * acx, ay + w * acy, az + w * acz
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        bx, by, bz = tri[t, 3], tri[t, 4], tri[t, 5]
        return bx + w * (tri[t, 6] - bx), by + w * (tri[t, 7] - by), bz + w * (tri[t, 8] - bz)
    denom = 1.0 / (va + vb + vc)
    v = vb * denom
    w = vc * denom
    return ax + abx * v + acx * w, ay + aby * v + acy * w, az + abz * v + acz * w


@device
def triangle_normal(tri, t):
    """Unit normal of triangle ``t`` (right-hand rule on a, b, c)."""
    abx, aby, abz = tri[t, 3] - tri[t, 0], tri[t, 4] - tri[t, 1], tri[t, 5] - tri[t, 2]
    acx, acy, acz = tri[t, 6] - tri[t, 0], tri[t, 7] - tri[t, 1], tri[t, 8] - tri[t, 2]
    nx = aby * acz - abz * acy
    ny = abz * acx - abx * acz
    nz = abx * acy - aby * acx
    norm = np.sqrt(nx * nx + ny * ny + nz * nz)
    norm = norm if norm > 0.0 else 1.0
    return nx / norm, ny / norm, nz / norm


@serial_kernel
def mesh_distance(row, tri, cell_start, cell_tris, px, py, pz, qx, qy, qz, reach):
    """Distance to the closest triangle of a mesh row within ``reach`` [m] of p.

    Returns (distance - thickness, normal); the normal points from the closest point to
    p, or, with p on the surface, to the side the previous position ``q`` was on.
    Returns +inf when no triangle is near.
    """
    ox, oy, oz, cell = row[G], row[G + 1], row[G + 2], row[G + 3]
    nx_, ny_, nz_ = int(row[G + 4]), int(row[G + 5]), int(row[G + 6])
    offset = int(row[G + 7])
    thickness = row[G + 8]
    r = reach + thickness
    i0 = min(max(int(np.floor((px - r - ox) / cell)), 0), nx_ - 1)
    i1 = min(max(int(np.floor((px + r - ox) / cell)), 0), nx_ - 1)
    j0 = min(max(int(np.floor((py - r - oy) / cell)), 0), ny_ - 1)
    j1 = min(max(int(np.floor((py + r - oy) / cell)), 0), ny_ - 1)
    k0 = min(max(int(np.floor((pz - r - oz) / cell)), 0), nz_ - 1)
    k1 = min(max(int(np.floor((pz + r - oz) / cell)), 0), nz_ - 1)
    best = np.inf
    bx = by = bz = 0.0
    bt = -1
    for i in range(i0, i1 + 1):
        for j in range(j0, j1 + 1):
            for k in range(k0, k1 + 1):
                c = offset + (i * ny_ + j) * nz_ + k
                for e in range(cell_start[c], cell_start[c + 1]):
                    t = cell_tris[e]
                    cx, cy, cz = closest_on_triangle(px, py, pz, tri, t)
                    d2 = (px - cx) ** 2 + (py - cy) ** 2 + (pz - cz) ** 2
                    if d2 < best:
                        best = d2
                        bx, by, bz = cx, cy, cz
                        bt = t
    if bt < 0:
        return np.inf, 0.0, 1.0, 0.0
    dist = np.sqrt(best)
    if dist > 1e-12:
        return dist - thickness, (px - bx) / dist, (py - by) / dist, (pz - bz) / dist
    fx, fy, fz = triangle_normal(tri, bt)
    side = (qx - bx) * fx + (qy - by) * fy + (qz - bz) * fz
    s = 1.0 if side >= 0.0 else -1.0
    return -thickness, s * fx, s * fy, s * fz
