"""Restitution of a-posteriori contacts: a velocity pass after the position solve.

Projecting a penetrating particle out of a collider leaves it on the surface with
almost no normal velocity: every contact found after the move is perfectly inelastic.
Müller et al. 2020 ("Detailed rigid body simulation with extended position based
dynamics", §3.5–3.6, eq. 34) restore the bounce after the position solve: for each
contact with normal ``n``, with ``v̄_n = v̄·n`` the normal velocity *before* the solve
and ``v_n`` the one after it,

.. math:: Δv = n\\,(-v_n + \\max(-e\\,\\bar v_n, 0)),

and ``e = 0`` when ``|v̄_n| <= 2 |g| h`` (a resting contact gains ``|g| h`` per substep:
bouncing that would make resting bodies jitter). Velocities are ``(x - x*)/h`` in
position Verlet, so the pass rewrites the previous positions ``x* <- x - h v``.

Dynamic friction is not repeated here: the depth-based friction of the position pass
(:mod:`.contact`) removes ``μ p / h`` of tangential speed, which is Müller's
``h μ |f_n|`` with the normal force ``f_n = m p / h²`` of the projection.
"""

from __future__ import annotations

import numba

from .._jit import block_bounds, block_count, parallel_kernel
from ..geometry.distance import collider_distance
from ..geometry.layout import RESTITUTION

#: A particle within this distance [m] of its contact surface after the solve is in
#: contact (projection leaves it at exactly its radius, up to round-off).
SLOP = 1e-6


@parallel_kernel
def restitute_contacts(
    px, py, pz, qx, qy, qz, bx, by, bz, radius, inv_mass, table, tri, cell_start, cell_tris, rest
):
    """Velocity pass for particle-collider contacts (Müller et al. 2020, eq. 34).

    ``x`` after the position solve, ``q`` the previous positions (rewritten), ``b`` the
    positions before the solve (so ``(b - q)/h`` is ``v̄``); ``rest`` = ``2 |g| h`` [m]
    (the threshold speed times h). Colliders with restitution 0 are skipped: the
    projection already left their contacts inelastic.
    """
    n = px.shape[0]
    for blk in numba.prange(block_count(n)):
        start, stop = block_bounds(blk, n)
        for p in range(start, stop):
            if inv_mass[p] <= 0.0:
                continue
            r = radius[p]
            for c in range(table.shape[0]):
                e = table[c, RESTITUTION]
                if e <= 0.0:
                    continue
                s, nx, ny, nz = collider_distance(
                    table, c, tri, cell_start, cell_tris,
                    px[p], py[p], pz[p], qx[p], qy[p], qz[p], r + SLOP,
                )  # fmt: skip
                if s > r + SLOP:
                    continue
                # Normal travel over the step (velocity times h), before and after.
                before = (bx[p] - qx[p]) * nx + (by[p] - qy[p]) * ny + (bz[p] - qz[p]) * nz
                if -before <= rest:
                    continue  # slow or separating: stays inelastic
                after = (px[p] - qx[p]) * nx + (py[p] - qy[p]) * ny + (pz[p] - qz[p]) * nz
                dv = -after - e * before
                qx[p] -= dv * nx
                qy[p] -= dv * ny
                qz[p] -= dv * nz
