"""Implicit Euler (Baraff & Witkin 1998): the solve, constraint filtering, the physics."""

import numba
import numpy as np
import pytest

import motes as mo
from motes.forces.base import Force, ForceJacobian
from motes.integrate.implicit import ConstraintFilter, ImplicitEuler, SolverError
from naive_cloth import implicit_step


def random_network(rng, n=12, m=30):
    x = rng.normal(size=(3, n))
    v = rng.normal(size=(3, n)) * 0.5
    pairs = np.array([rng.choice(n, 2, replace=False) for _ in range(m)])
    length = np.linalg.norm(x[:, pairs[:, 0]] - x[:, pairs[:, 1]], axis=0)
    rest = length * rng.uniform(0.6, 1.4, m)  # stretched and compressed springs
    ks = rng.uniform(10, 1000, m)
    kd = rng.uniform(0, 5, m)
    mass = rng.uniform(0.1, 2.0, n)
    return x, v, pairs, rest, ks, kd, mass


PRECONDITIONERS = ["multigrid", "jacobi"]


@pytest.mark.parametrize("preconditioner", PRECONDITIONERS)
@pytest.mark.parametrize(("seed", "n"), [(0, 12), (1, 60), (2, 90)])
def test_step_matches_a_dense_solve(seed, n, preconditioner):
    # 12 particles: too few to coarsen (multigrid is one Gauss-Seidel sweep each way);
    # 60 and 90: two or more levels.
    rng = np.random.default_rng(seed)
    x, v, pairs, rest, ks, kd, mass = random_network(rng, n=n, m=3 * n)
    external = rng.normal(size=x.shape)
    h = 0.05
    expected = implicit_step(x, v, mass, h, pairs, rest, ks, kd, external=external, damping=0.3)
    solver = ImplicitEuler(tolerance=1e-12, max_iterations=1000, preconditioner=preconditioner)
    x1, v1 = x.copy(), v.copy()
    report = solver.step(
        x1, v1, mass, h, forces=[mo.Springs(pairs, rest, ks, kd)], external=external, damping=0.3
    )
    assert report.converged
    # CG to a 1e-12 relative preconditioned residual: Δv agrees to ~1e-9 of its size.
    np.testing.assert_allclose(v1 - v, expected.T, rtol=0, atol=1e-8 * np.abs(expected).max())
    np.testing.assert_allclose(x1, x + h * v1, rtol=1e-14, atol=1e-14)


@pytest.mark.parametrize("preconditioner", PRECONDITIONERS)
@pytest.mark.parametrize("n", [12, 60])
def test_filtering_matches_a_dense_solve_and_holds_constraints_exactly(n, preconditioner):
    rng = np.random.default_rng(7)
    x, v, pairs, rest, ks, kd, mass = random_network(rng, n=n, m=3 * n)
    constraints = ConstraintFilter(n)
    constraints.pin([0, 3])
    constraints.pin(5, velocity=(1.0, -2.0, 0.5))
    constraints.restrict([7, 8], (0.0, 1.0, 0.0))  # slide in the x-z plane
    expected = implicit_step(
        x, v, mass, 0.1, pairs, rest, ks, kd, filt=constraints.filter, target=constraints.velocity
    )
    x1, v1 = x.copy(), v.copy()
    solver = ImplicitEuler(tolerance=1e-12, max_iterations=1000, preconditioner=preconditioner)
    solver.step(
        x1, v1, mass, 0.1, forces=[mo.Springs(pairs, rest, ks, kd)], constraints=constraints
    )
    np.testing.assert_allclose(v1 - v, expected.T, atol=1e-8 * np.abs(expected).max())
    # Filtering sets the constrained components exactly, not to the solver's tolerance.
    assert np.all(v1[:, [0, 3]] == 0.0)
    assert np.all(x1[:, [0, 3]] == x[:, [0, 3]])
    np.testing.assert_array_equal(v1[:, 5], [1.0, -2.0, 0.5])
    np.testing.assert_allclose(v1[1, [7, 8]], 0.0, atol=1e-15)


