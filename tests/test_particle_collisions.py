"""Particles of one system colliding with each other (``motes.ParticleCollisions``)."""

from __future__ import annotations

import numpy as np
import pytest

import motes
from motes.emit.nbody import add_particles
from motes.scene import load_scene


def _system(position, velocity, radius, **options):
    n = position.shape[1]
    system = motes.ParticleSystem(n, dtype=np.float64)
    contacts = motes.ParticleCollisions(**options)
    system.add(contacts)
    add_particles(system, position, velocity, size=np.full(n, radius), lifetime=np.full(n, 1e9))
    return system, contacts


def test_elastic_head_on_pair_swaps_velocities():
    x = np.array([[-0.2, 0.2], [0.0, 0.0], [0.0, 0.0]])
    v = np.array([[2.0, -1.0], [0.0, 0.0], [0.0, 0.0]])
    system, _ = _system(x, v, 0.05, restitution=1.0, friction=0.0)
    for _ in range(20):
        system.step(0.01)
    # Equal masses, e = 1: the velocities are exchanged (to round-off of the projection).
    np.testing.assert_allclose(system["velocity"][:, 0], [-1.0, 2.0], atol=1e-9)
    np.testing.assert_allclose(system["velocity"][:, 0].sum(), 1.0, rtol=1e-12)


def test_inelastic_pair_moves_together():
    x = np.array([[-0.2, 0.2], [0.0, 0.0], [0.0, 0.0]])
    v = np.array([[2.0, 0.0], [0.0, 0.0], [0.0, 0.0]])
    system, _ = _system(x, v, 0.05, restitution=0.0, friction=0.0)
    for _ in range(20):
        system.step(0.01)
    np.testing.assert_allclose(system["velocity"][:, 0], [1.0, 1.0], atol=1e-9)
    gap = np.diff(system["position"][:, 0])[0]
    assert gap == pytest.approx(0.1, abs=1e-9)  # touching, not overlapping


def test_momentum_is_conserved_in_a_crowd():
    """400 particles thrown together in free space: total momentum stays to round-off,
    with restitution, friction and unequal masses."""
    rng = np.random.default_rng(3)
    n = 400
    x = rng.uniform(-0.5, 0.5, (3, n))
    v = -x * 3.0 + rng.normal(0.0, 0.3, (3, n))  # converging
    system = motes.ParticleSystem(n, dtype=np.float64)
    contacts = motes.ParticleCollisions(restitution=0.5, friction=0.4, iterations=6)
    system.add(contacts)
    mass = rng.uniform(0.5, 2.0, n)
    add_particles(system, x, v, mass=mass, size=np.full(n, 0.04), lifetime=np.full(n, 1e9))
    before = (mass * v).sum(axis=1)
    touched = 0
    for _ in range(30):
        system.step(0.01)
        touched += contacts.last_contacts
    assert touched > 1000  # the crowd really collided
    after = (system["mass"][:, None] * system["velocity"]).sum(axis=0)
    np.testing.assert_allclose(after, before, atol=1e-11 * np.abs(mass * v).sum())


@pytest.mark.parametrize("structure", motes.spatial.STRUCTURES)
def test_structures_give_the_same_collisions(structure):
    rng = np.random.default_rng(8)
    x = rng.uniform(-0.3, 0.3, (3, 300))
    v = rng.normal(0.0, 1.0, (3, 300))
    results = []
    for s in ("grid", structure):
        system, _ = _system(x, v, 0.03, structure=s, restitution=0.4, friction=0.3)
        for _ in range(10):
            system.step(0.01)
        results.append(system["position"].copy())
    np.testing.assert_array_equal(results[0], results[1])


