"""Initial conditions for self-gravitating particles: Plummer spheres and Kepler pairs.

Vectorised NumPy sampling (no loop over particles), seeded by a ``numpy`` Generator.
"""

from __future__ import annotations

import numpy as np

from .. import _validate as check


def plummer_sphere(
    count: int,
    *,
    mass: float = 1.0,
    radius: float = 1.0,
    G: float = 1.0,
    seed: int | np.random.Generator = 0,
    max_radius: float = 100.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""A Plummer sphere in virial equilibrium (Aarseth, Hénon & Wielen 1974, A&A 37, 183).

    Density ``ρ(r) ∝ (1 + r²/a²)^{-5/2}`` with ``a = radius``; radii drawn from the
    cumulative mass ``M(r)/M = r³ / (r² + a²)^{3/2}``, speeds by rejection from the
    isotropic distribution function ``g(q) ∝ q² (1 - q²)^{7/2}``, ``q = v / v_esc``,
    ``v_esc = sqrt(2 G M) (r² + a²)^{-1/4}``; directions isotropic. The centre of mass
    and its velocity are moved to the origin. Potential energy ``W = -3π G M² / (32 a)``,
    kinetic ``K = -W / 2`` (virial ratio ``2K/|W| = 1``).

    Parameters
    ----------
    count : int
        Number of particles >= 1, each of mass ``mass / count``.
    mass : float
        Total mass ``M`` > 0 [kg].
    radius : float
        Plummer radius ``a`` > 0 [m].
    G : float
        Gravitational constant > 0 the velocities are in equilibrium for.
    seed : int or numpy.random.Generator
    max_radius : float
        Radii beyond ``max_radius · a`` are drawn again (> 1; the tail holds a fraction
        ``1 - (1 + 1/max_radius²)^{-3/2}`` of the mass, 1.5e-4 for 100).

    Returns
    -------
    position : float64 (3, count) [m]
    velocity : float64 (3, count) [m/s]
    particle_mass : float64 (count,) [kg]
    """
    count = check.integer("count", count, low=1)
    mass = check.positive("mass", mass)
    a = check.positive("radius", radius)
    G = check.positive("G", G)
    max_radius = check.real("max_radius", max_radius, low=1.0, low_open=True)
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    top = (1.0 + 1.0 / max_radius**2) ** -1.5  # M(r_max) / M
    u = rng.uniform(0.0, top, count)
    u = np.maximum(u, 1e-300)
    r = a / np.sqrt(u ** (-2.0 / 3.0) - 1.0)
    position = r * _directions(rng, count)
    q = np.empty(0)
    while q.shape[0] < count:
        # g(q) <= 0.1 on [0, 1] (its maximum is 0.092 at q = sqrt(2/9)).
        x = rng.uniform(0.0, 1.0, 2 * count)
        y = rng.uniform(0.0, 0.1, 2 * count)
        q = np.concatenate([q, x[y < x * x * (1.0 - x * x) ** 3.5]])
    v_esc = np.sqrt(2.0 * G * mass) * (r * r + a * a) ** -0.25
    velocity = q[:count] * v_esc * _directions(rng, count)
    position -= position.mean(axis=1, keepdims=True)
    velocity -= velocity.mean(axis=1, keepdims=True)
    return position, velocity, np.full(count, mass / count)


def _directions(rng: np.random.Generator, count: int) -> np.ndarray:
    """Isotropic unit vectors, shape (3, count)."""
    cos = rng.uniform(-1.0, 1.0, count)
    phi = rng.uniform(0.0, 2.0 * np.pi, count)
    sin = np.sqrt(1.0 - cos * cos)
    return np.stack([sin * np.cos(phi), sin * np.sin(phi), cos])


def kepler_pair(
    mass1: float,
    mass2: float,
    semi_major_axis: float,
    *,
    eccentricity: float = 0.0,
    G: float = 1.0,
) -> tuple[np.ndarray, np.ndarray, float]:
    """Two bodies on a Kepler orbit in the x-z plane, starting at pericentre.

    Parameters
    ----------
    mass1, mass2 : float
        Masses > 0 [kg].
    semi_major_axis : float
        ``a`` > 0 [m] of the relative orbit.
    eccentricity : float
        ``e`` in [0, 1).
    G : float
        Gravitational constant > 0.

    Returns
    -------
    position, velocity : float64 (3, 2)
        [m], [m/s]; centre of mass at rest at the origin.
    period : float
        ``2π sqrt(a³ / (G (m1 + m2)))`` [s].
    """
    m1 = check.positive("mass1", mass1)
    m2 = check.positive("mass2", mass2)
    a = check.positive("semi_major_axis", semi_major_axis)
    e = check.real("eccentricity", eccentricity, low=0.0, high=1.0, high_open=True)
    G = check.positive("G", G)
    total = m1 + m2
    separation = a * (1.0 - e)
    speed = np.sqrt(G * total * (1.0 + e) / separation)  # vis-viva at pericentre
    rel_x = np.array([separation, 0.0, 0.0])
    rel_v = np.array([0.0, 0.0, speed])
    position = np.stack([-m2 / total * rel_x, m1 / total * rel_x], axis=1)
    velocity = np.stack([-m2 / total * rel_v, m1 / total * rel_v], axis=1)
    return position, velocity, float(2.0 * np.pi * np.sqrt(a**3 / (G * total)))
