"""Emission (Reeves 1983): rates, shapes, initial-attribute distributions, emitters.

Emission shapes live in :mod:`motes.emit.shapes` (``motes.shapes``), since their names
(Sphere, Box, Cone) also name colliders and directions.
"""

from . import shapes
from .directions import Cone, Direction, Isotropic, Radial, ShapeNormal
from .distributions import Constant, Distribution, Function, Gradient, Normal, Uniform
from .emitter import Emitter, Path
from .rates import Burst, PerFrame, PerSecond, Rate, ScreenScaled

__all__ = [
    "Burst",
    "Cone",
    "Constant",
    "Direction",
    "Distribution",
    "Emitter",
    "Function",
    "Gradient",
    "Isotropic",
    "Normal",
    "Path",
    "PerFrame",
    "PerSecond",
    "Radial",
    "Rate",
    "ScreenScaled",
    "ShapeNormal",
    "Uniform",
    "shapes",
]
