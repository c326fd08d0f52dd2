"""Kinds acting on each other: contacts whose momentum passes both ways.

- :class:`ClothContact`: an emitter system's particles against a cloth (rain on a flag).
"""

from .cloth import ClothContact

__all__ = ["ClothContact"]