class LinearSpringToOrigin(Force):
    """f = -k x - c v on every particle: a force known only through its Jacobian."""

    def __init__(self, k, c):
        self.k, self.c = k, c

    def accumulate(self, store, position, velocity, time, out):
        out -= self.k * position + self.c * velocity

    def jacobian(self, store, position, velocity):
        n = position.shape[1]
        idx = np.arange(n)
        eye = np.broadcast_to(np.eye(3), (n, 3, 3))
        return ForceJacobian(idx, idx, -self.k * eye, -self.c * eye)


def test_generic_jacobians_are_implicit():
    # One particle, f = -k x - c v: backward Euler's Δv solves a 1x1 system per axis.
    k, c, m, h = 400.0, 2.0, 0.5, 0.1
    x = np.array([[1.0], [0.0], [0.0]])
    v = np.array([[0.0], [3.0], [0.0]])
    solver = ImplicitEuler(tolerance=1e-12)
    x0, v0 = x.copy(), v.copy()
    solver.step(x, v, np.array([m]), h, forces=[LinearSpringToOrigin(k, c)])
    dv = h * (-k * x0 - c * v0 - h * k * v0) / (m + h * c + h * h * k)
    np.testing.assert_allclose(v - v0, dv, rtol=1e-12)


def test_oscillator_period_and_numerical_damping_follow_theory():
    # Particle 1 (mass m) on a spring of stiffness k to pinned particle 0, moving along the
    # spring: the force is linear, so the linearised step is exact backward Euler,
    # whose map has eigenvalues (1 ± iωh)/(1 + ω²h²): amplitude ratio 1/sqrt(1 + ω²h²)
    # and phase atan(ωh) per step.
    m, k, h = 0.2, 50.0, 0.01
    omega = np.sqrt(k / m)
    x = np.array([[0.0, 1.1], [0.0, 0.0], [0.0, 0.0]])
    v = np.zeros((3, 2))
    constraints = ConstraintFilter(2)
    constraints.pin(0)
    springs = mo.Springs([[1, 0]], 1.0, k, 0.0)
    solver = ImplicitEuler(tolerance=1e-12)
    energy, offset = [], []
    for _ in range(400):
        solver.step(x, v, np.array([1.0, m]), h, forces=[springs], constraints=constraints)
        stretch = x[0, 1] - 1.0
        offset.append(stretch)
        energy.append(0.5 * m * v[0, 1] ** 2 + 0.5 * k * stretch**2)
    energy = np.array(energy)
    ratio = energy[1:] / energy[:-1]
    # Exact per-step energy ratio of the discrete map: 1/(1 + ω²h²) (CG at 1e-12).
    np.testing.assert_allclose(ratio, 1 / (1 + (omega * h) ** 2), rtol=1e-8)
    assert np.all(np.diff(energy) < 0)
    # Period from upward zero crossings (linear interpolation between steps).
    s = np.array(offset)
    up = np.flatnonzero((s[:-1] < 0) & (s[1:] >= 0))
    times = (up + 1 + -s[up] / (s[up + 1] - s[up])) * h
    period = np.mean(np.diff(times))
    exact = 2 * np.pi / omega
    # Backward Euler advances the phase by atan(ωh) per step: period 2πh/atan(ωh), a
    # relative error (ωh)²/3 + O(h⁴) = 0.083 % here; interpolation adds O((ωh)²) more.
    assert period == pytest.approx(2 * np.pi * h / np.arctan(omega * h), rel=2e-3)
    assert abs(period / exact - 1) <= (omega * h) ** 2 / 3 + 2e-3


