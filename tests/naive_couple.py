"""NumPy twin of the rigid contact's kernels (:mod:`motes.couple.rigid`): emitter
particles against rows of grown boxes and balls that belong to rigid bodies.

Particles are (n, 3) float64 rows; bodies are given as their centres, velocities,
angular velocities, inverse masses and inverse inertias (k of each), one row per body.
"""

from __future__ import annotations

import numpy as np

from motes.geometry.layout import KIND, G, Kind
from naive_distance import signed_distance


def _slab(row, a, d):
    """(enter, leave, normal of the entry face) of a + s d in a box row."""
    centre, half, axes = row[G : G + 3], row[G + 3 : G + 6], row[G + 6 : G + 15].reshape(3, 3)
    o, u = axes @ (a - centre), axes @ d
    enter, leave, normal = -np.inf, np.inf, np.zeros(3)
    for k in range(3):
        if u[k] == 0:
            if abs(o[k]) > half[k]:
                return np.inf, -np.inf, normal
            continue
        t0, t1 = (-half[k] - o[k]) / u[k], (half[k] - o[k]) / u[k]
        sign = -1.0
        if t0 > t1:
            t0, t1, sign = t1, t0, 1.0
        if t0 > enter:
            enter, normal = t0, sign * axes[k]
        leave = min(leave, t1)
    return enter, leave, normal


def _ball(row, a, d):
    centre, radius = row[G : G + 3], row[G + 3]
    o = a - centre
    roots = np.roots([d @ d, 2 * (o @ d), o @ o - radius**2])
    if len(roots) < 2 or (np.iscomplexobj(roots) and np.any(np.abs(roots.imag) > 0)):
        return np.inf, -np.inf, np.zeros(3)
    enter, leave = np.sort(roots.real)
    return enter, leave, (a + enter * d - centre) / radius


def carried(before, row, point):
    """``point`` moved with the shape from its pose ``before`` to ``row``."""
    offset = point - before[G : G + 3]
    if int(row[KIND]) != Kind.BOX:
        return row[G : G + 3] + offset
    local = before[G + 6 : G + 15].reshape(3, 3) @ offset
    return row[G : G + 3] + local @ row[G + 6 : G + 15].reshape(3, 3)


def detect(x, v, dt, rows, before):
    """Per particle: (row or -1, contact point (3,), normal (3,)); the path against each
    row starts where the shape carried its start since ``before``."""
    out = []
    for p, vel in zip(x, v, strict=True):
        best, hit = np.inf, (-1, np.zeros(3), np.zeros(3))
        for r, row in enumerate(rows):
            a = carried(before[r], row, p - vel * dt)
            d = p - a
            test = _slab if int(row[KIND]) == Kind.BOX else _ball
            enter, leave, normal = test(row, a, d)
            if enter > leave or leave < 0 or enter > 1 or enter >= best:
                continue
            if enter >= 0:
                best, hit = enter, (r, a + enter * d, normal)
                continue
            dist, n = signed_distance(row, a[None])
            if d @ n[0] < 0:
                best, hit = 0.0, (r, a - dist[0] * n[0], n[0])
        if hit[0] < 0:
            deepest = 0.0
            for r, row in enumerate(rows):
                dist, n = signed_distance(row, p[None])
                if dist[0] < deepest:
                    deepest, hit = dist[0], (r, p - dist[0] * n[0], n[0])
        out.append(hit)
    return out


def respond(x, v, mass, hits, bodies, restitution, friction, gap=1e-6):
    """Impulses in particle order. ``bodies`` is a dict of (k, ...) arrays ``centre``,
    ``velocity``, ``angular_velocity``, ``inverse_mass``, ``inverse_inertia``. Returns
    new (x, v) and the impulse and angular impulse (k, 3) each body received."""
    x, v = x.copy(), v.copy()
    linear = bodies["velocity"].copy()
    spin = bodies["angular_velocity"].copy()
    inv_m, inv_i = bodies["inverse_mass"], bodies["inverse_inertia"]
    impulse, angular = np.zeros_like(linear), np.zeros_like(linear)

    def weight(b, rho, d):
        t = np.cross(rho, d)
        return inv_m[b] + t @ inv_i[b] @ t

    for i, (b, s, n) in enumerate(hits):
        if b < 0:
            continue
        rho = s - bodies["centre"][b]
        relative = v[i] - (linear[b] + np.cross(spin[b], rho))
        vn = relative @ n
        inv_p = 1.0 / mass[i]
        jn = -(1 + restitution) * vn / (inv_p + weight(b, rho, n)) if vn < 0 else 0.0
        tangent = relative - vn * n
        vt = np.linalg.norm(tangent)
        j = jn * n
        if vt > 0 and jn > 0:
            t = tangent / vt
            j = j - min(vt / (inv_p + weight(b, rho, t)), friction * jn) * t
        v[i] += j * inv_p
        impulse[b] -= j
        angular[b] -= np.cross(rho, j)
        linear[b] -= j * inv_m[b]
        spin[b] -= inv_i[b] @ np.cross(rho, j)
        x[i] = s + gap * n
    return x, v, impulse, angular
