"""Blinn (1982) metaballs: field and gradient against twins, spheres, blending, meshes."""

import math

import numba
import numpy as np
import pytest

from motes.geometry import TriangleMesh
from motes.render import metaballs as metaballs_module
from motes.render.metaballs import Metaballs
from naive_metaballs import component_count, grid_nodes, is_closed_and_oriented, reach2
from naive_metaballs import field as naive_field
from naive_metaballs import gradient as naive_gradient


def twin_strengths(metaballs, weights):
    strength = metaballs.b * np.asarray(weights, np.float64)
    return strength, reach2(strength, metaballs.cutoff, metaballs.threshold, metaballs.a)


@pytest.fixture
def metaballs():
    # A lone particle: a sphere of radius 0.5; reach r_c = 0.5 sqrt(1 + ln(1000) / 2) = 1.05.
    return Metaballs.from_radius(0.5, sharpness=2.0, cell_size=0.1)


# -- the field and its gradient against the twins -----------------------------------------
def test_field_matches_the_naive_sum(rng, metaballs):
    positions = rng.uniform(-1.0, 1.0, (40, 3))
    weights = rng.uniform(0.2, 2.0, 40)
    origin, shape, spacing = np.array([-1.9, -1.7, -2.0]), (34, 31, 37), (0.11, 0.12, 0.1)
    got = metaballs.field(positions, origin, shape, spacing, weights=weights)
    assert got.shape == shape and got.dtype == np.float32
    strength, radius2 = twin_strengths(metaballs, weights)
    expected = naive_field(positions, origin, shape, spacing, metaballs.a, strength, radius2)
    # float32: offsets of order 2 m carry 1e-7 relative error, so a d² up to 9 (a d² <=
    # ln(b/(cutoff T))) gives exponents off by ~2e-6 relative, plus the exponential's own
    # 2e-6 and summation rounding: 2e-5 relative. A node within rounding of a particle's
    # reach may count it or not: one term of at most cutoff * T * max(weight) absolute.
    np.testing.assert_allclose(
        got, expected, rtol=2e-5, atol=metaballs.cutoff * metaballs.threshold * weights.max()
    )


def test_field_is_exactly_zero_beyond_every_reach_and_positive_within(rng, metaballs):
    positions = rng.uniform(-1.0, 1.0, (10, 3))
    origin, shape = np.array([-3.0, -3.0, -3.0]), (61, 61, 61)
    got = metaballs.field(positions, origin, shape)
    nodes = grid_nodes(origin, shape, metaballs.cell_size)
    nearest = np.min(np.linalg.norm(nodes[..., None, :] - positions, axis=-1), axis=-1)
    reach = metaballs.cutoff_radius
    assert np.all(got[nearest > reach * (1 + 1e-5)] == 0.0)
    assert np.all(got[nearest < reach * (1 - 1e-5)] > 0.0)


def test_particles_outside_the_grid_reach_in(metaballs):
    # A particle 0.8 m beyond the grid's face (reach 1.05 m) still adds to the nodes there.
    positions = np.array([[-0.8, 0.5, 0.5]])
    got = metaballs.field(positions, (0.0, 0.0, 0.0), (11, 11, 11))
    strength, radius2 = twin_strengths(metaballs, [1.0])
    expected = naive_field(
        positions, (0.0, 0.0, 0.0), (11, 11, 11), 0.1, metaballs.a, strength, radius2
    )
    assert expected.max() > 0.0
    np.testing.assert_allclose(got, expected, rtol=2e-5, atol=metaballs.cutoff)


def test_gradient_matches_the_naive_sum_and_finite_differences(rng, metaballs):
    positions = rng.uniform(-1.0, 1.0, (30, 3))
    points = rng.uniform(-1.5, 1.5, (200, 3))
    got = metaballs.gradient(points, positions)
    strength, radius2 = twin_strengths(metaballs, np.ones(30))
    expected = naive_gradient(points, positions, metaballs.a, strength, radius2)
    # Components may cancel: tolerance relative to the largest (float32 rounding as for
    # the field), plus one term at the reach, 2 a r_c cutoff T, for boundary particles.
    scale = np.abs(expected).max()
    term = 2 * metaballs.a * metaballs.cutoff_radius * metaballs.cutoff * metaballs.threshold
    np.testing.assert_allclose(got, expected, rtol=0, atol=2e-5 * scale + term)
    # The twin's analytic gradient is the derivative of the twin's field (central
    # differences, step 1e-5: truncation ~1e-10 relative, rounding ~1e-11 / 1e-5).
    step = 1e-5
    for axis in range(3):
        offset = np.zeros(3)
        offset[axis] = step
        plus = naive_field(
            positions, points[0] + offset, (1, 1, 1), 1.0, metaballs.a, strength, radius2
        )
        minus = naive_field(
            positions, points[0] - offset, (1, 1, 1), 1.0, metaballs.a, strength, radius2
        )
        np.testing.assert_allclose(
            (plus - minus).item() / (2 * step), expected[0, axis], rtol=1e-5, atol=1e-6
        )


