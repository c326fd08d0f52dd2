"""Cloth: mass-spring triangle meshes, stepped implicitly (Baraff & Witkin 1998)."""

from .cloth import Cloth, Scheme, SpringFamily
from .drivers import Airflow, Keyframes
from .topology import Topology

__all__ = ["Airflow", "Cloth", "Keyframes", "Scheme", "SpringFamily", "Topology"]