def heap_angle(position: np.ndarray) -> float:
    """Slope [degrees] of a heap's flank: the highest grain in rings about the vertical
    axis, fitted from where the outline falls below 90 % of the top to where it first
    falls below 30 % (past that, a carpet of scattered grains)."""
    radial = np.hypot(position[:, 0], position[:, 2])
    height = position[:, 1]
    bins = np.linspace(0.0, radial.max(), 81)
    ring = np.clip(np.digitize(radial, bins) - 1, 0, 79)
    tops = np.zeros(80)
    np.maximum.at(tops, ring, height)
    top = tops.max()
    first = int(np.argmax(tops < 0.9 * top))
    last = first + int(np.argmax(tops[first:] < 0.3 * top))
    if last - first < 2:  # no flank: a single layer
        return 0.0
    middle = 0.5 * (bins[1:] + bins[:-1])
    slope = -np.polyfit(middle[first : last + 1], tops[first : last + 1], 1)[0]
    return float(np.degrees(np.arctan(slope)))


def _pour(friction: float, grains: int = 1600) -> np.ndarray:
    """Grains poured through a small square opening onto the ground, 16 at a time, each
    batch clear of the last; their final positions."""
    rng = np.random.default_rng(0)
    r, h = 0.005, 1 / 240
    system = motes.ParticleSystem(grains, seed=1)
    ground = motes.colliders.Plane(restitution=0.0, friction=friction, friction_model="depth")
    system.add(motes.Gravity(), ground)
    system.add(motes.ParticleCollisions(restitution=0.1, friction=friction, iterations=8))
    square = np.stack(np.meshgrid(np.arange(4), np.arange(4)), 0).reshape(2, -1) - 1.5
    for step in range(12 * grains // 16 + 400):
        if step % 12 == 0 and system.store.count < grains:
            x = np.zeros((3, 16))
            x[[0, 2]] = square * 2.2 * r + rng.uniform(-0.05 * r, 0.05 * r, (2, 16))
            x[1] = 0.15
            v = np.zeros((3, 16))
            v[1] = -0.2
            add_particles(system, x, v, size=np.full(16, r), lifetime=np.full(16, 1e9))
        system.step(h)
    return system["position"].astype(np.float64)


@pytest.mark.slow
def test_friction_lets_a_heap_stand():
    """Poured frictionless grains spread into a low mound; with μ = 0.6 they stand in a
    heap whose flank keeps a slope, the angle of repose (17° here for grains that
    cannot roll; reported in docs/nbody.md)."""
    flat, steep = heap_angle(_pour(0.0)), heap_angle(_pour(0.6))
    assert flat < 8.0
    assert 12.0 < steep < 35.0


def test_scene_key_and_errors(tmp_path):
    scene = tmp_path / "grains.toml"
    scene.write_text(
        """
[scene]
duration = 0.1
[[system]]
name = "grains"
[[system.emitter]]
rate = { type = "per_second", rate = 200 }
speed = 0.0
size = 0.02
lifetime = 5
[[system.force]]
type = "gravity"
[system.collisions]
restitution = 0.2
friction = 0.7
iterations = 6
structure = "kdtree"
"""
    )
    contacts = load_scene(scene).systems["grains"].contacts
    assert len(contacts) == 1 and isinstance(contacts[0], motes.ParticleCollisions)
    assert (contacts[0].friction, contacts[0].structure) == (0.7, "kdtree")
    np.testing.assert_allclose(contacts[0]._gravity(), [0.0, -9.81, 0.0])
    scene.write_text(scene.read_text().replace('"kdtree"', '"bsp"'))
    with pytest.raises(motes.SceneError, match=r"system\[0\]\.collisions\.structure"):
        load_scene(scene)


def test_bad_arguments():
    with pytest.raises(ValueError, match="restitution"):
        motes.ParticleCollisions(restitution=1.5)
    with pytest.raises(ValueError, match="friction"):
        motes.ParticleCollisions(friction=-1)
    with pytest.raises(ValueError, match=r"iterations must be in \[1, 1000\]"):
        motes.ParticleCollisions(iterations=5000)
    with pytest.raises(ValueError, match="structure must be one of"):
        motes.ParticleCollisions(structure="bvh")


@pytest.mark.slow
def test_spheres_look_draws_each_particle_as_a_lit_sphere(tmp_path):
    """``kind = "spheres"``: each particle a shaded sphere of its radius and colour."""
    from motes.render.geometry import Spheres

    drawn = Spheres(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]), [0.5, 0.25],
                    colors=[[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]], subdivisions=1)  # fmt: skip
    tri = drawn.triangles(None)
    assert tri.faces.shape == (160, 3) and tri.positions.shape == (84, 3)
    # Every vertex on its own sphere, its normal pointing out of it.
    np.testing.assert_allclose(np.linalg.norm(tri.positions[:42], axis=1), 0.5)
    np.testing.assert_allclose(np.linalg.norm(tri.positions[42:] - [1, 0, 0], axis=1), 0.25)
    np.testing.assert_allclose(tri.normals[42:], (tri.positions[42:] - [1, 0, 0]) / 0.25,
                               atol=1e-6)  # fmt: skip
    np.testing.assert_array_equal(tri.colors[41], [1, 0, 0])
    np.testing.assert_array_equal(tri.colors[42], [0, 0, 1])
    with pytest.raises(ValueError, match="radii"):
        Spheres(np.zeros((1, 3)), -1.0)

    scene = tmp_path / "marbles.toml"
    scene.write_text(
        """
[scene]
duration = 0.2
[camera]
position = [0, 0.3, 1.2]
target = [0, 0.1, 0]
[[collider]]
type = "plane"
[[system]]
name = "marbles"
[[system.emitter]]
rate = { type = "burst", count = 30 }
shape = { type = "box", size = [0.3, 0.1, 0.3] }
position = [0, 0.15, 0]
speed = 0.0
size = 0.03
color = "#3060ff"
lifetime = 5
[[system.force]]
type = "gravity"
[system.collisions]
[system.render]
kind = "spheres"
"""
    )
    marbles = load_scene(scene)
    for _ in range(6):
        marbles.advance()
    image = marbles.render((160, 90)).astype(float)
    blue = (image[..., 2] > image[..., 0] + 40).mean()
    assert 0.01 < blue < 0.5  # blue marbles on a grey ground, not nothing, not a wash


