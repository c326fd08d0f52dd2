"""Rigid world: Verlet kernel, shapes, transforms, joints, ragdoll builder, bad input."""

import numba
import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import motes.rigid as mr
import naive_constraints as naive
from motes.collide import Plane
from motes.rigid.kernels import verlet
from motes.rigid.rotation import update_rotations
from motes.rigid.stepping import next_velocity


def rotation(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


def test_verlet_kernel_matches_the_twin():
    rng = np.random.default_rng(0)
    x, q = rng.normal(size=(2, 3000, 3))
    w = rng.uniform(0, 2, 3000)
    w[::7] = 0
    ours_x, ours_q = np.ascontiguousarray(x.T), np.ascontiguousarray(q.T)
    verlet(*ours_x, *ours_q, w, 0.0, -9.81, 1.0, 0.99, (1 / 60) ** 2)
    twin_x, twin_q = naive.verlet(x, q, w, (0.0, -9.81, 1.0), 0.99, 1 / 60)
    assert_allclose(ours_x.T, twin_x, rtol=1e-14, atol=1e-14)
    assert_array_equal(ours_q.T, twin_q)


def test_box_and_tetrahedron_shapes():
    box = mr.BodyShape.box((1, 2, 3), (1.0, 2.0, 0.5), 8.0)
    assert box.positions.shape == (8, 3) and len(box.sticks) == 28 and len(box.planes) == 6
    assert_allclose(box.center, (1, 2, 3))
    half = np.sort(box.planes[:, 3] - box.planes[:, :3] @ (1, 2, 3))
    assert_allclose(half, [0.25, 0.25, 0.5, 0.5, 1.0, 1.0])
    tet = mr.BodyShape.tetrahedron(edge=0.3)
    ends = tet.positions[tet.sticks]
    lengths = np.linalg.norm(ends[:, 1] - ends[:, 0], axis=1)
    assert_allclose(lengths, 0.3)
    assert len(tet.planes) == 4


def test_convex_hull_faces_match_scipy():
    from scipy.spatial import ConvexHull

    points = np.random.default_rng(3).normal(size=(12, 3))
    shape = mr.BodyShape.convex_hull(points)
    hull = ConvexHull(points)
    # SciPy lists triangles (coplanar ones repeated); compare the distinct planes.
    theirs = np.unique(np.round(np.c_[hull.equations[:, :3], -hull.equations[:, 3]], 6), axis=0)
    assert_allclose(np.unique(np.round(shape.planes, 6), axis=0), theirs, atol=2e-6)
    with pytest.raises(ValueError, match="coplanar"):
        mr.BodyShape.convex_hull([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]])


def test_transforms_recover_a_known_motion():
    w = mr.World()
    body = w.add_body(mr.BodyShape.box((0, 0, 0), (1.0, 0.5, 0.2), 3.0))
    r = rotation((1, 2, 3), 0.7)
    w.position[body.particles] = w.position[body.particles] @ r.T + (4, 5, 6)
    centre, rot = w.transforms()
    assert_allclose(centre[0], (4, 5, 6), atol=1e-12)
    assert_allclose(rot[0], r, atol=1e-12)


def test_compiled_rotation_refinement_converges_to_the_polar_rotation():
    rng = np.random.default_rng(4)
    rest = rng.normal(size=(6, 3))
    rest -= rest.mean(0)
    r = rotation((0.3, -1, 0.2), 1.1)
    x = rest @ r.T + rng.normal(scale=0.01, size=rest.shape) + 2.0
    rot = np.eye(3)[None].copy()
    fraction = np.full(6, 1 / 6)
    update_rotations(
        *np.ascontiguousarray(x.T), np.array([0, 6]), np.arange(6), fraction, rest, rot, 50
    )
    u, _, vt = np.linalg.svd(((x - x.mean(0)).T * fraction) @ rest)
    assert_allclose(rot[0], u @ vt, atol=1e-9)


