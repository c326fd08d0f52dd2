"""Constraints over particles, relaxed iteratively (Jakobsen 2001; Müller et al. 2007; XPBD).

Sticks, ropes, distance limits and angle limits (:class:`ConstraintBuilder`), coloured
once into a :class:`ConstraintSet` that is relaxed colour by colour in compiled
kernels, and :class:`Pins`.
"""

from .constraints import ConstraintBuilder, ConstraintSet, Pins
from .graph import color_constraints

__all__ = ["ConstraintBuilder", "ConstraintSet", "Pins", "color_constraints"]
