"""Springs.jacobian: the definite form (Baraff & Witkin 1998, Choi & Ko 2002) is
symmetric negative semi-definite for compressed and stretched springs, matches the
implicit integrator's compiled path, and carries a generic Force through conjugate
gradients."""

import numpy as np
import pytest

import motes as mo
from motes.forces.base import Force
from motes.integrate.implicit import ImplicitEuler
from naive_cloth import spring_terms


def network(seed, squeeze):
    """12 particles, 30 springs whose rest lengths are ``squeeze`` times their lengths
    (> 1: compressed, < 1: stretched), random velocities."""
    rng = np.random.default_rng(seed)
    n, m = 12, 30
    x = rng.normal(size=(3, n))
    v = rng.normal(size=(3, n))
    pairs = np.array([rng.choice(n, 2, replace=False) for _ in range(m)])
    length = np.linalg.norm(x[:, pairs[:, 0]] - x[:, pairs[:, 1]], axis=0)
    springs = mo.Springs(pairs, length * squeeze, rng.uniform(10, 1000, m), rng.uniform(0, 5, m))
    return x, v, springs


@pytest.mark.parametrize(("squeeze", "label"), [(1.5, "compressed"), (0.7, "stretched")])
def test_default_jacobian_is_symmetric_negative_semidefinite(squeeze, label):
    x, v, springs = network(1, squeeze)
    dfdx, dfdv = springs.jacobian(None, x, v).dense(12)
    for matrix in (dfdx, dfdv):
        np.testing.assert_array_equal(matrix, matrix.T)
        # Eigenvalues of a symmetric matrix are computed to ~1e-13 of its norm.
        assert np.linalg.eigvalsh(matrix).max() <= 1e-12 * np.abs(matrix).max()
    # It is the form the compiled implicit path uses (its NumPy twin).
    _, twin_dfdx, twin_dfdv = spring_terms(
        x, v, springs.pairs, springs.rest_length, springs.stiffness, springs.damping
    )
    np.testing.assert_allclose(dfdx, twin_dfdx, rtol=1e-12, atol=1e-12 * np.abs(dfdx).max())
    np.testing.assert_allclose(dfdv, twin_dfdv, rtol=1e-12, atol=1e-12 * np.abs(dfdv).max())


def test_exact_jacobian_of_compressed_springs_is_indefinite():
    # What the default drops: with the true derivative, compressed springs give ∂f/∂x a
    # positive eigenvalue (transverse buckling), so M - h² ∂f/∂x loses definiteness at
    # large h and conjugate gradients can break down.
    x, v, springs = network(1, 1.5)
    dfdx, _ = springs.jacobian(None, x, np.zeros_like(v), exact=True).dense(12)
    np.testing.assert_allclose(dfdx, dfdx.T, atol=1e-12 * np.abs(dfdx).max())
    assert np.linalg.eigvalsh(dfdx).max() > 1.0
    # Stretched springs not moving: the default is the true derivative.
    x, v, springs = network(2, 0.7)
    rest = np.zeros_like(v)
    exact, _ = springs.jacobian(None, x, rest, exact=True).dense(12)
    default, _ = springs.jacobian(None, x, rest).dense(12)
    np.testing.assert_allclose(default, exact, rtol=1e-12, atol=1e-12 * np.abs(exact).max())


class GenericSprings(Force):
    """Springs seen only through the generic Force interface (accumulate + jacobian)."""

    reads = ("position", "velocity")

    def __init__(self, springs):
        self.springs = springs

    def accumulate(self, store, position, velocity, time, out):
        self.springs.accumulate(store, position, velocity, time, out)

    def jacobian(self, store, position, velocity):
        return self.springs.jacobian(store, position, velocity)


def test_a_force_built_on_the_jacobian_steps_like_the_compiled_path():
    # Compressed springs at a large step: the generic path (block-CSR assembly of the
    # default Jacobian) converges and gives the compiled path's step.
    x, v, springs = network(3, 1.5)
    mass = np.random.default_rng(3).uniform(0.1, 2.0, 12)
    steps = []
    for force in (springs, GenericSprings(springs)):
        x1, v1 = x.copy(), v.copy()
        report = ImplicitEuler(tolerance=1e-12, max_iterations=2000).step(
            x1, v1, mass, 0.1, forces=[force]
        )
        assert report.converged
        steps.append(v1)
    np.testing.assert_allclose(steps[1], steps[0], rtol=1e-9, atol=1e-9 * np.abs(steps[0]).max())