def test_normals_are_the_normalised_negative_gradient(rng, metaballs):
    positions = rng.uniform(-1.0, 1.0, (30, 3))
    points = rng.uniform(-1.5, 1.5, (100, 3))
    gradient = metaballs.gradient(points, positions)
    normals = metaballs.normals(points, positions)
    length = np.linalg.norm(gradient, axis=1, keepdims=True)
    reached = length[:, 0] > 0
    np.testing.assert_allclose(normals[reached], -gradient[reached] / length[reached], atol=1e-5)
    assert np.all(normals[~reached] == 0.0)
    # Far from every particle: no field, no gradient, no normal.
    far = metaballs.normals([[10.0, 0.0, 0.0]], positions)
    assert np.all(far == 0.0) and far.dtype == np.float32


# -- a lone particle is a sphere ----------------------------------------------------------
def test_from_radius_puts_the_threshold_at_the_radius():
    metaballs = Metaballs.from_radius(0.3, sharpness=1.5, threshold=2.0, cell_size=0.05)
    assert metaballs.radius == pytest.approx(0.3)
    assert metaballs.b * math.exp(-metaballs.a * 0.3**2) == pytest.approx(metaballs.threshold)
    assert metaballs.a * 0.3**2 == pytest.approx(1.5)  # Blinn's blobbiness B = -1.5
    r_c = metaballs.cutoff_radius
    assert metaballs.b * math.exp(-metaballs.a * r_c**2) == pytest.approx(
        metaballs.cutoff * metaballs.threshold
    )


@pytest.mark.parametrize("cells_per_radius", [5, 10])
def test_a_lone_particle_meshes_into_a_sphere(cells_per_radius):
    r = 1.0
    h = r / cells_per_radius
    metaballs = Metaballs.from_radius(r, sharpness=2.0, cell_size=h)
    center = np.array([0.3, -0.2, 0.1])  # off the lattice
    mesh = metaballs.mesh(center[None, :])
    distance = np.linalg.norm(mesh.vertices - center, axis=1)
    # Vertices: linear interpolation along an edge of length h misplaces the crossing of
    # f(ρ) = b e^{-a ρ²} by at most h² |f''| / (8 |f'|) along the edge, |f''/f'| =
    # |2 a r - 1/r| = 3/r radially, plus the sphere's curvature 1/r for edges across it:
    # h² (3 + 1) / (8 r). (Measured: 8e-4 r at h = r/10.)
    vertex_error = h**2 * 4 / (8 * r)
    np.testing.assert_allclose(distance, r, atol=vertex_error)
    assert abs(distance.mean() - r) < vertex_error
    # Flat triangles with corners on the sphere cut inside it by their sagitta, at most
    # l² / (8 r) for edges l <= sqrt(2) h (within a cell face): the radius is off by at
    # most vertex_error + h² / (4 r), the volume by 3 and the area by 2 times that.
    radius_error = (vertex_error + h**2 / (4 * r)) / r
    np.testing.assert_allclose(mesh.volume(), 4 / 3 * math.pi * r**3, rtol=3 * radius_error)
    np.testing.assert_allclose(mesh.area(), 4 * math.pi * r**2, rtol=2 * radius_error)
    # Normals are the analytic radial direction (float32).
    radial = (mesh.vertices - center) / distance[:, None]
    np.testing.assert_allclose(np.einsum("ij,ij->i", mesh.normals, radial), 1.0, atol=1e-5)
    assert is_closed_and_oriented(mesh.faces) and component_count(mesh.faces) == 1


def test_weights_scale_the_strength(rng):
    metaballs = Metaballs.from_radius(0.5, cell_size=0.1)
    doubled = Metaballs(a=metaballs.a, b=2 * metaballs.b, threshold=1.0, cell_size=0.1,
                        cutoff=metaballs.cutoff)  # fmt: skip
    positions = rng.uniform(-1.0, 1.0, (5, 3))
    weighted = metaballs.field(positions, (-2, -2, -2), (41, 41, 41), weights=np.full(5, 2.0))
    np.testing.assert_allclose(
        weighted, doubled.field(positions, (-2, -2, -2), (41, 41, 41)), rtol=1e-6
    )
    # A weight of 0 removes the particle.
    alone = metaballs.field(positions[:1], (-2, -2, -2), (41, 41, 41))
    masked = metaballs.field(positions, (-2, -2, -2), (41, 41, 41), weights=[1, 0, 0, 0, 0])
    np.testing.assert_array_equal(alone, masked)


