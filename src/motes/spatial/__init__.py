"""Spatial queries over particles: a uniform grid for fixed-radius neighbours, an octree
built from Morton codes (Barnes–Hut)."""

from .grid import NeighborOverflow, Neighbors, UniformGrid
from .octree import Octree

__all__ = ["NeighborOverflow", "Neighbors", "Octree", "UniformGrid"]
