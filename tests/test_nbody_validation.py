"""Validation of n-body dynamics against closed forms and conservation laws.

Every system steps with ``integrator="velocity_verlet"``: kick-drift-kick leapfrog with
the force evaluated again at the new positions (symplectic, second order), in float64.

- Kepler orbit (G = 1, m = 1 and 0.5, a = 1, e = 0.5, h = P/400, 30 orbits): leapfrog
  conserves a shadow energy, so the energy error oscillates within the orbit with an
  amplitude O(h²) (measured 6.7e-4 at pericentre) and does not grow; the mean over an
  orbit moved by 4e-7 in 50 orbits. Bounds: 2e-3 on the error, 1e-5 on the change of
  the per-orbit mean. The time between pericentres differs from Kepler's period by the
  O(h²) precession of the discrete orbit (measured 1.0e-3 of P): bound 3e-3.
- Plummer sphere (N = 1000, G = M = a = 1, ε = 0.05, h = 0.02 to t = 10, three
  crossing times ``r_v / v_rms``): sampled in equilibrium, it stays there. With N = 1000
  the virial ratio fluctuates by a few per cent (sampling noise ~ 1/sqrt(N)), so 2K/|W|
  within [0.85, 1.15] and the half-mass radius within 10 % of its start.
- Momentum: direct summation's pair terms cancel to round-off, so total momentum stays
  at 1e-12 of Σ m|v|.
- Two charges released from rest: energy conservation gives the speed at separation
  ``r``: ``v = sqrt(k q² (1/r0 - 1/r) / m)`` each (rtol 1e-4 at h small enough that the
  O(h²) error is 1e-6).
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from motes import ParticleSystem
from motes.emit.nbody import kepler_pair, plummer_sphere
from motes.forces import Coulomb, NBodyGravity
from motes.forces.nbody import K_COULOMB


def particles(position, velocity, mass, *forces, attributes=()):
    """A float64 system holding the given particles (no emitter)."""
    n = position.shape[1]
    system = ParticleSystem(
        n, dtype=np.float64, integrator="velocity_verlet",
        attributes=("mass", "inv_mass", *attributes),
    )  # fmt: skip
    system.add(*forces)
    system.store.spawn(n)
    system.store.raw("position")[:] = position
    system.store.raw("velocity")[:] = velocity
    system.store.raw("mass")[:] = mass
    system.store.raw("inv_mass")[:] = 1.0 / mass
    return system


def kinetic(velocity, mass):
    return 0.5 * float((mass * (velocity * velocity).sum(axis=0)).sum())


def test_kepler_orbit_period_and_energy():
    mass = np.array([1.0, 0.5])
    position, velocity, period = kepler_pair(1.0, 0.5, 1.0, eccentricity=0.5)
    system = particles(position, velocity, mass, NBodyGravity(1.0, method="direct"))
    steps, orbits = 400, 30
    dt = period / steps
    x = np.empty((steps * orbits, 3, 2))
    v = np.empty_like(x)
    for k in range(steps * orbits):
        system.step(dt)
        x[k] = system.store.raw("position")
        v[k] = system.store.raw("velocity")
    separation = np.linalg.norm(x[:, :, 0] - x[:, :, 1], axis=1)
    energy = 0.5 * (mass * (v * v).sum(axis=1)).sum(axis=1) - mass[0] * mass[1] / separation
    e0 = kinetic(velocity, mass) - mass[0] * mass[1] / np.linalg.norm(
        position[:, 0] - position[:, 1]
    )
    error = (energy - e0) / abs(e0)
    assert np.abs(error).max() < 2e-3
    per_orbit = error.reshape(orbits, steps).mean(axis=1)
    assert abs(per_orbit[-1] - per_orbit[0]) < 1e-5  # no secular drift
    inner = separation[1:-1]
    pericentres = np.flatnonzero((inner < separation[:-2]) & (inner < separation[2:])) + 1
    assert len(pericentres) == orbits - 1
    measured = (pericentres[-1] - pericentres[0]) * dt / (len(pericentres) - 1)
    assert_allclose(measured, period, rtol=3e-3)
    # The centre of mass stays at rest at the origin.
    com = (mass * x[-1]).sum(axis=1) / mass.sum()
    assert np.abs(com).max() < 1e-12


def half_mass_radius(position, mass):
    r = np.linalg.norm(position - (mass * position).sum(axis=1, keepdims=True) / mass.sum(), axis=0)
    order = np.argsort(r)
    return r[order][np.searchsorted(np.cumsum(mass[order]), 0.5 * mass.sum())]


def test_plummer_sphere_stays_in_virial_equilibrium():
    position, velocity, mass = plummer_sphere(1000, seed=11)
    gravity = NBodyGravity(1.0, softening=0.05, method="direct")
    system = particles(position, velocity, mass, gravity)
    r_half = half_mass_radius(position, mass)
    p0 = np.abs(mass * velocity).sum()
    for _ in range(10):
        for _ in range(50):
            system.step(0.02)
        x = system.store.raw("position")
        v = system.store.raw("velocity")
        ratio = 2.0 * kinetic(v, mass) / abs(gravity.potential_energy(x, mass))
        assert 0.85 < ratio < 1.15
        assert abs(half_mass_radius(x, mass) / r_half - 1.0) < 0.1
        assert np.abs((mass * v).sum(axis=1)).max() < 1e-12 * p0


@pytest.mark.slow
def test_plummer_sphere_with_barnes_hut_over_ten_crossing_times():
    """N = 20,000 (fluctuations ~1 %), θ = 0.5, t = 30: bounds [0.93, 1.07] and 5 %.

    About 15 minutes on the shared 2-core machine (3,000 tree evaluations, and ten
    float64 potential energies by direct summation in NumPy)."""
    position, velocity, mass = plummer_sphere(20_000, seed=12)
    gravity = NBodyGravity(1.0, softening=0.02, method="barnes_hut", theta=0.5)
    system = particles(position, velocity, mass, gravity)
    r_half = half_mass_radius(position, mass)
    for _ in range(10):
        for _ in range(150):
            system.step(0.02)
        x = system.store.raw("position")
        v = system.store.raw("velocity")
        ratio = 2.0 * kinetic(v, mass) / abs(gravity.potential_energy(x, mass))
        assert 0.93 < ratio < 1.07
        assert abs(half_mass_radius(x, mass) / r_half - 1.0) < 0.05


def test_two_charges_repel_as_coulombs_law_gives():
    q, m, r0 = 1e-6, 1e-3, 0.1
    position = np.array([[0.0, r0], [0.0, 0.0], [0.0, 0.0]])
    system = particles(position, np.zeros((3, 2)), np.full(2, m), Coulomb(), attributes=("charge",))
    system.store.raw("charge")[:] = q
    for _ in range(4000):
        system.step(2.5e-5)
    x = system.store.raw("position")
    v = system.store.raw("velocity")
    r = x[0, 1] - x[0, 0]
    assert r > 2 * r0  # they flew apart along the line between them
    speed = np.sqrt(K_COULOMB * q * q * (1.0 / r0 - 1.0 / r) / m)
    assert_allclose(v[0], [-speed, speed], rtol=1e-4)
    assert_allclose(v[1:], 0.0, atol=1e-12)
