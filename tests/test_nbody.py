"""Pair forces: Morton codes, the radix sort, the octree, direct and Barnes–Hut sums,
Coulomb's law, user pair potentials, scene files and bad input.

Tolerances:

- direct summation against the float64 twin (``naive_nbody.py``): float64 ``rtol 1e-12``
  of the largest force (a few ulps per term, n terms); float32 ``1e-5`` (the tile
  computes ``1/sqrt`` in float32, measured 1e-6 of the largest force for 3,000 points).
- momentum: ``|Σ F| / Σ|F|``: pair terms cancel up to one rounding each, so float64
  ``1e-14`` (measured 5e-17) and float32 ``1e-6`` (measured 3e-8).
- Barnes–Hut against direct summation on a 3,000-point Plummer sphere, relative error
  per particle ``|Δa| / |a|``: bounds about twice the measured values (θ = 0.5:
  monopole RMS 9.3e-4, max 5.7e-3; quadrupole RMS 2.3e-4; θ = 0.2 with quadrupoles RMS
  6.8e-6).
"""

from __future__ import annotations

import numba
import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import naive_nbody as naive
from motes import ParticleSystem
from motes.emit.nbody import add_particles, disc_galaxy, kepler_pair, plummer_sphere
from motes.forces import Coulomb, NBodyGravity, PairForce, lennard_jones
from motes.forces.apply import add_forces
from motes.forces.nbody import K_COULOMB, inverse_square, pair_potential_sum
from motes.scene import load_scene
from motes.scene.schema import SceneError
from motes.spatial.morton import BITS, morton_codes, radix_sort
from motes.spatial.octree import Octree


@pytest.fixture(scope="module")
def sphere():
    position, _, mass = plummer_sphere(3000, seed=3)
    return position, mass, naive.inverse_square(position, mass, 0.01)


def relative_errors(result, reference):
    return np.sqrt(((result - reference) ** 2).sum(axis=0) / (reference**2).sum(axis=0))


# -- Morton order and the tree ---------------------------------------------------------------


def test_radix_sort_is_a_stable_sort(rng):
    for keys in (
        rng.integers(0, 2**62, 70_000),
        rng.integers(0, 50, 70_000),  # many equal keys: stability shows
        np.array([5]),
        np.zeros(0, np.int64),
    ):
        original = keys.copy()
        sorted_keys, order = radix_sort(keys)
        assert_array_equal(order, np.argsort(keys, kind="stable"))
        assert_array_equal(sorted_keys, np.sort(keys))
        assert_array_equal(keys, original)  # the input is left alone


def test_morton_codes_interleave_bits(rng):
    q = rng.integers(0, 1 << BITS, (3, 1000))
    codes = np.empty(1000, np.int64)
    x, y, z = (np.ascontiguousarray(r, dtype=np.float64) + 0.5 for r in q)
    morton_codes(x, y, z, np.zeros(3), 1.0, codes)
    assert_array_equal(codes, naive.morton(q))


@pytest.mark.parametrize("clustered", [False, True])
def test_octree_partitions_points_into_cells(rng, clustered):
    points = plummer_sphere(5000, seed=1)[0] if clustered else rng.random((3, 5000))
    tree = Octree(leaf_size=8).build(points)
    n = points.shape[1]
    assert tree.node_count[0] == n and tree.node_start.shape[0] < 2 * n
    leaves = tree.leaves()
    # Leaves tile the sorted slots exactly once.
    covered = np.zeros(n, np.int64)
    for leaf in leaves:
        covered[tree.node_start[leaf] : tree.node_start[leaf] + tree.node_count[leaf]] += 1
    assert_array_equal(covered, 1)
    assert (tree.node_count[leaves] <= 8).all()
    # Children tile their parent's run, and there are at least two of them.
    inner = np.flatnonzero(tree.node_child >= 0)
    assert (tree.node_children[inner] >= 2).all()
    for k in inner:
        kids = np.arange(tree.node_child[k], tree.node_child[k] + tree.node_children[k])
        assert tree.node_start[kids[0]] == tree.node_start[k]
        assert tree.node_count[kids].sum() == tree.node_count[k]
        assert_array_equal(
            tree.node_start[kids[1:]], tree.node_start[kids[:-1]] + tree.node_count[kids[:-1]]
        )
    # Every point lies in its leaf's cell (to the quantisation of the codes).
    sorted_points = points[:, tree.order]
    slack = tree.edge / (1 << BITS)
    for leaf in leaves:
        run = sorted_points[
            :, tree.node_start[leaf] : tree.node_start[leaf] + tree.node_count[leaf]
        ]
        offset = np.abs(run - tree.node_center[:, leaf : leaf + 1])
        assert (offset <= tree.node_size[leaf] / 2 + slack).all()
    assert (np.diff(tree.codes) >= 0).all()


