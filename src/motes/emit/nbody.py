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


def disc_galaxy(
    count: int,
    *,
    core_mass: float = 1.0,
    disc_mass: float = 0.1,
    radius: float = 1.0,
    inner_radius: float = 0.1,
    normal=(0.0, 1.0, 0.0),
    thickness: float = 0.02,
    G: float = 1.0,
    softening: float = 0.0,
    seed: int | np.random.Generator = 0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""A rotating disc of stars around a heavy core, on circular orbits.

    The core (particle 0) holds ``core_mass``; ``count`` stars share ``disc_mass`` with
    an exponential surface density ``Σ ∝ exp(-r / r_d)``, ``r_d = radius / 3``, between
    ``inner_radius`` and ``radius``, and a Gaussian thickness. Each star moves on the
    circular orbit of the mass inside its radius, ``v² = G M(<r) r² / (r² + ε²)^{3/2}``
    (the softened force), counter-clockwise about ``normal``. With a light disc this is
    Toomre & Toomre's (1972) model of interacting galaxies.

    Parameters
    ----------
    count : int
        Stars >= 1 (the core is one more particle).
    core_mass, disc_mass : float
        [kg], > 0 and >= 0.
    radius, inner_radius : float
        Outer and inner radius of the disc [m], ``0 <= inner_radius < radius``.
    normal : (3,) array_like
        Rotation axis (non-zero).
    thickness : float
        Standard deviation of the height over the disc, as a fraction of ``radius``.
    G, softening : float
        The gravitational constant (> 0) and Plummer softening [m] (>= 0) of the force
        the orbits are for.
    seed : int or numpy.random.Generator

    Returns
    -------
    position, velocity : float64 (3, count + 1)
        [m], [m/s]; the core at the origin, at rest.
    particle_mass : float64 (count + 1,) [kg]
    """
    count = check.integer("count", count, low=1)
    core_mass = check.positive("core_mass", core_mass)
    disc_mass = check.non_negative("disc_mass", disc_mass)
    outer = check.positive("radius", radius)
    inner = check.real("inner_radius", inner_radius, low=0.0, high=outer, high_open=True)
    axis = check.unit_vector("normal", normal)
    thickness = check.non_negative("thickness", thickness)
    G = check.positive("G", G)
    eps2 = check.non_negative("softening", softening) ** 2
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    r = _exponential_disc_radii(rng, count, outer / 3.0, inner, outer)
    star_mass = np.full(count, disc_mass / count)
    position, velocity = _circular_orbits(
        rng, r, star_mass, core_mass, axis, thickness * outer, G, eps2
    )
    position = np.concatenate([np.zeros((3, 1)), position], axis=1)
    velocity = np.concatenate([np.zeros((3, 1)), velocity], axis=1)
    return position, velocity, np.concatenate([[core_mass], star_mass])


def ring(
    count: int,
    *,
    central_mass: float,
    mass: float = 0.0,
    radius: float = 1.0,
    inner_radius: float | None = None,
    normal=(0.0, 1.0, 0.0),
    thickness: float = 0.0,
    G: float = 1.0,
    softening: float = 0.0,
    seed: int | np.random.Generator = 0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""Particles on circular orbits about a central mass at the origin: a planet's ring,
    an asteroid belt, or (``count = 1``, ``inner_radius = radius``) one planet.

    Radii are uniform in area between ``inner_radius`` and ``radius``; each particle moves
    on the circular orbit of the central mass and the ring's mass inside its radius,
    ``v² = G M(<r) r² / (r² + ε²)^{3/2}``, counter-clockwise about ``normal``. The
    central mass itself is not placed (it is another particle, or a body of the scene).

    Parameters
    ----------
    count : int
        Particles >= 1, each of mass ``mass / count``.
    central_mass, mass : float
        [kg], > 0 and >= 0.
    radius, inner_radius : float
        Outer and inner radius [m], ``0 < inner_radius <= radius`` (default: ``radius``,
        a circle).
    normal : (3,) array_like
        Rotation axis (non-zero).
    thickness : float
        Standard deviation of the height over the plane, as a fraction of ``radius``.
    G, softening, seed
        As for :func:`disc_galaxy`.

    Returns
    -------
    position, velocity : float64 (3, count)
        [m], [m/s], relative to the central mass.
    particle_mass : float64 (count,) [kg]
    """
    count = check.integer("count", count, low=1)
    central_mass = check.positive("central_mass", central_mass)
    mass = check.non_negative("mass", mass)
    outer = check.positive("radius", radius)
    inner = outer if inner_radius is None else inner_radius
    inner = check.real("inner_radius", inner, low=0.0, high=outer, low_open=True)
    axis = check.unit_vector("normal", normal)
    thickness = check.non_negative("thickness", thickness)
    G = check.positive("G", G)
    eps2 = check.non_negative("softening", softening) ** 2
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    r = np.sqrt(rng.uniform(inner * inner, outer * outer, count))
    each = np.full(count, mass / count)
    position, velocity = _circular_orbits(rng, r, each, central_mass, axis, thickness * outer,
                                          G, eps2)  # fmt: skip
    return position, velocity, each


def _circular_orbits(rng, r, masses, central, axis, height, G, eps2):
    """Positions and velocities (3, n) of bodies at radii ``r`` [m] at random angles in
    the plane normal to ``axis`` (heights of standard deviation ``height``), each on the
    circular orbit of ``central`` plus the masses inside its radius (softened force),
    counter-clockwise about ``axis``."""
    count = r.shape[0]
    phi = rng.uniform(0.0, 2.0 * np.pi, count)
    lift = rng.normal(0.0, height, count)
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(axis, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    radial = np.outer(e1, np.cos(phi)) + np.outer(e2, np.sin(phi))
    tangent = np.cross(axis[:, None], radial, axis=0)
    order = np.argsort(r, kind="stable")
    inside = np.empty(count)
    inside[order] = np.cumsum(masses[order]) - masses[order]
    enclosed = central + inside
    speed = np.sqrt(G * enclosed * r * r / (r * r + eps2) ** 1.5)
    return r * radial + lift * axis[:, None], speed * tangent


def _exponential_disc_radii(rng, count, scale, inner, outer) -> np.ndarray:
    """Radii with density ``∝ r exp(-r / scale)`` on ``[inner, outer]``, by inverting the
    cumulative ``F(x) = 1 - (1 + x) e^{-x}`` (``x = r / scale``) by bisection: 60 halvings
    reach float64 resolution, and no draw is rejected however narrow the ring."""

    def cdf(x):
        return -np.expm1(-x) - x * np.exp(-x)

    lo_x, hi_x = inner / scale, outer / scale
    u = rng.uniform(cdf(lo_x), cdf(hi_x), count)
    lo = np.full(count, lo_x)
    hi = np.full(count, hi_x)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        below = cdf(mid) < u
        lo = np.where(below, mid, lo)
        hi = np.where(below, hi, mid)
    return scale * 0.5 * (lo + hi)


def add_particles(system, position, velocity, *, mass=None, **attributes) -> slice:
    """Append particles with given states to ``system`` (a ``ParticleSystem``).

    Parameters
    ----------
    system : ParticleSystem
    position, velocity : array_like of shape (3, n)
        [m], [m/s].
    mass : array_like of shape (n,), optional
        [kg], > 0; sets ``mass`` and ``inv_mass`` (both allocated if needed).
    **attributes : array_like of shape (n,) or (components, n)
        Other attributes by name (``charge=...``), allocated if built in.

    Returns
    -------
    slice
        The new particles' indices in the store. Particles past the capacity are
        dropped (counted in ``store.dropped``), as for emission.

    Examples
    --------
    >>> import numpy as np
    >>> from motes import ParticleSystem
    >>> system = ParticleSystem(10)
    >>> add_particles(system, np.zeros((3, 2)), np.ones((3, 2)), mass=[1.0, 2.0])
    slice(0, 2, None)
    >>> system.store.raw("inv_mass")[:2].tolist()
    [1.0, 0.5]
    """
    position = np.asarray(position, dtype=np.float64)
    if position.ndim != 2 or position.shape[0] != 3:
        raise ValueError(f"position must have shape (3, n), got {position.shape}")
    n = position.shape[1]
    velocity = np.asarray(velocity, dtype=np.float64)
    if velocity.shape != (3, n):
        raise ValueError(f"velocity must have shape (3, {n}), got {velocity.shape}")
    values = dict(attributes)
    if mass is not None:
        mass = np.asarray(mass, dtype=np.float64)
        if mass.shape != (n,) or not (mass > 0).all():
            raise ValueError(f"mass must be {n} numbers > 0, got shape {mass.shape}")
        values["mass"] = mass
        values["inv_mass"] = 1.0 / mass
    store = system.store
    store.require(*(name for name in values if not store.has(name)))
    new = store.spawn(n)
    made = new.stop - new.start
    store.raw("position")[:, new] = position[:, :made]
    store.raw("velocity")[:, new] = velocity[:, :made]
    for name, value in values.items():
        store.raw(name)[..., new] = np.asarray(value)[..., :made]
    return new
