"""Emitter shapes: uniformity (chi-square), geometry, determinism and input validation.

Each uniformity test maps the samples to a statistic that is uniform on [0, 1] for a
correct sampler (inverse CDF of the stated measure) and runs a chi-square goodness-of-fit
test on a 20-bin histogram.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import chisquare

from motes.emit.shapes import Box, Cone, Disc, Line, MeshSurface, Point, Shape, Sphere

SEED = 1234
N = 100_000
BINS = 20
# For a correct sampler the p-value is uniform over seeds, so p < 1e-3 happens for at most
# 0.1% of seeds. The seed is fixed, so each test is deterministic: it does not flake, and a
# failure means a biased sampler (or, with probability 1e-3, an unlucky seed: try another).
P_MIN = 1e-3
# Geometric checks: every coordinate is O(1) m, so 1e-9 m leaves room for ~1e7 ulps of
# round-off in the rotations while still catching any real offset.
TOL = 1e-9


def uniform_pvalue(x: np.ndarray) -> float:
    """Chi-square p-value of the hypothesis that ``x`` is uniform on [0, 1]."""
    assert np.all((x >= 0.0) & (x <= 1.0))
    counts, _ = np.histogram(x, bins=BINS, range=(0.0, 1.0))
    return float(chisquare(counts).pvalue)


def counts_pvalue(counts: np.ndarray, weights: np.ndarray) -> float:
    """Chi-square p-value of category ``counts`` against probabilities ∝ ``weights``."""
    expected = counts.sum() * weights / weights.sum()
    return float(chisquare(counts, expected).pvalue)


def basis(axis) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """An orthonormal frame ``(a, e1, e2)`` with ``a`` along ``axis`` (built independently
    of the implementation's own helper)."""
    a = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    e1 = np.cross(a, [0.3, -0.7, 0.2])
    e1 /= np.linalg.norm(e1)
    return a, e1, np.cross(a, e1)


def azimuth01(vectors: np.ndarray, e1: np.ndarray, e2: np.ndarray) -> np.ndarray:
    """Azimuth of ``vectors`` in the (e1, e2) plane, as a fraction of a turn in [0, 1]."""
    return np.mod(np.arctan2(vectors @ e2, vectors @ e1) / (2 * np.pi), 1.0)


def draw(shape: Shape, count: int = N, seed: int = SEED):
    return shape.sample(np.random.default_rng(seed), count)


def assert_uniform(*stats: np.ndarray) -> None:
    for k, x in enumerate(stats):
        p = uniform_pvalue(x)
        assert p > P_MIN, f"statistic {k} is not uniform: p = {p:.3g}"


# --------------------------------------------------------------------------------------
# Uniformity and geometry, shape by shape
# --------------------------------------------------------------------------------------


def test_point_is_the_origin_with_isotropic_normals():
    pos, nrm = draw(Point())
    np.testing.assert_array_equal(pos, 0.0)
    a, e1, e2 = basis([0, 0, 1])
    # Archimedes: the z component of a uniform direction is uniform on [-1, 1].
    assert_uniform((nrm @ a + 1) / 2, azimuth01(nrm, e1, e2))


def test_sphere_volume_uniform():
    radius = 2.5
    pos, nrm = draw(Sphere(radius))
    r = np.linalg.norm(pos, axis=1)
    assert np.all(r <= radius + TOL)
    a, e1, e2 = basis([0, 0, 1])
    # Volume inside r is ∝ r^3; the polar cosine and azimuth of a uniform ball are uniform.
    assert_uniform((r / radius) ** 3, (pos @ a / r + 1) / 2, azimuth01(pos, e1, e2))
    np.testing.assert_allclose(nrm, pos / r[:, None], atol=TOL)


def test_sphere_surface_uniform():
    radius = 0.7
    pos, nrm = draw(Sphere(radius, surface=True))
    np.testing.assert_allclose(np.linalg.norm(pos, axis=1), radius, atol=TOL)
    np.testing.assert_allclose(nrm, pos / radius, atol=TOL)
    a, e1, e2 = basis([1, 1, 0])
    assert_uniform((pos @ a / radius + 1) / 2, azimuth01(pos, e1, e2))


def test_box_volume_uniform():
    size = np.array([1.0, 3.0, 0.5])
    pos, nrm = draw(Box(size))
    u = pos / size + 0.5
    assert np.all((u >= -TOL) & (u <= 1 + TOL))
    assert_uniform(*np.clip(u, 0.0, 1.0).T)
    np.testing.assert_allclose(nrm, pos / np.linalg.norm(pos, axis=1)[:, None], atol=TOL)


def test_box_surface_faces_proportional_to_area_and_uniform_on_each():
    size = np.array([1.0, 3.0, 0.25])
    pos, nrm = draw(Box(size, surface=True))
    half = size / 2
    # On the surface: inside the box, and on at least one face.
    assert np.all(np.abs(pos) <= half + TOL)
    assert np.all(np.max(np.abs(pos) / half, axis=1) >= 1 - TOL)

    # The normal identifies the face: one nonzero component of +-1, at that face's plane.
    assert np.all(np.sum(nrm != 0, axis=1) == 1)
    axis = np.argmax(np.abs(nrm), axis=1)
    sign = nrm[np.arange(N), axis]
    np.testing.assert_allclose(pos[np.arange(N), axis], sign * half[axis], atol=TOL)

    face = 2 * axis + (sign < 0)
    counts = np.bincount(face, minlength=6)
    sx, sy, sz = size
    areas = np.array([sy * sz, sy * sz, sx * sz, sx * sz, sx * sy, sx * sy])
    assert counts_pvalue(counts, areas) > P_MIN

    for k in range(3):
        on_face = pos[axis == k]
        others = [j for j in range(3) if j != k]
        assert_uniform(*(on_face[:, others] / size[others] + 0.5).T)


@pytest.mark.parametrize("inner_radius", [0.0, 0.6])
@pytest.mark.parametrize("normal", [(0, 1, 0), (1.0, -2.0, 0.5)], ids=["default", "tilted"])
def test_disc_uniform_over_area(normal, inner_radius):
    radius = 1.5
    pos, nrm = draw(Disc(radius, normal=normal, inner_radius=inner_radius))
    a, e1, e2 = basis(normal)
    np.testing.assert_allclose(pos @ a, 0.0, atol=TOL)  # in the plane through the origin
    np.testing.assert_allclose(nrm, np.broadcast_to(a, nrm.shape), atol=1e-15)
    r = np.linalg.norm(pos, axis=1)
    assert np.all((r >= inner_radius - TOL) & (r <= radius + TOL))
    # Area inside r is ∝ r^2 - r_in^2.
    frac = np.clip((r**2 - inner_radius**2) / (radius**2 - inner_radius**2), 0, 1)
    assert_uniform(frac, azimuth01(pos, e1, e2))


def test_cone_volume_uniform_with_tilted_axis():
    radius, height, axis = 0.8, 2.0, (0.0, 0.6, -0.8)
    pos, nrm = draw(Cone(radius, height, axis=axis))
    a, e1, e2 = basis(axis)
    h = pos @ a
    rho = np.linalg.norm(pos - np.outer(h, a), axis=1)
    assert np.all((h >= -TOL) & (h <= height + TOL))
    assert np.all(rho <= radius * h / height + TOL)
    # Cross-section area at h is ∝ h^2, so the volume below h is ∝ h^3; within a
    # cross-section the area inside rho is ∝ rho^2.
    assert_uniform(
        np.clip((h / height) ** 3, 0, 1),
        np.clip((rho / (radius * h / height)) ** 2, 0, 1),
        azimuth01(pos, e1, e2),
    )
    np.testing.assert_allclose(nrm, pos / np.linalg.norm(pos, axis=1)[:, None], atol=TOL)


def test_cone_surface_uniform_with_outward_normals():
    radius, height, axis = 0.5, 1.2, (1.0, 1.0, 1.0)
    pos, nrm = draw(Cone(radius, height, axis=axis, surface=True))
    a, e1, e2 = basis(axis)
    h = pos @ a
    radial = pos - np.outer(h, a)
    rho = np.linalg.norm(radial, axis=1)
    assert np.all((h >= -TOL) & (h <= height + TOL))
    np.testing.assert_allclose(rho, radius * h / height, atol=TOL)  # on the lateral surface
    # Lateral area below h is ∝ h^2 (circumference ∝ h).
    assert_uniform(np.clip((h / height) ** 2, 0, 1), azimuth01(pos, e1, e2))

    # The normal is perpendicular to the generator line through the apex and the sample,
    # points away from the axis, and tilts back toward the apex by the half-angle.
    generator = pos / np.linalg.norm(pos, axis=1)[:, None]
    np.testing.assert_allclose(np.sum(nrm * generator, axis=1), 0.0, atol=TOL)
    assert np.all(np.sum(nrm * radial, axis=1) > 0)
    np.testing.assert_allclose(nrm @ a, -radius / np.hypot(radius, height), atol=TOL)


def test_line_uniform_with_perpendicular_normals():
    start, end = np.array([1.0, -2.0, 0.5]), np.array([-0.5, 1.0, 2.0])
    pos, nrm = draw(Line(start, end))
    d = end - start
    t = (pos - start) @ d / (d @ d)
    assert np.all((t >= -TOL) & (t <= 1 + TOL))
    np.testing.assert_allclose(pos, start + np.outer(t, d), atol=TOL)  # on the segment
    a, e1, e2 = basis(d)
    np.testing.assert_allclose(nrm @ a, 0.0, atol=TOL)
    assert_uniform(np.clip(t, 0, 1), azimuth01(nrm, e1, e2))


# Four disjoint triangles in the planes z = 0, 1, 2, 3, areas spanning a factor of 400;
# the third is wound clockwise seen from +z, so its normal is -z.
MESH_AREAS = np.array([2.0, 0.02, 0.5, 8.0])


def four_triangle_mesh() -> MeshSurface:
    vertices, faces = [], []
    for k, area in enumerate(MESH_AREAS):
        s = np.sqrt(2 * area)  # right triangle with legs s: area s^2 / 2
        vertices += [[0, 0, k], [s, 0, k], [0, s, k]]
        faces.append([3 * k, 3 * k + 2, 3 * k + 1] if k == 2 else [3 * k, 3 * k + 1, 3 * k + 2])
    return MeshSurface(vertices, faces)


def test_mesh_triangles_chosen_in_proportion_to_area():
    pos, nrm = draw(four_triangle_mesh())
    tri = np.rint(pos[:, 2]).astype(int)
    np.testing.assert_allclose(pos[:, 2], tri, atol=TOL)
    assert counts_pvalue(np.bincount(tri, minlength=4), MESH_AREAS) > P_MIN
    expected_z = np.where(tri == 2, -1.0, 1.0)
    np.testing.assert_array_equal(nrm, np.column_stack([0 * tri, 0 * tri, expected_z]))


TRIANGLE = np.array([[0.2, -0.1, 0.3], [1.5, 0.4, -0.2], [-0.3, 1.1, 0.9]])


def barycentric(pos: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Barycentric coordinates (n, 3) of points in the plane of ``tri``."""
    edges = np.stack([tri[1] - tri[0], tri[2] - tri[0]], axis=1)  # (3, 2)
    bc, *_ = np.linalg.lstsq(edges, (pos - tri[0]).T, rcond=None)
    return np.column_stack([1 - bc.sum(axis=0), bc.T])


def subtriangle_pvalue(lam: np.ndarray, n: int = 5) -> float:
    """Chi-square p-value for equal counts in the n^2 congruent sub-triangles obtained by
    cutting the triangle along lines of constant barycentric coordinate, spacing 1/n."""
    u, v = n * lam[:, 1], n * lam[:, 2]
    i = np.minimum(np.floor(u), n - 1).astype(int)
    j = np.minimum(np.floor(v), n - 1).astype(int)
    upper = (u - i) + (v - j) >= 1
    cell = (i * n + j) * 2 + upper
    counts = np.bincount(cell, minlength=2 * n * n)
    cells = np.arange(2 * n * n)
    ii, jj = np.divmod(cells // 2, n)
    # A lower sub-triangle exists where i + j <= n - 1, an upper one where i + j <= n - 2.
    valid = ii + jj + cells % 2 <= n - 1
    assert counts[~valid].sum() == 0
    return counts_pvalue(counts[valid], np.ones(n * n))


def test_mesh_uniform_within_a_triangle():
    pos, nrm = draw(MeshSurface(TRIANGLE, [[0, 1, 2]]))
    lam = barycentric(pos, TRIANGLE)
    np.testing.assert_allclose(lam @ TRIANGLE, pos, atol=TOL)  # in the triangle's plane
    assert np.all(lam >= -TOL)
    lam = np.clip(lam, 0, 1)
    # Marginal: P(lambda > x) = (1 - x)^2 for a uniform point in a triangle.
    assert_uniform(*((1 - lam) ** 2).T)
    assert subtriangle_pvalue(lam) > P_MIN
    face_normal = np.cross(TRIANGLE[1] - TRIANGLE[0], TRIANGLE[2] - TRIANGLE[0])
    np.testing.assert_allclose(
        nrm, np.broadcast_to(face_normal / np.linalg.norm(face_normal), nrm.shape), atol=1e-15
    )


def test_mesh_normals_follow_the_right_hand_rule():
    # A tetrahedron with every face wound counter-clockwise seen from outside.
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
    faces = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]
    pos, nrm = draw(MeshSurface(vertices, faces), count=2000)
    centroid = vertices.mean(axis=0)
    assert np.all(np.sum(nrm * (pos - centroid), axis=1) > 0)


def test_mesh_skips_degenerate_faces():
    vertices = np.vstack([TRIANGLE, [[5, 5, 5], [6, 6, 6], [7, 7, 7]]])
    mesh = MeshSurface(vertices, [[3, 4, 5], [0, 1, 2], [3, 3, 4]])
    pos, nrm = draw(mesh, count=1000)
    assert np.all(barycentric(pos, TRIANGLE) >= -TOL)
    assert np.all(np.isfinite(nrm))


# --------------------------------------------------------------------------------------
# The tests have teeth: a plausible but wrong sampler fails them decisively
# --------------------------------------------------------------------------------------


def test_chi_square_rejects_naive_disc_sampler():
    rng = np.random.default_rng(SEED)
    radius = 1.5
    r = radius * rng.random(N)  # wrong: crowds the centre, density ∝ 1/r
    assert uniform_pvalue((r / radius) ** 2) < 1e-6


def test_chi_square_rejects_naive_triangle_samplers():
    rng = np.random.default_rng(SEED)
    # Wrong: normalised uniform weights crowd the centroid.
    w = rng.random((N, 3))
    assert subtriangle_pvalue(w / w.sum(axis=1, keepdims=True)) < 1e-6
    # Wrong: triangle chosen uniformly, ignoring area.
    counts = np.bincount(rng.integers(0, 4, N), minlength=4)
    assert counts_pvalue(counts, MESH_AREAS) < 1e-6


# --------------------------------------------------------------------------------------
# Properties every shape shares
# --------------------------------------------------------------------------------------

SHAPES = {
    "point": lambda: Point(),
    "sphere": lambda: Sphere(1.3),
    "sphere-surface": lambda: Sphere(1.3, surface=True),
    "box": lambda: Box([1.0, 2.0, 0.5]),
    "box-surface": lambda: Box([1.0, 2.0, 0.5], surface=True),
    "disc": lambda: Disc(1.0, normal=(1, 1, 0), inner_radius=0.2),
    "cone": lambda: Cone(0.5, 2.0, axis=(0, 0, -1)),
    "cone-surface": lambda: Cone(0.5, 2.0, axis=(0, 0, -1), surface=True),
    "line": lambda: Line((0, 0, 0), (1, 2, 3)),
    "mesh": four_triangle_mesh,
}
all_shapes = pytest.mark.parametrize("make", SHAPES.values(), ids=SHAPES.keys())


@all_shapes
def test_output_shape_dtype_and_unit_normals(make):
    shape = make()
    pos, nrm = draw(shape, count=5000)
    for arr in (pos, nrm):
        assert arr.shape == (5000, 3)
        assert arr.dtype == np.float64
        assert np.all(np.isfinite(arr))
    np.testing.assert_allclose(np.linalg.norm(nrm, axis=1), 1.0, atol=1e-12)
    assert np.all(np.linalg.norm(pos, axis=1) <= shape.bounding_radius + TOL)


@all_shapes
def test_zero_count_gives_empty_arrays(make):
    pos, nrm = draw(make(), count=0)
    assert pos.shape == nrm.shape == (0, 3)
    assert pos.dtype == nrm.dtype == np.float64


@all_shapes
def test_same_seed_same_samples(make):
    shape = make()
    pos1, nrm1 = draw(shape, count=1000, seed=99)
    pos2, nrm2 = draw(shape, count=1000, seed=99)
    np.testing.assert_array_equal(pos1, pos2)
    np.testing.assert_array_equal(nrm1, nrm2)
    pos3, _ = draw(shape, count=1000, seed=100)
    assert isinstance(shape, Point) or not np.array_equal(pos1, pos3)


@all_shapes
def test_only_the_given_generator_is_used(make):
    # The legacy global generator is exactly what must stay untouched.
    state = np.random.get_state()  # noqa: NPY002
    draw(make(), count=100)
    after = np.random.get_state()  # noqa: NPY002
    assert all(np.array_equal(x, y) for x, y in zip(state, after, strict=True))


def test_sample_rejects_bad_count_and_rng():
    shape = Sphere(1.0)
    with pytest.raises(ValueError, match="count"):
        shape.sample(np.random.default_rng(0), -1)
    with pytest.raises(TypeError, match="count"):
        shape.sample(np.random.default_rng(0), 2.5)
    with pytest.raises(TypeError, match="rng"):
        shape.sample(np.random, 10)


# --------------------------------------------------------------------------------------
# Bad parameters fail at construction, naming the parameter
# --------------------------------------------------------------------------------------

nan, inf = float("nan"), float("inf")
GOOD_VERTICES = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]

BAD = {
    "sphere-zero-radius": (lambda: Sphere(0.0), ValueError, "radius must be > 0"),
    "sphere-negative-radius": (lambda: Sphere(-1.0), ValueError, "radius must be > 0"),
    "sphere-nan-radius": (lambda: Sphere(nan), ValueError, "radius must be finite"),
    "sphere-string-radius": (lambda: Sphere("1"), TypeError, "radius"),
    "box-short-size": (lambda: Box([1.0, 2.0]), ValueError, r"size must have shape \(3,\)"),
    "box-nan-size": (lambda: Box([1.0, nan, 1.0]), ValueError, "size must be finite"),
    "box-zero-edge": (lambda: Box([1.0, 0.0, 1.0]), ValueError, "size must have every"),
    "box-negative-edge": (lambda: Box([1.0, -1.0, 1.0]), ValueError, "size must have every"),
    "disc-zero-radius": (lambda: Disc(0.0), ValueError, "radius must be > 0"),
    "disc-inner-equal": (lambda: Disc(1.0, inner_radius=1.0), ValueError, "inner_radius must be <"),
    "disc-inner-larger": (lambda: Disc(1.0, inner_radius=2.0), ValueError, "inner_radius"),
    "disc-inner-negative": (lambda: Disc(1.0, inner_radius=-0.1), ValueError, "inner_radius"),
    "disc-zero-normal": (lambda: Disc(1.0, normal=(0, 0, 0)), ValueError, "normal must have non"),
    "disc-nan-normal": (lambda: Disc(1.0, normal=(nan, 0, 1)), ValueError, "normal must be finite"),
    "disc-2d-normal": (lambda: Disc(1.0, normal=(0, 1)), ValueError, "normal must have shape"),
    "cone-zero-radius": (lambda: Cone(0.0, 1.0), ValueError, "radius must be > 0"),
    "cone-zero-height": (lambda: Cone(1.0, 0.0), ValueError, "height must be > 0"),
    "cone-inf-height": (lambda: Cone(1.0, inf), ValueError, "height must be finite"),
    "cone-zero-axis": (lambda: Cone(1.0, 1.0, axis=(0, 0, 0)), ValueError, "axis must have non"),
    "cone-inf-axis": (lambda: Cone(1.0, 1.0, axis=(inf, 0, 0)), ValueError, "axis must be finite"),
    "line-same-ends": (lambda: Line((1, 2, 3), (1, 2, 3)), ValueError, "end must differ"),
    "line-nan-start": (lambda: Line((0, nan, 0), (1, 0, 0)), ValueError, "start must be finite"),
    "line-2d-end": (lambda: Line((0, 0, 0), (1, 0)), ValueError, "end must have shape"),
    "mesh-2d-vertices": (
        lambda: MeshSurface([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]]),
        ValueError,
        r"vertices must have shape \(n, 3\)",
    ),
    "mesh-nan-vertex": (
        lambda: MeshSurface([[0, 0, 0], [1, nan, 0], [0, 1, 0]], [[0, 1, 2]]),
        ValueError,
        "vertices must be finite",
    ),
    "mesh-face-out-of-range": (
        lambda: MeshSurface(GOOD_VERTICES, [[0, 1, 3]]),
        ValueError,
        r"faces must index vertices in \[0, 2\]",
    ),
    "mesh-negative-face-index": (
        lambda: MeshSurface(GOOD_VERTICES, [[0, -1, 2]]),
        ValueError,
        "faces must index",
    ),
    "mesh-float-faces": (
        lambda: MeshSurface(GOOD_VERTICES, [[0.0, 1.0, 2.0]]),
        TypeError,
        "faces must be an integer array",
    ),
    "mesh-quad-faces": (
        lambda: MeshSurface([*GOOD_VERTICES, [1, 1, 0]], [[0, 1, 3, 2]]),
        ValueError,
        r"faces must have shape \(F, 3\)",
    ),
    "mesh-no-faces": (
        lambda: MeshSurface(GOOD_VERTICES, np.zeros((0, 3), dtype=int)),
        ValueError,
        "faces must have shape",
    ),
    "mesh-zero-area": (
        lambda: MeshSurface([[0, 0, 0], [1, 1, 1], [2, 2, 2]], [[0, 1, 2], [0, 0, 1]]),
        ValueError,
        "faces describe a mesh of zero total area",
    ),
}


@pytest.mark.parametrize(("make", "error", "match"), BAD.values(), ids=BAD.keys())
def test_bad_parameters_are_refused(make, error, match):
    with pytest.raises(error, match=match):
        make()