def test_identical_points_share_one_leaf():
    points = np.zeros((3, 100))
    tree = Octree(leaf_size=4).build(points)
    assert tree.node_start.shape[0] == 1 and tree.node_count[0] == 100


# -- direct summation -------------------------------------------------------------------------


@pytest.mark.parametrize("dtype, rtol", [(np.float64, 1e-12), (np.float32, 1e-5)])
def test_direct_matches_the_twin(sphere, dtype, rtol):
    position, mass, reference = sphere
    out = np.zeros(position.shape, dtype)
    inverse_square(position.astype(dtype), mass, out, softening=0.01, method="direct")
    assert out.dtype == dtype
    assert_allclose(out, reference, rtol=0, atol=rtol * np.abs(reference).max())


@pytest.mark.parametrize("dtype, bound", [(np.float64, 1e-14), (np.float32, 1e-6)])
def test_direct_conserves_momentum(sphere, dtype, bound):
    position, mass, _ = sphere
    forces = add_forces(
        [NBodyGravity(1.0, softening=0.01, method="direct")],
        position, np.zeros_like(position), mass, 0.0,
    )  # fmt: skip
    out = np.zeros(position.shape, dtype)
    gravity = NBodyGravity(1.0, softening=0.01, method="direct")
    store = ParticleSystem(3000, dtype=dtype, attributes=("mass",)).store
    store.spawn(3000)
    store.raw("mass")[:] = mass
    gravity.accumulate(store, position.astype(dtype), None, 0.0, out)
    for f in (forces, out.astype(np.float64)):
        assert np.abs(f.sum(axis=1)).max() / np.abs(f).sum(axis=1).max() < bound


def test_direct_with_zero_softening_skips_self_pairs():
    position = np.array([[0.0, 2.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]])
    out = np.zeros((3, 3))
    inverse_square(position, np.ones(3), out, method="direct")
    assert np.isfinite(out).all()
    assert_allclose(out, naive.inverse_square(position, np.ones(3), 0.0), rtol=1e-14)


def test_thread_count_does_not_change_results(sphere):
    position, mass, _ = sphere
    results = []
    previous = numba.get_num_threads()
    try:
        for threads in sorted({1, previous}):
            numba.set_num_threads(threads)
            for method in ("direct", "barnes_hut"):
                out = np.zeros(position.shape, np.float32)
                inverse_square(
                    position.astype(np.float32), mass, out, softening=0.01, method=method
                )
                results.append(out)
    finally:
        numba.set_num_threads(previous)
    for a, b in zip(results[:2], results[2:], strict=False):
        assert_array_equal(a, b)


# -- Barnes–Hut -------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "theta, quadrupole, rms_bound, max_bound",
    [(0.5, False, 2e-3, 1.2e-2), (0.5, True, 5e-4, 3e-3), (0.2, True, 2e-5, 1.2e-4)],
)
def test_barnes_hut_against_direct(sphere, theta, quadrupole, rms_bound, max_bound):
    position, mass, reference = sphere
    out = np.zeros(position.shape)
    inverse_square(
        position, mass, out, softening=0.01, method="barnes_hut", theta=theta,
        quadrupole=quadrupole,
    )  # fmt: skip
    errors = relative_errors(out, reference)
    assert np.sqrt((errors**2).mean()) < rms_bound
    assert errors.max() < max_bound


