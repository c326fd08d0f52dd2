"""Collisions: planes, spheres and boxes for particle systems (detected after the move);
for rigid worlds also capsules and triangle meshes, swept (a-priori) detection and body
against body contacts."""

from .capsule import Capsule
from .colliders import Box, Collider, Friction, Kind, Plane, Response, Sphere
from .contact import Detection
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
