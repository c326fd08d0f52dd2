"""Kinds acting on each other: contacts whose momentum passes both ways.

- :class:`ClothContact`: an emitter system's particles against a cloth (rain on a flag).
- :class:`RigidContact`: an emitter system's particles against the boxes and balls of a
  rigid world (debris that knocks a box over).
- :class:`FloatingBodies`: box bodies of a rigid world in a liquid (floating, sinking).
"""

from .cloth import ClothContact
from .fluid_rigid import FloatingBodies
from .rigid import RigidContact

__all__ = ["ClothContact", "FloatingBodies", "RigidContact"]
