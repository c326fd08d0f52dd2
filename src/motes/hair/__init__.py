"""Hair: particle-chain strands on a moving head, stepped implicitly."""

from .hair import Hair, Head, euler_matrix, growth_directions, scalp_directions

__all__ = ["Hair", "Head", "euler_matrix", "growth_directions", "scalp_directions"]
