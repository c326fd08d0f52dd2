"""Cloth and implicit integration against references: catenary, statics, momentum,
stability at large steps."""

import numba
import numpy as np
import pytest

import motes as mo
from motes.cloth import Airflow, Cloth, SpringFamily
from motes.integrate.implicit import ConstraintFilter, ImplicitEuler

G = 9.81


def test_hanging_chain_relaxes_to_the_catenary():
    # Supports at (±1, 0), length 3: y = a cosh(x/a) + c with a = 0.616473, mid-point
    # sag a (cosh(1/a) - 1) = 1.005267. 64 links of equal length with the mass lumped at
    # the nodes; very stiff links (strain ~1e-6 under the largest tension) so the length
    # is the catenary's.
    links = 64
    n = links + 1
    length = 3.0
    s = length / links
    density = 1.0  # [kg/m]
    mass = np.full(n, density * s)
    x = np.zeros((3, n))
    x[0] = np.linspace(-1.0, 1.0, n)  # start straight (links compressed), let it fall
    v = np.zeros((3, n))
    pairs = np.stack([np.arange(links), np.arange(1, n)], 1)
    springs = mo.Springs(pairs, s, 5e8, 50.0)
    constraints = ConstraintFilter(n)
    constraints.pin([0, n - 1])
    gravity = np.zeros((3, n))
    gravity[1] = -mass * G
    solver = ImplicitEuler(tolerance=1e-10, max_iterations=2000)
    # Large damped steps: backward Euler relaxes toward the static equilibrium.
    for _ in range(300):
        solver.step(
            x,
            v,
            mass,
            0.05,
            forces=[springs],
            external=gravity,
            damping=5.0 * mass,
            constraints=constraints,
        )
    assert np.abs(v).max() < 1e-4  # at rest (measured 3e-5 m/s)
    sag = -x[1, links // 2]
    # Tolerance 1 % (the issue's). Measured 1.005425: the lumped 64-link chain is within
    # 0.02 % of the continuous catenary (discretisation error O(1/links²)).
    assert sag == pytest.approx(1.005267, rel=1e-2)
    assert sag == pytest.approx(1.005267, rel=1e-3)
    # And the whole shape, not only the middle: y = a (cosh(x/a) - cosh(1/a)).
    a = 0.616473
    np.testing.assert_allclose(x[1], a * (np.cosh(x[0] / a) - np.cosh(1 / a)), atol=5e-3)


def relaxed_cloth(**options):
    cloth = Cloth.grid(
        12,
        12,
        size=(0.6, 0.6),
        strain_limit=None,
        air_damping=4.0,
        solver=ImplicitEuler(tolerance=1e-10, max_iterations=2000),
        **options,
    )
    cloth.pin(cloth.grid_index(0, slice(None)))
    return cloth


def test_pinned_cloth_at_rest_feels_no_net_force_and_hangs_on_its_pins():
    cloth = relaxed_cloth()
    for _ in range(300):
        cloth.step(1 / 30)
    free = ~cloth.pinned
    force = cloth.force()
    weight = cloth.mass * G
    # Equilibrium: the springs carry the weight of each free particle (CG at 1e-10 and
    # speeds ~1e-9 m/s leave a residual far below 1e-6 of the weight).
    assert np.abs(cloth.velocity).max() < 1e-6
    assert np.max(np.linalg.norm(force[:, free], axis=0) / weight[free]) < 1e-6
    # The pins supply the weight of the whole cloth, straight up.
    reaction = -force[:, ~free].sum(axis=1)
    np.testing.assert_allclose(
        reaction, [0.0, cloth.mass.sum() * G, 0.0], atol=1e-6 * cloth.mass.sum() * G
    )


def test_momentum_change_is_the_impulse_of_gravity_and_pins():
    # Released from rest, held horizontally by two corners, the cloth swings down; over
    # every step the
    # change of total momentum equals h·(total weight) plus the impulse the constraint
    # filter applies at the pins (Baraff & Witkin §5.3: the residual of A Δv = b in the
    # constrained directions). Spring forces are internal and cancel.
    flat = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
    cloth = Cloth.grid(
        12,
        12,
        size=(0.6, 0.6),
        rotation=flat,
        strain_limit=None,
        air_damping=0.0,
        solver=ImplicitEuler(tolerance=1e-12, max_iterations=2000),
    )
    cloth.pin(cloth.grid_index(0, [0, -1]))
    h = 1 / 60
    impulse = np.zeros(3)
    momentum0 = (cloth.mass * cloth.velocity).sum(axis=1)
    for _ in range(20):
        cloth.step(h)
        impulse += h * cloth.mass.sum() * np.array([0.0, -G, 0.0])
        impulse += cloth.last_report.constraint_impulse
    momentum = (cloth.mass * cloth.velocity).sum(axis=1)
    assert np.linalg.norm(momentum - momentum0) > 0.05  # it did swing
    np.testing.assert_allclose(momentum - momentum0, impulse, atol=1e-9)


def stiff_cloth(scheme):
    # The cloth of the stability claim and the benchmark: 64×64 particles on 1 m², 0.2
    # kg/m² (5e-5 kg per particle), structural springs 200 N/m (ω ≈ 2000 rad/s for
    # one particle on its springs).
    cloth = Cloth.grid(64, 64, size=(1.0, 1.0), origin=(-0.5, 1.0, 0.0), scheme=scheme)
    cloth.pin(cloth.grid_index(0, [0, -1]))
    return cloth


def test_stiff_cloth_is_stable_implicitly_at_h_1_30_and_explicit_euler_diverges():
    implicit = stiff_cloth("implicit_euler")
    explicit = stiff_cloth("explicit_euler")
    with np.errstate(all="ignore"):
        for _ in range(30):
            implicit.step(1 / 30)
            explicit.step(1 / 30)
    assert not implicit.diverged
    assert np.linalg.norm(implicit.velocity, axis=0).max() < 10.0
    assert implicit.stretch().max() < 0.2
    # The strain limiter pulls positions back toward the pins, but the velocities
    # diverge (measured ~1e88 m/s after 30 steps).
    assert explicit.diverged or np.abs(explicit.velocity).max() > 1e3


def test_cloth_step_is_independent_of_the_thread_count():
    results = []
    previous = numba.get_num_threads()
    try:
        for threads in (1, min(2, numba.config.NUMBA_NUM_THREADS)):
            numba.set_num_threads(threads)
            cloth = Cloth.grid(
                40,
                40,
                wind=Airflow((2.0, 0.0, 3.0), gust=0.5),
                colliders=[mo.colliders.Sphere((0.5, -0.8, 0.0), 0.3)],
                bending=SpringFamily(5.0, 0.01),
            )
            cloth.pin(cloth.grid_index(0, [0, -1]))
            for _ in range(3):
                cloth._step(1 / 30)  # bypass the one-thread rule for small cloths
            results.append(cloth.position.copy())
    finally:
        numba.set_num_threads(previous)
    np.testing.assert_array_equal(results[0], results[1])
