"""Particles of a rigid world against colliders: packing, and a-posteriori projection.

After the move, a particle of radius r whose signed distance s to a collider is below r
is projected out along the collider's normal by the depth ``p = r - s`` (Jakobsen 2001,
§4), and its tangential displacement over the step ``Δ_t`` (from its previous position)
is reduced by Coulomb friction with the normal impulse estimated from the depth:

.. math:: Δ_t \\leftarrow Δ_t \\left(1 - \\min\\left(1, \\frac{μ p}{|Δ_t|}\\right)\\right),

so a particle sliding slower than ``μ p`` per step stops (static friction) and a faster
one loses ``μ p`` of its tangential travel (kinetic friction). Detection before the move
(swept) is in :mod:`.swept`.
"""

from __future__ import annotations

import numba
import numpy as np

from .._jit import block_bounds, block_count, parallel_kernel
from ..geometry.distance import collider_distance
from ..geometry.layout import FRICTION, SWEPT, G, stack
from .capsule import Capsule
from .colliders import Box, Collider, Detection, Plane, Response, Sphere
from .mesh import TriangleMeshCollider


def check_collider(collider, detection=None) -> Detection:
    """Validate a collider for a rigid world; return its detection mode (``None``: the
    collider's own)."""
    if not isinstance(collider, Collider):
        raise TypeError(
            f"collider must be a Plane, Sphere, Box, Capsule or TriangleMeshCollider, "
            f"got {type(collider).__name__}"
        )
    if collider.response != Response.BOUNCE or collider.inside:
        raise ValueError("rigid worlds support solid colliders with response 'bounce' only")
    if detection is None:
        return collider.detection
    if isinstance(detection, str) and detection in Detection._value2member_map_:
        detection = Detection(detection)
    if not isinstance(detection, Detection):
        raise ValueError(f"detection must be 'posteriori' or 'priori', got {detection!r}")
    return detection


def pack(colliders, detections=None):
    """Rows ``(k, ROW)`` float64 (:mod:`motes.geometry.layout`) and the concatenated
    mesh data; ``detections`` (one per collider) overrides the colliders' own.

    Returns ``table, triangles (t, 9), cell_start, cell_triangles``.
    """
    rows = []
    tris = [np.zeros((0, 9))]
    starts = [np.zeros(1, dtype=np.int64)]
    lists = [np.zeros(0, dtype=np.int64)]
    tri_offset = cell_offset = 0
    colliders = list(colliders)
    if detections is None:
        detections = [c.detection for c in colliders]
    for col, det in zip(colliders, detections, strict=True):
        if not isinstance(col, (Plane, Sphere, Box, Capsule, TriangleMeshCollider)):
            raise TypeError(f"unsupported collider {type(col).__name__}")
        row = col.packed()
        row[SWEPT] = det == Detection.PRIORI
        if isinstance(col, TriangleMeshCollider):
            row[G + 7] = cell_offset
            tris.append(col.triangles)
            starts.append(col.cell_start[1:] + starts[-1][-1])
            lists.append(col.cell_triangles + tri_offset)
            tri_offset += len(col.triangles)
            cell_offset += int(np.prod(col.dims))
        rows.append(row)
    return (
        stack(rows),
        np.ascontiguousarray(np.concatenate(tris)),
        np.concatenate(starts).astype(np.int64),
        np.concatenate(lists).astype(np.int64),
    )


@parallel_kernel
def project_contacts(
    px, py, pz, qx, qy, qz, radius, inv_mass, table, tri, cell_start, cell_tris, hits
):
    """Project every movable particle out of every collider, with depth friction.

    ``q`` are the positions at the start of the step; ``hits`` (n,) counts contacts.
    """
    n = px.shape[0]
    for b in numba.prange(block_count(n)):
        start, stop = block_bounds(b, n)
        for p in range(start, stop):
            if inv_mass[p] <= 0.0:
                continue
            r = radius[p]
            for c in range(table.shape[0]):
                s, nx, ny, nz = collider_distance(
                    table,
                    c,
                    tri,
                    cell_start,
                    cell_tris,
                    px[p],
                    py[p],
                    pz[p],
                    qx[p],
                    qy[p],
                    qz[p],
                    r,
                )
                depth = r - s
                if depth <= 0.0:
                    continue
                hits[p] += 1
                x = px[p] + depth * nx
                y = py[p] + depth * ny
                z = pz[p] + depth * nz
                # Tangential travel over the step, reduced by mu * depth (Coulomb).
                dx, dy, dz = x - qx[p], y - qy[p], z - qz[p]
                dn = dx * nx + dy * ny + dz * nz
                tx, ty, tz = dx - dn * nx, dy - dn * ny, dz - dn * nz
                t = np.sqrt(tx * tx + ty * ty + tz * tz)
                cut = min(1.0, table[c, FRICTION] * depth / t) if t > 0.0 else 0.0
                px[p] = x - cut * tx
                py[p] = y - cut * ty
                pz[p] = z - cut * tz
