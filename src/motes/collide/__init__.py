"""Collisions detected after the move: planes, spheres and (oriented) boxes."""

from .colliders import Box, Collider, Friction, Kind, Plane, Response, Sphere

__all__ = ["Box", "Collider", "Friction", "Kind", "Plane", "Response", "Sphere"]