def test_barnes_hut_error_falls_with_theta(sphere):
    position, mass, reference = sphere
    rms = []
    for theta in (1.0, 0.7, 0.5, 0.3):
        out = np.zeros(position.shape)
        inverse_square(position, mass, out, softening=0.01, method="barnes_hut", theta=theta)
        rms.append(np.sqrt((relative_errors(out, reference) ** 2).mean()))
    assert np.all(np.diff(rms) < 0)


def test_barnes_hut_float32_follows_float64(sphere):
    position, mass, _ = sphere
    results = []
    for dtype in (np.float64, np.float32):
        out = np.zeros(position.shape, dtype)
        inverse_square(position.astype(dtype), mass, out, softening=0.01, method="barnes_hut")
        results.append(out.astype(np.float64))
    assert np.sqrt((relative_errors(results[1], results[0]) ** 2).mean()) < 1e-5


# -- Coulomb's law ---------------------------------------------------------------------------


def charged_system(charges, positions, dtype=np.float64):
    system = ParticleSystem(len(charges), dtype=dtype, integrator="velocity_verlet")
    system.add(Coulomb())
    system.store.spawn(len(charges))
    system.store.raw("charge")[:] = charges
    system.store.raw("position")[:] = np.asarray(positions, dtype=np.float64).T
    system.store.raw("velocity")[:] = 0.0
    return system


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_two_charges_follow_coulombs_law(sign):
    q1, q2, r = 2e-6, sign * 3e-6, 0.25
    system = charged_system([q1, q2], [[0.0, 0.0, 0.0], [r, 0.0, 0.0]])
    out = np.zeros((3, 2))
    system.forces[0].accumulate(system.store, system.store.raw("position")[:, :2], None, 0.0, out)
    expected = K_COULOMB * q1 * q2 / r**2  # > 0: repulsion pushes particle 1 to +x
    assert_allclose(out[0], [-expected, expected], rtol=1e-13)
    assert_allclose(out[1:], 0.0, atol=1e-20)


def test_coulomb_refuses_barnes_hut_for_mixed_signs():
    force = Coulomb(method="barnes_hut")
    state = np.array([[0.0, 1.0], [0.0, 0.0], [0.0, 0.0]])
    system = charged_system([1e-6, -1e-6], state.T)
    with pytest.raises(ValueError, match="one sign"):
        force.accumulate(system.store, state, None, 0.0, np.zeros((3, 2)))


def test_coulomb_needs_its_attribute():
    system = ParticleSystem(4)
    with pytest.raises(KeyError, match="spin"):
        system.add(Coulomb("spin"))
    with pytest.raises(KeyError, match="charge"):
        add_forces([Coulomb()], np.zeros((3, 2)), np.zeros((3, 2)), np.ones(2), 0.0)


# -- user pair potentials ---------------------------------------------------------------------


def lj_numpy(r):
    s6 = (0.3 / r) ** 6
    return 24.0 / r * (2 * s6 * s6 - s6)


@pytest.mark.parametrize("cutoff", [None, 0.9])
def test_pair_force_matches_the_twin(rng, cutoff):
    position = rng.random((3, 600)) * 6.0
    force = PairForce(lennard_jones(1.0, 0.3), cutoff=cutoff)
    out = add_forces([force], position, np.zeros_like(position), np.ones(600), 0.0)
    reference = naive.pair_force(position, lj_numpy, cutoff)
    assert_allclose(out, reference, rtol=0, atol=1e-12 * np.abs(reference).max())
    assert np.abs(out.sum(axis=1)).max() < 1e-14 * np.abs(out).sum()


def test_lennard_jones_minimum():
    f = lennard_jones(2.0, 0.5)
    r_min = 2 ** (1 / 6) * 0.5
    assert abs(f(r_min)) < 1e-12
    assert f(0.9 * r_min) > 0 > f(1.1 * r_min)


# -- systems, energies, scenes -----------------------------------------------------------------


def test_potential_energy_of_a_pair():
    position, _, _ = kepler_pair(2.0, 3.0, 1.5)
    w = NBodyGravity(G=0.5, softening=0.2).potential_energy(position, np.array([2.0, 3.0]))
    assert_allclose(w, -0.5 * 6.0 / np.hypot(1.5, 0.2), rtol=1e-14)
    assert pair_potential_sum(np.zeros((3, 0)), np.zeros(0), 0.0) == 0.0