def test_ball_joint_and_hinge_by_shared_particles():
    w = mr.World(iterations=20, gravity=(0, -9.81, 0))
    a = w.add_body(mr.BodyShape.tetrahedron((0, 0, 0), 0.5, 1.0), group=0)
    w.pin(a.particles)  # a fixed base
    tip = w.position[a.particles[0]].copy()
    # Ball joint: b's corner 3 is a's corner 0.
    shape = mr.BodyShape.tetrahedron(tip - mr.BodyShape.tetrahedron(edge=0.5).positions[3], 0.5)
    b = w.add_body(shape, share={3: int(a.particles[0])}, group=0)
    w.set_velocity(b.particles[:3], (1.0, 0.0, 0.0))
    # Hinge: c shares two particles (an edge) with a.
    edge = w.position[a.particles[[1, 2]]]
    axis = edge[1] - edge[0]
    side = np.cross(axis, (0.0, 1.0, 0.0))
    side /= np.linalg.norm(side)
    down = np.cross(side, axis / np.linalg.norm(axis))
    mid = edge.mean(0)
    hinge_shape = mr.BodyShape.from_points([*edge, mid + 0.3 * side, mid + 0.3 * down])
    c = w.add_body(hinge_shape, share={0: int(a.particles[1]), 1: int(a.particles[2])}, group=0)
    for _ in range(120):
        w.step(1 / 60)
    assert_allclose(w.position[b.particles[3]], tip, atol=1e-9)  # shared: never apart
    assert np.linalg.norm(w.position[b.particles[0]] - shape.positions[0]) > 0.05  # it swung
    # The hinged body only turns about the hinge axis.
    _, rot = w.transforms()
    r_rel = rot[c.index]
    axis_unit = axis / np.linalg.norm(axis)
    assert_allclose(r_rel @ axis_unit, axis_unit, atol=1e-6)
    assert np.arccos((np.trace(r_rel) - 1) / 2) > 0.1


def test_ragdoll_has_the_stated_topology_and_mass():
    w = mr.World()
    rd = mr.add_ragdoll(w, (0, 0, 0), height=1.8, mass=75.0)
    assert w.count == 15 and len(w.constraints) == 31
    assert_allclose(w.mass.sum(), 75.0)
    assert_allclose(w.position[:, 1].max(), 0.936 * 1.8)
    assert rd.limit_violation(w.position).max() == 0.0
    assert len(rd.segments) == 18


def test_ragdoll_falls_over_and_rests_within_its_limits():
    w = mr.World()
    rd = mr.add_ragdoll(w, (0, 0, 0))
    w.add_collider(Plane((0, 1, 0), 0.0, friction=0.6))
    w.set_velocity(rd.indices, (0.0, 0.5, 1.5))
    worst = 0.0
    for _ in range(240):
        w.step(1 / 60)
        worst = max(worst, rd.limit_violation(w.position).max())
    assert w.position[:, 1].max() < 0.5  # lying down
    assert np.abs(w.velocity).max() < 0.05
    # Joint limits are relaxed together with the ground contacts (10 iterations): while
    # the fall's impact is absorbed they give a few degrees.
    assert np.degrees(worst) < 6.0


def test_world_steps_are_deterministic_and_thread_count_independent():
    def run(threads):
        previous = numba.get_num_threads()
        numba.set_num_threads(threads)
        try:
            w = mr.World(iterations=3)
            n = 100
            grid = np.stack(np.meshgrid(np.arange(n), np.arange(n)), -1).reshape(-1, 2) * 0.05
            p = w.add_particles(np.c_[grid[:, 0], np.full(n * n, 1.0), grid[:, 1]], 0.01)
            idx = p.reshape(n, n)
            pairs = np.r_[
                np.c_[idx[:, :-1].ravel(), idx[:, 1:].ravel()],
                np.c_[idx[:-1].ravel(), idx[1:].ravel()],
            ]
            w.add_sticks(pairs)
            w.pin(idx[0])
            w.add_collider(Plane((0, 1, 0), 0.3, friction=0.4))
            for _ in range(20):
                w.step(1 / 60)
            return w.position.copy()
        finally:
            numba.set_num_threads(previous)

    assert_array_equal(run(1), run(numba.config.NUMBA_NUM_THREADS))


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: mr.World(iterations=0), "iterations must be >= 1"),
        (lambda: mr.World(damping=-1), "damping must be >= 0"),
        (lambda: mr.World(projection="newton"), "projection must be one of"),
        (lambda: mr.World().add_particles([[0, 0, 0]], mass=0), "mass must be"),
        (lambda: mr.World().add_body("box"), "shape must be a BodyShape"),
        (lambda: mr.World().add_sticks([[0, 1]]), "particle indices must be in"),
        (lambda: mr.add_ragdoll(mr.World(), height=-1), "height must be > 0"),
        (lambda: mr.BodyShape.box(size=(1, 0, 1)), "size must be > 0"),
        (lambda: mr.World().add_collider(Plane(), detection="later"), "detection must be"),
        (lambda: mr.World().set_velocity([3], (1, 0, 0)), "indices must be in"),
    ],
)
def test_bad_input_names_the_parameter(call, message):
    with pytest.raises((ValueError, TypeError), match=message):
        call()


