"""Slow, obviously correct NumPy twins of the force kernels in ``motes.forces``.

Every twin works in float64 on ``(n, 3)`` rows (the kernels use ``(3, n)``), follows the
formula in its kernel's docstring literally, and returns the force [N] per particle.
``mass=None`` means every particle weighs 1 kg.
"""

from __future__ import annotations

import numpy as np


def _mass(mass, n):
    return np.ones(n) if mass is None else np.asarray(mass, dtype=np.float64)


def radial_inverse_square(x, mass, center, strength, softening):
    """``m s (c - x) / (|c - x|^2 + ε^2)^{3/2}``."""
    r = np.asarray(center, dtype=np.float64) - np.asarray(x, dtype=np.float64)
    d = np.sum(r**2, axis=1) + softening**2
    return (_mass(mass, len(r)) * strength / d**1.5)[:, None] * r


def radial_linear(x, mass, center, strength):
    """``m s (c - x)``."""
    r = np.asarray(center, dtype=np.float64) - np.asarray(x, dtype=np.float64)
    return (_mass(mass, len(r)) * strength)[:, None] * r


def vortex(x, mass, center, axis, strength, radius, pull):
    """``m (s â × r_⊥ - p r_⊥) / (|r_⊥|^2 + R^2)``, ``r_⊥`` the offset from the axis."""
    axis = np.asarray(axis, dtype=np.float64)
    axis = axis / np.linalg.norm(axis)
    r = np.asarray(x, dtype=np.float64) - center
    perp = r - np.outer(r @ axis, axis)
    swirl = np.cross(axis, perp)
    denom = np.sum(perp**2, axis=1) + radius**2
    return _mass(mass, len(r))[:, None] * (strength * swirl - pull * perp) / denom[:, None]


# -- Perlin (2002) improved noise, transcribed from the reference implementation ---------
def fade(t):
    return t * t * t * (t * (t * 6 - 15) + 10)


def fade_derivative(t):
    return 30 * t**2 * (t - 1) ** 2


def grad(h, x, y, z):
    """Perlin's ``grad``: the dot product of gradient ``h & 15`` with ``(x, y, z)``."""
    h = h & 15
    u = np.where(h < 8, x, y)
    v = np.where(h < 4, y, np.where((h == 12) | (h == 14), x, z))
    return np.where(h & 1 == 0, u, -u) + np.where(h & 2 == 0, v, -v)


def noise(points, perm):
    """Value (n,) and gradient (n, 3) of Perlin noise with table ``perm`` (512,).

    The noise is ``Σ_c w_c(f) g_c · (f - c)`` over the eight cell corners ``c`` with
    weights ``w_c = Π_j (c_j ? u_j : 1 - u_j)``, ``u = fade(f)``; its gradient follows
    from the product rule corner by corner.
    """
    p = np.asarray(points, dtype=np.float64)
    cell = np.floor(p)
    f = p - cell
    lattice = cell.astype(np.int64) & 255
    u = fade(f)
    du = fade_derivative(f)
    value = np.zeros(len(p))
    gradient = np.zeros((len(p), 3))
    eye = np.eye(3)
    for c in np.ndindex(2, 2, 2):
        h = perm[perm[perm[lattice[:, 0] + c[0]] + lattice[:, 1] + c[1]] + lattice[:, 2] + c[2]]
        offset = f - np.array(c)
        ramp = grad(h, *offset.T)
        g = np.stack([grad(h, *e) for e in eye], axis=1)  # the corner's gradient vector
        factors = np.where(np.array(c) == 1, u, 1 - u)
        dfactors = np.where(np.array(c) == 1, du, -du)
        weight = factors.prod(axis=1)
        dweight = np.stack(
            [dfactors[:, j] * np.prod(np.delete(factors, j, axis=1), axis=1) for j in range(3)],
            axis=1,
        )
        value += weight * ramp
        gradient += weight[:, None] * g + ramp[:, None] * dweight
    return value, gradient


def curl_noise(x, mass, perms, strength, scale, octaves, shift):
    """``m strength ∇_p × ψ``, ``ψ_k = Σ_o 4^-o N_k(2^o (x/scale + shift e_k))``."""
    p = np.asarray(x, dtype=np.float64) / scale
    jac = np.zeros((len(p), 3, 3))  # jac[:, k, j] = ∂ψ_k/∂p_j
    for k in range(3):
        q = p + shift * np.eye(3)[k]
        for o in range(octaves):
            _, g = noise(2.0**o * q, perms[k])
            jac[:, k] += 2.0**-o * g
    curl = np.stack(
        [jac[:, 2, 1] - jac[:, 1, 2], jac[:, 0, 2] - jac[:, 2, 0], jac[:, 1, 0] - jac[:, 0, 1]],
        axis=1,
    )
    return _mass(mass, len(p))[:, None] * strength * curl


def springs(x, v, pairs, rest_length, stiffness, damping):
    """Damped Hooke springs, one spring at a time: ``f_a = -(k_s(|d|-s) + k_d ḋ·d̂) d̂``."""
    x = np.asarray(x, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    m = len(pairs)
    rest_length, stiffness, damping = (
        np.broadcast_to(q, (m,)) for q in (rest_length, stiffness, damping)
    )
    force = np.zeros_like(x)
    for k, (a, b) in enumerate(pairs):
        d = x[a] - x[b]
        length = np.linalg.norm(d)
        if length == 0:
            continue
        unit = d / length
        f = -(stiffness[k] * (length - rest_length[k]) + damping[k] * (v[a] - v[b]) @ unit) * unit
        force[a] += f
        force[b] -= f
    return force
