"""Colliders by their short names: ``motes.colliders.Plane``, ``.Sphere``, ``.Box``,
``.Capsule``, ``.TriangleMeshCollider``, and particles against each other,
``.ParticleCollisions``."""

from .collide import (
    Box,
    Capsule,
    Collider,
    Detection,
    Friction,
    ParticleCollisions,
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
    "ParticleCollisions",
    "Plane",
    "Response",
    "Sphere",
    "TriangleMeshCollider",
]
