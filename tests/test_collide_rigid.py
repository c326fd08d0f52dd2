"""Collisions of rigid-world particles: a posteriori, swept (a priori), body against body."""

import numpy as np
import pytest
from numpy.testing import assert_allclose

import motes.rigid as mr
import naive_constraints as naive
from motes.collide import Box, Plane, Sphere
from motes.collide.capsule import Capsule
from motes.collide.contact import pack, project_contacts
from motes.collide.mesh import TriangleMeshCollider
from motes.collide.swept import sweep_contacts


def sphere_mesh(radius=1.0, subdivisions=2):
    from motes.render.geometry import icosphere

    vertices, faces = icosphere(subdivisions)
    return vertices * radius, faces


def colliders():
    r = np.linalg.qr(np.random.default_rng(1).normal(size=(3, 3)))[0]
    r *= np.sign(np.linalg.det(r))
    return [
        Plane((0.1, 1.0, 0.0), -0.5, friction=0.3),
        Sphere((0.5, 0.2, 0.0), 0.6, friction=0.5),
        Box((-0.6, 0.0, 0.3), (0.8, 0.5, 0.7), rotation=r, friction=0.2),
        Capsule((0.0, 0.0, -0.8), (0.6, 0.4, -0.5), 0.3, friction=0.4),
        TriangleMeshCollider(sphere_mesh(0.5, 1), thickness=0.02, friction=0.1),
    ]


def run_kernel(x, q, radius, w, cols):
    table, tri, start, lists = pack(cols, ["posteriori"] * len(cols))
    ours = np.ascontiguousarray(x.T)
    prev = np.ascontiguousarray(q.T)
    hits = np.zeros(len(x), dtype=np.int64)
    project_contacts(*ours, *prev, radius, w, table, tri, start, lists, hits)
    return ours.T, hits


@pytest.mark.parametrize("which", range(5))
def test_projection_matches_the_twin_for_each_shape(which):
    rng = np.random.default_rng(which)
    cols = [colliders()[which]]
    centre = [(0, -0.5, 0), (0.5, 0.2, 0), (-0.6, 0, 0.3), (0.3, 0.2, -0.65), (0, 0, 0)][which]
    n = 150 if which == 4 else 400  # the twin tests every triangle in Python
    x = np.asarray(centre) + rng.uniform(-0.7, 0.7, size=(n, 3))
    if which == 4:  # a thin shell: sample around the sphere's surface
        x *= 0.5 * rng.uniform(0.9, 1.1, (n, 1)) / np.linalg.norm(x, axis=1, keepdims=True)
    q = x + rng.normal(scale=0.05, size=x.shape)
    radius = rng.uniform(0, 0.05, n)
    w = np.ones(n)
    w[:10] = 0
    ours, hits = run_kernel(x, q, radius, w, cols)
    theirs = naive.project_contacts(x, q, radius, w, cols)
    assert hits.sum() > 15  # the cloud really overlaps the shape
    # float64 round-off of a handful of operations on O(1) values.
    assert_allclose(ours, theirs, rtol=0, atol=1e-10)


def test_mesh_grid_finds_what_brute_force_finds():
    mesh = sphere_mesh(1.0, 3)  # 1,280 triangles: gridded
    gridded = TriangleMeshCollider(mesh, thickness=0.01)
    single = TriangleMeshCollider(mesh, thickness=0.01, cell_size=100.0)
    assert np.prod(gridded.dims) > 8 and np.prod(single.dims) == 1
    rng = np.random.default_rng(5)
    x = rng.normal(size=(2000, 3))
    x *= rng.uniform(0.9, 1.1, 2000)[:, None] / np.linalg.norm(x, axis=1)[:, None]
    args = (x, x.copy(), np.full(2000, 0.05), np.ones(2000))
    assert_allclose(run_kernel(*args, [gridded])[0], run_kernel(*args, [single])[0], atol=1e-12)


def test_depth_friction_is_coulomb_sliding():
    # A block sliding on the ground: each step gravity presses it g h² deep, and the
    # depth friction removes mu g h² of tangential travel: deceleration mu g, so it stops
    # after v² / (2 mu g) (Jakobsen's depth friction is Coulomb's law here).
    mu, v = 0.4, 3.0
    w = mr.World(iterations=2)
    w.add_particles([[0.0, 0.0, 0.0]], 1.0)
    w.add_collider(Plane((0, 1, 0), 0.0, friction=mu))
    w.set_velocity([0], (v, 0, 0))
    for _ in range(180):
        w.step(1 / 60)
    # One step of travel (v h = 5 cm) bounds the discretisation error of the stop.
    assert_allclose(w.position[0, 0], v**2 / (2 * mu * 9.81), atol=v / 60)


