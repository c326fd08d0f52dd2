"""Plain NumPy/Python twins of the constraint kernels (slow, obviously correct)."""

import numpy as np

DISTANCE, ANGLE = 0, 1


def greedy_colors(ends, n):
    """Lowest colour not used by an earlier constraint sharing a particle."""
    used = [set() for _ in range(n)]
    colors = []
    for row in ends:
        particles = [p for p in row if p >= 0]
        taken = set().union(*(used[p] for p in particles))
        color = next(c for c in range(len(ends) + 1) if c not in taken)
        colors.append(color)
        for p in particles:
            used[p].add(color)
    return np.array(colors)


def project(x, w, kind, ends, lo, hi, compliance, stiffness, lam, c, dt, approx, q=None):
    """Project constraint ``c`` on x ((n, 3) float64), in place; the kernel's equations.

    With ``q`` (positions at the start of the step) distance constraints push along the
    pair's direction in ``q`` (SHAKE) when it is within 60° of the current one.
    """
    i, j, k = ends[c]
    d = x[j] - x[i]
    if kind[c] == ANGLE:
        a = np.linalg.norm(x[i] - x[k])
        b = np.linalg.norm(x[j] - x[k])
        t_lo = np.sqrt(max(a * a + b * b - 2 * a * b * lo[c], 0.0))
        t_hi = np.sqrt(max(a * a + b * b - 2 * a * b * hi[c], 0.0))
    else:
        t_lo, t_hi = lo[c], hi[c]
    length = np.linalg.norm(d)
    if length == 0:
        return
    target = np.clip(length, t_lo, t_hi)
    if length == target or w[i] + w[j] == 0:
        return
    alpha = compliance[c] / dt**2
    if q is not None and kind[c] == DISTANCE:
        g = q[j] - q[i]
        cos = d @ g / (length * np.linalg.norm(g))
        if cos > 0.5:
            w_eff = (w[i] + w[j]) * cos
            dlam = stiffness[c] * (-(length - target) - alpha * lam[c]) / (w_eff + alpha)
            lam[c] += dlam
            x[i] += w[i] * dlam / np.linalg.norm(g) * g * -1
            x[j] -= w[j] * dlam / np.linalg.norm(g) * g * -1
            return
    if approx and alpha == 0 and kind[c] == DISTANCE:
        # Jakobsen's square-root-free form of (length - target) / length.
        s = stiffness[c] * (length**2 - target**2) / (length**2 + target**2)
        s /= w[i] + w[j]
    else:
        dlam = stiffness[c] * (-(length - target) - alpha * lam[c]) / (w[i] + w[j] + alpha)
        lam[c] += dlam
        s = -dlam / length
    x[i] += w[i] * s * d
    x[j] -= w[j] * s * d


def sweep(x, w, cs, dt, approx=False, q=None):
    """One sweep of a ConstraintSet's constraints in slot order, on x (n, 3)."""
    for c in range(len(cs.ends)):
        project(
            x,
            w,
            cs.kind,
            cs.ends,
            cs.lo,
            cs.hi,
            cs.compliance,
            cs.stiffness,
            cs.multipliers,
            c,
            dt,
            approx,
            q,
        )


def verlet(x, q, w, g, keep, h):
    """Position Verlet on (n, 3) arrays; returns the new (x, q)."""
    moving = (w > 0)[:, None]
    return np.where(moving, x + keep * (x - q) + h * h * np.asarray(g), x), x.copy()


# --- collisions ------------------------------------------------------------------------


def closest_on_segment(p, a, b):
    ab = b - a
    t = np.clip((p - a) @ ab / max(ab @ ab, 1e-300), 0.0, 1.0)
    return a + t * ab


def closest_on_triangle(p, a, b, c):
    """Projection on the plane if inside the triangle, else the closest edge point."""
    n = np.cross(b - a, c - a)
    n = n / np.linalg.norm(n)
    q = p - (p - a) @ n * n
    inside = all(np.cross(v1 - v0, q - v0) @ n >= 0 for v0, v1 in ((a, b), (b, c), (c, a)))
    if inside:
        return q
    edges = [closest_on_segment(p, *e) for e in ((a, b), (b, c), (c, a))]
    return min(edges, key=lambda e: np.linalg.norm(p - e))


def signed_distance(collider, p, q):
    """Signed distance and outward normal of a motes collider at point p (prev. q)."""
    from motes.collide import Box, Plane, Sphere
    from motes.collide.capsule import Capsule

    if isinstance(collider, Plane):
        return p @ collider.normal - collider.offset, collider.normal
    if isinstance(collider, (Sphere, Capsule)):
        if isinstance(collider, Sphere):
            centre = collider.center
        else:
            centre = closest_on_segment(p, collider.a, collider.b)
        d = p - centre
        return np.linalg.norm(d) - collider.radius, d / np.linalg.norm(d)
    if isinstance(collider, Box):
        local = (p - collider.center) @ collider.rotation
        q_ = np.abs(local) - collider.half_extent
        outside = np.maximum(q_, 0) * np.sign(local)
        if np.any(q_ > 0):
            dist = np.linalg.norm(outside)
            return dist, collider.rotation @ (outside / dist)
        axis = int(np.argmax(q_))
        n = np.zeros(3)
        n[axis] = 1.0 if local[axis] >= 0 else -1.0
        return q_[axis], collider.rotation @ n
    # Triangle mesh: brute force over every triangle.
    tris = collider.triangles.reshape(-1, 3, 3)
    best = min((closest_on_triangle(p, *t) for t in tris), key=lambda c: np.linalg.norm(p - c))
    d = p - best
    return np.linalg.norm(d) - collider.thickness, d / np.linalg.norm(d)


def project_contacts(x, q, radius, w, colliders):
    """A-posteriori projection with depth friction, particle by particle; x, q (n, 3)."""
    x = x.copy()
    for p in range(len(x)):
        if w[p] <= 0:
            continue
        for col in colliders:
            s, n = signed_distance(col, x[p], q[p])
            depth = radius[p] - s
            if depth <= 0:
                continue
            x[p] = x[p] + depth * n
            d = x[p] - q[p]
            t = d - (d @ n) * n
            tl = np.linalg.norm(t)
            if tl > 0:
                x[p] -= min(1.0, col.friction * depth / tl) * t
    return x