# -- blending and meshes ------------------------------------------------------------------
@pytest.mark.parametrize(("separation", "pieces"), [(0.7, 1), (1.8, 2)])
def test_two_blobs_merge_when_close(metaballs, separation, pieces):
    positions = np.array([[0.0, 0.0, 0.0], [separation, 0.0, 0.0]])
    # Midway, each blob adds b e^{-a (s/2)²}: T at s = 2 r = 1.0 m in isolation; with both
    # the neck closes at s = 2 r sqrt(1 + ln 2 / sharpness) = 1.16 m.
    mesh = metaballs.mesh(positions)
    assert component_count(mesh.faces) == pieces
    assert is_closed_and_oriented(mesh.faces)


def test_random_clouds_mesh_closed_outward_and_deterministic(rng, metaballs):
    positions = rng.normal(0.0, 0.6, (300, 3))
    mesh = metaballs.mesh(positions)
    assert isinstance(mesh, TriangleMesh) and len(mesh) > 0
    assert is_closed_and_oriented(mesh.faces) and mesh.volume() > 0
    # The analytic normals point outward: they agree with the faces' normals, except on a
    # few faces where the grid resolves a thin neck poorly (2 of 17,712 here).
    face_normals = mesh.face_normals()
    agree = np.einsum("ij,ij->i", mesh.normals[mesh.faces[:, 0]], face_normals) > 0
    area = np.linalg.norm(face_normals, axis=1)
    assert area[agree].sum() > 0.999 * area.sum()
    alignment = np.einsum("ij,ij->i", mesh.normals, mesh.vertex_normals())
    assert np.median(alignment) > 0.99
    again = metaballs.mesh(positions)
    previous = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        single = metaballs.mesh(positions)
    finally:
        numba.set_num_threads(previous)
    for other in (again, single):
        for name in ("vertices", "faces", "normals"):
            np.testing.assert_array_equal(getattr(mesh, name), getattr(other, name))


def test_mesh_matches_scikit_image_on_the_same_field(rng, metaballs):
    measure = pytest.importorskip("skimage.measure")
    positions = rng.normal(0.0, 0.5, (25, 3))
    mesh = metaballs.mesh(positions)
    # The grid mesh() chose: snapped to multiples of cell_size, r_c + one cell around.
    h = metaballs.cell_size
    margin = metaballs.cutoff_radius + h
    origin = np.floor((positions.min(axis=0) - margin) / h) * h
    shape = np.floor((positions.max(axis=0) + margin - origin) / h).astype(int) + 1
    field = metaballs.field(positions, origin, shape)
    sk_vertices, sk_faces, _, _ = measure.marching_cubes(
        field, metaballs.threshold, spacing=(h, h, h), gradient_direction="ascent"
    )
    sk_vertices += origin
    assert len(sk_vertices) == len(mesh.vertices)
    # Same vertices and triangle choices only (see test_marching_cubes): 5e-4 and 2e-3.
    sk_mesh = TriangleMesh(sk_vertices, sk_faces)
    np.testing.assert_allclose(mesh.area(), sk_mesh.area(), rtol=5e-4)
    np.testing.assert_allclose(mesh.volume(), sk_mesh.volume(), rtol=2e-3)


def test_bounds_cut_the_surface_open(metaballs):
    mesh = metaballs.mesh([[0.0, 0.0, 0.0]], bounds=((-1.0, -1.0, 0.0), (1.0, 1.0, 1.0)))
    assert len(mesh) > 0 and not is_closed_and_oriented(mesh.faces)
    assert mesh.vertices[:, 2].min() >= 0.0  # the lower half was cut away


def test_the_automatic_grid_does_not_shift_with_the_particles(metaballs):
    # Grids are snapped to multiples of cell_size: a shift by whole cells shifts the mesh.
    first = metaballs.mesh([[0.03, 0.01, 0.02]])
    moved = metaballs.mesh([[0.33, 0.01, 0.02]])
    np.testing.assert_allclose(moved.vertices - (0.3, 0, 0), first.vertices, atol=1e-5)


