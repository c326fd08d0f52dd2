"""k nearest neighbours on the octree, against scipy's cKDTree.

Distances are computed in float64 from the same coordinates as cKDTree's, so they must
be equal to the last bit and the neighbours identical (random points have no ties).
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_array_equal
from scipy.spatial import cKDTree

from motes.emit.nbody import plummer_sphere
from motes.spatial import Octree


def clouds(rng):
    return {
        "uniform": rng.random((3, 20_000)),
        "clustered": plummer_sphere(20_000, seed=5)[0],
        "float32": rng.random((3, 5_000)).astype(np.float32),
    }


@pytest.mark.parametrize("kind", ["uniform", "clustered", "float32"])
@pytest.mark.parametrize("leaf_size", [1, 16])
def test_knn_equals_ckdtree(rng, kind, leaf_size):
    points = clouds(rng)[kind]
    tree = Octree(leaf_size=leaf_size).build(points)
    reference = cKDTree(points.T.astype(np.float64))
    queries = rng.uniform(-0.5, 1.5, (3, 700))
    distance, index = tree.knn(queries, 16)
    expected_distance, expected_index = reference.query(queries.T, 16)
    assert_array_equal(distance, expected_distance)
    assert_array_equal(index, expected_index)
    distance, index = tree.knn(points, 5, exclude_self=True)
    expected_distance, expected_index = reference.query(points.T.astype(np.float64), 6)
    assert_array_equal(distance, expected_distance[:, 1:])
    assert_array_equal(index, expected_index[:, 1:])


def test_knn_with_every_point():
    points = np.random.default_rng(1).random((3, 40))
    distance, index = Octree(leaf_size=4).build(points).knn(points[:, :3], 40)
    assert_array_equal(np.sort(index, axis=1), np.tile(np.arange(40), (3, 1)))
    assert (np.diff(distance, axis=1) >= 0).all()


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda t: t.knn(np.zeros((3, 2)), 0), "k must be >= 1"),
        (lambda t: t.knn(np.zeros((3, 2)), 11), "k must be <= 10"),
        (lambda t: t.knn(np.zeros((3, 2)), 10, exclude_self=True), "k must be <= 9"),
        (lambda t: t.knn(np.zeros((3, 2)), 2, exclude_self=True), "own points"),
        (lambda t: t.knn(np.zeros((2, 2)), 2), "shape"),
    ],
)
def test_knn_bad_input(call, message):
    tree = Octree().build(np.random.default_rng(0).random((3, 10)))
    with pytest.raises(ValueError, match=message):
        call(tree)