SCENE = """
[scene]
duration = 0.1
[[system]]
name = "cloud"
capacity = 300
integrator = "velocity_verlet"
  [[system.emitter]]
  rate = {{ type = "burst", count = 200 }}
  shape = {{ type = "sphere", radius = 1.0 }}
  speed = 0.0
  lifetime = 100
  charge = {{ uniform = [1e-9, 2e-9] }}
  [[system.force]]
  {force}
"""


@pytest.mark.parametrize(
    "force",
    [
        pytest.param(
            'type = "nbody_gravity"\n  G = 1.0\n  softening = 0.05\n  method = "barnes_hut"',
            marks=pytest.mark.slow,
        ),
        pytest.param(
            'type = "coulomb"\n  softening = 0.01\n  theta = 0.5\n  quadrupole = true',
            marks=pytest.mark.slow,
        ),
        'type = "lennard_jones"\n  epsilon = 1e-6\n  sigma = 0.05\n  cutoff = 0.2',
    ],
)
def test_scene_files_build_pair_forces(force):
    scene = load_scene(SCENE.format(force=force))
    scene.advance()
    system = scene.systems["cloud"]
    assert np.isfinite(system.particle_state().positions).all()
    charge = system.store.raw("charge")[:200]
    assert ((charge >= 1e-9) & (charge <= 2e-9)).all()


@pytest.mark.parametrize(
    "force, message",
    [
        ('type = "nbody_gravity"\n  G = -1.0', "G"),
        ('type = "nbody_gravity"\n  theta = 0', "theta"),
        ('type = "coulomb"\n  method = "fmm"', "method"),
        ('type = "lennard_jones"\n  epsilon = 1.0', "sigma"),
        ('type = "nbody_gravity"\n  radius = 1.0', "radius"),
    ],
)
def test_scene_file_mistakes_name_the_key(force, message):
    with pytest.raises(SceneError, match=message):
        load_scene(SCENE.format(force=force))


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda: NBodyGravity(G=0.0), "G must be > 0"),
        (lambda: NBodyGravity(theta=1.5), "theta must be <= 1"),
        (lambda: NBodyGravity(theta=0.0), "theta must be > 0"),
        (lambda: NBodyGravity(softening=-1.0), "softening must be >= 0"),
        (lambda: NBodyGravity(method="tree"), "method"),
        (lambda: NBodyGravity(leaf_size=0), "leaf_size must be >= 1"),
        (lambda: Coulomb(k=-1.0), "k must be > 0"),
        (lambda: Coulomb("not a name"), "attribute name"),
        (lambda: PairForce(lambda r: r), "numba.njit"),
        (lambda: PairForce(lennard_jones(1.0, 1.0), cutoff=0.0), "cutoff must be > 0"),
        (lambda: lennard_jones(-1.0, 1.0), "epsilon must be > 0"),
        (lambda: plummer_sphere(0), "count must be >= 1"),
        (lambda: kepler_pair(1.0, 1.0, 1.0, eccentricity=1.0), "eccentricity must be < 1"),
        (lambda: Octree().build(np.zeros((3, 0))), "n >= 1"),
        (lambda: Octree().build(np.full((3, 2), np.nan)), "finite"),
    ],
)
def test_bad_input_names_the_parameter(make, message):
    with pytest.raises((ValueError, TypeError), match=message):
        make()


@pytest.mark.slow
def test_the_nbody_guide_examples_run(capsys):
    import re
    from pathlib import Path

    page = Path(__file__).resolve().parents[1] / "docs" / "nbody.md"
    namespace: dict = {}
    for block in re.findall(r"```python\n(.*?)```", page.read_text(), flags=re.S):
        exec(compile(block, str(page), "exec"), namespace)
    assert "2000 stars, 500 dust grains" in capsys.readouterr().out
    assert np.isfinite(namespace["dust"].store.raw("velocity")[:, :500]).all()


