"""Marching cubes (Lorensen & Cline 1987): generated tables, topology, twins, references."""

import numba
import numpy as np
import pytest
from scipy.spatial import cKDTree

from motes.geometry import TriangleMesh
from motes.render.marching_cubes import (
    CORNER_OFFSETS,
    EDGE_CORNERS,
    case_tables,
    marching_cubes,
)
from naive_metaballs import (
    component_count,
    grid_nodes,
    is_closed_and_oriented,
    same_triangles,
)
from naive_metaballs import marching_cubes as naive_marching_cubes


def padded_random_field(rng, shape, *, smooth=False):
    """Random values inside a border of zeros: with a level >= 0 the border is outside,
    so the surface is closed."""
    field = np.zeros(shape, np.float32)
    inner = rng.standard_normal(tuple(s - 2 for s in shape))
    if smooth:  # a separable box blur, twice: fewer, larger blobs
        for axis in (0, 1, 2, 0, 1, 2):
            inner = sum(np.roll(inner, shift, axis) for shift in (-1, 0, 1)) / 3.0
    field[1:-1, 1:-1, 1:-1] = inner
    return field


def corner_field(case):
    """A single cell whose corner c is 1 (inside at level 0) when bit c of case is set."""
    field = np.empty((2, 2, 2), np.float32)
    for c in range(8):
        field[tuple(CORNER_OFFSETS[c])] = 1.0 if case >> c & 1 else -1.0
    return field


# -- the generated tables -----------------------------------------------------------------
def test_tables_use_exactly_the_cut_edges_of_each_case():
    counts, table = case_tables()
    assert counts[0] == counts[255] == 0
    for case in range(256):
        inside = [case >> c & 1 for c in range(8)]
        cut = {e for e, (c0, c1) in enumerate(EDGE_CORNERS) if inside[c0] != inside[c1]}
        used = set(table[case, : counts[case]].ravel().tolist())
        assert used == cut, case
        assert np.all(table[case, counts[case] :] == -1)


def test_tables_are_generated_once_and_read_only():
    _counts, table = case_tables()
    assert case_tables()[1] is table
    with pytest.raises(ValueError, match="read-only"):
        table[0, 0, 0] = 1


@pytest.mark.parametrize("corner", range(8))
def test_a_lone_inside_corner_is_cut_off_by_one_outward_triangle(corner):
    for case in (1 << corner, 255 ^ (1 << corner)):  # one corner inside, or one outside
        vertices, faces = marching_cubes(corner_field(case), 0.0)
        assert faces.shape == (1, 3)
        normal = TriangleMesh(vertices, faces).face_normals()[0]
        away = vertices[faces[0]].mean(axis=0) - CORNER_OFFSETS[corner]
        # Outward is toward the outside (field <= 0): away from a lone inside corner,
        # toward a lone outside one.
        assert np.dot(normal, away) * (1 if case == 1 << corner else -1) > 0


@pytest.mark.parametrize("seed", range(6))
def test_random_fields_give_closed_consistently_oriented_surfaces(seed):
    rng = np.random.default_rng(seed)
    shape = tuple(rng.integers(5, 12, 3))
    field = padded_random_field(rng, shape)
    level = rng.uniform(0.0, 0.5)
    vertices, faces = marching_cubes(field, level)
    assert len(faces) > 0
    assert is_closed_and_oriented(faces)
    # Closed and outward: the enclosed volume is positive, and no larger than the grid.
    assert 0 < TriangleMesh(vertices, faces).volume() < np.prod(np.array(shape) - 1)
    # One vertex per crossed grid edge: welded, none unused.
    crossed = sum(
        np.count_nonzero(np.diff(field > np.float32(level), axis=axis)) for axis in range(3)
    )
    assert len(vertices) == crossed
    assert np.array_equal(np.unique(faces), np.arange(len(vertices)))


def test_every_case_closes_when_embedded_in_an_empty_grid():
    # Each of the 254 non-empty cases as a lone cell in an outside grid (cells three
    # nodes apart, so their corners never touch): every sign pattern and every resolution
    # of ambiguous faces gets exercised, in one call.
    field = np.full((3 * 7 + 1, 3 * 7 + 1, 3 * 6 + 1), -1.0, np.float32)
    for case in range(1, 255):
        x, y, z = np.unravel_index(case - 1, (7, 7, 6))
        field[3 * x + 1 : 3 * x + 3, 3 * y + 1 : 3 * y + 3, 3 * z + 1 : 3 * z + 3] = corner_field(
            case
        )
    _, faces = marching_cubes(field, 0.0)
    assert is_closed_and_oriented(faces)
    # Closed pieces: at least one per case (more where a case has several polygons).
    assert component_count(faces) >= 254


# -- against the naive twin and scikit-image ----------------------------------------------
@pytest.mark.parametrize("seed", range(3))
def test_matches_the_naive_per_cell_implementation(seed):
    rng = np.random.default_rng(seed)
    field = rng.standard_normal((6, 5, 7)).astype(np.float32)  # the surface reaches the border
    spacing, origin = (0.5, 0.25, 2.0), (1.0, -2.0, 0.5)
    vertices, faces = marching_cubes(field, 0.1, spacing=spacing, origin=origin)
    expected_vertices, expected_faces = naive_marching_cubes(field, 0.1, spacing, origin)
    # Same vertices up to float32 rounding of coordinates of order 10, same triangles.
    assert same_triangles(vertices, faces, expected_vertices, expected_faces, atol=1e-5)


