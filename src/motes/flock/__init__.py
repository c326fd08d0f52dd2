"""Flocks of birds and schools of fish: Reynolds' boids (1987) and steering behaviours
(1999) as a particle kind, neighbours through the uniform grid, every boid's step in one
parallel compiled kernel."""

from .behaviors import (
    Arrive,
    Avoid,
    AvoidColliders,
    Contain,
    Evade,
    Flee,
    FollowLeader,
    FollowPath,
    Pursue,
    Seek,
    Wander,
)
from .flock import Flock
from .rules import Limits, Rule

__all__ = [
    "Arrive",
    "Avoid",
    "AvoidColliders",
    "Contain",
    "Evade",
    "Flee",
    "Flock",
    "FollowLeader",
    "FollowPath",
    "Limits",
    "Pursue",
    "Rule",
    "Seek",
    "Wander",
]
