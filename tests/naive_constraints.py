"""Plain NumPy/Python twins of the constraint kernels (slow, obviously correct)."""

import numpy as np

DISTANCE, ANGLE, SIDE = 0, 1, 2


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
    i, j, k = ends[c][:3]
    if kind[c] == SIDE:
        left, right = ends[c][3], ends[c][4]
        bone, axis = x[k] - x[i], x[right] - x[left]
        n = np.sign(hi[c]) * np.cross(bone, axis)
        sin = np.linalg.norm(n) / np.sqrt((bone @ bone) * (axis @ axis))
        if sin <= 0.5:
            return  # ill-defined plane
        n /= np.linalg.norm(n)
        side = (x[j] - x[k]) @ n - lo[c]
        if side <= 0:
            return
        # The side at the start of the step, across the start's plane where defined.
        start = x if q is None else q
        m = np.sign(hi[c]) * np.cross(start[k] - start[i], start[right] - start[left])
        u, v = start[k] - start[i], start[right] - start[left]
        m = m / np.linalg.norm(m) if m @ m > 0.25 * (u @ u) * (v @ v) else n
        before = (start[j] - start[k]) @ m - lo[c]
        allowed = max(before - abs(hi[c]) * dt, 0.0)
        if side <= allowed:
            return
        perp = bone - axis * (axis @ bone) / (axis @ axis)
        ci = (x[j] - x[k]) @ perp / (perp @ perp)
        weight = w[j] + w[i] * ci**2 + w[k] * (1 + ci) ** 2
        if weight <= 0:
            return
        if lam[c] == 0:  # the step's budget: the violation found first (offset by 1)
            lam[c] = 1 + side - allowed
        amount = min(side - allowed, lam[c] - 1)
        if amount <= 0:
            return
        lam[c] -= amount
        fade = min((sin - 0.5) / (np.sqrt(0.5) - 0.5), 1.0)
        s = fade * stiffness[c] * amount / weight
        x[j] -= w[j] * s * n
        x[i] -= w[i] * ci * s * n
        x[k] += w[k] * (1 + ci) * s * n
        return
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


def _segment_triangle(a, d, tri):
    """Fraction s along a + s d where the segment crosses the triangle (Möller–Trumbore)."""
    e1, e2 = tri[1] - tri[0], tri[2] - tri[0]
    h = np.cross(d, e2)
    det = e1 @ h
    if abs(det) < 1e-300:
        return np.inf
    s_ = a - tri[0]
    u = (s_ @ h) / det
    qv = np.cross(s_, e1)
    v = (d @ qv) / det
    s = (e2 @ qv) / det
    if u < 0 or u > 1 or v < 0 or u + v > 1 or s < 0 or s > 1:
        return np.inf
    return s


def sweep_one(collider, a, d, r):
    """Earliest hit (fraction, normal, stand-off) of a -> a + d against one collider."""
    from motes.collide import Box, Plane

    miss = (np.inf, np.zeros(3), 0.0)
    if isinstance(collider, Plane):
        n = collider.normal
        s0 = a @ n - collider.offset - r
        s1 = s0 + d @ n
        return (s0 / (s0 - s1), n, 0.0) if s0 >= 0 and s1 < 0 else miss
    if isinstance(collider, Box):
        rot = collider.rotation
        o = (a - collider.center) @ rot
        v = d @ rot
        enter, leave, normal = -np.inf, np.inf, np.zeros(3)
        for k in range(3):
            h = collider.half_extent[k] + r
            if v[k] == 0:
                if abs(o[k]) > h:
                    return miss
                continue
            t0, t1, sign = (-h - o[k]) / v[k], (h - o[k]) / v[k], -1.0
            if t0 > t1:
                t0, t1, sign = t1, t0, 1.0
            if t0 > enter:
                enter, normal = t0, sign * rot[:, k]
            leave = min(leave, t1)
        return (enter, normal, 0.0) if enter <= leave and 0 <= enter <= 1 else miss
    tris = collider.triangles.reshape(-1, 3, 3)
    hits = [_segment_triangle(a, d, t) for t in tris]
    k = int(np.argmin(hits))
    if not np.isfinite(hits[k]):
        return miss
    n = np.cross(tris[k][1] - tris[k][0], tris[k][2] - tris[k][0])
    n /= np.linalg.norm(n)
    if n @ d > 0:
        n = -n
    return hits[k], n, r + collider.thickness


def sweep_contacts(x, q, radius, w, colliders, gap=1e-6):
    """Stop each particle at its path's first hit and reflect its step; x, q (n, 3)."""
    x, q = x.copy(), q.copy()
    for p in range(len(x)):
        if w[p] <= 0:
            continue
        a, d = q[p].copy(), x[p] - q[p]
        best = (np.inf, None, 0.0, None)
        for col in colliders:
            t, n, off = sweep_one(col, a, d, radius[p])
            if t < best[0]:
                best = (t, n, off, col)
        t, n, off, col = best
        if col is None:
            continue
        x[p] = a + t * d + (off + gap) * n
        step = d - (1 + col.restitution) * (d @ n) * n
        q[p] = x[p] - step
    return x, q


# --- body against body -----------------------------------------------------------------


def _exit(planes, rest_l, u, r):
    """Distance along u (host frame) out of the host's faces grown by r; -1 if outside."""
    s = planes[:, :3] @ rest_l - planes[:, 3]
    if np.any(s >= r):
        return -1.0
    along = planes[:, :3] @ u
    ok = along > 1e-9
    return float(np.min((r - s[ok]) / along[ok])) if ok.any() else -1.0


