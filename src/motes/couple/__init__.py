"""Kinds acting on each other: contacts whose momentum passes both ways.

- :class:`ClothContact`: an emitter system's particles against a cloth (rain on a flag).
- :class:`FloatingBodies`: box bodies of a rigid world in a liquid (floating, sinking).
"""

from .cloth import ClothContact
from .fluid_rigid import FloatingBodies

__all__ = ["ClothContact", "FloatingBodies"]
