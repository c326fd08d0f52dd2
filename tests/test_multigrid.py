"""Aggregation multigrid, the implicit solve's preconditioner: levels, Galerkin coarse
matrices, a symmetric positive definite cycle, and iteration counts that stay flat."""

import itertools

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.spatial import cKDTree

import motes as mo
from motes.cloth import Cloth
from motes.integrate.implicit import ConstraintFilter, ImplicitEuler
from motes.integrate.multigrid import COARSEST, Hierarchy, strong_springs
from motes.integrate.multigrid_kernels import vcycle
from test_implicit import LinearSpringToOrigin


def cloth_network(side=12):
    """A side × side cloth's springs (structural, shear and bending)."""
    c = Cloth.grid(side, side, size=(1.0, 1.0))
    c.step(1 / 60)
    return c.n, c.solver._pattern.pairs


def dense(pattern) -> np.ndarray:
    """``A`` assembled densely from its parts (diagonal, block-CSR, springs)."""
    n = pattern.n
    a = np.zeros((3 * n, 3 * n))
    for i in range(n):
        a[3 * i : 3 * i + 3, 3 * i : 3 * i + 3] = pattern.diag[i].reshape(3, 3)
        for slot in range(pattern.row_ptr[i], pattern.row_ptr[i + 1]):
            j = pattern.cols[slot]
            a[3 * i : 3 * i + 3, 3 * j : 3 * j + 3] += pattern.off[slot].reshape(3, 3)
    for (i, j), (alpha, beta, *u) in zip(pattern.pairs, pattern.coef, strict=True):
        block = alpha * np.eye(3) + beta * np.outer(u, u)
        a[3 * i : 3 * i + 3, 3 * j : 3 * j + 3] -= block
        a[3 * j : 3 * j + 3, 3 * i : 3 * i + 3] -= block
    return a


def solved_network(rng, constraints=None, generic=False):
    """Springs between each of 300 random points in a slab and its 5 nearest neighbours
    (plus a force known by its Jacobian), after one step: the solver's pattern then
    holds this step's ``A``."""
    n = 300
    x = rng.uniform(0, 1, size=(3, n)) * np.array([[1.0], [1.0], [0.1]])
    _, near = cKDTree(x.T).query(x.T, 6)
    pairs = np.unique(
        np.sort(np.stack([np.repeat(np.arange(n), 5), near[:, 1:].ravel()], 1)), axis=0
    )
    length = np.linalg.norm(x[:, pairs[:, 0]] - x[:, pairs[:, 1]], axis=0)
    springs = mo.Springs(pairs, length * rng.uniform(0.7, 1.3, len(pairs)), 300.0, 1.0)
    forces = [springs] + ([LinearSpringToOrigin(50.0, 0.5)] if generic else [])
    solver = ImplicitEuler(tolerance=1e-10)
    mass = rng.uniform(0.1, 1, n) * 1e-2
    solver.step(x, np.zeros((3, n)), mass, 0.05, forces=forces, constraints=constraints)
    return solver._pattern


def test_aggregates_cover_every_particle_and_levels_shrink_to_the_coarsest():
    n, pairs = cloth_network(24)
    h = Hierarchy(n, pairs, np.empty(0, np.int64), np.empty(0, np.int64))
    sizes = [n, *h.sizes()]
    assert all(b < 0.75 * a for a, b in itertools.pairwise(sizes))
    assert sizes[-1] <= COARSEST
    # Every particle in one aggregate, every aggregate non-empty and connected in the
    # spring graph (an aggregate is a seed and its neighbours, or joins one).
    assert np.array_equal(np.unique(h.agg), np.arange(sizes[1]))
    graph = sp.coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    graph = (graph + graph.T).tocsr()
    for a in range(sizes[1]):
        members = np.flatnonzero(h.agg == a)
        count, _ = sp.csgraph.connected_components(graph[members][:, members])
        assert count == 1


def test_weak_bending_springs_do_not_join_aggregates():
    c = Cloth.grid(16, 16, size=(1.0, 1.0))
    c.step(1 / 60)
    pattern = c.solver._pattern
    strong = strong_springs(pattern.n, pattern.pairs, pattern.coef)
    # Bending springs (5 N/m) are weak beside structural ones (200 N/m); shear (50) is not.
    lengths = np.linalg.norm(
        c.position[:, pattern.pairs[:, 0]] - c.position[:, pattern.pairs[:, 1]], axis=0
    )
    bending = lengths > 1.6 / 15
    assert not strong[bending].any() and strong[~bending].all()