def body_contacts(x, q, radius, model, rotation, friction):
    """Twin of ``rigid.body_contacts.body_contacts`` for a world's ``WorldModel``.

    ``x``, ``q`` are (n, 3); ``rotation`` (b, 3, 3) the bodies' rotations (held fixed).
    Returns the new x.
    """
    x = x.copy()
    start, owner_particles = model.body_start, model.body_particles
    fraction, planes_all = model.body_fraction, model.body_planes
    plane_start, group = model.body_plane_start, model.body_group
    inv_m = model.body_inv_mass
    edge_start, edges = model.body_edge_start, model.body_edges
    nb = len(start) - 1
    parts = [owner_particles[start[b] : start[b + 1]] for b in range(nb)]
    fracs = [fraction[start[b] : start[b + 1]] for b in range(nb)]
    planes = [planes_all[plane_start[b] : plane_start[b + 1]] for b in range(nb)]
    iinv = [rotation[b] @ model.body_inertia_inv[b] @ rotation[b].T for b in range(nb)]
    centre = [fracs[b] @ x[parts[b]] for b in range(nb)]
    before = [fracs[b] @ q[parts[b]] for b in range(nb)]
    lo = [np.min(x[parts[b]] - radius[parts[b], None], axis=0) for b in range(nb)]
    hi = [np.max(x[parts[b]] + radius[parts[b], None], axis=0) for b in range(nb)]

    def weight(b, rho, n):
        t = np.cross(rho, n)
        return inv_m[b] + t @ iinv[b] @ t

    def move(b, rho, n, lam):  # impulse -lam n at centre + rho
        omega = -lam * iinv[b] @ np.cross(rho, n)
        idx = parts[b]
        x[idx] += -lam * inv_m[b] * n + np.cross(omega, x[idx] - centre[b])

    def push(a, b, s, rho, n, lam):
        move(a, s, -n, lam)
        move(b, rho, n, lam)
        centre[a] = centre[a] + lam * inv_m[a] * n
        centre[b] = centre[b] - lam * inv_m[b] * n

    def overlap(a, b):
        if len(planes[b]) == 0:
            return np.inf, -1
        normals = planes[b][:, :3] @ rotation[b].T  # world normals, (f, 3)
        s = (x[parts[a]] - centre[b]) @ normals.T - planes[b][:, 3]
        deepest = np.max(radius[parts[a], None] - s, axis=0)
        f = int(np.argmin(deepest))
        return deepest[f], f

    def edge_contacts(intruder, host, sign, n, a, b, found):
        rot = rotation[host]
        u = sign * (rot.T @ n)
        for i, j in edges[edge_start[intruder] : edge_start[intruder + 1]]:
            r = 0.5 * (radius[i] + radius[j])
            l0, l1 = rot.T @ (x[i] - centre[host]), rot.T @ (x[j] - centre[host])
            t_in, t_out, outside = 0.0, 1.0, False
            for f in planes[host]:
                s0 = f[:3] @ l0 - f[3] - r
                s1 = f[:3] @ l1 - f[3] - r
                if s0 >= 0 and s1 >= 0:
                    t_in = 1.0
                    break
                if s0 >= 0:
                    t_in, outside = max(t_in, s0 / (s0 - s1)), True
                elif s1 >= 0:
                    t_out = min(t_out, s0 / (s0 - s1))
            if t_in >= t_out or t_in <= 0 or t_out >= 1 or not outside:
                continue
            samples = [t_in + (k + 0.5) / 4 * (t_out - t_in) for k in range(4)]
            depths = [_exit(planes[host], l0 + t * (l1 - l0), u, r) for t in samples]
            k = int(np.argmax(depths))
            if depths[k] <= 0:
                continue
            point = x[i] + samples[k] * (x[j] - x[i])
            other = point + sign * depths[k] * n
            pa, pb = (point, other) if sign > 0 else (other, point)
            found.append((depths[k], pa - centre[a], pb - centre[b]))

    for first in range(nb):
        for second in range(first + 1, nb):
            if group[first] == group[second]:
                continue
            if np.any(lo[first] > hi[second]) or np.any(lo[second] > hi[first]):
                continue
            ab, face_ab = overlap(first, second)
            ba, face_ba = overlap(second, first)
            if min(ab, ba) <= 0:
                continue
            a, b, face = (first, second, face_ab) if ab <= ba else (second, first, face_ba)
            n = rotation[b] @ planes[b][face, :3]
            found = []
            for i in parts[a]:
                local = rotation[b].T @ (x[i] - centre[b])
                if np.any(planes[b][:, :3] @ local - planes[b][:, 3] >= radius[i]):
                    continue
                gap = planes[b][face, :3] @ local - planes[b][face, 3]
                found.append((radius[i] - gap, x[i] - centre[a], x[i] - centre[b] - gap * n))
            u = -(rotation[a].T @ n)
            for i in parts[b]:
                if len(planes[a]) == 0:
                    break
                t = _exit(planes[a], rotation[a].T @ (x[i] - centre[a]), u, radius[i])
                if t <= 0:
                    continue
                found.append((t, x[i] - centre[a] - t * n, x[i] - centre[b]))
            edge_contacts(a, b, 1.0, n, a, b, found)
            edge_contacts(b, a, -1.0, n, a, b, found)
            if not found:
                continue
            deepest = 0.0
            for depth, s, rho in found:
                deepest = max(deepest, depth)
                total = weight(a, s, n) + weight(b, rho, n)
                if total > 0:
                    push(a, b, s, rho, n, depth / total / len(found))
            if friction <= 0:
                continue
            travel = (centre[a] - before[a]) - (centre[b] - before[b])
            tangent = travel - (travel @ n) * n
            t = np.linalg.norm(tangent)
            total = inv_m[a] + inv_m[b]
            if t <= 0 or total <= 0:
                continue
            lam = min(t, friction * deepest) / total
            push(a, b, np.zeros(3), np.zeros(3), -tangent / t, lam)
    return x
