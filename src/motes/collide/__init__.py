"""Collisions: planes, spheres, boxes, capsules and triangle meshes that every kind
collides with, found after the move or swept along each step's path (a priori); for
rigid worlds also body against body contacts; particles of a system against each other
(:class:`ParticleCollisions`)."""

from .capsule import Capsule
from .colliders import Box, Collider, Detection, Friction, Kind, Plane, Response, Sphere
from .mesh import TriangleMeshCollider
from .spheres import ParticleCollisions

__all__ = [
    "Box",
    "Capsule",
    "Collider",
    "Detection",
    "Friction",
    "Kind",
    "ParticleCollisions",
    "Plane",
    "Response",
    "Sphere",
    "TriangleMeshCollider",
]