def test_disc_galaxy_stars_are_on_circular_orbits():
    position, velocity, mass = disc_galaxy(
        500, core_mass=2.0, disc_mass=0.0, radius=1.0, inner_radius=0.2,
        normal=(0.0, 0.0, 1.0), thickness=0.0, G=0.5, softening=0.05, seed=4,
    )  # fmt: skip
    assert mass[0] == 2.0 and position[:, 0].tolist() == [0.0, 0.0, 0.0]
    accel = np.zeros_like(position)
    inverse_square(position, mass, accel, coupling=0.5, softening=0.05, method="direct")
    r = np.linalg.norm(position[:, 1:], axis=0)
    assert ((r >= 0.2) & (r <= 1.0)).all()
    assert_allclose(position[2, 1:], 0.0, atol=1e-15)
    # Massless stars: the pull toward the core is exactly the centripetal v²/r.
    inward = -(accel[:, 1:] * position[:, 1:]).sum(axis=0) / r
    speed2 = (velocity[:, 1:] ** 2).sum(axis=0)
    assert_allclose(inward, speed2 / r, rtol=1e-12)
    assert_allclose((velocity[:, 1:] * position[:, 1:]).sum(axis=0), 0.0, atol=1e-12)
    assert (np.cross(position[:, 1:].T, velocity[:, 1:].T)[:, 2] > 0).all()  # about +z


def test_plummer_sphere_is_in_virial_equilibrium():
    position, velocity, mass = plummer_sphere(4000, mass=2.0, radius=0.5, G=3.0, seed=9)
    assert_allclose(mass.sum(), 2.0)
    assert_allclose(position.mean(axis=1), 0.0, atol=1e-12)
    kinetic = 0.5 * (mass * (velocity**2).sum(axis=0)).sum()
    potential = NBodyGravity(3.0).potential_energy(position, mass)
    # W = -3π G M² / (32 a); sampling noise of N = 4000 is about 2 %.
    assert_allclose(potential, -3 * np.pi * 3.0 * 4.0 / (32 * 0.5), rtol=0.05)
    assert_allclose(2 * kinetic / abs(potential), 1.0, atol=0.06)


@pytest.mark.slow
def test_scene_places_galaxies_and_clusters():
    scene = load_scene(
        """
[[system]]
name = "sky"
capacity = 700
integrator = "velocity_verlet"
  [[system.force]]
  type = "nbody_gravity"
  G = 1.0
  softening = 0.05
  [[system.particles]]
  type = "disc_galaxy"
  count = 400
  center = [1.0, 0.0, 0.0]
  velocity = [0.0, 0.0, 0.5]
  core_size = 0.1
  color = "#ffcc88"
  outer_color = [0.2, 0.3, 1.0]
  [[system.particles]]
  type = "plummer"
  count = 300
  center = [-3.0, 0.0, 0.0]
  radius = 0.3
"""
    )
    store = scene.systems["sky"].store
    assert store.count == 700
    assert_allclose(store.raw("position")[:, 0], [1.0, 0.0, 0.0])
    assert store.raw("size")[0] == np.float32(0.1) and store.raw("size")[1] == np.float32(0.02)
    assert_allclose(store.raw("mass")[:400].sum(), 1.1, rtol=1e-6)
    assert_allclose(store.raw("inv_mass")[:700], 1.0 / store.raw("mass")[:700], rtol=1e-6)
    assert_allclose(store.raw("position")[0, 400:].mean(), -3.0, atol=1e-5)
    scene.advance()
    assert np.isfinite(store.raw("position")[:, :700]).all()


@pytest.mark.parametrize(
    "extra, message",
    [
        ("count = 2000", "capacity"),
        ('count = 10\n  type = "spiral"', "type"),
        ("count = 10\n  radius = -1.0", "radius"),
    ],
)
def test_scene_particle_mistakes_name_the_key(extra, message):
    text = f"""
[[system]]
name = "sky"
capacity = 100
  [[system.force]]
  type = "nbody_gravity"
  [[system.particles]]
  {extra}
"""
    if "type =" not in extra:
        text = text.replace("[[system.particles]]", '[[system.particles]]\n  type = "plummer"')
    with pytest.raises(SceneError, match=message):
        load_scene(text)


