"""Cloth: topology, masses, kernels against their NumPy twins, pins, handles, colliders."""

import numpy as np
import pytest

import motes as mo
from motes.cloth import Airflow, Cloth, Keyframes, SpringFamily, topology
from motes.cloth.kernels import (
    aero_triangle_kernel,
    collide_kernel,
    gather_triangles_kernel,
)
from motes.collide.colliders import pack
from naive import penetration, respond
from naive_cloth import aero_forces


def test_grid_topology_counts_and_mass():
    nx, ny = 6, 4
    top = topology.grid(nx, ny, 2.0, 1.0)
    assert len(top.faces) == 2 * (nx - 1) * (ny - 1)
    assert len(top.structural) == ny * (nx - 1) + nx * (ny - 1)
    assert len(top.shear) == 2 * (nx - 1) * (ny - 1)
    assert len(top.bending) == ny * (nx - 2) + nx * (ny - 2)
    mesh = mo.TriangleMesh(top.vertices, top.faces)
    # Every triangle faces +z (counter-clockwise seen from the front).
    assert np.all(mesh.face_normals()[:, 2] > 0)
    mass = topology.vertex_masses(top.vertices, top.faces, 0.3)
    assert mass.sum() == pytest.approx(0.3 * 2.0 * 1.0)
    # An interior vertex of a uniform grid carries one cell's mass.
    assert mass[nx + 1] == pytest.approx(0.3 * (2.0 / 5) * (1.0 / 3))


def test_triangle_mesh_springs_are_edges_and_flaps():
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    vertices = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
    top = topology.from_triangles(vertices, faces)
    assert sorted(map(tuple, top.structural)) == [(0, 1), (0, 2), (0, 3), (1, 2), (2, 3)]
    assert sorted(map(tuple, np.sort(top.bending, axis=1))) == [(1, 3)]
    cloth = Cloth(vertices, faces)
    assert cloth.springs.spring_count == 6


def test_aero_kernel_matches_its_twin():
    rng = np.random.default_rng(4)
    top = topology.grid(7, 5, 1.0, 0.8)
    x = np.ascontiguousarray(top.vertices.T + rng.normal(scale=0.05, size=(3, 35)))
    v = rng.normal(size=(3, 35))
    wind = Airflow((3.0, 0.5, -1.0), gust=0.4, gusts=3, seed=2)
    out = np.empty((3, len(top.faces)))
    aero_triangle_kernel(
        *x, *v, top.faces, wind.velocity, wind.packed(), 0.7, wind.frequencies, wind.phases, out
    )
    first, tris = topology.vertex_triangles(top.faces, 35)
    f = np.zeros((3, 35))
    gather_triangles_kernel(out, first, tris, *f)
    expected = aero_forces(
        x, v, top.faces, wind.velocity, wind.packed(), 0.7, wind.frequencies, wind.phases
    )
    np.testing.assert_allclose(f.T, expected, rtol=1e-10, atol=1e-12)


def test_aero_forces_depend_on_orientation():
    # One triangle in the x-y plane, wind along z: face-on, pure drag along the wind,
    # ½ ρ C_d A |w|²; edge-on: nothing; at 45°: lift across the wind as large as the
    # drag times C_l/C_d.
    def force(normal_tilt):
        c, s = np.cos(normal_tilt), np.sin(normal_tilt)
        x = np.array([[0, 0, 0], [1, 0, 0], [0, c, s]], dtype=float).T.copy()
        out = np.empty((3, 1))
        air = np.array([1.2, 1.0, 0.5, 0.0])
        aero_triangle_kernel(
            *x,
            *np.zeros((3, 3)),
            np.array([[0, 1, 2]]),
            np.array([0.0, 0.0, 4.0]),
            air,
            0.0,
            np.empty(0),
            np.empty(0),
            out,
        )
        return out[:, 0]

    np.testing.assert_allclose(force(0.0), [0, 0, 0.5 * 1.2 * 0.5 * 16], atol=1e-12)
    np.testing.assert_allclose(force(np.pi / 2), 0.0, atol=1e-12)
    f = force(np.pi / 4)  # normal (0, -sin, cos)/...: tilted 45° to the wind
    area = 0.5
    q = 0.5 * 1.2 * area * 16 * np.cos(np.pi / 4)
    assert f[2] == pytest.approx(q * 1.0)
    assert abs(f[1]) == pytest.approx(q * 0.5 * np.sin(np.pi / 4))


@pytest.mark.parametrize(
    "collider",
    [
        mo.colliders.Sphere((0.1, -0.2, 0.0), 0.5, friction=0.3, restitution=0.2),
        mo.colliders.Box((0.0, -0.3, 0.1), (0.8, 0.6, 0.9), friction=0.5, friction_model="depth"),
        mo.colliders.Plane((0.0, 1.0, 0.2), offset=-0.1, friction=0.1),
    ],
)
def test_collide_kernel_matches_the_particle_twin(collider):
    rng = np.random.default_rng(9)
    x = rng.uniform(-0.6, 0.6, size=(3, 200))
    v = rng.normal(size=(3, 200))
    table, _ = pack([collider])
    movable = np.ones(200, dtype=bool)
    movable[:5] = False
    got_x, got_v = x.copy(), v.copy()
    collide_kernel(*got_x, *got_v, movable, table, 0.01)
    depth, normal = penetration(collider, x.T)
    px, pv, _, _ = respond(collider, x.T, v.T, depth, normal, 0.01)
    px[:5], pv[:5] = x.T[:5], v.T[:5]
    np.testing.assert_allclose(got_x.T, px, atol=1e-12)
    np.testing.assert_allclose(got_v.T, pv, atol=1e-12)


