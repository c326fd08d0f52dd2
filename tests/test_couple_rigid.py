"""Emitter particles against the boxes and balls of a rigid world: contacts found,
momentum and angular momentum passed both ways."""

from __future__ import annotations

import numpy as np
import pytest

import motes as mo
import naive_couple
from motes.collide.swept import GAP
from motes.couple import RigidContact
from motes.couple import rigid as kernels
from motes.geometry.layout import Kind, grown, pack_row, stack
from motes.rigid import BodyShape, World

DT = 1 / 60


def _shots(positions, velocities, mass, dtype=np.float64) -> mo.ParticleSystem:
    system = mo.ParticleSystem(max(len(positions), 1) + 400, dtype=dtype, attributes=("mass",))
    _spawn(system, positions, velocities, mass)
    return system


def _spawn(system, positions, velocities, mass) -> None:
    new = system.store.spawn(len(positions))
    system.store.raw("position")[:, new] = np.asarray(positions).T
    system.store.raw("velocity")[:, new] = np.asarray(velocities).T
    system.store.raw("mass")[new] = mass


def _momenta(system, world, origin):
    """Momentum and angular momentum about ``origin`` of particles and world (float64)."""
    n = len(system)
    m = system.store.raw("mass")[:n].astype(np.float64)
    x = system.store.raw("position")[:, :n].T.astype(np.float64) - origin
    v = system.store.raw("velocity")[:, :n].T.astype(np.float64)
    wx, wv = world.position - origin, world.velocity
    momentum = m @ v + world.mass @ wv
    angular = m @ np.cross(x, v) + world.mass @ np.cross(wx, wv)
    return momentum, angular


def _tilt(world, body) -> float:
    """Angle [deg] between a body's rest y axis and the world's."""
    rotation = world.transforms()[1][body.index]
    return float(np.degrees(np.arccos(np.clip(rotation[1, 1], -1.0, 1.0))))


