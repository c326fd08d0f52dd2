"""Constraints: colouring, the relaxation kernel against its twin, stiffness models."""

import numba
import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import motes.constrain as mc
import naive_constraints as naive


def random_graph(seed, n=60, m=150):
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(n, 3))
    pairs = np.array([rng.choice(n, 2, replace=False) for _ in range(m)])
    triples = np.array([rng.choice(n, 3, replace=False) for _ in range(m // 5)])
    builder = mc.ConstraintBuilder()
    rest = np.linalg.norm(x[pairs[:, 1]] - x[pairs[:, 0]], axis=1) * rng.uniform(0.8, 1.2, m)
    third = m // 3
    builder.add_sticks(pairs[:third], rest[:third], stiffness=0.7)
    builder.add_ropes(pairs[third : 2 * third], rest[third : 2 * third], compliance=1e-4)
    builder.add_distance(pairs[2 * third :], 0.9 * rest[2 * third :], 1.1 * rest[2 * third :])
    builder.add_angle_limits(triples, 0.8, 2.2)
    rows = np.array([rng.choice(n, 5, replace=False) for _ in range(m // 10)])
    builder.add_hinge_sides(rows, rng.choice([-1.0, 1.0], len(rows)), 0.05)
    w = rng.uniform(0.5, 2.0, n)
    w[:3] = 0.0
    return builder.build(n), x, w


def test_colors_never_share_a_particle_and_match_the_greedy_twin():
    cs, _, _ = random_graph(0)
    for color in range(cs.color_count):
        ends = cs.ends[cs.color_start[color] : cs.color_start[color + 1]]
        used = ends[ends >= 0]
        assert len(np.unique(used)) == len(used)
    original = np.empty_like(cs.ends)
    original[cs.order] = cs.ends
    # Angle rows keep (i, j, pivot); the twin only needs the set of particles.
    colors = np.repeat(np.arange(cs.color_count), np.diff(cs.color_start))
    expected = naive.greedy_colors(original, cs.particle_count)
    assert_array_equal(colors, expected[cs.order])


@pytest.mark.parametrize(("approx", "shake"), [(False, False), (True, False), (False, True)])
def test_sweep_matches_the_twin(approx, shake):
    cs, x, w = random_graph(1)
    dt = 1 / 60
    ours = np.ascontiguousarray(x.T)
    theirs = x.copy()
    start = x + np.random.default_rng(9).normal(scale=0.05, size=x.shape)
    previous = np.ascontiguousarray(start.T) if shake else None
    lam_twin = cs.multipliers.copy()
    for _ in range(5):
        cs.sweep(ours, w, dt, sqrt_approximation=approx, previous=previous)
        saved, cs.multipliers = cs.multipliers, lam_twin
        naive.sweep(theirs, w, cs, dt, approx, start if shake else None)
        lam_twin, cs.multipliers = cs.multipliers, saved
    # fastmath reassociation only: float64 round-off over 5 sweeps of O(1) coordinates.
    assert_allclose(ours.T, theirs, rtol=0, atol=1e-10)
    assert_allclose(cs.multipliers, lam_twin, rtol=1e-9, atol=1e-12)


def test_results_do_not_depend_on_the_thread_count():
    cs, x, w = random_graph(2, n=20_000, m=60_000)
    results = []
    for threads in (1, numba.config.NUMBA_NUM_THREADS):
        previous = numba.get_num_threads()
        numba.set_num_threads(threads)
        try:
            pos = np.ascontiguousarray(x.T)
            cs.reset_multipliers()
            for _ in range(3):
                cs.sweep(pos, w, 1 / 60)
        finally:
            numba.set_num_threads(previous)
        results.append(pos)
    assert_array_equal(results[0], results[1])


def chain(n, stiffness=1.0, compliance=0.0, approx=False):
    x = np.zeros((3, n))
    x[0] = np.arange(n) * 1.2  # stretched 20 %
    w = np.ones(n)
    w[0] = 0
    b = mc.ConstraintBuilder()
    b.add_sticks(
        np.stack([np.arange(n - 1), np.arange(1, n)], 1),
        1.0,
        stiffness=stiffness,
        compliance=compliance,
    )
    return b.build(n), x, w


def test_rigid_sticks_converge_to_their_rest_length_with_or_without_sqrt():
    for approx in (False, True):
        cs, x, w = chain(6)
        cs.relax(x, w, 1 / 60, iterations=200, sqrt_approximation=approx)
        assert_allclose(cs.lengths(x), 1.0, atol=1e-9)


def test_sqrt_approximation_error_is_e_squared_over_two():
    # One stick of rest length 1 stretched to d = 1 + e, its first particle fixed: the
    # exact projection lands on length 1. Jakobsen's factor (d² - 1)/(d² + 1) replaces
    # (d - 1)/d = e - e² + ...; it is e - e²/2 + ..., so it overshoots by (e²/2) d and
    # lands at 2d/(d² + 1) = 1 - e²/(2 + 2e + e²) exactly.
    for e in (1e-3, 1e-2, 0.05, 0.3):
        cs, x, w = chain(2)
        x[0, 1] = 1 + e
        cs.sweep(x, w, 1 / 60, sqrt_approximation=True)
        assert_allclose(x[0, 1] - 1.0, -(e**2) / (2 + 2 * e + e**2), rtol=1e-6)


def hanging_stretch(iterations, dt, **model):
    """Static stretch [m] of a 1 kg mass hanging from a fixed point on a unit stick."""
    b = mc.ConstraintBuilder()
    b.add_sticks([[0, 1]], 1.0, **model)
    cs = b.build(2)
    x = np.array([[0.0, 0.0], [0.0, -1.0], [0.0, 0.0]])
    previous = x.copy()
    w = np.array([0.0, 1.0])
    for _ in range(round(3.0 / dt)):  # heavy damping: settled well within 3 s
        x, previous = x + 0.9 * (x - previous), x
        x[1, 1] -= 9.81 * dt * dt
        cs.relax(x, w, dt, iterations=iterations)
    return -x[1, 1] - 1.0


def test_xpbd_compliance_gives_the_same_spring_for_any_iterations_and_step():
    # XPBD (Macklin et al. 2016) at equilibrium: C = -α λ and λ balances the weight,
    # so the stretch is m g α whatever the iteration count and step.
    alpha = 1e-3
    for iterations, dt in [(1, 1 / 60), (20, 1 / 60), (4, 1 / 240)]:
        assert_allclose(hanging_stretch(iterations, dt, compliance=alpha), 9.81 * alpha, rtol=1e-3)


def test_pbd_stiffness_depends_on_the_iteration_count():
    soft = hanging_stretch(1, 1 / 60, stiffness=0.3)
    stiff = hanging_stretch(20, 1 / 60, stiffness=0.3)
    assert soft > 10 * stiff > 0


def test_ropes_go_slack_and_limits_hold_bounds():
    b = mc.ConstraintBuilder()
    b.add_ropes([[0, 1]], 1.0)
    b.add_distance([[2, 3]], 0.5, 0.8)
    cs = b.build(4)
    x = np.array([[0.0, 0.5, 0.0, 2.0], [0, 0, 1, 1], [0, 0, 0, 0]])
    w = np.array([0.0, 1.0, 0.0, 1.0])
    before = x.copy()
    cs.sweep(x, w, 1 / 60)
    assert_array_equal(x[:, :2], before[:, :2])  # rope slack: untouched
    assert_allclose(np.linalg.norm(x[:, 3] - x[:, 2]), 0.8, atol=1e-12)


def test_angle_limit_opens_a_folded_joint_to_its_minimum_angle():
    b = mc.ConstraintBuilder()
    b.add_angle_limits([[0, 1, 2]], np.radians(90), np.radians(150))
    cs = b.build(3)
    x = np.array([[0.0, 1.0, np.cos(0.3)], [0, 0, np.sin(0.3)], [0, 0, 0]])
    w = np.array([0.0, 1.0, 1.0])
    cs.relax(x, w, 1 / 60, iterations=30)
    a, c = x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]
    angle = np.arccos(a @ c / np.linalg.norm(a) / np.linalg.norm(c))
    # The rod fixes the distance for the current arm lengths; arms are free here so
    # they stretch a little and the angle lands close to, not on, the limit.
    assert np.radians(85) < angle < np.radians(95)


def test_hinge_side_limit_straightens_a_knee_bent_backwards():
    # Hip 0 at the origin, knee 1 below it, the hip axis 0 -> 2 along +x.
    b = mc.ConstraintBuilder()
    b.add_hinge_sides([[0, 1, 0, 2, 3]], orientation=1.0, recovery=3.0)
    cs = b.build(4)
    x = np.array([[0.0, 0.0, 0.3, 0.0], [0.0, -0.5, 0.0, -1.0], [0.0, 0.0, 0.0, 0.2]])
    n = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
    n /= np.linalg.norm(n)
    assert (x[:, 3] - x[:, 1]) @ n > 0  # the ankle is on the forbidden side
    w = np.ones(4)
    start = x.copy()
    start[2, 3] = 0.0  # it crossed the plane during this step
    momentum = x.sum(axis=1)  # equal masses
    fresh = x.copy()
    cs.sweep(fresh, w, 1 / 60, previous=start)
    # Hip, knee and ankle share the correction (a bend of the knee, no net momentum);
    # one projection of the linearised bend leaves 0.2 m -> 2 mm past the plane.
    assert_allclose(fresh.sum(axis=1), momentum, atol=1e-12)
    bone, axis = fresh[:, 1] - fresh[:, 0], fresh[:, 2] - fresh[:, 0]
    plane = np.cross(bone, axis) / np.linalg.norm(np.cross(bone, axis))
    assert abs((fresh[:, 3] - fresh[:, 1]) @ plane) < 0.01
    # Past the plane at the start of the step already: undone at the recovery speed
    # only (3 m/s * 1/60 s = 5 cm per step), not thrown back in one step.
    w = np.array([0.0, 0.0, 0.0, 1.0])  # only the ankle moves: the plane stays put
    old = x.copy()
    cs.reset_multipliers()  # a new step: a new correction budget
    cs.sweep(old, w, 1 / 60, previous=x.copy())
    assert_allclose((old[:, 3] - old[:, 1]) @ n, 0.2 - 0.05, atol=1e-12)
    before = x.copy()
    x[2, 3] = -0.2  # bent the allowed way: untouched
    before[2, 3] = -0.2
    cs.reset_multipliers()
    cs.sweep(x, w, 1 / 60)
    assert_array_equal(x, before)


def test_pins_hold_particles():
    cs, x, w = chain(4)
    pins = mc.Pins([3], [[5.0, 0.0, 0.0]])
    w[3] = 0
    cs.relax(x, w, 1 / 60, iterations=5, pins=pins)
    assert_array_equal(x[:, 3], [5.0, 0.0, 0.0])


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda b: b.add_sticks([[0, 0]], 1.0), "distinct"),
        (lambda b: b.add_sticks([[0, 1]], -1.0), "min_length must be >= 0"),
        (lambda b: b.add_sticks([[0, 1]], 1.0, stiffness=0), "stiffness must be > 0"),
        (lambda b: b.add_sticks([[0, 1]], 1.0, stiffness=0.5, compliance=1), "one model"),
        (lambda b: b.add_distance([[0, 1]], 2.0, 1.0), "max_length must be >= min_length"),
        (lambda b: b.add_angle_limits([[0, 1, 2]], 4.0), "min_angle must be <="),
        (lambda b: b.add_sticks([[0.5, 1]], 1.0), "integer array"),
    ],
)
def test_bad_constraints_name_the_parameter(call, message):
    with pytest.raises(ValueError, match=message):
        call(mc.ConstraintBuilder())


def test_relax_checks_its_arrays():
    cs, x, w = chain(3)
    with pytest.raises(ValueError, match="position must be"):
        cs.relax(x.astype(np.float32), w, 1 / 60)
    b = mc.ConstraintBuilder()
    with pytest.raises(ValueError, match="constraints index particle 2"):
        b.add_sticks([[0, 2]], 1.0)
        b.build(2)