def test_pins_hold_and_handles_follow_their_path():
    cloth = Cloth.grid(8, 6, size=(1.0, 0.8))
    top = cloth.grid_index(0, slice(None))
    left, right = top[:4], top[4:]
    start = cloth.position.copy()
    cloth.pin(left)
    path = Keyframes([0.0, 1.0], [[0.0, 0.0, 0.0], [0.5, 0.2, 0.0]])
    cloth.move(right, path)
    for _ in range(30):
        cloth.step(1 / 60)
    np.testing.assert_array_equal(cloth.position[:, left], start[:, left])
    np.testing.assert_allclose(
        cloth.position[:, right], start[:, right] + path(0.5)[:, None], atol=1e-12
    )
    cloth.release(right)
    assert not cloth.pinned[right].any() and cloth.pinned[left].all()


def test_cloth_rests_on_a_sphere_and_a_table():
    sphere = mo.colliders.Sphere((0.0, 0.5, 0.0), 0.3, friction=0.5, restitution=0.0)
    table = mo.colliders.Box((0.0, 0.25, 0.0), (3.0, 0.5, 3.0), friction=0.5, restitution=0.0)
    rotation = np.array([[1.0, 0, 0], [0, 0, 1.0], [0, -1.0, 0]])  # lie flat, facing up
    cloth = Cloth.grid(
        24,
        24,
        size=(1.2, 1.2),
        origin=(-0.6, 1.0, -0.6),
        rotation=rotation,
        colliders=[sphere, table],
        thickness=0.01,
    )
    for _ in range(90):
        cloth.step(1 / 60)
    r = np.linalg.norm(cloth.position - np.array(sphere.center)[:, None], axis=0)
    # Pushed out every step: nothing inside the sphere or the table, to round-off.
    assert r.min() >= 0.3 + 0.01 - 1e-9
    assert cloth.position[1].min() >= 0.5 + 0.01 - 1e-9
    # Draped: the middle is held up by the sphere, the edges have fallen to the table.
    middle = cloth.grid_index(12, 12)[0]
    assert cloth.position[1, middle] > 0.75
    assert cloth.position[1, cloth.grid_index(0, 0)[0]] < 0.6


def test_strain_limit_keeps_a_hanging_cloth_from_stretching():
    soft = {
        "structural": SpringFamily(5.0, 0.01),
        "shear": SpringFamily(1.0, 0.0),
        "strain_iterations": 30,
    }
    rubber = Cloth.grid(16, 16, strain_limit=None, **soft)
    limited = Cloth.grid(16, 16, strain_limit=0.05, **soft)
    for cloth in (rubber, limited):
        cloth.pin(cloth.grid_index(0, slice(None)))
        for _ in range(60):
            cloth.step(1 / 60)
    assert rubber.stretch().max() > 0.12  # measured 0.156
    # Passes stop once no spring exceeds the limit by more than 0.1 % strain.
    assert limited.stretch().max() <= 0.05 + 1e-3


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"density": 0.0}, "density must be > 0"),
        ({"structural": (-1.0, 0.0)}, "stiffness must be >= 0"),
        ({"strain_limit": -0.1}, "strain_limit must be > 0"),
        ({"scheme": "leapfrog"}, "scheme must be one of"),
        ({"thickness": -1.0}, "thickness must be >= 0"),
        ({"wind": (1, 0, 0)}, "wind must be a Airflow"),
        ({"colliders": [1]}, "colliders must hold Collider"),
    ],
)
def test_bad_cloth_parameters(kwargs, message):
    with pytest.raises((ValueError, TypeError), match=message):
        Cloth.grid(4, 4, **kwargs)


def test_bad_mesh_input():
    with pytest.raises(ValueError, match="faces must"):
        Cloth(np.zeros((3, 3)), [[0, 1, 5]])
    with pytest.raises(ValueError, match="non-zero area"):
        Cloth(np.zeros((3, 3)), [[0, 1, 2]])
    with pytest.raises(ValueError, match="strictly increasing"):
        Keyframes([1.0, 0.0], [[0, 0, 0], [1, 0, 0]])


def test_cloth_drapes_over_a_triangle_mesh_and_never_enters_it():
    # A roof: two slopes meeting in a ridge along z, y = 0.8 - 0.5 |x| for |x| <= 1.
    vertices = [
        [-1.0, 0.3, -1.0],
        [0.0, 0.8, -1.0],
        [0.0, 0.8, 1.0],
        [-1.0, 0.3, 1.0],
        [1.0, 0.3, -1.0],
        [1.0, 0.3, 1.0],
    ]
    faces = [[0, 1, 2], [0, 2, 3], [1, 4, 5], [1, 5, 2]]
    roof = mo.TriangleMeshCollider((np.array(vertices), np.array(faces)), friction=0.8)
    rotation = np.array([[1.0, 0, 0], [0, 0, 1.0], [0, -1.0, 0]])  # lie flat, facing up
    cloth = Cloth.grid(
        20,
        20,
        size=(1.0, 1.0),
        origin=(-0.5, 1.0, -0.5),
        rotation=rotation,
        colliders=[roof],
        thickness=0.01,
    )
    for _ in range(90):
        cloth.step(1 / 60)
        x, y = cloth.position[0], cloth.position[1]
        # Projected out every step: at least the thickness above the roof (round-off).
        assert np.all(y >= 0.8 - 0.5 * np.abs(x) + 0.01 - 1e-9)
    # Held up on the ridge; the sides have fallen along the slopes, below the ridge.
    middle = cloth.grid_index(10, 10)[0]
    assert cloth.position[1, middle] == pytest.approx(0.81, abs=0.02)
    x, y = cloth.position[0], cloth.position[1]
    edge = np.abs(x) > 0.45
    assert edge.sum() >= 20 and y[edge].max() < 0.7
    assert np.isfinite(cloth.velocity).all()
