"""Rigid bodies, joints and ragdolls made of particles (Jakobsen 2001).

A :class:`World` steps particles by position Verlet and relaxes sticks, joint limits,
pins and collisions together; :class:`BodyShape` builds tetrahedra, boxes and convex
hulls; :func:`add_ragdoll` builds a character from a few proportions.
"""

from .motion import RigidMotion
from .ragdoll import Ragdoll, RagdollProportions, add_ragdoll
from .shapes import BodyShape
from .transform import body_transforms
from .world import Body, World

__all__ = [
    "Body",
    "BodyShape",
    "Ragdoll",
    "RagdollProportions",
    "RigidMotion",
    "World",
    "add_ragdoll",
    "body_transforms",
]
