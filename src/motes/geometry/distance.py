"""The one signed distance from a point to a packed collider row, and the mesh query.

:func:`signed_distance` covers planes, spheres, oriented boxes and capsules. It is an
inlined device function: the fused particle step (float32, vectorised) passes ``kind``
and ``inside`` as compile-time constants so that each collider costs only its own
arithmetic, while cloth, rigid worlds and fluids read them from the row at run time.
It is written for the vectoriser and for float32: every constant comes from ``one``
(the caller's dtype; a Python literal would promote float32 arithmetic to float64), and
choices between values are selects or branches whose both sides are cheap.

:func:`segment_triangle` tests a path against one triangle: the swept (a-priori)
detection of :mod:`.sweep` uses it for meshes.

The triangle-mesh query (:func:`mesh_distance`, a loop over grid cells and triangles)
is float64 and a compiled function of its own, called rather than inlined: it costs far
more than a call, and inlining it into every caller tripled their compile time.

Rows are laid out as :mod:`motes.geometry.layout` documents. Distances are signed [m]:
negative inside the solid (for an ``inside`` row, the solid is everything outside the
shape), with the unit normal pointing out of the solid.
"""

from __future__ import annotations

import numpy as np

from .._jit import device, serial_kernel
from .layout import INSIDE, KIND, G, Kind

_PLANE = int(Kind.PLANE)
_SPHERE = int(Kind.SPHERE)
_BOX = int(Kind.BOX)
_CAPSULE = int(Kind.CAPSULE)
_MESH = int(Kind.MESH)


@device
def _ball(cx, cy, cz, radius, px, py, pz, one):
    """Signed distance to a ball and its outward normal (+y at the centre)."""
    dx = px - cx
    dy = py - cy
    dz = pz - cz
    dist = np.sqrt(dx * dx + dy * dy + dz * dz)
    away = dist > one - one
    safe = dist if away else one
    return dist - radius, dx / safe, dy / safe if away else one, dz / safe


@device
def _box(table, c, px, py, pz, one):
    """Signed distance to an oriented box and its outward normal.

    Outside, the Euclidean distance to the box (faces, edges and corners alike);
    inside, out through the face of least penetration (ties: u before v before w).
    """
    zero = one - one
    dx = px - table[c, G]
    dy = py - table[c, G + 1]
    dz = pz - table[c, G + 2]
    l0 = dx * table[c, G + 6] + dy * table[c, G + 7] + dz * table[c, G + 8]
    l1 = dx * table[c, G + 9] + dy * table[c, G + 10] + dz * table[c, G + 11]
    l2 = dx * table[c, G + 12] + dy * table[c, G + 13] + dz * table[c, G + 14]
    q0 = abs(l0) - table[c, G + 3]
    q1 = abs(l1) - table[c, G + 4]
    q2 = abs(l2) - table[c, G + 5]
    s0 = one if l0 >= zero else -one
    s1 = one if l1 >= zero else -one
    s2 = one if l2 >= zero else -one
    e0 = max(q0, zero) * s0
    e1 = max(q1, zero) * s1
    e2 = max(q2, zero) * s2
    out2 = e0 * e0 + e1 * e1 + e2 * e2
    deepest = max(q0, max(q1, q2))
    if out2 > zero:
        dist = np.sqrt(out2)
        o0 = e0 / dist
        o1 = e1 / dist
        o2 = e2 / dist
    else:
        dist = deepest
        first = q0 == deepest
        second = (q1 == deepest) & (q0 != deepest)
        o0 = s0 if first else zero
        o1 = s1 if second else zero
        o2 = zero if first | second else s2
    nx = o0 * table[c, G + 6] + o1 * table[c, G + 9] + o2 * table[c, G + 12]
    ny = o0 * table[c, G + 7] + o1 * table[c, G + 10] + o2 * table[c, G + 13]
    nz = o0 * table[c, G + 8] + o1 * table[c, G + 11] + o2 * table[c, G + 14]
    return dist, nx, ny, nz