@pytest.mark.parametrize("generic", [False, True])
@pytest.mark.parametrize("pinned", [False, True])
def test_coarse_matrices_are_galerkin_products_over_free_particles(pinned, generic):
    rng = np.random.default_rng(5)
    constraints = None
    if pinned:
        constraints = ConstraintFilter(300)
        constraints.pin([0, 1, 2, 40])
        constraints.restrict([7, 9], (0.0, 0.0, 1.0))
    pattern = solved_network(rng, constraints, generic)
    held = np.zeros(pattern.n, bool) if constraints is None else constraints.constrained
    filt = np.tile(np.eye(3).ravel(), (pattern.n, 1)) if constraints is None else constraints.filter
    pattern.multigrid(filt, held)
    h = pattern.hierarchy
    assert h.levels >= 2
    a = dense(pattern)
    # P: each free particle moves with its aggregate; constrained ones take no part.
    p = np.zeros((3 * pattern.n, 3 * h.sizes()[0]))
    for i in np.flatnonzero(~held):
        p[3 * i : 3 * i + 3, 3 * h.agg[i] : 3 * h.agg[i] + 3] = np.eye(3)
    for level, size in enumerate(h.sizes()):
        lo = h.level_start[level]
        coarse = np.zeros((3 * size, 3 * size))
        for q in range(size):
            coarse[3 * q : 3 * q + 3, 3 * q : 3 * q + 3] = pattern.cdiag[lo + q].reshape(3, 3)
            for e in range(h.crow_ptr[lo + q], h.crow_ptr[lo + q + 1]):
                r = h.ccols[e] - lo
                coarse[3 * q : 3 * q + 3, 3 * r : 3 * r + 3] = pattern.coff[e].reshape(3, 3)
        expected = p.T @ a @ p
        np.testing.assert_allclose(coarse, expected, atol=1e-12 * np.abs(expected).max())
        if level + 1 < h.levels:
            nxt = h.sizes()[level + 1]
            p2 = np.zeros((3 * size, 3 * nxt))
            for q in range(size):
                t = h.cagg[lo + q] - h.level_start[level + 1]
                p2[3 * q : 3 * q + 3, 3 * t : 3 * t + 3] = np.eye(3)
            a, p = coarse, p2


def test_the_cycle_is_symmetric_positive_definite_on_the_free_directions():
    rng = np.random.default_rng(8)
    constraints = ConstraintFilter(300)
    constraints.pin([3, 50])
    constraints.restrict([10, 11], (1.0, 0.0, 0.0))
    pattern = solved_network(rng, constraints, generic=True)
    held = constraints.constrained
    fine, coarse, crhs, cx = pattern.multigrid(constraints.filter, held)
    n = pattern.n
    v = np.zeros((3 * n, 3 * n))
    r = np.zeros((n, 3))
    x = np.empty((n, 3))
    s = sp.block_diag([f.reshape(3, 3) for f in constraints.filter]).toarray()
    for k in range(3 * n):
        r[:] = 0.0
        r.flat[k] = 1.0
        r[:] = (s @ r.ravel()).reshape(n, 3)  # the cycle sees filtered residuals
        vcycle(fine, coarse, r, x, crhs, cx)
        v[:, k] = x.ravel()
    v = s @ v @ s
    np.testing.assert_allclose(v, v.T, atol=1e-5 * np.abs(v).max())  # float32 rows
    eig = np.linalg.eigvalsh(0.5 * (v + v.T))
    free = 3 * n - 2 * 3 - 2  # two pinned particles, two restricted directions
    assert np.sum(eig > 1e-9 * eig.max()) == free
    assert eig.min() > -1e-6 * eig.max()
    # It is a good preconditioner: V A is close to the identity on the free directions
    # (a condition number of a few, where block Jacobi's is in the hundreds).
    a = s @ dense(pattern) @ s
    mu = np.sort(np.abs(np.linalg.eigvals(v @ a)))[-free:]
    assert mu.max() / mu.min() < 10


def iterations(side, preconditioner):
    c = Cloth.grid(
        side,
        side,
        size=(1.0, 1.0),
        origin=(-0.5, 1.0, 0.0),
        solver=ImplicitEuler(tolerance=1e-3, preconditioner=preconditioner),
    )
    c.pin(c.grid_index(0, [0, -1]))
    counts = []
    for _ in range(20):
        c.step(1 / 60)
        counts.append(c.last_report.iterations)
    return np.mean(counts)


def test_multigrid_iterations_stay_flat_as_the_cloth_gets_finer():
    # Block Jacobi needs about twice the iterations when the side doubles (the condition
    # number grows with h²k/m, masses shrinking as 1/side²); multigrid about the same.
    jacobi = [iterations(side, "jacobi") for side in (24, 48)]
    multigrid = [iterations(side, "multigrid") for side in (24, 48)]
    assert jacobi[1] > 1.6 * jacobi[0]
    assert multigrid[1] < 1.3 * multigrid[0]
    assert multigrid[1] < 0.25 * jacobi[1]
