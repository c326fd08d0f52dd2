"""Emitter particles against a cloth: contacts found, momentum passed both ways."""

from __future__ import annotations

import numpy as np
import pytest

import motes as mo
from motes.couple import ClothContact
from motes.spatial.triangles import TriangleGrid

# A horizontal sheet in the x-z plane at y = 0: Cloth.grid lies in its frame's x-y plane,
# so the frame's y axis is turned onto -z.
FLAT = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]).T


def _sheet(n=16, **options) -> mo.Cloth:
    options = {"gravity": (0, 0, 0), "air_damping": 0.0, "strain_limit": None, **options}
    return mo.Cloth.grid(n, n, size=(1.0, 1.0), origin=(-0.5, 0.0, -0.5), rotation=FLAT, **options)


def _shots(positions, velocities, mass=None, dtype=np.float32) -> mo.ParticleSystem:
    system = mo.ParticleSystem(len(positions), dtype=dtype, attributes=("mass",) if mass else ())
    new = system.store.spawn(len(positions))
    system.store.raw("position")[:, new] = np.asarray(positions).T
    system.store.raw("velocity")[:, new] = np.asarray(velocities).T
    if mass:
        system.store.raw("mass")[new] = mass
    return system


def _momentum(system, cloth, mass):
    particles = mass * system.store.raw("velocity")[:, : len(system)].astype(np.float64)
    return particles.sum(axis=1) + (cloth.mass * cloth.velocity).sum(axis=1)


def test_the_triangle_grid_lists_every_triangle_near_a_point():
    rng = np.random.default_rng(0)
    tri = rng.uniform(-1, 1, (200, 9))
    grid = TriangleGrid().build(tri, pad=0.05)
    for corner in range(3):
        points = tri[:, 3 * corner : 3 * corner + 3]
        cells = np.floor((points - grid.origin) * grid.inv_cell).astype(int)
        flat = (cells[:, 0] * grid.dims[1] + cells[:, 1]) * grid.dims[2] + cells[:, 2]
        for t, c in enumerate(flat):
            assert t in grid.cell_tris[grid.cell_start[c] : grid.cell_start[c + 1]]


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_a_collision_without_gravity_conserves_the_momentum_of_particles_and_cloth(dtype):
    rng = np.random.default_rng(1)
    k, mass = 200, 2e-5  # 4 g of shot against a 200 g sheet
    positions = np.column_stack(
        [rng.uniform(-0.4, 0.4, k), rng.uniform(0.02, 0.3, k), rng.uniform(-0.4, 0.4, k)]
    )
    velocities = np.column_stack(
        [rng.uniform(-1, 1, k), rng.uniform(-8, -4, k), rng.uniform(-1, 1, k)]
    )
    system = _shots(positions, velocities, mass, dtype)
    # A tight solve: the cloth's internal forces conserve momentum only as far as the
    # implicit solve converges (its default tolerance, 1e-2, is for looks).
    cloth = _sheet(solver=mo.ImplicitEuler(tolerance=1e-10))
    system.add(ClothContact(cloth, restitution=0.5, friction=0.4, thickness=0.005))
    before = _momentum(system, cloth, mass)
    dt = 1 / 120
    for _ in range(12):
        system.step(dt)
        exchanged = _momentum(system, cloth, mass)
        cloth.step(dt)
        # The exchange alone: exact up to the particles' rounding of their velocities.
        np.testing.assert_allclose(exchanged, _momentum(system, cloth, mass), atol=1e-9)
    after = _momentum(system, cloth, mass)
    # Every particle reached the sheet and was thrown back; the sheet was pushed down.
    assert np.all(system.store.raw("velocity")[1, :k] > 0)
    assert np.all(system.store.raw("position")[1, :k] > cloth.position[1].max())
    assert cloth.velocity[1].mean() < -0.01
    # The exchange itself is exact; float32 particle velocities round at ~1e-7 relative,
    # and the implicit cloth step conserves momentum to its solver's round-off.
    scale = mass * np.abs(velocities).sum()
    np.testing.assert_allclose(after, before, atol=1e-5 * scale)


