"""One neighbour interface over the grid, the octree and the k-d tree, checked against
scipy's cKDTree on evenly spread and on strongly clustered points.

Points are float32 (the grid's coordinates), handed to cKDTree as float64, so every
structure compares the same values: radius lists and pairs must be equal as sets, k
nearest distances equal to 1e-12 relative (the same float64 sums, possibly another
square root), and the neighbour indices equal (random coordinates have no ties).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from motes.emit.nbody import plummer_sphere
from motes.spatial import STRUCTURES, KDTree, Octree, UniformGrid, spatial_index

N = 3000
RADIUS = {"uniform": 0.08, "plummer": 0.15}  # about 20 neighbours each, on average


def _points(kind: str) -> np.ndarray:
    if kind == "uniform":
        return np.random.default_rng(4).random((3, N), dtype=np.float32)
    # A Plummer sphere: half the points within 1.3 scale radii, a halo out to 10s of them.
    pos, _, _ = plummer_sphere(N, radius=0.1, seed=5)
    return pos.astype(np.float32)


def _index(structure: str, radius: float):
    if structure == "grid":
        return spatial_index("grid", cell_size=radius)
    return spatial_index(structure)


@pytest.fixture(params=["uniform", "plummer"])
def cloud(request):
    return request.param, _points(request.param)


@pytest.mark.parametrize("structure", STRUCTURES)
def test_radius_lists_and_pairs_equal_ckdtree(structure, cloud):
    kind, points = cloud
    r = RADIUS[kind]
    reference = cKDTree(points.T.astype(np.float64))
    index = _index(structure, r).build(points)

    expected = reference.query_pairs(r, output_type="ndarray")
    expected = expected[np.lexsort((expected[:, 1], expected[:, 0]))]
    np.testing.assert_array_equal(index.pairs(r), expected)

    lists = index.neighbors(r)
    balls = reference.query_ball_point(points.T.astype(np.float64), r)
    for i in range(0, N, 7):
        assert sorted(lists.row(i).tolist()) == sorted(j for j in balls[i] if j != i)

    others = np.random.default_rng(6).uniform(-0.3, 1.3, (3, 200)).astype(np.float32)
    found = index.query(others, r)
    balls = reference.query_ball_point(others.T.astype(np.float64), r)
    for i in range(others.shape[1]):
        assert sorted(found.row(i).tolist()) == sorted(balls[i])


@pytest.mark.parametrize("structure", STRUCTURES)
def test_knn_equals_ckdtree(structure, cloud):
    kind, points = cloud
    k = 8
    reference = cKDTree(points.T.astype(np.float64))
    index = _index(structure, RADIUS[kind]).build(points)

    distance, neighbour = index.knn(points, k, exclude_self=True)
    want_d, want_i = reference.query(points.T.astype(np.float64), k + 1)
    np.testing.assert_allclose(distance, want_d[:, 1:], rtol=1e-12, atol=0)
    np.testing.assert_array_equal(neighbour, want_i[:, 1:])

    others = np.random.default_rng(7).normal(0.5, 1.0, (3, 300)).astype(np.float32)
    distance, neighbour = index.knn(others, k)
    want_d, want_i = reference.query(others.T.astype(np.float64), k)
    np.testing.assert_allclose(distance, want_d, rtol=1e-12, atol=0)
    np.testing.assert_array_equal(neighbour, want_i)


@pytest.mark.parametrize("structure", STRUCTURES)
def test_degenerate_sets(structure):
    """One point, a few points over many leaves, and all points at one place."""
    one = np.zeros((3, 1), np.float32)
    index = _index(structure, 0.1).build(one)
    assert index.neighbors(0.1).indices.size == 0
    d, i = index.knn(np.ones((3, 2), np.float32), 1)
    np.testing.assert_array_equal(i, [[0], [0]])

    three = np.array([[0, 1, 2], [0, 0, 0], [0, 0, 0]], np.float32)
    tree = KDTree(leaf_size=1).build(three) if structure == "kdtree" else None
    index = tree if tree is not None else _index(structure, 1.0).build(three)
    np.testing.assert_array_equal(index.pairs(1.0), [[0, 1], [1, 2]])
    d, i = index.knn(three, 2, exclude_self=True)
    np.testing.assert_array_equal(d, [[1, 2], [1, 1], [1, 2]])

    same = np.zeros((3, 50), np.float32)
    index = _index(structure, 0.1).build(same)
    assert index.neighbors(0.1).counts.tolist() == [49] * 50
    assert len(index.pairs(0.0 + 1e-9)) == 50 * 49 // 2


def test_kdtree_is_balanced_and_boxes_hold_their_points():
    points = _points("plummer").astype(np.float64)
    tree = KDTree(leaf_size=10).build(points)
    leaves = tree.leaves()
    # Every leaf at the same depth, with between half and all of leaf_size points.
    assert leaves.min() == 2**tree.depth - 1 and leaves.size == 2**tree.depth
    assert tree.node_count[leaves].max() <= 10 and tree.node_count[leaves].min() >= 5
    np.testing.assert_array_equal(np.sort(tree.order), np.arange(N))
    np.testing.assert_array_equal(tree.sorted_points, points[:, tree.order])
    lo, hi = tree._node_boxes()
    for node in range(0, tree.node_start.size, 37):
        first = tree.node_start[node]
        run = tree.sorted_points[:, first : first + tree.node_count[node]]
        assert np.all(run >= lo[:, node : node + 1]) and np.all(run <= hi[:, node : node + 1])


def test_kdtree_build_does_not_depend_on_thread_count():
    import numba

    points = _points("plummer")
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = KDTree().build(points)
        numba.set_num_threads(before)
        two = KDTree().build(points)
    finally:
        numba.set_num_threads(before)
    np.testing.assert_array_equal(one.order, two.order)


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="structure must be one of 'grid', 'octree', 'kdtree'"):
        spatial_index("bvh")
    with pytest.raises(ValueError, match="needs a cell_size"):
        spatial_index("grid")
    with pytest.raises(ValueError, match="cell_size applies to the 'grid' structure only"):
        spatial_index("kdtree", cell_size=0.1)
    with pytest.raises(ValueError, match="leaf_size"):
        KDTree(leaf_size=0)
    with pytest.raises(ValueError, match="positions must be finite"):
        KDTree().build(np.array([[0.0, np.nan], [0, 0], [0, 0]]))
    with pytest.raises(ValueError, match="at least one point"):
        KDTree().build(np.zeros((3, 0)))
    tree = Octree().build(np.random.default_rng(0).random((3, 10)))
    with pytest.raises(ValueError, match=r"k must be <= 9"):
        tree.knn(tree.sorted_points, 10, exclude_self=True)
    with pytest.raises(ValueError, match=r"k must be <= 10"):
        UniformGrid(0.5).build(np.random.default_rng(0).random((3, 10))).knn(np.zeros((3, 1)), 11)