def test_the_kernels_match_their_numpy_twin():
    rng = np.random.default_rng(3)
    rotation = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    rotation *= np.linalg.det(rotation)
    rows = [
        pack_row(Kind.BOX, [0.0, 0.0, 0.0, 0.3, 0.05, 0.4, *rotation.ravel()]),
        pack_row(Kind.BOX, [1.0, 0.2, 0.0, 0.2, 0.2, 0.2, *np.eye(3).ravel()]),
        pack_row(Kind.SPHERE, [-0.8, 0.1, 0.3, 0.25]),
    ]
    rows = grown(stack(rows), 0.01)
    # The shapes as they were at the last exchange: moved and turned a little since.
    before = rows.copy()
    before[:, 8:11] -= rng.normal(0.0, 0.05, (3, 3))
    turn = np.linalg.qr(np.eye(3) + rng.normal(0.0, 0.1, (3, 3)))[0]
    turn *= np.linalg.det(turn)
    before[:2, 14:23] = (before[:2, 14:23].reshape(2, 3, 3) @ turn).reshape(2, 9)
    n = 400
    # Paths ending near the shapes, up to ~1 m long: through them, into them, past them.
    x = rows[rng.integers(0, 3, n), 8:11] + rng.normal(0.0, 0.3, (n, 3))
    v = rng.normal(0.0, 20.0, (n, 3))
    v[:20] = 0.0  # at rest: found only if inside
    mass = rng.uniform(0.01, 0.1, n)
    bodies = {
        "centre": np.array([[0.0, 0.01, 0.0], [1.0, 0.2, 0.01], [-0.8, 0.1, 0.3]]),
        "velocity": rng.normal(size=(3, 3)),
        "angular_velocity": rng.normal(size=(3, 3)) * np.array([[1.0], [1.0], [0.0]]),
        "inverse_mass": np.array([0.5, 0.25, 2.0]),
        "inverse_inertia": np.array([np.diag([3.0, 4.0, 5.0]), 6.0 * np.eye(3), np.zeros((3, 3))]),
    }
    found = naive_couple.detect(x, v, DT, rows, before)
    hit_row, hit_p, hit_n = np.empty(n, np.int64), np.empty((3, n)), np.empty((3, n))
    xs, vs = np.ascontiguousarray(x.T), np.ascontiguousarray(v.T)
    kernels._detect(n, xs, vs, DT, rows, before, hit_row, hit_p, hit_n)
    assert 60 < (hit_row >= 0).sum() < n - 60
    np.testing.assert_array_equal(hit_row, [r for r, _, _ in found])
    for i, (r, p, normal) in enumerate(found):
        if r >= 0:
            np.testing.assert_allclose(hit_p[:, i], p, atol=1e-12)
            np.testing.assert_allclose(hit_n[:, i], normal, atol=1e-12)
    theirs = naive_couple.respond(x, v, mass, found, bodies, 0.4, 0.3)
    impulse, angular = np.zeros((3, 3)), np.zeros((3, 3))
    linear, spin = bodies["velocity"].copy(), bodies["angular_velocity"].copy()
    keep, hits = np.ones(n, bool), np.zeros(1, np.int32)
    kernels._respond(
        n, xs, vs, mass, 1, hit_row, hit_p, hit_n, np.arange(3), bodies["centre"], linear,
        spin, bodies["inverse_mass"], bodies["inverse_inertia"], 0.4, 0.3, False, keep, hits,
        False, 0, impulse, angular,
    )  # fmt: skip
    np.testing.assert_allclose(xs.T, theirs[0], atol=1e-12)
    np.testing.assert_allclose(vs.T, theirs[1], rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(impulse, theirs[2], rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(angular, theirs[3], rtol=1e-10, atol=1e-12)


def _stream(k, mass, spread, dtype=np.float64, seed=1):
    """A free 1 kg box in empty space and ``k`` pieces of shot flying at it along +x at
    10 m/s, above its centre (so that it spins about -z), starting ``spread`` m apart."""
    world = World(gravity=(0.0, 0.0, 0.0))
    box = world.add_body(BodyShape.box((0.0, 0.0, 0.0), (0.2, 1.0, 0.6), mass=1.0))
    rng = np.random.default_rng(seed)
    x = -0.11 - rng.uniform(0.0, spread, k)  # the grown face is at x = -0.105
    positions = np.column_stack([x, rng.uniform(0.1, 0.45, k), rng.uniform(-0.25, 0.25, k)])
    velocities = np.column_stack(
        [np.full(k, 10.0), rng.uniform(-0.5, 0.5, k), rng.uniform(-0.5, 0.5, k)]
    )
    system = _shots(positions, velocities, mass, dtype)
    system.add(RigidContact(world, restitution=0.5, friction=0.3, thickness=0.005))
    tally = {"contacts": 0, "pushed": 0.0, "ids": set()}  # pushed: Σ m |v'| [N s]

    def count(event):
        tally["contacts"] += len(event)
        tally["pushed"] += mass * np.linalg.norm(event.velocity, axis=1).sum()
        tally["ids"].update(event.ids.tolist())

    system.on("collision", count)
    return world, box, system, tally


ORIGIN = np.array([0.5, -1.0, 2.0])  # any fixed point


@pytest.mark.parametrize("dtype", [np.float64, pytest.param(np.float32, marks=pytest.mark.slow)])
def test_a_stream_against_a_free_box_keeps_the_momentum(dtype):
    k, mass = 150, 4e-3  # 0.6 kg of shot at 10 m/s against a 1 kg box
    world, box, system, tally = _stream(k, mass, 2.5, dtype)
    before = _momenta(system, world, ORIGIN)
    speed, spin = 0.0, 0.0
    for _ in range(40):
        system.step(DT)
        world.step(DT)
        motion = world.motion([box.particles])
        speed = max(speed, np.linalg.norm(motion.velocity[0]))
        spin = max(spin, np.linalg.norm(motion.angular_velocity[0]))
    after = _momenta(system, world, ORIGIN)
    # Most of the shot hit the box (the rest passed it once it had turned and run off),
    # which took half of the momentum and spins about -z.
    assert len(tally["ids"]) > 0.75 * k
    assert motion.velocity[0, 0] > 0.5 * k * mass * 10.0
    assert motion.angular_velocity[0, 2] < -3.0
    scale = k * mass * 10.0
    # The exchange is exact: float64 sums round at ~1e-16 relative, and float32 particle
    # velocities at 2^-24 of each component a contact writes.
    rounding = 0.0 if dtype == np.float64 else 2.0**-24 * np.sqrt(3) * tally["pushed"]
    np.testing.assert_allclose(after[0], before[0], rtol=0, atol=1e-12 * scale + rounding)
    if dtype == np.float64:
        # Angular momentum: a particle is put back on the body where the body is now;
        # against a body that moved by δ since the last exchange this shifts its line by
        # at most |δ| <= (|V| + |ω| R) Δt (R the half diagonal), plus the stand-off GAP.
        reach = 0.5 * np.linalg.norm((0.2, 1.0, 0.6))
        shift = GAP + (speed + spin * reach) * DT
        np.testing.assert_allclose(after[1], before[1], rtol=0, atol=shift * tally["pushed"])


def test_a_volley_against_a_box_at_rest_keeps_the_angular_momentum():
    # Every piece hits in the first step, while the box is at rest: then each impulse
    # acts on the particle's own path and the exchange keeps the angular momentum about
    # any point exactly, but for the stand-off GAP along the normal.
    k, mass = 150, 4e-3
    world, _, system, tally = _stream(k, mass, 0.05)
    before = _momenta(system, world, ORIGIN)
    for _ in range(20):
        system.step(DT)
        world.step(DT)
    after = _momenta(system, world, ORIGIN)
    assert tally["contacts"] == k  # each hit once, and flew off
    assert (world.mass @ world.velocity)[0] > 0.5 * k * mass * 10.0
    scale = k * mass * 10.0 * np.abs(system["position"] - ORIGIN).max()  # [N m s]
    np.testing.assert_allclose(after[0], before[0], rtol=0, atol=1e-13 * scale)
    bound = GAP * tally["pushed"] + 1e-13 * scale
    np.testing.assert_allclose(after[1], before[1], rtol=0, atol=bound)


def test_a_bounce_keeps_restitution_of_the_relative_normal_speed():
    # A box moving at 2 m/s toward a particle at rest, infinitely heavy (pinned once
    # given its velocity would stop it, so it is made very heavy instead).
    world = World(gravity=(0.0, 0.0, 0.0))
    box = world.add_body(BodyShape.box((0.0, 0.0, 0.0), (0.5, 0.5, 0.5), mass=1e9))
    world.set_velocity(box.particles, (-2.0, 0.0, 0.0))  # pending: seen by the contact
    system = _shots([(-0.26, 0.1, 0.0)], [(0.0, 0.0, 0.0)], mass=0.01)
    system.add(RigidContact(world, restitution=0.5, thickness=0.02))
    system.step(DT)
    # Relative approach 2 m/s, leaves at 0.5 x 2 relative: -2 - 1 = -3 m/s.
    np.testing.assert_allclose(system["velocity"][0], (-3.0, 0.0, 0.0), atol=1e-6)
    np.testing.assert_allclose(system["position"][0], (-0.27, 0.1, 0.0), atol=2 * GAP)


def test_coulomb_friction_never_reverses_the_sliding():
    world = World(gravity=(0.0, 0.0, 0.0))
    box = world.add_body(BodyShape.box((0.0, -0.5, 0.0), (2.0, 1.0, 2.0)))
    world.pin(box.particles)  # immovable: the particles alone respond
    # The first crosses the top face in its step, the second ends within the thickness.
    system = _shots(
        [(0.0, 0.02, 0.0), (0.0, 0.001, 0.0)], [(0.5, -3.0, 0.0), (3.0, -0.1, 0.0)], mass=0.01
    )
    system.add(RigidContact(world, friction=0.5, thickness=0.002))
    system.step(DT)
    v = system["velocity"]
    np.testing.assert_allclose(v[0], (0.0, 0.0, 0.0), atol=1e-9)  # mu j_n = 1.5 > 0.5
    np.testing.assert_allclose(v[1], (3.0 - 0.5 * 0.1, 0.0, 0.0), atol=1e-9)
    assert np.all(world.motion([box.particles]).velocity == 0)


@pytest.mark.slow
def test_a_fast_particle_never_passes_a_thin_spinning_box():
    world = World(gravity=(0.0, 0.0, 0.0))
    plate = world.add_body(BodyShape.box((0.0, 0.0, 0.0), (0.01, 1.0, 1.0), mass=2.0))
    rest = world.position[plate.particles].copy()
    world.set_velocity(plate.particles, np.cross((0.0, 3.0, 0.0), rest))  # 3 rad/s about y
    k = 500
    rng = np.random.default_rng(2)
    positions = np.column_stack(
        [rng.uniform(-3.0, -1.5, k), rng.uniform(-0.35, 0.35, k), rng.uniform(-0.35, 0.35, k)]
    )
    # 100 m/s: 1.7 m per step, 170 times the plate's thickness.
    system = _shots(positions, np.tile((100.0, 0.0, 0.0), (k, 1)), mass=1e-4, dtype=np.float32)
    system.add(RigidContact(world, thickness=0.002))
    covered = 0
    for _ in range(8):
        world.step(DT)
        system.step(DT)  # the exchange sees the plate as the world left it
        _, centre, half, axes = world.boxes()
        thin = int(np.argmin(half[0]))
        across = [a for a in range(3) if a != thin]
        normal = axes[0, thin] * np.sign(axes[0, thin, 0])  # the plate's face toward +x
        local = (system["position"] - centre[0]) @ axes[0].T
        inside = np.all(np.abs(local[:, across]) < half[0, across], axis=1)
        front = (system["position"][inside] - centre[0]) @ normal
        assert np.all(front < -half[0, thin])  # all on the side they came from, none inside
        covered = max(covered, inside.sum())
    assert covered == k  # all of them were in front of the plate at once


def test_an_off_centre_stream_tips_a_standing_box_and_a_centred_light_one_does_not():
    def run(height, mass):
        world = World()
        world.add_collider(mo.colliders.Plane((0, 1, 0), 0.0, friction=0.6, restitution=0.0))
        box = world.add_body(BodyShape.box((0.0, 0.5, 0.0), (0.3, 1.0, 0.3), mass=2.0))
        system = _shots(np.zeros((0, 3)), np.zeros((0, 3)), mass)
        system.add(RigidContact(world, response="kill", thickness=0.01))
        tilt = 0.0
        for _ in range(150):
            # One piece per step at 20 m/s: a push of m u / Δt = mass x 1200 N.
            _spawn(system, [(-1.0, height, 0.0)], [(20.0, 0.0, 0.0)], mass)
            system.step(DT)
            world.step(DT)
            tilt = max(tilt, _tilt(world, box))
        return tilt, world.motion([box.particles]).centre[0]

    # 6 N at 0.9 m: 5.4 N m about the far bottom edge against the weight's 2.9 N m
    # (M g w / 2), and less than the friction limit mu M g = 11.8 N: it tips, not slides.
    tilt, _ = run(0.9, 0.005)
    assert tilt > 45.0
    # 2.4 N at the centre of mass (0.5 m): 1.2 N m, and no sliding either.
    tilt, centre = run(0.5, 0.002)
    assert tilt < 2.0
    assert abs(centre[0]) < 0.02


def test_a_particle_and_a_ball_of_equal_mass_exchange_velocities():
    world = World(gravity=(0.0, 0.0, 0.0))
    # Away from the origin: a ball's centre of mass rounds off its own position, and
    # that must not give it an inertia (a single particle cannot spin).
    ball = world.add_particles([(0.3, 1.7, -0.45)], mass=0.05, radius=0.1)
    world.add_sphere_contacts(ball)
    system = _shots([(-0.7, 1.7, -0.45)], [(10.0, 0.0, 0.0)], mass=0.05)
    system.add(RigidContact(world, restitution=1.0, thickness=0.01))
    for _ in range(8):
        system.step(DT)
        world.step(DT)
    np.testing.assert_allclose(system["velocity"][0], (0.0, 0.0, 0.0), atol=1e-9)
    np.testing.assert_allclose(world.velocity[0], (10.0, 0.0, 0.0), atol=1e-9)


@pytest.mark.slow
def test_kill_splashes_raise_collision_events_and_push_the_box():
    world = World(gravity=(0.0, 0.0, 0.0))
    world.add_body(BodyShape.box((0.0, 0.0, 0.0), (0.5, 0.5, 0.5), mass=2.0))
    system = _shots([(-0.2, 0.0, 0.0), (-0.2, 2.0, 0.0)], [(6.0, 0.0, 0.0)] * 2, mass=0.01)
    system.add(mo.colliders.Plane((0, 1, 0), -10.0))
    system.add(RigidContact(world, response="kill"))
    seen = []
    system.on("collision", seen.append)
    system.step(DT)
    assert len(system) == 1 and system["position"][0, 1] == 2.0  # the one that missed
    assert len(seen) == 1 and seen[0].collider.tolist() == [1]  # after the one collider
    world.step(DT)
    # Perfectly inelastic: the box takes the drop's momentum but for the share the drop
    # keeps at the common speed, m / (m + M) = 0.5 %.
    momentum = world.mass @ world.velocity
    np.testing.assert_allclose(momentum, (0.06 * 2.0 / 2.01, 0.0, 0.0), rtol=1e-9, atol=1e-12)


def test_bad_parameters_name_themselves():
    world = World()
    box = world.add_body(BodyShape.box((0, 0, 0), (1, 1, 1)))
    tetra = world.add_body(BodyShape.tetrahedron((3, 0, 0)))
    with pytest.raises(ValueError, match="restitution"):
        RigidContact(world, restitution=2)
    with pytest.raises(ValueError, match="response"):
        RigidContact(world, response="stick")
    with pytest.raises(ValueError, match="thickness"):
        RigidContact(world, thickness=0)
    with pytest.raises(ValueError, match="body 1 of the world is not a box"):
        RigidContact(world, bodies=[box, tetra])
    point = world.add_particles([(5.0, 0.0, 0.0)])
    with pytest.raises(ValueError, match=f"spheres: particle {point[0]}"):
        RigidContact(world, spheres=point)
    with pytest.raises(TypeError, match="rigid World"):
        RigidContact(object())
    empty = World()
    empty.add_body(BodyShape.tetrahedron())
    with pytest.raises(ValueError, match="without boxes or balls"):
        RigidContact(empty)
    assert RigidContact(world).bodies == [0]
