"""Plain NumPy twins of the implicit-step, cloth and hair kernels (slow, obviously right)."""

from __future__ import annotations

import numpy as np


def spring_terms(x, v, pairs, rest, ks, kd):
    """Spring forces f (n, 3), ∂f/∂x and ∂f/∂v as dense (3n, 3n) matrices.

    The stiffness Jacobian is Baraff & Witkin's with the transverse term clamped at 0
    for compressed springs and the damping force's position derivative dropped.
    """
    n = x.shape[1]
    f = np.zeros((n, 3))
    dfdx = np.zeros((3 * n, 3 * n))
    dfdv = np.zeros((3 * n, 3 * n))
    for k, (a, b) in enumerate(pairs):
        d = x[:, a] - x[:, b]
        length = np.linalg.norm(d)
        u = d / length
        r = max(0.0, 1.0 - rest[k] / length)
        closing = (v[:, a] - v[:, b]) @ u
        fa = -(ks[k] * (length - rest[k]) + kd[k] * closing) * u
        f[a] += fa
        f[b] -= fa
        kx = -ks[k] * (r * np.eye(3) + (1 - r) * np.outer(u, u))
        kv = -kd[k] * np.outer(u, u)
        for i, j, sign in ((a, a, 1), (b, b, 1), (a, b, -1), (b, a, -1)):
            dfdx[3 * i : 3 * i + 3, 3 * j : 3 * j + 3] += sign * kx
            dfdv[3 * i : 3 * i + 3, 3 * j : 3 * j + 3] += sign * kv
    return f, dfdx, dfdv


def implicit_step(
    x, v, mass, h, pairs, rest, ks, kd, *, external=None, damping=0.0, filt=None, target=None
):
    """Δv (n, 3) of one linearised backward Euler step, by a dense solve.

    With projections ``S`` (filt, (n, 9)) and ``z = (I - S)(target - v)``, solves
    ``S A S y = S (b - A z)`` (plus ``(I - S) y = 0``) and returns ``z + y``.
    """
    n = x.shape[1]
    f, dfdx, dfdv = spring_terms(x, v, pairs, rest, ks, kd)
    if external is not None:
        f += external.T
    f -= np.broadcast_to(damping, (n,))[:, None] * v.T  # linear drag -c v
    m = np.repeat(mass, 3)
    a = np.diag(m + h * np.broadcast_to(damping, (n,)).repeat(3)) - h * dfdv - h * h * dfdx
    b = h * (f.ravel() + h * dfdx @ v.T.ravel())
    s = np.zeros((3 * n, 3 * n))
    filt = np.tile(np.eye(3).ravel(), (n, 1)) if filt is None else filt
    for i in range(n):
        s[3 * i : 3 * i + 3, 3 * i : 3 * i + 3] = filt[i].reshape(3, 3)
    target = np.zeros((3, n)) if target is None else target
    z = (np.eye(3 * n) - s) @ (target - v).T.ravel()
    lhs = s @ a @ s + (np.eye(3 * n) - s)
    y = np.linalg.solve(lhs, s @ (b - a @ z))
    return (z + y).reshape(n, 3)


def aero_forces(x, v, faces, wind, air, time, frequencies, phases):
    """Per-vertex drag + lift (n, 3) [N]: a third of each triangle's (Keckeisen 2004)."""
    rho, cd, cl, amplitude = air
    out = np.zeros((x.shape[1], 3))
    speed = np.linalg.norm(wind)
    for tri in faces:
        p = x[:, tri].T
        normal = np.cross(p[1] - p[0], p[2] - p[0])
        area = 0.5 * np.linalg.norm(normal)
        centroid = p.mean(axis=0)
        lag = centroid @ wind / speed**2 if speed > 0 else 0.0
        g = 1.0
        if len(frequencies):
            g += amplitude * np.mean(np.sin(2 * np.pi * frequencies * (time - lag) + phases))
        w = g * np.asarray(wind) - v[:, tri].mean(axis=1)
        if area == 0 or w @ w == 0:
            continue
        n = normal / (2 * area)
        w_hat = w / np.linalg.norm(w)
        cos = n @ w_hat
        if cos < 0:
            n, cos = -n, -cos
        q = 0.5 * rho * area * (w @ w) * cos
        f = q * cd * w_hat + q * cl * (n - cos * w_hat)
        out[tri] += f / 3
    return out


def strain_limit(x, weight, rank, pairs, rest, limit, tolerance, passes, shock):
    """Provot 1995 strain limiting, springs visited in the given order (Gauss-Seidel);
    in the first ``shock`` passes the end of lower rank stays put when the other can
    move. Returns (x, passes)."""
    x = x.copy()
    for p in range(passes):
        done = True
        for (a, b), s in zip(pairs, rest, strict=True):
            d = x[:, a] - x[:, b]
            length = np.linalg.norm(d)
            excess = length - (1 + limit) * s
            if excess <= 0:
                continue
            done = done and excess <= tolerance * s
            wa, wb = weight[a], weight[b]
            if p < shock and rank[a] < rank[b] and wb > 0:
                wa = 0.0
            elif p < shock and rank[b] < rank[a] and wa > 0:
                wb = 0.0
            if wa + wb > 0:
                step = -excess / (length * (wa + wb)) * d
                x[:, a] += wa * step
                x[:, b] -= wb * step
        if done:
            return x, p + 1
    return x, passes
