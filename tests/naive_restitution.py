"""Plain NumPy twins of the restitution and sphere-contact kernels (one loop per pair)."""

import numpy as np

from motes.geometry.layout import RESTITUTION
from naive_distance import signed_distance

SLOP = 1e-6


def restitute_contacts(x, q, before, radius, inv_mass, table, rest):
    """Müller et al. 2020 eq. 34 for plane and sphere rows; returns the new ``q`` (n, 3)."""
    q = q.copy()
    for row in table:
        e = row[RESTITUTION]
        if e <= 0:
            continue
        s, n = signed_distance(row, x)
        vbar = np.einsum("ij,ij->i", before - q, n)
        v = np.einsum("ij,ij->i", x - q, n)
        hit = (s <= radius + SLOP) & (-vbar > rest) & (inv_mass > 0)
        q[hit] -= ((-v - e * vbar)[:, None] * n)[hit]
    return q


def project_spheres(x, inv_mass, radius, members):
    x = x.copy()
    for a, i in enumerate(members):
        for j in members[a + 1 :]:
            w = inv_mass[i] + inv_mass[j]
            d = x[j] - x[i]
            dist = np.linalg.norm(d)
            reach = radius[i] + radius[j]
            if w <= 0 or dist >= reach or dist == 0:
                continue
            push = (reach - dist) / w * d / dist
            x[i] -= inv_mass[i] * push
            x[j] += inv_mass[j] * push
    return x


def restitute_spheres(x, q, before, inv_mass, radius, members, e, rest):
    q = q.copy()
    for a, i in enumerate(members):
        for c in range(a + 1, len(members)):
            j = members[c]
            w = inv_mass[i] + inv_mass[j]
            pair_e = min(e[a], e[c])
            d = x[j] - x[i]
            dist = np.linalg.norm(d)
            if w <= 0 or pair_e <= 0 or dist > radius[i] + radius[j] + SLOP or dist == 0:
                continue
            n = d / dist
            vbar = (before[j] - q[j] - before[i] + q[i]) @ n
            if -vbar <= rest:
                continue
            v = (x[j] - q[j] - x[i] + q[i]) @ n
            dv = (-v - pair_e * vbar) / w * n
            q[i] += inv_mass[i] * dv
            q[j] -= inv_mass[j] * dv
    return q
