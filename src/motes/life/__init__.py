"""Life cycle: over-life curves, extinction policies and events."""

from .curves import ColorOverLife, Curve, SizeOverLife, SpeedOverLife
from .events import ParticleEvent
from .extinction import AlphaBelow, DistanceFrom, Extinction, IntensityBelow

__all__ = [
    "AlphaBelow",
    "ColorOverLife",
    "Curve",
    "DistanceFrom",
    "Extinction",
    "IntensityBelow",
    "ParticleEvent",
    "SizeOverLife",
    "SpeedOverLife",
]