@pytest.mark.parametrize("wall", ["box", "mesh", "plane"])
def test_a_100_m_s_particle_never_passes_a_1_cm_wall_a_priori_and_does_a_posteriori(wall):
    rng = np.random.default_rng(7)
    n = 200
    if wall == "box":
        make = lambda: Box((0.0, 0.0, 0.0), (0.01, 4.0, 4.0), restitution=0.0)  # noqa: E731
    elif wall == "mesh":
        square = np.array([[0, -2, -2], [0, 2, -2], [0, 2, 2], [0, -2, 2]], float)
        make = lambda: TriangleMeshCollider(  # noqa: E731
            (square, [[0, 1, 2], [0, 2, 3]]), thickness=0.005, restitution=0.0
        )
    else:
        make = lambda: Plane((-1.0, 0.0, 0.0), 0.0)  # noqa: E731  # solid beyond x = 0
    # Restitution 0: a particle that lands inside the wall a posteriori is projected out
    # and keeps going (with restitution it would bounce back when pushed out in front).
    results = {}
    for detection in ("priori", "posteriori"):
        w = mr.World(gravity=(0, 0, 0), iterations=1)
        # Starts spread over a whole step of travel, so every phase is tried.
        start = np.c_[-2.0 - rng.uniform(0, 100 / 60, n), rng.uniform(-1, 1, (n, 2))]
        p = w.add_particles(start, 1.0)
        w.set_velocity(p, (100.0, 0.0, 0.0))
        w.add_collider(make(), detection=detection)
        for _ in range(6):
            w.step(1 / 60)
        results[detection] = w.position[:, 0]
    assert np.all(results["priori"] < 0.0)
    if wall != "plane":  # a plane's solid side is infinite: nothing passes it anyway
        assert np.all(results["posteriori"] > 0.5)


def test_swept_bounce_keeps_restitution():
    w = mr.World(gravity=(0, 0, 0), iterations=1)
    w.add_particles([[-1.0, 0.0, 0.0]], 1.0)
    w.add_collider(Box((0, 0, 0), (0.01, 1, 1), restitution=0.5), detection="priori")
    w.set_velocity([0], (50.0, 0.0, 0.0))
    for _ in range(3):
        w.step(1 / 60)
    assert_allclose(w.velocity[0], (-25.0, 0.0, 0.0), atol=1e-6)


def test_body_contacts_separate_bodies_and_keep_momentum():
    w = mr.World(gravity=(0, 0, 0), iterations=10, body_friction=0.0)
    a = w.add_body(mr.BodyShape.box((0, 0, 0), (1, 1, 1), 2.0))
    b = w.add_body(mr.BodyShape.box((0.1, 0.9, 0.05), (1, 1, 1), 1.0))
    momentum = lambda: (w.mass[:, None] * (w.position - w.previous)).sum(0)  # noqa: E731
    for _ in range(5):
        w.step(1 / 60)
        assert_allclose(momentum(), 0.0, atol=1e-12)  # equal and opposite corrections
    centre, _ = w.transforms()
    assert centre[1, 1] - centre[0, 1] > 1.0  # pushed apart along y
    # The centre of mass has not moved.
    total = (2.0 * centre[0] + 1.0 * centre[1]) / 3.0
    assert_allclose(total, (2.0 * np.zeros(3) + np.array([0.1, 0.9, 0.05])) / 3.0, atol=1e-9)
    assert a.solid and b.solid


def test_spheres_and_capsules_are_swept_too():
    for collider in (Sphere((0, 0, 0), 0.05), Capsule((0, -1, 0), (0, 1, 0), 0.02)):
        w = mr.World(gravity=(0, 0, 0), iterations=1)
        w.add_particles([[-1.0, 0.0, 0.0]], 1.0)
        w.add_collider(collider, detection="priori")
        w.set_velocity([0], (100.0, 0.0, 0.0))
        for _ in range(3):
            w.step(1 / 60)
        assert w.position[0, 0] < 0.0  # stopped in front, not 1.7 m per step through it


