"""A-priori (swept) detection for rigid worlds: the straight path x -> x' of each
particle is tested against the swept colliders before the constraints relax it.

A particle's path over a step is the segment from its previous position ``q`` to its
predicted position ``x``. The earliest entry ``q + t (x - q)``, t in [0, 1], into any
a-priori collider (:func:`motes.geometry.sweep.first_hit`: planes, spheres, oriented
boxes, capsules; :func:`~motes.geometry.sweep.mesh_first_hit`: triangle meshes) stops
the particle there (shifted out along the normal by a small gap, and for meshes by its
radius and the shell's thickness), and its velocity is reflected with the collider's
restitution ``e`` (the previous position is rewritten so that ``(x - q)/h`` is the
reflected velocity).
"""

from __future__ import annotations

import numba
import numpy as np

from .._jit import block_bounds, block_count, parallel_kernel
from ..geometry.layout import INSIDE, KIND, RESTITUTION, SWEPT, Kind
from ..geometry.sweep import first_hit, mesh_first_hit

#: Gap left between a stopped particle and the surface [m] (keeps it on the free side
#: after round-off).
GAP = 1e-6

MESH = int(Kind.MESH)


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
                kind = int(table[c, KIND])
                if kind == MESH:
                    t, nx, ny, nz, o = mesh_first_hit(
                        table[c], tri, cell_start, cell_tris, ax, ay, az, dx, dy, dz, radius[p]
                    )
                else:
                    t, nx, ny, nz = first_hit(
                        kind,
                        table[c, INSIDE] > 0.0,
                        table,
                        c,
                        ax,
                        ay,
                        az,
                        dx,
                        dy,
                        dz,
                        0.0,
                        0.0,
                        0.0,
                        radius[p],
                        1.0,
                    )
                    o = 0.0
                if t < best:
                    best, bc, bx, by, bz, off = t, c, nx, ny, nz, o
            if best > 1.0:
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