def test_a_bounce_keeps_restitution_of_the_relative_normal_speed_against_a_pinned_sheet():
    cloth = _sheet()
    cloth.pin(np.arange(cloth.n))  # infinitely heavy: the particle alone responds
    system = _shots([(0.1, 0.05, 0.1)], [(0.0, -6.0, 0.0)], mass=0.01)
    system.add(ClothContact(cloth, restitution=0.6, thickness=0.002))
    system.step(1 / 60)
    np.testing.assert_allclose(system["velocity"][0], (0.0, 3.6, 0.0), atol=1e-5)
    np.testing.assert_allclose(system["position"][0, 1], 0.002, atol=1e-6)
    assert np.all(cloth.velocity == 0)


def test_coulomb_friction_never_reverses_the_sliding():
    cloth = _sheet()
    cloth.pin(np.arange(cloth.n))
    # The first crosses the sheet in its step, the second ends within the thickness.
    system = _shots(
        [(0.0, 0.02, 0.0), (0.0, 0.002, 0.0)], [(0.5, -3.0, 0.0), (3.0, -0.1, 0.0)], mass=0.01
    )
    system.add(ClothContact(cloth, friction=0.5, thickness=0.002))
    system.step(1 / 60)
    v = system["velocity"]
    np.testing.assert_allclose(v[0], (0.0, 0.0, 0.0), atol=1e-6)  # mu j_n = 1.5 > 0.5
    np.testing.assert_allclose(v[1], (3.0 - 0.5 * 0.1, 0.0, 0.0), atol=1e-6)


@pytest.mark.slow
def test_kill_splashes_raise_collision_events_and_push_the_cloth():
    cloth = _sheet()
    system = _shots([(0.0, 0.05, 0.0), (2.0, 0.05, 0.0)], [(0.0, -6.0, 0.0)] * 2, mass=1e-5)
    system.add(ClothContact(cloth, response="kill", thickness=0.002))
    seen = []
    system.on("collision", seen.append)
    system.step(1 / 60)
    assert len(system) == 1 and system["position"][0, 0] == 2.0  # the one off the sheet
    assert len(seen) == 1 and seen[0].collider.tolist() == [0]
    # Perfectly inelastic against the cloth point: the drop's momentum passes to the
    # cloth but for the share it keeps at the common speed (m_p / m_eff ~ 1e-2 here).
    pushed = (cloth.mass * cloth.velocity).sum(axis=1)
    np.testing.assert_allclose(pushed, (0, -6e-5, 0), rtol=0.03, atol=1e-12)
    assert pushed[1] > -6e-5


def test_a_fast_particle_never_passes_the_cloth():
    cloth = _sheet(32)
    edge = cloth.grid_index([0, -1], slice(None)), cloth.grid_index(slice(None), [0, -1])
    cloth.pin(np.concatenate(edge))
    k = 500
    rng = np.random.default_rng(2)
    positions = np.column_stack(
        [rng.uniform(-0.45, 0.45, k), np.full(k, 0.5), rng.uniform(-0.45, 0.45, k)]
    )
    system = _shots(positions, np.tile((0.0, -100.0, 0.0), (k, 1)), mass=1e-6)
    system.add(ClothContact(cloth, thickness=0.001))
    for _ in range(4):
        system.step(1 / 60)
        cloth.step(1 / 60)
    assert np.all(system["position"][:, 1] > cloth.position[1].min() - 1e-3)


def test_bad_parameters_name_themselves():
    cloth = _sheet(4)
    with pytest.raises(ValueError, match="restitution"):
        ClothContact(cloth, restitution=2)
    with pytest.raises(ValueError, match="response"):
        ClothContact(cloth, response="stick")
    with pytest.raises(ValueError, match="thickness"):
        ClothContact(cloth, thickness=0)
    with pytest.raises(TypeError, match="Cloth"):
        ClothContact(object())
