"""Integrators against the closed forms of their own discrete maps."""

import numpy as np
import pytest
from numpy.testing import assert_allclose

import motes as mo

OMEGA = 1.3


def oscillator(integrator, x0=1.0, v0=0.3):
    """One unit-mass particle on x'' = -ω² x (a user force), float64."""
    system = mo.ParticleSystem(1, seed=0, integrator=integrator, dtype=np.float64)
    system.add(mo.CallbackForce(lambda p, v, t: -(OMEGA**2) * p))
    system.store.spawn(1)
    system["position"] = [[x0, 0.0, 0.0]]
    system["velocity"] = [[v0, 0.0, 0.0]]
    return system


def state(system):
    return system["position"][0, 0], system["velocity"][0, 0]


def test_explicit_euler_energy_grows_by_exactly_one_plus_omega_h_squared():
    h = 0.05
    system = oscillator("explicit_euler")
    x, v = state(system)
    energy = v**2 + OMEGA**2 * x**2
    for _ in range(100):
        system.step(h)
        x, v = state(system)
        new = v**2 + OMEGA**2 * x**2
        # Exact in real arithmetic; float64 round-off per step is ~1e-16 relative.
        assert new / energy == pytest.approx(1 + (OMEGA * h) ** 2, rel=1e-12)
        energy = new


def test_symplectic_euler_conserves_its_modified_energy():
    h = 0.1
    system = oscillator("semi_implicit_euler")
    values = []
    for _ in range(500):
        system.step(h)
        x, v = state(system)
        values.append(v**2 + OMEGA**2 * x**2 - h * OMEGA**2 * x * v)
    assert np.ptp(values) < 1e-12 * abs(values[0])
    # ... while the true energy oscillates by O(h).
    x, v = state(system)
    assert np.ptp([v**2 + OMEGA**2 * x**2, values[0]]) > 0


def test_velocity_verlet_with_omega_h_one_returns_after_six_steps():
    h = 1 / OMEGA
    system = oscillator("velocity_verlet")
    start = np.array(state(system))
    for _ in range(6):
        system.step(h)
    # The one-step map is a rotation by 60° (cos θ = 1 - (ωh)²/2 = 1/2) in scaled phase space.
    assert_allclose(state(system), start, atol=1e-12)
    system.step(h)
    assert not np.allclose(state(system), start, atol=1e-3)


def test_rk4_is_fourth_order():
    errors = []
    for steps in (20, 40):
        h = 2.0 / steps
        system = oscillator("rk4")
        for _ in range(steps):
            system.step(h)
        t = 2.0
        exact = np.cos(OMEGA * t) + 0.3 / OMEGA * np.sin(OMEGA * t)
        errors.append(abs(state(system)[0] - exact))
    # Halving h divides the error by 2⁴ = 16 (asymptotically); allow 14..18.
    assert 14 < errors[0] / errors[1] < 18


G = 9.81
V0 = 5.0


def projectile(integrator, steps, h):
    system = mo.ParticleSystem(1, seed=0, integrator=integrator, dtype=np.float64)
    system.add(mo.Gravity((0, -G, 0)))
    system.store.spawn(1)
    system["velocity"] = [[0.0, V0, 0.0]]
    heights = []
    for _ in range(steps):
        system.step(h)
        heights.append(system["position"][0, 1])
    t = h * np.arange(1, steps + 1)
    return t, np.array(heights)


@pytest.mark.parametrize(
    ("integrator", "closed_form"),
    [
        ("explicit_euler", lambda t, h: V0 * t - 0.5 * G * t * (t - h)),
        ("semi_implicit_euler", lambda t, h: V0 * t - 0.5 * G * t * (t + h)),
        ("verlet", lambda t, h: V0 * t - 0.5 * G * t * (t + h)),
        ("velocity_verlet", lambda t, h: V0 * t - 0.5 * G * t * t),
        ("rk4", lambda t, h: V0 * t - 0.5 * G * t * t),
    ],
)
def test_projectile_matches_each_integrators_discrete_closed_form(integrator, closed_form):
    h = 0.05
    t, y = projectile(integrator, 40, h)
    assert_allclose(y, closed_form(t, h), rtol=1e-12, atol=1e-12)


def test_verlet_damping_slows_a_free_particle():
    system = mo.ParticleSystem(1, integrator="verlet", verlet_damping=0.1, dtype=np.float64)
    system.store.spawn(1)
    system["velocity"] = [[1.0, 0.0, 0.0]]  # x_prev = x - v h = -0.1
    system.step(0.1)
    # x' = x + (x - x_prev)(1 - d): displacement 0.1 × 0.9.
    assert system["position"][0, 0] == pytest.approx(0.09)
    assert system["velocity"][0, 0] == pytest.approx(0.9)


def test_unknown_integrator_is_named():
    with pytest.raises(ValueError, match="integrator must be one of"):
        mo.ParticleSystem(1, integrator="leapfrog")