@device
def signed_distance(kind, inside, table, c, px, py, pz, one):
    """Signed distance [m] from a point to collider row ``c``, and the unit normal.

    Parameters
    ----------
    kind : int
        ``table[c, KIND]``: PLANE, SPHERE, BOX or CAPSULE (a compile-time constant
        in the fused step).
    inside : bool
        ``table[c, INSIDE] > 0``: the solid is the outside of the shape, so distance
        and normal are negated.
    table : (k, ROW) array
        Packed rows (:mod:`motes.geometry.layout`).
    c : int
        Row.
    px, py, pz : float
        The point [m], in the dtype of ``one``.
    one : float
        1 in the dtype to compute in.

    Returns
    -------
    distance, nx, ny, nz : float
        Distance [m], negative inside the solid; unit normal pointing out of the solid
        (at a sphere's centre or on a capsule's axis: +y).
    """
    if kind == _PLANE:
        nx = table[c, G]
        ny = table[c, G + 1]
        nz = table[c, G + 2]
        dist = px * nx + py * ny + pz * nz - table[c, G + 3]
    elif kind == _SPHERE:
        dist, nx, ny, nz = _ball(
            table[c, G], table[c, G + 1], table[c, G + 2], table[c, G + 3], px, py, pz, one
        )
    elif kind == _CAPSULE:
        ax = table[c, G]
        ay = table[c, G + 1]
        az = table[c, G + 2]
        ux = table[c, G + 3] - ax
        uy = table[c, G + 4] - ay
        uz = table[c, G + 5] - az
        uu = ux * ux + uy * uy + uz * uz
        # Closest point of the axis; a capsule with a = b is a ball (t = 0).
        t = ((px - ax) * ux + (py - ay) * uy + (pz - az) * uz) / (uu if uu > one - one else one)
        t = min(max(t, one - one), one)
        dist, nx, ny, nz = _ball(
            ax + t * ux, ay + t * uy, az + t * uz, table[c, G + 6], px, py, pz, one
        )
    else:
        dist, nx, ny, nz = _box(table, c, px, py, pz, one)
    if inside:
        return -dist, -nx, -ny, -nz
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
def segment_triangle(ax, ay, az, dx, dy, dz, tri, t):
    """Fraction ``s`` in [0, 1] along ``a + s d`` where the segment crosses triangle ``t``
    (corners flattened in ``tri[t]``), or inf (Möller & Trumbore 1997)."""
    e1x, e1y, e1z = tri[t, 3] - tri[t, 0], tri[t, 4] - tri[t, 1], tri[t, 5] - tri[t, 2]
    e2x, e2y, e2z = tri[t, 6] - tri[t, 0], tri[t, 7] - tri[t, 1], tri[t, 8] - tri[t, 2]
    hx = dy * e2z - dz * e2y
    hy = dz * e2x - dx * e2z
    hz = dx * e2y - dy * e2x
    det = e1x * hx + e1y * hy + e1z * hz
    if abs(det) < 1e-300:
        return np.inf
    f = 1.0 / det
    sx, sy, sz = ax - tri[t, 0], ay - tri[t, 1], az - tri[t, 2]
    u = f * (sx * hx + sy * hy + sz * hz)
    if u < 0.0 or u > 1.0:
        return np.inf
    qx = sy * e1z - sz * e1y
    qy = sz * e1x - sx * e1z
    qz = sx * e1y - sy * e1x
    v = f * (dx * qx + dy * qy + dz * qz)
    if v < 0.0 or u + v > 1.0:
        return np.inf
    s = f * (e2x * qx + e2y * qy + e2z * qz)
    if s < 0.0 or s > 1.0:
        return np.inf
    return s


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
    """Distance [m] to the closest triangle of a MESH row within ``reach`` [m] of p.

    ``tri`` (t, 9) holds the triangles of a table (corners a, b, c flattened),
    ``cell_start``/``cell_tris`` the CSR lists of its grid cells. Returns
    (distance - thickness, normal); the normal points from the closest point to p, or,
    with p on the surface, to the side the previous position ``q`` was on. Returns +inf
    when no triangle is near. float64.
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


@device
def row_signed_distance(table, c, px, py, pz, one):
    """:func:`signed_distance` with kind and inside read from row ``c`` at run time."""
    return signed_distance(int(table[c, KIND]), table[c, INSIDE] > 0, table, c, px, py, pz, one)


@device
def collider_distance(table, c, tri, cell_start, cell_tris, px, py, pz, qx, qy, qz, reach):
    """Signed distance and normal to row ``c`` of any kind, meshes included (float64).

    ``tri``, ``cell_start``, ``cell_tris``, the previous position ``q`` and ``reach``
    [m] as in :func:`mesh_distance`.
    """
    if int(table[c, KIND]) == _MESH:
        return mesh_distance(table[c], tri, cell_start, cell_tris, px, py, pz, qx, qy, qz, reach)
    return row_signed_distance(table, c, px, py, pz, 1.0)
