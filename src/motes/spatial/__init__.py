"""Spatial queries over particles: a uniform grid for fixed-radius neighbours."""

from .grid import NeighborOverflow, Neighbors, UniformGrid

__all__ = ["NeighborOverflow", "Neighbors", "UniformGrid"]
