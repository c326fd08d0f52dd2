"""Plain NumPy twins of the spatial and fluid kernels: slow and obviously correct."""

from __future__ import annotations

import numpy as np

import naive_distance


def neighbor_sets(points: np.ndarray, radius: float, queries: np.ndarray | None = None):
    """Brute force: for each query (rows of (m, 3)), the set of points within ``radius``.

    Without ``queries`` the points query themselves and leave themselves out. Distances
    in float64, ``d² <= r²`` as the grid and cKDTree test.
    """
    p = np.asarray(points, np.float64)
    q = p if queries is None else np.asarray(queries, np.float64)
    d2 = ((q[:, None, :] - p[None, :, :]) ** 2).sum(axis=2)
    hits = d2 <= radius * radius
    if queries is None:
        np.fill_diagonal(hits, False)
    return [set(np.flatnonzero(row).tolist()) for row in hits]


# -- SPH kernels (Müller, Charypar & Gross 2003), vectorised over distances ----------------
def poly6(r, h):
    return np.where(r <= h, 315 / (64 * np.pi * h**9) * np.clip(h * h - r * r, 0, None) ** 3, 0)


def spiky_grad_scale(r, h):
    """∇W_spiky(r⃗) = scale · r⃗; 0 at r = 0."""
    safe = np.where(r > 0, r, 1.0)
    return np.where((r > 0) & (r <= h), -45 / (np.pi * h**6) * (h - r) ** 2 / safe, 0.0)


def spiky(r, h):
    return np.where(r <= h, 15 / (np.pi * h**6) * np.clip(h - r, 0, None) ** 3, 0.0)


def wall_fraction(d, h):
    """∫ poly6 over the half-space beyond a wall at distance d, by quadrature in 1D."""
    u = np.clip(np.asarray(d, float) / h, 0, 1)
    z = np.linspace(0, 1, 4001)
    slab = 315 / 256 * (1 - z * z) ** 4
    cumulative = np.concatenate([[0], np.cumsum((slab[1:] + slab[:-1]) / 2 * np.diff(z))])
    return cumulative[-1] - np.interp(u, z, cumulative)


def wall_share(d, spacing, h, scale):
    """The rest lattice's planes beyond a wall, each smeared over its area: the share of
    the kernel (a fraction of δ₀) and its derivative in d, summed plane by plane."""
    u0 = np.clip(np.asarray(d, float), 0, None)[..., None] + (np.arange(40) + 0.5) * spacing
    a = np.clip(1 - (u0 / h) ** 2, 0, None) * (u0 < h)
    c = scale * 315 / (256 * h) * spacing
    return c * (a**4).sum(-1), c * (-8 * u0 / h**2 * a**3).sum(-1)


# -- boundaries ---------------------------------------------------------------------------
def signed_distance(row, p):
    """(d, n) of points p (m, 3) to one packed boundary row (the shared twin)."""
    return naive_distance.signed_distance(row, p)


def walls(rows, p, h, spacing, scale):
    """Free kernel share Q = Π(1 - f_b) and ∇(1 - Q) (m, 3), by the product rule."""
    fs, grads = [], []
    for row in rows:
        d, n = signed_distance(row, p)
        near = d < h
        share, share_slope = wall_share(d, spacing, h, scale)
        f = np.where(near, share, 0.0)
        slope = np.where(near, share_slope, 0.0)
        fs.append(f)
        grads.append(slope[:, None] * n)
    free = np.prod([1 - f for f in fs], axis=0) if fs else np.ones(len(p))
    grad = np.zeros_like(p)
    for b in range(len(fs)):
        others = np.prod([1 - f for c, f in enumerate(fs) if c != b], axis=0) if fs else 1
        grad += grads[b] * np.asarray(others)[..., None]
    return free, grad


# -- solver passes, over all pairs within h -------------------------------------------------
def pairs_within(p, h):
    rel = p[:, None, :] - p[None, :, :]
    r = np.linalg.norm(rel, axis=2)
    near = r <= h
    np.fill_diagonal(near, False)
    return rel, r, near


def density_lambda(p, weight, rows, h, spacing, scale, delta0, eps):
    rel, r, near = pairs_within(p, h)
    delta = poly6(0.0, h) + np.where(near, poly6(r, h), 0).sum(axis=1)
    free, wall_grad = walls(rows, p, h, spacing, scale)
    delta = delta + delta0 * (1 - free)
    g = np.where(near, spiky_grad_scale(r, h), 0)[..., None] * rel / delta0
    own = g.sum(axis=1) + wall_grad
    sum_g2 = (weight[None, :] * (g**2).sum(axis=2)).sum(axis=1)
    c = np.maximum(delta / delta0 - 1, 0)
    return delta, -c / (sum_g2 + weight * (own**2).sum(axis=1) + eps)