@pytest.mark.parametrize("seed", range(3))
def test_matches_scikit_image_on_smooth_fields(seed):
    measure = pytest.importorskip("skimage.measure")
    rng = np.random.default_rng(seed)
    spacing, origin = np.array([0.1, 0.12, 0.09]), np.array([-1.2, -1.3, -1.1])
    nodes = grid_nodes(origin, (25, 23, 27), spacing)
    field = sum(
        np.exp(-8.0 * np.sum((nodes - c) ** 2, axis=-1)) for c in rng.uniform(-0.6, 0.6, (6, 3))
    )
    vertices, faces = marching_cubes(field, 0.3, spacing=spacing, origin=origin)
    sk_vertices, sk_faces, _, _ = measure.marching_cubes(
        field.astype(np.float32), 0.3, spacing=spacing, gradient_direction="ascent"
    )
    sk_vertices += origin
    # Both interpolate linearly on the same crossed edges: the same vertices (on smooth
    # fields Lewiner's tables add no vertex inside cells with ambiguous faces). Up to
    # rounding: scikit-image interpolates in float32, where t = (level - f0) / (f1 - f0)
    # loses a few ulps of f / (f1 - f0); 1e-4 of a cell covers it.
    assert len(vertices) == len(sk_vertices)
    assert cKDTree(sk_vertices).query(vertices)[0].max() < 1e-5
    # They differ only in which diagonal splits a non-planar polygon inside a cell. Each
    # choice moves the surface by O(h² × curvature) locally and the choices do not all
    # lean one way: measured at most 2e-4 (area) and 9e-4 (volume) relative over 12
    # such fields; allowed 5e-4 and 2e-3.
    mesh, sk_mesh = TriangleMesh(vertices, faces), TriangleMesh(sk_vertices, sk_faces)
    np.testing.assert_allclose(
        mesh.area(), measure.mesh_surface_area(sk_vertices, sk_faces), rtol=5e-4
    )
    np.testing.assert_allclose(mesh.volume(), sk_mesh.volume(), rtol=2e-3)


def test_sphere_of_an_analytic_field():
    # f = 1 - |x|² at level 0.5: a sphere of radius r = sqrt(0.5). Linear interpolation on
    # an edge of length h misplaces the crossing by at most h² max|f''| / (8 |f'|) =
    # h² / (8 r) radially (f'' = -2, f' = -2r): 4.4e-4 at h = 0.05.
    x = np.linspace(-1.0, 1.0, 41)
    field = 1.0 - np.sum(np.square(np.meshgrid(x, x, x, indexing="ij")), axis=0)
    vertices, faces = marching_cubes(field, 0.5, spacing=(0.05,) * 3, origin=(-1.0,) * 3)
    r = np.sqrt(0.5)
    np.testing.assert_allclose(np.linalg.norm(vertices, axis=1), r, atol=0.05**2 / (8 * r) + 1e-6)
    assert is_closed_and_oriented(faces) and component_count(faces) == 1


# -- properties ---------------------------------------------------------------------------
def test_output_is_deterministic_and_thread_count_independent():
    field = padded_random_field(np.random.default_rng(9), (40, 30, 35), smooth=True)
    first = marching_cubes(field, 0.2)
    again = marching_cubes(field, 0.2)
    previous = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        single = marching_cubes(field, 0.2)
    finally:
        numba.set_num_threads(previous)
    for a, b, c in zip(first, again, single, strict=True):
        np.testing.assert_array_equal(a, b)
        np.testing.assert_array_equal(a, c)


def test_dtypes_shapes_and_empty_surfaces():
    vertices, faces = marching_cubes(np.zeros((3, 4, 5)), 0.5)
    assert vertices.shape == (0, 3) and vertices.dtype == np.float32
    assert faces.shape == (0, 3) and faces.dtype == np.int32
    vertices, faces = marching_cubes(np.ones((3, 4, 5)), 0.5)  # all inside: no surface
    assert len(faces) == 0


def test_samples_equal_to_the_level_count_as_outside():
    # Inside is strictly field > level: a corner exactly at the level is outside, and the
    # vertex lands on it.
    field = np.zeros((3, 3, 3), np.float32)
    field[1, 1, 1] = 2.0
    field[1, 1, 2] = 1.0
    vertices, faces = marching_cubes(field, 1.0)
    assert is_closed_and_oriented(faces)
    assert np.any(np.all(vertices == (1.0, 1.0, 2.0), axis=1))


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"field": np.zeros((3, 3))}, "field must have shape"),
        ({"field": np.zeros((1, 3, 3))}, "field must have shape"),
        ({"field": np.full((2, 2, 2), np.nan)}, "field must be finite"),
        ({"level": float("nan")}, "level must be finite"),
        ({"level": "0.5"}, "level must be a real number"),
        ({"spacing": (1.0, 0.0, 1.0)}, "spacing must be > 0"),
        ({"spacing": (1.0, 1.0)}, "spacing must have shape"),
        ({"origin": (0.0, np.inf, 0.0)}, "origin must be finite"),
    ],
)
def test_bad_input_is_refused_with_the_parameter_named(kwargs, message):
    arguments = {"field": np.zeros((2, 2, 2)), "level": 0.5} | kwargs
    field, level = arguments.pop("field"), arguments.pop("level")
    with pytest.raises((ValueError, TypeError), match=message):
        marching_cubes(field, level, **arguments)