def test_solver_reports_and_raises_when_it_cannot_converge():
    rng = np.random.default_rng(3)
    x, v, pairs, rest, ks, kd, mass = random_network(rng, n=40, m=120)
    springs = mo.Springs(pairs, rest, ks * 1e4, kd)
    solver = ImplicitEuler(tolerance=1e-10, max_iterations=2)
    with pytest.raises(SolverError, match="after 2 iterations") as error:
        solver.step(x.copy(), v.copy(), mass, 0.1, forces=[springs])
    assert not error.value.report.converged
    lenient = ImplicitEuler(tolerance=1e-10, max_iterations=2, on_failure="accept")
    report = lenient.step(x.copy(), v.copy(), mass, 0.1, forces=[springs])
    assert report.iterations == 2 and not report.converged


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"tolerance": 0.0}, "tolerance must be > 0"),
        ({"max_iterations": 0}, "max_iterations must be >= 1"),
        ({"on_failure": "ignore"}, "on_failure must be one of"),
        ({"preconditioner": "ilu"}, "preconditioner must be one of"),
    ],
)
def test_bad_solver_parameters(kwargs, message):
    with pytest.raises(ValueError, match=message):
        ImplicitEuler(**kwargs)


def test_bad_step_input():
    solver = ImplicitEuler()
    x = np.zeros((3, 2))
    with pytest.raises(ValueError, match="mass must be finite and > 0"):
        solver.step(x, x.copy(), np.array([1.0, 0.0]), 0.1)
    with pytest.raises(TypeError, match="float64"):
        solver.step(x.astype(np.float32), x.astype(np.float32), np.ones(2), 0.1)
    with pytest.raises(ValueError, match="springs join particle 5"):
        solver.step(x, x.copy(), np.ones(2), 0.1, forces=[mo.Springs([[0, 5]], 1.0, 1.0, 0.0)])


def test_solve_is_independent_of_the_thread_count():
    # 3000 particles: several BLOCKs, so two threads really split the work.
    rng = np.random.default_rng(11)
    x, v, pairs, rest, ks, kd, mass = random_network(rng, n=3000, m=9000)
    springs = mo.Springs(pairs, rest, ks, kd)
    results = []
    previous = numba.get_num_threads()
    try:
        for threads in (1, min(2, numba.config.NUMBA_NUM_THREADS)):
            numba.set_num_threads(threads)
            x1, v1 = x.copy(), v.copy()
            ImplicitEuler(tolerance=1e-8).step(x1, v1, mass, 0.05, forces=[springs])
            results.append(v1)
    finally:
        numba.set_num_threads(previous)
    np.testing.assert_array_equal(results[0], results[1])


def test_particle_system_runs_implicit_euler():
    # Two particles on a stiff spring: explicit steps this size would blow up.
    system = mo.ParticleSystem(4, integrator="implicit_euler")
    system.store.require("inv_mass")
    system.store.spawn(2)
    system["position"] = [[0, 0, 0], [1.5, 0, 0]]
    system["lifetime"] = np.inf
    system["inv_mass"] = [0.0, 1.0]  # particle 0 pinned
    system.add(mo.Springs([[0, 1]], 1.0, 1e5, 0.0), mo.Gravity((0, -9.81, 0)))
    for _ in range(60):
        system.step(1 / 30)
    pos = system["position"]
    assert np.all(pos[0] == 0.0)
    assert np.isfinite(pos).all()
    # Backward Euler's damping settles it where spring and gravity balance.
    np.testing.assert_allclose(np.linalg.norm(pos[1]), 1.0 + 9.81 / 1e5, rtol=1e-3)
    assert system.implicit_solver.last_report.converged