def test_a_crate_lying_across_a_narrower_plank_rests_on_it():
    # No corner of either body is inside the other: only the edge test finds the contact.
    w = mr.World()
    w.add_collider(Plane((0, 1, 0), 0.0))
    w.add_body(mr.BodyShape.box((0, 0.05, 0), (0.27, 0.08, 1.0), 2.0))
    w.add_body(mr.BodyShape.box((0, 0.5, 0), (0.35, 0.35, 0.35), 4.0))
    for _ in range(60):
        w.step(1 / 60)
    centre, _ = w.transforms()
    # Plank top (0.09 m incl. contact radii) plus half the crate: about 0.26 m.
    assert_allclose(centre[1, 1], 0.09 + 0.175, atol=0.01)


def test_swept_kernel_matches_the_twin():
    rng = np.random.default_rng(11)
    r = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    r *= np.sign(np.linalg.det(r))
    cols = [
        Plane((0.2, 1.0, 0.1), -0.8, restitution=0.3),
        Box((0.3, 0.0, 0.0), (0.05, 1.5, 1.5), rotation=r, restitution=0.6),
        TriangleMeshCollider(sphere_mesh(0.6, 1), thickness=0.01, restitution=0.1),
    ]
    n = 300
    q = rng.uniform(-1.5, 1.5, size=(n, 3))
    x = q + rng.normal(scale=1.0, size=(n, 3))  # long paths: many cross something
    radius = rng.uniform(0, 0.03, n)
    w = np.ones(n)
    w[:5] = 0
    table, tri, start, lists = pack(cols, ["priori"] * 3)
    ours_x, ours_q = np.ascontiguousarray(x.T), np.ascontiguousarray(q.T)
    hits = np.zeros(n, dtype=np.int64)
    sweep_contacts(*ours_x, *ours_q, radius, w, table, tri, start, lists, hits)
    theirs_x, theirs_q = naive.sweep_contacts(x, q, radius, w, cols)
    assert hits.sum() > 50
    # float64 round-off of the intersection arithmetic on O(1) values.
    assert_allclose(ours_x.T, theirs_x, rtol=0, atol=1e-9)
    assert_allclose(ours_q.T, theirs_q, rtol=0, atol=1e-9)


def test_body_contact_kernel_matches_the_twin():
    from motes.rigid.body_contacts import body_contacts

    rng = np.random.default_rng(12)
    turn = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    turn *= np.sign(np.linalg.det(turn))  # a rotation, not a reflection
    w = mr.World(gravity=(0, 0, 0))
    w.add_body(mr.BodyShape.box((0, 0, 0), (1.0, 0.6, 0.8), 3.0))
    w.add_body(mr.BodyShape.box((0.3, 0.55, 0.1), (0.5, 0.5, 0.5), 1.0, rotation=turn))
    w.add_body(mr.BodyShape.tetrahedron((-0.5, 0.3, 0.2), 0.6, 2.0))
    w.add_body(
        mr.BodyShape.convex_hull(rng.normal(scale=0.3, size=(9, 3)) + np.array([0.5, -0.3, 0.4]))
    )
    w.add_body(mr.BodyShape.box((0.0, -0.35, 0.0), (1.4, 0.1, 0.2), 1.0))  # edge across a box
    model = w.model
    x = w.state.particle_position.copy()
    q = x + rng.normal(scale=0.01, size=x.shape)
    _, rotation = w.transforms()
    rotation = np.ascontiguousarray(rotation)
    ours = x.copy()
    hits = np.zeros(w.count, dtype=np.int64)
    body_contacts(
        *ours,
        *q,
        model.particle_inv_mass,
        w.radius,
        model.body_start,
        model.body_particles,
        model.body_fraction,
        model.body_rest,
        model.body_inv_mass,
        model.body_inertia_inv,
        model.body_plane_start,
        model.body_planes,
        model.body_group,
        rotation.copy(),
        model.body_edge_start,
        model.body_edges,
        0.4,
        hits,
    )
    theirs = naive.body_contacts(x.T, q.T, w.radius, model, rotation, 0.4)
    assert hits.sum() > 5 and np.abs(ours.T - x.T).max() > 1e-3  # real contacts
    # Rotations refined in the kernel start converged (SVD); round-off of O(1) sums.
    assert_allclose(ours.T, theirs, rtol=0, atol=1e-9)
