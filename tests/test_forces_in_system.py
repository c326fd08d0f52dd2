"""Forces inside a running system: orbits, springs across deaths, thread settings."""

import numba
import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import motes as mo


def test_circular_orbit_period_matches_kepler():
    gm, r = 4.0, 2.0
    system = mo.ParticleSystem(1, integrator="rk4", dtype=np.float64)
    system.add(mo.RadialField((0, 0, 0), gm, softening=1e-9))
    system.store.spawn(1)
    system["position"] = [[r, 0, 0]]
    speed = np.sqrt(gm / r)
    system["velocity"] = [[0, 0, speed]]
    period = 2 * np.pi * np.sqrt(r**3 / gm)
    steps = 400
    system.run(steps, period / steps)
    # RK4 with 400 steps per orbit: phase error ~ (ωh)^4 ≈ 2e-7 of the orbit length.
    assert_allclose(system["position"][0], [r, 0, 0], atol=1e-5)


@pytest.mark.parametrize("compaction", ["stable", "swap"])
def test_springs_drop_with_dead_particles(compaction):
    system = mo.ParticleSystem(6, dtype=np.float64, attributes=("mass",), compaction=compaction)
    system.store.spawn(6)
    rng = np.random.default_rng(3)
    system["position"] = rng.normal(size=(6, 3))
    system["velocity"] = rng.normal(size=(6, 3))
    system["lifetime"] = [10, 10, 0.05, 10, 10, 10]
    pairs = np.array([[0, 1], [1, 2], [2, 3], [3, 4], [4, 5], [5, 0]])
    springs = mo.Springs(pairs, 1.0, 50.0, 0.5)
    system.add(springs)
    system.run(5, 0.02)
    assert len(system) == 5
    ids = system["id"]
    assert_array_equal(np.sort(ids), [0, 1, 3, 4, 5])
    if compaction == "stable":
        assert_array_equal(ids, [0, 1, 3, 4, 5])
    # Springs touching particle 2 are gone; the rest renumbered onto survivors.
    joined = {tuple(sorted(pair)) for pair in ids[springs.pairs].tolist()}
    assert joined == {(0, 1), (3, 4), (4, 5), (0, 5)}
    system.run(50, 0.01)
    assert np.isfinite(system["velocity"]).all()


def test_internal_springs_conserve_total_momentum():
    system = mo.ParticleSystem(20, dtype=np.float64, integrator="velocity_verlet")
    system.store.spawn(20)
    rng = np.random.default_rng(4)
    system["position"] = rng.normal(size=(20, 3))
    system["velocity"] = rng.normal(size=(20, 3))
    pairs = np.array([[i, (i + 1) % 20] for i in range(20)] + [[0, 10], [5, 15]])
    system.add(mo.Springs(pairs, 0.5, 100.0, 1.0))
    momentum = system["velocity"].sum(axis=0)
    system.run(200, 0.005)
    # Equal and opposite pair forces: only round-off changes the total (~1e-13).
    assert_allclose(system["velocity"].sum(axis=0), momentum, atol=1e-10)


@pytest.mark.parametrize("count", [10, 20_000])
def test_thread_setting_is_restored_after_a_step(count):
    system = mo.ParticleSystem(count)
    system.store.spawn(count)
    before = numba.get_num_threads()
    system.step(0.01)
    assert numba.get_num_threads() == before
