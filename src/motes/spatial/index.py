"""One interface over the spatial structures, and choosing one by name.

Every structure — :class:`~motes.spatial.UniformGrid`, :class:`~motes.spatial.Octree`,
:class:`~motes.spatial.KDTree` — is built from ``(3, n)`` positions and answers the same
three questions with the same results (compared in float64; the grid stores float32
coordinates, so give it float32 points for bit-equal answers):

- ``neighbors(radius)``: every point's neighbours within ``radius``, CSR lists by point
  index (:class:`~motes.spatial.Neighbors`); ``query(points, radius)`` for other points;
- ``knn(points, k, exclude_self=False)``: the ``k`` nearest, ``(distance, index)`` of
  shape (m, k), nearest first;
- ``pairs(distance)``: every unordered pair within ``distance``, sorted ``(i, j)`` rows.

Which one wins depends on the points (``docs/spatial.md`` has the measured table): the
grid for fixed-radius queries on evenly spread points (liquids, flocks), the trees for
clustered points (a Plummer sphere, a galaxy) and for k nearest neighbours.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from .grid import UniformGrid
from .kdtree import KDTree
from .neighbors import Neighbors
from .octree import Octree

#: Names a scene file or :func:`spatial_index` accepts.
STRUCTURES = ("grid", "octree", "kdtree")


class SpatialIndex(Protocol):
    """What every spatial structure answers (see the module docstring)."""

    def build(self, positions) -> SpatialIndex: ...

    def neighbors(self, radius: float) -> Neighbors: ...

    def query(self, points, radius: float) -> Neighbors: ...

    def knn(
        self, points, k: int, *, exclude_self: bool = False
    ) -> tuple[np.ndarray, np.ndarray]: ...

    def pairs(self, distance: float) -> np.ndarray: ...


def spatial_index(structure: str, *, cell_size: float | None = None, leaf_size: int | None = None):
    """A new, empty spatial structure named ``structure`` (one of :data:`STRUCTURES`).

    ``cell_size`` [m] is the grid's cell edge (required for ``"grid"``; a query radius
    is fastest at or below it); ``leaf_size`` the trees' most points per leaf (default
    32 for the octree, 16 for the k-d tree).
    """
    if structure not in STRUCTURES:
        allowed = ", ".join(repr(s) for s in STRUCTURES)
        raise ValueError(f"structure must be one of {allowed}, got {structure!r}")
    if structure == "grid":
        if cell_size is None:
            raise ValueError("structure 'grid' needs a cell_size [m] > 0")
        return UniformGrid(cell_size)
    if cell_size is not None:
        raise ValueError(f"cell_size applies to the 'grid' structure only, not {structure!r}")
    tree = Octree if structure == "octree" else KDTree
    return tree() if leaf_size is None else tree(leaf_size=leaf_size)


def sorted_neighbors(index, positions: np.ndarray, radius: float):
    """Build ``index`` (a spatial structure) on ``positions`` (3, n) and return the lists
    within ``radius`` [m] numbered in the structure's sorted order: ``(begin, end,
    indices, order)``, where row ``r`` is ``indices[begin[r]:end[r]]``, rows and entry
    values are sorted slots, and ``order[r]`` is the point in slot ``r``. A solver that
    permutes its particles by ``order`` then reads neighbours from nearby memory. A
    uniform grid's rows stay in its search buffer (:meth:`UniformGrid.neighbor_rows`),
    valid until its next query."""
    index.build(positions)
    if isinstance(index, UniformGrid):
        begin, end, indices = index.neighbor_rows(radius)
        return begin, end, indices, index.order
    lists = index.neighbors(radius)
    order = index.order
    slot_of = np.empty(order.shape[0], np.int64)
    slot_of[order] = np.arange(order.shape[0])
    counts = lists.counts[order]
    offsets = np.zeros(order.shape[0] + 1, np.int64)
    np.cumsum(counts, out=offsets[1:])
    starts = np.repeat(lists.offsets[:-1][order], counts)
    within = np.arange(int(offsets[-1])) - np.repeat(offsets[:-1], counts)
    indices = slot_of[lists.indices[starts + within]].astype(np.int32)
    return offsets[:-1], offsets[1:], indices, order