class LinearPairs(Force):
    """Zero-rest-length linear springs given only through a ForceJacobian (off-diagonal
    blocks in the generic block-CSR path)."""

    def __init__(self, pairs, k):
        self.pairs, self.k = np.asarray(pairs), k

    def accumulate(self, store, position, velocity, time, out):
        a, b = self.pairs.T
        d = position[:, a] - position[:, b]
        np.add.at(out.T, a, -self.k * d.T)
        np.add.at(out.T, b, self.k * d.T)

    def jacobian(self, store, position, velocity):
        a, b = self.pairs.T
        m = len(a)
        block = np.broadcast_to(-self.k * np.eye(3), (m, 3, 3))
        rows = np.concatenate([a, a, b, b])
        cols = np.concatenate([a, b, a, b])
        dfdx = np.concatenate([block, -block, -block, block])
        return ForceJacobian(rows, cols, dfdx, np.zeros_like(dfdx))


def test_system_product_matches_the_dense_matrix():
    # A v through the per-spring part, the assembled diagonal and the generic block-CSR
    # part, against the dense A = M + h c - h ∂f/∂v - h² ∂f/∂x.
    from naive_cloth import spring_terms

    rng = np.random.default_rng(5)
    x, v, pairs, rest, ks, kd, mass = random_network(rng, n=10, m=25)
    extra = LinearPairs(rng.choice(10, size=(6, 2), replace=True), 30.0)
    extra.pairs = extra.pairs[extra.pairs[:, 0] != extra.pairs[:, 1]]
    h = 0.05
    solver = ImplicitEuler(tolerance=1e-12, max_iterations=1000)
    x1, v1 = x.copy(), v.copy()
    solver.step(x1, v1, mass, h, forces=[mo.Springs(pairs, rest, ks, kd), extra], damping=0.2)
    _, dfdx, dfdv = spring_terms(x, v, pairs, rest, ks, kd)
    gx, gv = extra.jacobian(None, x, v).dense(10)
    dense = np.diag(np.repeat(mass + h * 0.2, 3)) - h * (dfdv + gv) - h * h * (dfdx + gx)
    w = rng.normal(size=(10, 3))
    np.testing.assert_allclose(
        solver._pattern.product(w).ravel(),
        dense @ w.ravel(),
        rtol=1e-12,
        atol=1e-12 * np.abs(dense).max(),
    )
    rows = np.array([7, 0, 3], dtype=np.int64)  # a few rows alone (the pins' impulse)
    np.testing.assert_allclose(
        solver._pattern.product_rows(rows, w),
        (dense @ w.ravel()).reshape(10, 3)[rows],
        rtol=1e-12,
        atol=1e-12 * np.abs(dense).max(),
    )
    # And the step solved that system: A Δv = b with b = h (f0 + h ∂f/∂x v0).
    f, _, _ = spring_terms(x, v, pairs, rest, ks, kd)
    f0 = f.ravel() + (-0.2 * v.T).ravel()
    generic = np.zeros((3, 10))
    extra.accumulate(None, x, v, 0.0, generic)
    b = h * (f0 + generic.T.ravel() + h * (dfdx + gx) @ v.T.ravel())
    np.testing.assert_allclose(dense @ (v1 - v).T.ravel(), b, atol=1e-9 * np.abs(b).max())


def test_particle_system_drag_is_implicit():
    # Linear drag toward a wind, f = -k (v - w): backward Euler gives exactly
    # v1 = (m v0 + h k w) / (m + h k), stable for any h (explicit Euler overshoots w
    # once h k / m > 1 and diverges past 2; here h k / m = 5).
    k, h, wind = 10.0, 0.5, np.array([2.0, 0.0, -1.0])
    system = mo.ParticleSystem(4, integrator="implicit_euler", dtype=np.float64)
    system.store.spawn(1)
    system["lifetime"] = np.inf
    system["velocity"] = [[0.0, 3.0, 0.0]]
    system.add(mo.Drag(k, wind=wind))
    v = np.array([0.0, 3.0, 0.0])
    for _ in range(3):
        system.step(h)
        v = (v + h * k * wind) / (1.0 + h * k)
        # One particle: the block-Jacobi preconditioner is the exact inverse.
        np.testing.assert_allclose(system["velocity"][0], v, rtol=1e-12)