def test_scene_particles_need_gravity():
    text = """
[[system]]
name = "sky"
capacity = 100
  [[system.particles]]
  type = "plummer"
  count = 10
"""
    with pytest.raises(SceneError, match="nbody_gravity"):
        load_scene(text)


@pytest.mark.slow
def test_galaxies_scene_keeps_its_cores_bound_and_draws_stars():
    """The built-in scene, shrunk to 1,500 stars (the full one runs in the slow tier)."""
    scene = load_scene(
        "galaxies",
        overrides={"system.stars.particles.0.count": 900, "system.stars.particles.1.count": 600},
    )
    stars = scene.systems["stars"]
    for _ in range(15):
        scene.advance()
    position = stars.store.raw("position")[:, :1500].astype(np.float64)
    assert stars.store.count == 1500 and np.isfinite(position).all()
    # Each core still holds its inner disc: most of its stars stay within its radius.
    for core, first, last, radius in ((0, 1, 900, 1.1), (900, 901, 1500, 0.9)):
        offset = np.linalg.norm(position[:, first:last] - position[:, core : core + 1], axis=0)
        assert np.mean(offset < radius * 1.2) > 0.9
    image = scene.render((160, 90))
    assert image.std() > 2


def test_coulomb_reads_a_charge_the_user_declared():
    from motes import Attribute

    system = ParticleSystem(4, attributes=(Attribute("charge", default=-1.0, unit="C"),))
    system.add(Coulomb())  # the user's declaration stands
    system.store.spawn(2)
    assert system.store.raw("charge")[:2].tolist() == [-1.0, -1.0]


def test_ring_bodies_are_on_circular_orbits_in_their_plane():
    from motes.emit.nbody import ring

    normal = np.array([0.3, 1.0, 0.2]) / np.linalg.norm([0.3, 1.0, 0.2])
    x, v, m = ring(400, central_mass=2.0, radius=1.0, inner_radius=0.5, normal=normal,
                   G=1.5, seed=4)  # fmt: skip
    r = np.linalg.norm(x, axis=0)
    assert r.min() >= 0.5 and r.max() <= 1.0
    np.testing.assert_allclose(normal @ x, 0.0, atol=1e-12)  # in the plane
    np.testing.assert_allclose(np.einsum("ij,ij->j", x, v), 0.0, atol=1e-12)  # tangential
    np.testing.assert_allclose(np.linalg.norm(v, axis=0), np.sqrt(1.5 * 2.0 / r), rtol=1e-12)
    np.testing.assert_allclose(np.cross(x.T, v.T) @ normal, np.sqrt(1.5 * 2.0 * r), rtol=1e-12)
    np.testing.assert_array_equal(m, 0.0)
    one, _, _ = ring(1, central_mass=1.0, radius=2.0, seed=1)  # one planet on its circle
    assert np.linalg.norm(one) == pytest.approx(2.0)
    with pytest.raises(ValueError, match="inner_radius"):
        ring(3, central_mass=1.0, radius=1.0, inner_radius=2.0)


def test_leapfrog_evaluates_position_forces_once_per_step_with_the_same_result():
    """With forces of the positions alone, the leapfrog carries its end acceleration to
    the next step: one evaluation per step (after the first), and the same bits as
    evaluating it afresh every step."""
    from motes.forces.base import Force

    class Counted(Force):
        reads = ("position",)

        def __init__(self):
            self.inner = NBodyGravity(G=1.0, softening=0.05, method="direct")
            self.calls = 0

        def bind(self, store):
            self.inner.bind(store)

        def accumulate(self, store, position, velocity, time, out):
            self.calls += 1
            self.inner.accumulate(store, position, velocity, time, out)

    def run(forget):
        system = ParticleSystem(64, integrator="velocity_verlet", dtype=np.float64)
        force = Counted()
        system.add(force)
        x, v, m = plummer_sphere(64, seed=3)
        add_particles(system, x, v, mass=m, lifetime=np.full(64, np.inf))
        for _ in range(20):
            if forget:
                system._carried = None
            system.step(0.01)
        return system["position"].copy(), force.calls

    carried, calls = run(False)
    fresh, fresh_calls = run(True)
    assert calls == 21 and fresh_calls == 40
    np.testing.assert_array_equal(carried, fresh)
