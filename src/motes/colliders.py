"""Colliders by their short names: ``motes.colliders.Plane``, ``.Sphere``, ``.Box``,
``.Capsule``, ``.TriangleMeshCollider``."""

from .collide import (
    Box,
    Capsule,
    Collider,
    Detection,
    Friction,
    Plane,
    Response,
    Sphere,
    TriangleMeshCollider,
)

__all__ = [
    "Box",
    "Capsule",
    "Collider",
    "Detection",
    "Friction",
    "Plane",
    "Response",
    "Sphere",
    "TriangleMeshCollider",
]
