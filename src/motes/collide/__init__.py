"""Collisions: planes, spheres, boxes, capsules and triangle meshes that every kind
collides with, found after the move or swept along each step's path (a priori); for
rigid worlds also body against body contacts."""

from .capsule import Capsule
from .colliders import Box, Collider, Detection, Friction, Kind, Plane, Response, Sphere
from .mesh import TriangleMeshCollider

__all__ = [
    "Box",
    "Capsule",
    "Collider",
    "Detection",
    "Friction",
    "Kind",
    "Plane",
    "Response",
    "Sphere",
    "TriangleMeshCollider",
]
