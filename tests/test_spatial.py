"""Uniform grid neighbour search against scipy's cKDTree and a brute-force twin."""

import numba
import numpy as np
import pytest
from numpy.testing import assert_array_equal
from scipy.spatial import cKDTree

from motes.spatial import NeighborOverflow, UniformGrid
from naive_fluids import neighbor_sets


def uniform(rng, n):
    return rng.random((3, n), dtype=np.float32)


def clustered(rng, n):
    """A few dense Gaussian blobs plus sparse outliers far away (a big, mostly empty box)."""
    centers = rng.random((5, 3)) * 4.0
    blobs = centers[rng.integers(0, 5, n - 20)] + rng.normal(0.0, 0.05, (n - 20, 3))
    outliers = rng.random((20, 3)) * 200.0 - 100.0
    return np.concatenate([blobs, outliers]).T.astype(np.float32)


def as_sets(lists, rows):
    return [set(lists.row(i).tolist()) for i in range(rows)]


@pytest.mark.parametrize("make", [uniform, clustered])
@pytest.mark.parametrize("cell_over_radius", [1.0, 0.5, 2.0])
def test_self_query_equals_ckdtree(rng, make, cell_over_radius):
    pts = make(rng, 3000)
    radius = 0.08
    grid = UniformGrid(radius * cell_over_radius, capacity=4).build(pts)
    lists = grid.neighbors(radius)
    tree = cKDTree(pts.T.astype(np.float64))
    expected = [set(r) - {i} for i, r in enumerate(tree.query_ball_point(pts.T, radius))]
    assert as_sets(lists, pts.shape[1]) == expected
    assert lists.counts.max() > 4  # the buffer had to grow
    pairs = lists.pairs()
    reference = tree.query_pairs(radius, output_type="ndarray")
    assert {tuple(p) for p in pairs.tolist()} == {tuple(sorted(p)) for p in reference.tolist()}
    assert len(pairs) == len(reference)


def test_query_of_other_points_equals_brute_force(rng):
    pts = uniform(rng, 1500)
    queries = rng.random((3, 200), dtype=np.float32) * 1.4 - 0.2  # some outside the box
    lists = UniformGrid(0.1).build(pts).query(queries, 0.1)
    assert as_sets(lists, 200) == neighbor_sets(pts.T, 0.1, queries.T.astype(np.float64))


def test_slots_index_the_sorted_order(rng):
    pts = uniform(rng, 2000)
    grid = UniformGrid(0.1).build(pts)
    by_point = grid.neighbors(0.1)
    by_slot = grid.neighbors(0.1, slots=True)
    order = grid.order
    assert_array_equal(grid.sorted_positions, pts[:, order])
    for s in range(0, 2000, 97):
        assert set(order[by_slot.row(s)].tolist()) == set(by_point.row(order[s]).tolist())


def test_neighbor_rows_are_the_slot_lists_left_in_place(rng):
    pts = uniform(rng, 3000)
    grid = UniformGrid(0.1).build(pts)
    by_slot = grid.neighbors(0.1, slots=True)
    begin, end, entries = grid.neighbor_rows(0.1)
    assert_array_equal(end - begin, by_slot.counts)
    assert (begin[1:] >= end[:-1]).all()  # rows do not overlap
    for s in range(3000):
        assert_array_equal(entries[begin[s] : end[s]], by_slot.row(s))  # same order too
    # The CSR lists' ranges are the same form.
    b, e, idx = by_slot.ranges
    assert_array_equal(idx[b[5] : e[5]], by_slot.row(5))


def test_points_exactly_at_the_radius_are_neighbors():
    # A lattice of spacing 1 with radius 1: the six axis neighbours are exactly at r, and
    # the float64 test d² <= r² includes them, as cKDTree does.
    g = np.arange(4, dtype=np.float32)
    pts = np.stack(np.meshgrid(g, g, g, indexing="ij")).reshape(3, -1)
    lists = UniformGrid(1.0).build(pts).neighbors(1.0)
    tree = cKDTree(pts.T.astype(np.float64))
    expected = [set(r) - {i} for i, r in enumerate(tree.query_ball_point(pts.T, 1.0))]
    assert as_sets(lists, 64) == expected
    assert lists.counts.max() == 6 and lists.counts.min() == 3


def test_edge_cases_empty_one_and_all_in_one_cell(rng):
    empty = UniformGrid(0.1).build(np.zeros((3, 0), np.float32))
    assert empty.neighbors(0.1).offsets.tolist() == [0]
    assert empty.query(np.zeros((3, 2), np.float32), 0.1).offsets.tolist() == [0, 0, 0]
    one = UniformGrid(0.1).build(np.zeros((3, 1), np.float32))
    assert one.neighbors(0.1).offsets.tolist() == [0, 0]
    assert one.query(np.full((3, 1), 0.05, np.float32), 0.1).indices.tolist() == [0]
    # 300 points in one cell (and all in the same spot for a third of them).
    pts = (rng.random((3, 300)) * 0.01).astype(np.float32)
    pts[:, :100] = 0.005
    lists = UniformGrid(1.0).build(pts).neighbors(0.5)
    assert lists.counts.tolist() == [299] * 300


def test_overflow_is_reported_or_grown(rng):
    pts = uniform(rng, 500)
    grid = UniformGrid(0.3, capacity=2).build(pts)
    with pytest.raises(NeighborOverflow, match="capacity is 2") as error:
        grid.neighbors(0.3, grow=False)
    assert error.value.most > 2
    lists = grid.neighbors(0.3)
    assert grid.capacity >= lists.counts.max() == error.value.most


def test_deterministic_and_thread_count_independent(rng):
    pts = clustered(rng, 20_000)  # over a block, so several threads share the work
    previous = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = UniformGrid(0.05).build(pts).neighbors(0.05)
        numba.set_num_threads(previous)
        many = UniformGrid(0.05).build(pts).neighbors(0.05)
        again = UniformGrid(0.05).build(pts).neighbors(0.05)
    finally:
        numba.set_num_threads(previous)
    for other in (many, again):
        assert_array_equal(one.offsets, other.offsets)
        assert_array_equal(one.indices, other.indices)


def test_far_outliers_bound_the_cell_count(rng):
    pts = clustered(rng, 2000)  # a 200 m box around blobs of 5 cm: 10^10 cells of 0.05 m
    grid = UniformGrid(0.05).build(pts)
    assert grid.cell_start.shape[0] - 1 <= 4 * 2000
    assert grid.cell > 0.05


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [({"cell_size": 0.0}, "cell_size must be > 0"), ({"cell_size": 1, "capacity": 0}, "capacity")],
)
def test_bad_parameters_name_themselves(kwargs, message):
    with pytest.raises(ValueError, match=message):
        UniformGrid(**kwargs)


def test_bad_points_are_refused():
    grid = UniformGrid(0.1)
    with pytest.raises(ValueError, match=r"positions must have shape \(3, n\)"):
        grid.build(np.zeros((10, 3)))
    with pytest.raises(ValueError, match="finite"):
        grid.build(np.full((3, 2), np.nan))
    with pytest.raises(ValueError, match="radius must be > 0"):
        grid.build(np.zeros((3, 2))).neighbors(-1.0)
