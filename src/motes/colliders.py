"""Colliders by their short names: ``motes.colliders.Plane``, ``.Sphere``, ``.Box``."""

from .collide.colliders import Box, Collider, Friction, Plane, Response, Sphere

__all__ = ["Box", "Collider", "Friction", "Plane", "Response", "Sphere"]