def test_empty_input_gives_an_empty_mesh(metaballs):
    for positions, weights in [(np.zeros((0, 3)), None), (np.zeros((3, 3)), np.zeros(3))]:
        mesh = metaballs.mesh(positions, weights=weights)
        assert len(mesh) == 0 and mesh.vertices.shape == (0, 3)


def test_a_cloud_weaker_than_the_threshold_has_no_surface():
    metaballs = Metaballs(a=4.0, b=0.5, threshold=1.0, cell_size=0.1)  # b < T: no lone sphere
    assert metaballs.radius == 0.0
    assert len(metaballs.mesh([[0.0, 0.0, 0.0]])) == 0
    # ... but enough of them together do.
    assert len(metaballs.mesh(np.zeros((4, 3)))) > 0


# -- bad input ----------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"a": 0.0}, "a must be > 0"),
        ({"b": -1.0}, "b must be > 0"),
        ({"threshold": float("nan")}, "threshold must be finite"),
        ({"cell_size": 0.0}, "cell_size must be > 0"),
        ({"cutoff": 0.0}, "cutoff must be > 0"),
        ({"cutoff": 1.0}, "cutoff must be < 1"),
        ({"b": 0.5, "cutoff": 0.6}, "cutoff must be < 0.5"),
        ({"padding": -1}, "padding must be >= 0"),
        ({"padding": 1.5}, "padding must be an integer"),
    ],
)
def test_bad_parameters_are_refused_with_the_parameter_named(kwargs, message):
    arguments = {"a": 4.0, "b": 2.0, "threshold": 1.0, "cell_size": 0.1} | kwargs
    with pytest.raises((ValueError, TypeError), match=message):
        Metaballs(**arguments)


def test_bad_from_radius_arguments_are_refused():
    with pytest.raises(ValueError, match="radius must be > 0"):
        Metaballs.from_radius(0.0)
    with pytest.raises(ValueError, match="sharpness must be > 0"):
        Metaballs.from_radius(1.0, sharpness=-1.0)


def test_bad_call_arguments_are_refused(metaballs):
    with pytest.raises(ValueError, match=r"positions must have shape \(n, 3\)"):
        metaballs.mesh(np.zeros((4, 2)))
    with pytest.raises(ValueError, match="positions must be finite"):
        metaballs.mesh([[0.0, np.nan, 0.0]])
    with pytest.raises(ValueError, match=r"weights must have shape \(2,\)"):
        metaballs.mesh(np.zeros((2, 3)), weights=[1.0])
    with pytest.raises(ValueError, match="weights must be finite and >= 0"):
        metaballs.mesh(np.zeros((2, 3)), weights=[1.0, -1.0])
    with pytest.raises(ValueError, match="bounds must have lower < upper"):
        metaballs.mesh(np.zeros((1, 3)), bounds=((0, 0, 0), (1, -1, 1)))
    with pytest.raises(ValueError, match="shape must be 3 node counts"):
        metaballs.field(np.zeros((1, 3)), (0, 0, 0), (4, 4))
    with pytest.raises(ValueError, match="spacing must be > 0"):
        metaballs.field(np.zeros((1, 3)), (0, 0, 0), (4, 4, 4), spacing=(0.1, 0.0, 0.1))


def test_points_spread_too_far_for_one_bin_grid_are_refused():
    metaballs = Metaballs.from_radius(0.5, cell_size=0.1, max_nodes=1000)
    with pytest.raises(ValueError, match="evaluate them in smaller batches"):
        metaballs.gradient([[0.0, 0.0, 0.0], [100.0, 100.0, 100.0]], [[0.0, 0.0, 0.0]])


def test_grids_above_max_nodes_are_refused_with_a_suggestion():
    metaballs = Metaballs.from_radius(0.5, cell_size=0.01, max_nodes=100_000)
    with pytest.raises(ValueError, match=r"more than max_nodes=100,000: use a cell_size at least"):
        metaballs.mesh(np.array([[0.0, 0.0, 0.0], [3.0, 3.0, 3.0]]))


@pytest.mark.parametrize("column_nodes", [1, 7, 64])
def test_the_field_does_not_depend_on_the_column_width(rng, metaballs, monkeypatch, column_nodes):
    # Columns are chosen by thread count; every node sums its particles in bin order
    # whatever the columns, so the field is bit-identical.
    positions = rng.uniform(-1.0, 1.0, (200, 3))
    expected = metaballs.field(positions, (-2, -2, -2), (41, 37, 43))
    monkeypatch.setattr(metaballs_module, "COLUMN_NODES", column_nodes)
    np.testing.assert_array_equal(metaballs.field(positions, (-2, -2, -2), (41, 37, 43)), expected)
