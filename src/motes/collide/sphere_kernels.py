"""Particles colliding with each other as spheres of their radius, over a list of pairs.

Candidate pairs come from the spatial layer (:mod:`motes.spatial`: every pair closer
than the largest reach, ``index.pairs(2 r_max)``), so the cost is per contact, not
``O(n²)``. Both passes visit the pairs in their sorted order on one thread
(Gauss–Seidel), so results do not depend on the thread count, and each pair moves its two
particles by equal and opposite amounts weighted by inverse mass, so momentum is
conserved pair by pair.

Positions are in the position-based form every kind can take: ``x`` now, ``q`` at the
start of the step (``(x - q) / h`` is the velocity).

- **Position pass** (Jakobsen 2001, §4; friction as Macklin et al. 2014, §6.1): an
  overlapping pair (distance ``d < r_i + r_j``) is pushed apart along
  ``n = (x_j - x_i) / d`` by the overlap; then the pair's relative tangential travel over
  the step is cut by ``μ`` times the overlap (Coulomb friction by penetration depth, the
  rule the collider contacts follow, :func:`motes.collide.contact.project_contacts`):
  a pair that slides less than that sticks, which is what lets a heap of grains stand.
- **Velocity pass** (Müller et al. 2020, §3.5, eq. 34): for a pair touching after the
  solve, the relative normal velocity becomes ``-e`` times the one before the solve; below
  ``2 |g| h`` the contact stays inelastic (a resting pile must not jitter).

Emitter systems (:class:`motes.collide.spheres.ParticleCollisions`) and rigid worlds'
sphere particles (:meth:`motes.rigid.World.add_sphere_contacts`: balls, pendulum bobs)
both use these passes. A row of touching spheres struck at one end: the position pass
shares the push along the whole row within one substep, and the velocity pass then sees
only the first pair approaching. The blow passes from sphere to sphere (a Newton's
cradle) when the spheres meet pair by pair: hang them a little apart, further than a
sphere moves in a substep.
"""

from __future__ import annotations

import numpy as np

from .._jit import serial_kernel

#: A pair within this distance [m] of touching after the solve is in contact.
SLOP = 1e-6


@serial_kernel
def project_pairs(px, py, pz, qx, qy, qz, inv_mass, radius, pairs, friction, up, stacking, hits):
    """Push overlapping ``pairs`` (p, 2) apart, then cut their relative tangential travel
    by ``friction`` × overlap; ``hits`` (n,) counts each particle's contacts.

    ``stacking`` >= 0 weights the pair by height along the unit vector ``up`` (mass
    scaling, Macklin et al. 2014, §5.2): a particle a diameter ``2 r`` below another counts
    ``exp(stacking)`` times heavier in this pass, so a pile carries its weight down to the
    ground in a few passes instead of sinking into itself. 0 uses the true masses (the
    only choice that conserves momentum; fine without gravity).
    """
    for k in range(pairs.shape[0]):
        i, j = pairs[k, 0], pairs[k, 1]
        dx, dy, dz = px[j] - px[i], py[j] - py[i], pz[j] - pz[i]
        d2 = dx * dx + dy * dy + dz * dz
        reach = radius[i] + radius[j]
        if d2 >= reach * reach or d2 == 0.0:
            continue
        a, b = inv_mass[i], inv_mass[j]
        if stacking > 0.0:
            # j above i by `rise` diameters: i heavier by exp(stacking * rise).
            rise = (dx * up[0] + dy * up[1] + dz * up[2]) / reach
            s = np.exp(0.5 * stacking * min(max(rise, -1.0), 1.0))
            a, b = a / s, b * s
        w = a + b
        if w <= 0.0:
            continue
        d = np.sqrt(d2)
        nx, ny, nz = dx / d, dy / d, dz / d
        depth = reach - d
        wi, wj = a / w, b / w
        px[i] -= wi * depth * nx
        py[i] -= wi * depth * ny
        pz[i] -= wi * depth * nz
        px[j] += wj * depth * nx
        py[j] += wj * depth * ny
        pz[j] += wj * depth * nz
        hits[i] += 1
        hits[j] += 1
        if friction <= 0.0:
            continue
        # Relative travel of j against i over the step, its tangential part.
        tx = (px[j] - qx[j]) - (px[i] - qx[i])
        ty = (py[j] - qy[j]) - (py[i] - qy[i])
        tz = (pz[j] - qz[j]) - (pz[i] - qz[i])
        tn = tx * nx + ty * ny + tz * nz
        tx, ty, tz = tx - tn * nx, ty - tn * ny, tz - tn * nz
        t = np.sqrt(tx * tx + ty * ty + tz * tz)
        if t == 0.0:
            continue
        cut = min(1.0, friction * depth / t)
        px[i] += wi * cut * tx
        py[i] += wi * cut * ty
        pz[i] += wi * cut * tz
        px[j] -= wj * cut * tx
        py[j] -= wj * cut * ty
        pz[j] -= wj * cut * tz


@serial_kernel
def restitute_pairs(px, py, pz, qx, qy, qz, bx, by, bz, inv_mass, radius, pairs, e, rest):
    """Velocity pass over touching ``pairs``: restitution ``e[k]`` (p,) of pair ``k``
    (0: the pair is skipped, left inelastic by the position pass).

    ``b`` are the positions before the solve, ``q`` those at the start of the step
    (rewritten so that ``(x - q) / h`` is the new velocity); ``rest`` = ``2 |g| h²`` [m]
    (the inelastic threshold speed times ``h``).
    """
    for k in range(pairs.shape[0]):
        i, j = pairs[k, 0], pairs[k, 1]
        w = inv_mass[i] + inv_mass[j]
        if w <= 0.0 or e[k] <= 0.0:
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
        dv = (-after - e[k] * before) / w  # relative change, per unit inverse mass
        qx[i] += inv_mass[i] * dv * nx
        qy[i] += inv_mass[i] * dv * ny
        qz[i] += inv_mass[i] * dv * nz
        qx[j] -= inv_mass[j] * dv * nx
        qy[j] -= inv_mass[j] * dv * ny
        qz[j] -= inv_mass[j] * dv * nz
