"""Particles colliding with each other as spheres: position projection and restitution.

A world's sphere particles (:meth:`motes.rigid.World.add_sphere_contacts`) are tested
pair by pair, ``O(k²)`` for ``k`` of them: meant for tens to a few hundred (balls,
pendulum bobs), not for granular matter. Pairs are visited in a fixed order by one
thread (Gauss–Seidel), so results do not depend on the thread count.

Position pass: an overlapping pair ``i, j`` (distance ``d < r_i + r_j``) is pushed
apart along ``n = (x_j - x_i)/d`` by the overlap, split by inverse mass (Jakobsen 2001,
§4). Velocity pass after the solve (Müller et al. 2020, §3.5, eq. 34): the relative
normal velocity becomes ``-e`` times the one before the solve, split by inverse mass;
below ``2 |g| h`` it is left inelastic.

A row of touching spheres struck at one end: the position pass shares the push along
the whole row within one substep, and the velocity pass then sees only the first pair
approaching. The blow passes from sphere to sphere (a Newton's cradle) when the spheres
meet pair by pair: hang them a little apart, further than a sphere moves in a substep.
"""

from __future__ import annotations

import numpy as np

from .._jit import serial_kernel
from .restitution import SLOP


@serial_kernel
def project_spheres(px, py, pz, inv_mass, radius, members, hits):
    """Push overlapping pairs among ``members`` apart (inverse-mass weighted)."""
    k = members.shape[0]
    for a in range(k):
        i = members[a]
        for b in range(a + 1, k):
            j = members[b]
            w = inv_mass[i] + inv_mass[j]
            if w <= 0.0:
                continue
            dx, dy, dz = px[j] - px[i], py[j] - py[i], pz[j] - pz[i]
            d2 = dx * dx + dy * dy + dz * dz
            reach = radius[i] + radius[j]
            if d2 >= reach * reach or d2 == 0.0:
                continue
            d = np.sqrt(d2)
            push = (reach - d) / (d * w)
            px[i] -= inv_mass[i] * push * dx
            py[i] -= inv_mass[i] * push * dy
            pz[i] -= inv_mass[i] * push * dz
            px[j] += inv_mass[j] * push * dx
            py[j] += inv_mass[j] * push * dy
            pz[j] += inv_mass[j] * push * dz
            hits[i] += 1
            hits[j] += 1


@serial_kernel
def restitute_spheres(px, py, pz, qx, qy, qz, bx, by, bz, inv_mass, radius, members, e, rest):
    """Velocity pass over touching pairs; ``e`` (k,) per member, a pair uses the smaller.

    ``b`` are the positions before the solve, ``q`` the previous ones (rewritten so that
    ``(x - q)/h`` is the new velocity); ``rest`` = ``2 |g| h`` [m].
    """
    k = members.shape[0]
    for a in range(k):
        i = members[a]
        for c in range(a + 1, k):
            j = members[c]
            w = inv_mass[i] + inv_mass[j]
            pair_e = min(e[a], e[c])
            if w <= 0.0 or pair_e <= 0.0:
                continue
            dx, dy, dz = px[j] - px[i], py[j] - py[i], pz[j] - pz[i]
            d = np.sqrt(dx * dx + dy * dy + dz * dz)
            if d > radius[i] + radius[j] + SLOP or d == 0.0:
                continue
            nx, ny, nz = dx / d, dy / d, dz / d
            # Relative normal travel of j away from i over the step, before and after.
            before = (bx[j] - qx[j] - bx[i] + qx[i]) * nx
            before += (by[j] - qy[j] - by[i] + qy[i]) * ny
            before += (bz[j] - qz[j] - bz[i] + qz[i]) * nz
            if -before <= rest:
                continue
            after = (px[j] - qx[j] - px[i] + qx[i]) * nx
            after += (py[j] - qy[j] - py[i] + qy[i]) * ny
            after += (pz[j] - qz[j] - pz[i] + qz[i]) * nz
            dv = (-after - pair_e * before) / w  # relative change, per unit inverse mass
            qx[i] += inv_mass[i] * dv * nx
            qy[i] += inv_mass[i] * dv * ny
            qz[i] += inv_mass[i] * dv * nz
            qx[j] -= inv_mass[j] * dv * nx
            qy[j] -= inv_mass[j] * dv * ny
            qz[j] -= inv_mass[j] * dv * nz