def _naive_project(x, q, inv_mass, radius, pairs, friction, up, stacking):
    """Obviously-correct twin of ``sphere_kernels.project_pairs`` (one Python loop)."""
    x = x.copy()
    for i, j in pairs:
        d = x[j] - x[i]
        dist = np.linalg.norm(d)
        reach = radius[i] + radius[j]
        if dist >= reach or dist == 0.0:
            continue
        a, b = inv_mass[i], inv_mass[j]
        if stacking > 0:
            s = np.exp(0.5 * stacking * np.clip(d @ up / reach, -1.0, 1.0))
            a, b = a / s, b * s
        if a + b <= 0:
            continue
        n = d / dist
        wi, wj = a / (a + b), b / (a + b)
        depth = reach - dist
        x[i] -= wi * depth * n
        x[j] += wj * depth * n
        if friction > 0:
            t = (x[j] - q[j]) - (x[i] - q[i])
            t -= (t @ n) * n
            length = np.linalg.norm(t)
            if length > 0:
                cut = min(1.0, friction * depth / length)
                x[i] += wi * cut * t
                x[j] -= wj * cut * t
    return x


@pytest.mark.parametrize("friction, stacking", [(0.0, 0.0), (0.6, 0.0), (0.6, 3.0)])
def test_projection_matches_its_numpy_twin(friction, stacking):
    from motes.collide.sphere_kernels import project_pairs

    rng = np.random.default_rng(5)
    n = 60
    x = rng.uniform(-0.3, 0.3, (n, 3))
    q = x - rng.normal(0.0, 0.01, (n, 3))
    radius = rng.uniform(0.04, 0.08, n)
    inv_mass = rng.choice([0.0, 0.5, 1.0, 2.0], n)
    first, second = np.triu_indices(n, k=1)
    pairs = np.stack([first, second], axis=1).astype(np.int64)
    up = np.array([0.0, 1.0, 0.0])
    want = _naive_project(x, q, inv_mass, radius, pairs, friction, up, stacking)
    rows = np.ascontiguousarray(x.T)
    project_pairs(*rows, *np.ascontiguousarray(q.T), inv_mass, radius, pairs, friction, up,
                  stacking, np.zeros(n, np.int64))  # fmt: skip
    np.testing.assert_allclose(rows.T, want, atol=1e-12)
    assert np.abs(want - x).max() > 0.01  # pairs did overlap and move
