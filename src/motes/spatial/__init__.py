"""Spatial queries over particles, behind one interface (:mod:`.index`): a uniform grid,
an octree built from Morton codes (also Barnes–Hut's), and a k-d tree (a binary space
partition). Each answers neighbours within a radius (CSR lists), k nearest neighbours
and pairs within a distance."""

from .grid import UniformGrid
from .index import STRUCTURES, SpatialIndex, spatial_index
from .kdtree import KDTree
from .neighbors import NeighborOverflow, Neighbors
from .octree import Octree

__all__ = [
    "STRUCTURES",
    "KDTree",
    "NeighborOverflow",
    "Neighbors",
    "Octree",
    "SpatialIndex",
    "UniformGrid",
    "spatial_index",
]