def test_ragdoll_hinge_sides_straighten_a_knee_bent_backwards():
    w = mr.World(gravity=(0, 0, 0), iterations=20)
    doll = mr.add_ragdoll(w, (0, 0, 0), hinge_sides=True)
    assert len(w.constraints) == 35
    knee, ankle = doll.particles["knee_l"], doll.particles["ankle_l"]
    w.position[ankle] += (0.0, 0.1, 0.25)  # the shin kicked forward: a knee bent backwards
    w.previous[ankle] = w.position[ankle]
    assert np.degrees(doll.limit_violation(w.position)[13]) > 20
    for _ in range(12):  # recovered at 3 m/s, not thrown back in one step
        w.step(1 / 60)
        assert np.linalg.norm(w.velocity, axis=1).max() < 4.0
    assert np.degrees(doll.limit_violation(w.position)[13]) < 1.0
    assert w.position[ankle, 2] < w.position[knee, 2] + 0.01


def _momenta(world):
    """Momentum and angular momentum about the origin of the world's particles."""
    # What the next step starts from, pending changes included.
    v = next_velocity(world.state, world.control).T
    return world.mass @ v, world.mass @ np.cross(world.position, v)


def test_an_impulse_changes_a_body_s_momentum_and_angular_momentum_exactly():
    world = mr.World(gravity=(0, 0, 0))
    turn = rotation((1.0, 2.0, 0.5), 0.7)
    box = world.add_body(mr.BodyShape.box((0.3, 1.0, -0.2), (0.4, 1.0, 0.6), 3.0, rotation=turn))
    tetra = world.add_body(mr.BodyShape.tetrahedron((2.0, 0.0, 0.0), 0.5))
    world.set_velocity(box.particles, (1.0, 0.0, 0.0))
    world.step(1 / 60)
    motion = world.motion([box.particles, tetra.particles])
    assert_allclose(motion.velocity[0], (1.0, 0.0, 0.0), atol=1e-12)
    assert_allclose(motion.angular_velocity, 0.0, atol=1e-12)
    assert_allclose(motion.inverse_mass, (1 / 3.0, 1.0))
    before = _momenta(world)
    j, point = np.array([0.4, -1.0, 0.3]), np.array([0.4, 1.3, 0.1])
    world.add_impulse([box.particles], [j], [np.cross(point - motion.centre[0], j)])
    after = _momenta(world)
    assert_allclose(after[0] - before[0], j, atol=1e-13)
    assert_allclose(after[1] - before[1], np.cross(point, j), atol=1e-13)
    # The motion the next step starts from includes the impulse; the world keeps it.
    changed = world.motion([box.particles])
    assert_allclose(changed.velocity[0] - motion.velocity[0], j / 3.0, atol=1e-13)
    world.step(1 / 60)
    assert_allclose(world.mass @ world.velocity, after[0], atol=1e-12)
    # One particle takes no angular impulse; a pinned body none at all.
    world.add_impulse([[0]], [j], [(1.0, 1.0, 1.0)])
    assert_allclose(_momenta(world)[0] - after[0], j, atol=1e-12)
    world.pin(tetra.particles)
    world.add_impulse([tetra.particles], [j])
    assert_allclose(_momenta(world)[0] - after[0], j, atol=1e-12)


def test_boxes_are_read_from_their_particles_as_they_turn():
    world = mr.World(gravity=(0, 0, 0))
    turn = rotation((0.0, 0.0, 1.0), 0.4)
    shape = mr.BodyShape.box((0.0, 1.0, 0.0), (0.2, 0.4, 0.6), rotation=turn)
    box = world.add_body(shape)
    world.add_body(mr.BodyShape.tetrahedron((2.0, 0.0, 0.0)))
    assert mr.BodyShape.tetrahedron().box_geometry() is None
    world.set_velocity(box.particles, np.cross((0.0, 2.0, 1.0), world.position[box.particles]))
    for _ in range(20):
        world.step(1 / 60)
    index, centre, half, axes = world.boxes()
    assert_array_equal(index, [0])
    assert_allclose(np.sort(half[0]), (0.1, 0.2, 0.3), atol=1e-12)
    local = (world.position[box.particles] - centre[0]) @ axes[0].T
    assert_allclose(np.abs(local), np.broadcast_to(half[0], (8, 3)), atol=1e-6)
