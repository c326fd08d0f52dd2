"""Emission shapes by their short names: ``motes.shapes.Sphere``, ``.Disc``, ``.Cone`` ..."""

from .emit.shapes import Box, Cone, Disc, Line, MeshSurface, Point, Shape, Sphere

__all__ = ["Box", "Cone", "Disc", "Line", "MeshSurface", "Point", "Shape", "Sphere"]
