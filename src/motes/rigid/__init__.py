"""Rigid bodies, joints and ragdolls made of particles (Jakobsen 2001).

A :class:`World` steps particles by position Verlet and relaxes sticks, joint limits,
pins and collisions together; :class:`BodyShape` builds tetrahedra, boxes and convex
hulls; :func:`add_ragdoll` builds a character from a few proportions. A world's step is
:func:`step` of its :class:`WorldModel` (what stepping reads), :class:`WorldState` (what
it changes) and :class:`WorldControl` (the inputs of the next step).
"""

from .model import WorldModel, WorldParameters
from .motion import RigidMotion
from .ragdoll import Ragdoll, RagdollProportions, add_ragdoll
from .shapes import BodyShape
from .state import WorldControl, WorldState, WorldWorkspace
from .stepping import step
from .transform import body_transforms
from .world import Body, World

__all__ = [
    "Body",
    "BodyShape",
    "Ragdoll",
    "RagdollProportions",
    "RigidMotion",
    "World",
    "WorldControl",
    "WorldModel",
    "WorldParameters",
    "WorldState",
    "WorldWorkspace",
    "add_ragdoll",
    "body_transforms",
    "step",
]
