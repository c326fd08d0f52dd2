"""Cloth: mass-spring triangle meshes, stepped implicitly (Baraff & Witkin 1998)."""

from .cloth import Cloth, Scheme, SpringFamily
from .drivers import Path, Wind
from .topology import Topology

__all__ = ["Cloth", "Path", "Scheme", "SpringFamily", "Topology", "Wind"]
