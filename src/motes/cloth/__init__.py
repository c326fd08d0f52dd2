"""Cloth: mass-spring triangle meshes, stepped implicitly (Baraff & Witkin 1998)."""

from .cloth import Cloth
from .drivers import Airflow, Keyframes
from .model import ClothModel, Scheme, SpringFamily, build_model
from .state import ClothControl, ClothState, Handle
from .topology import Topology

__all__ = [
    "Airflow",
    "Cloth",
    "ClothControl",
    "ClothModel",
    "ClothState",
    "Handle",
    "Keyframes",
    "Scheme",
    "SpringFamily",
    "Topology",
    "build_model",
]
