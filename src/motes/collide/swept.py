"""A-priori (swept) detection: the straight path x -> x' of each particle is tested
against planes, oriented boxes and triangles before the constraints relax it.

A particle's path over a step is the segment from its previous position ``q`` to its
predicted position ``x``. The earliest hit ``q + t (x - q)``, t in [0, 1], against any
a-priori collider stops the particle there (shifted out along the normal by its radius
and a small gap), and its velocity is reflected with the collider's restitution ``e``
(the previous position is rewritten so that ``(x - q)/h`` is the reflected velocity).
Shapes are grown by the particle radius: exact for planes; for boxes the grown box is
the slab intersection (square corners, conservative); triangles are thin (their shell
thickness and the radius shift the stopping point only).

Tests: the slab method (Kay & Kajiya 1986) for boxes, the signed distances of the ends
for planes, Möller & Trumbore (1997) for triangles.
"""

from __future__ import annotations

import numba
import numpy as np

from .._jit import block_bounds, block_count, parallel_kernel, serial_kernel
from ..geometry.distance import segment_box, segment_triangle, triangle_normal
from ..geometry.layout import KIND, RESTITUTION, SWEPT, G, Kind

#: Gap left between a stopped particle and the surface [m] (keeps it on the free side
#: after round-off).
GAP = 1e-6

PLANE, BOX, MESH = int(Kind.PLANE), int(Kind.BOX), int(Kind.MESH)


@serial_kernel
def _sweep_one(table, c, tri, cell_start, cell_tris, ax, ay, az, dx, dy, dz, r):
    """Earliest hit (fraction, normal, stand-off) of the segment a -> a + d against row
    ``c``, or inf."""
    row = table[c]
    kind = int(row[KIND])
    if kind == PLANE:
        nx, ny, nz = row[G], row[G + 1], row[G + 2]
        s0 = ax * nx + ay * ny + az * nz - row[G + 3] - r
        s1 = s0 + dx * nx + dy * ny + dz * nz
        if s0 >= 0.0 and s1 < 0.0:
            return s0 / (s0 - s1), nx, ny, nz, 0.0
        return np.inf, 0.0, 0.0, 0.0, 0.0
    if kind == BOX:
        enter, leave, fx, fy, fz = segment_box(table, c, ax, ay, az, dx, dy, dz, r)
        if enter <= leave and 0.0 <= enter <= 1.0:
            return enter, fx, fy, fz, 0.0
        return np.inf, 0.0, 0.0, 0.0, 0.0
    if kind == MESH:
        ox, oy, oz, cell = row[G], row[G + 1], row[G + 2], row[G + 3]
        n0, n1, n2 = int(row[G + 4]), int(row[G + 5]), int(row[G + 6])
        offset = int(row[G + 7])
        grow = r + row[G + 8]
        lo = np.empty(3, dtype=np.int64)
        hi = np.empty(3, dtype=np.int64)
        dims = (n0, n1, n2)
        base = (ox, oy, oz)
        start = (ax, ay, az)
        step = (dx, dy, dz)
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
                        s = segment_triangle(ax, ay, az, dx, dy, dz, tri, cell_tris[e])
                        if s < best:
                            best = s
                            bt = cell_tris[e]
        if bt < 0:
            return np.inf, 0.0, 0.0, 0.0, 0.0
        nx, ny, nz = triangle_normal(tri, bt)
        if nx * dx + ny * dy + nz * dz > 0.0:  # face the side the particle came from
            nx, ny, nz = -nx, -ny, -nz
        return best, nx, ny, nz, grow
    return np.inf, 0.0, 0.0, 0.0, 0.0


@parallel_kernel
def sweep_contacts(
    px, py, pz, qx, qy, qz, radius, inv_mass, table, tri, cell_start, cell_tris, hits
):
    """Stop each movable particle at its path's first a-priori hit; reflect its velocity.

    ``q`` (previous positions) -> ``p`` (predicted) is the path; both are rewritten
    for particles that hit. ``hits`` (n,) counts the hits.
    """
    n = px.shape[0]
    for b in numba.prange(block_count(n)):
        start, stop = block_bounds(b, n)
        for p in range(start, stop):
            if inv_mass[p] <= 0.0:
                continue
            ax, ay, az = qx[p], qy[p], qz[p]
            dx, dy, dz = px[p] - ax, py[p] - ay, pz[p] - az
            best = np.inf
            bc = -1
            bx = by = bz = off = 0.0
            for c in range(table.shape[0]):
                if table[c, SWEPT] == 0.0:
                    continue
                t, nx, ny, nz, o = _sweep_one(
                    table, c, tri, cell_start, cell_tris, ax, ay, az, dx, dy, dz, radius[p]
                )
                if t < best:
                    best, bc, bx, by, bz, off = t, c, nx, ny, nz, o
            if bc < 0:
                continue
            hits[p] += 1
            stand = off + GAP
            x = ax + best * dx + stand * bx
            y = ay + best * dy + stand * by
            z = az + best * dz + stand * bz
            # Reflect the step's displacement: tangential kept, normal times -e.
            dn = dx * bx + dy * by + dz * bz
            e = table[bc, RESTITUTION]
            vx = dx - (1.0 + e) * dn * bx
            vy = dy - (1.0 + e) * dn * by
            vz = dz - (1.0 + e) * dn * bz
            px[p], py[p], pz[p] = x, y, z
            qx[p], qy[p], qz[p] = x - vx, y - vy, z - vz
