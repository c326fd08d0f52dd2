"""Hair: particle-chain strands on a moving head, stepped implicitly."""

from .hair import Hair
from .head import Head, euler_matrix, growth_directions, scalp_directions
from .model import HairModel, build_model
from .state import HairControl, HairState

__all__ = [
    "Hair",
    "HairControl",
    "HairModel",
    "HairState",
    "Head",
    "build_model",
    "euler_matrix",
    "growth_directions",
    "scalp_directions",
]