def project(p, rows, radius):
    """Each boundary in order pushes points closer than radius back to it; the pushes."""
    p = p.copy()
    deepest = np.zeros(len(p))
    for row in rows:
        d, n = signed_distance(row, p)
        push = np.clip(radius - d, 0, None)
        p += push[:, None] * n
        deepest = np.maximum(deepest, push)
    return p, deepest


def correction(p, weight, lam, rows, h, spacing, scale, delta0, k_corr, inv_wq):
    rel, r, near = pairs_within(p, h)
    scorr = k_corr * (poly6(r, h) * inv_wq) ** 4
    coef = np.where(near, (lam[:, None] + lam[None, :] - scorr) * spiky_grad_scale(r, h), 0)
    dp = (coef[..., None] * rel).sum(axis=1) * (weight / delta0)[:, None]
    _, wall_grad = walls(rows, p, h, spacing, scale)
    return dp + (weight * lam)[:, None] * wall_grad


def cohesion_spline(r, h):
    a = ((h - r) * r) ** 3
    inner = 2 * a - h**6 / 64
    value = np.where(2 * r > h, a, inner) * 32 / (np.pi * h**9)
    return np.where((r > 0) & (r <= h), value, 0.0)


def surface_normals(p, phase, delta, h):
    """Akinci et al. 2013, eq. 5 over same-phase neighbours: n_i = h Σ ∇W_poly6 / δ_j."""
    rel, r, near = pairs_within(p, h)
    same = phase[:, None] == phase[None, :]
    grad = -6 * 315 / (64 * np.pi * h**9) * np.clip(h * h - r * r, 0, None) ** 2
    w = np.where(near & same, grad / delta[None, :], 0)
    return h * (w[..., None] * rel).sum(axis=1)


def exchange(p, v, phase, mass, delta, gamma, h, dt, xsph, k, sigma, repulsion, delta0):
    rel, r, near = pairs_within(p, h)
    mi, mj = mass[:, None], mass[None, :]
    mu = 2 * mi * mj / (mi + mj)
    w = 2 * poly6(r, h) / (delta[:, None] + delta[None, :])
    lecture = np.where(near, k * np.exp(-(r**2) / (2 * sigma**2)) * dt, 0)
    smooth = np.where(near, xsph * mu * w, 0)
    momentum = mass[:, None] * v
    f = (lecture[..., None] * (momentum[None, :, :] - momentum[:, None, :])).sum(axis=1)
    f += (smooth[..., None] * (v[None, :, :] - v[:, None, :])).sum(axis=1)
    same = phase[:, None] == phase[None, :]
    kij = 2 * delta0 / (delta[:, None] + delta[None, :])
    safe = np.where(r > 0, r, 1)
    coh = -gamma[phase][:, None] * mi * mj * kij * cohesion_spline(r, h) * dt / safe
    rep = repulsion * mu * spiky(r, h) / delta0 * dt / safe
    s = np.where(near & (r > 0), np.where(same, coh, rep), 0)
    f += (s[..., None] * rel).sum(axis=1)
    normals = surface_normals(p, phase, delta, h)
    c = np.where(near & (r > 0) & same, -gamma[phase][:, None] * mi * kij * dt, 0)
    f += (c[..., None] * (normals[:, None, :] - normals[None, :, :])).sum(axis=1)
    return v + f / mass[:, None]


def momentum_exchange_pairs(p, v, mass, k, sigma, h, dt):
    """The lecture's viscosity alone, pair by pair in a Python loop (reads like the notes)."""
    out = mass[:, None] * v
    n = len(p)
    for i in range(n):
        for j in range(n):
            d = np.linalg.norm(p[i] - p[j])
            if i != j and d <= h:
                out[i] += (
                    k * np.exp(-(d**2) / (2 * sigma**2)) * dt * (mass[j] * v[j] - mass[i] * v[i])
                )
    return out / mass[:, None]


def vorticity(p, v, delta, h):
    """ω_i = Σ_j ∇_i W_ij × (v_j - v_i) / δ_j, spiky gradients (Macklin & Müller eq. 15)."""
    rel, r, near = pairs_within(p, h)
    g = np.where(near, spiky_grad_scale(r, h), 0.0) / delta[None, :]
    dv = v[None, :, :] - v[:, None, :]
    return (g[..., None] * np.cross(rel, dv)).sum(axis=1)


def confinement(p, v, delta, omega, h, scale):
    """v + scale · N × ω, N = η/|η|, η_i = Σ_j (|ω_j| - |ω_i|) ∇_i W_ij / δ_j."""
    rel, r, near = pairs_within(p, h)
    g = np.where(near, spiky_grad_scale(r, h), 0.0) / delta[None, :]
    mag = np.linalg.norm(omega, axis=1)
    eta = (g[..., None] * (mag[None, :] - mag[:, None])[..., None] * rel).sum(axis=1)
    length = np.linalg.norm(eta, axis=1, keepdims=True)
    normal = np.divide(eta, length, out=np.zeros_like(eta), where=length > 0)
    return v + scale * np.cross(normal, omega)
