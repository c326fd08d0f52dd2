"""Grid fluids: Stam's stable fluids on a staggered grid, with buoyancy, vorticity
confinement, viscosity, obstacles and sources (:class:`GridFluid`)."""

from .coupling import GridFlow, ParticleSource
from .fluid import GridFluid
from .model import Advection, Buoyancy, Dissipation, Solver, Wall
from .pressure import PoissonSolver, SolveReport
from .sources import Source

__all__ = [
    "Advection",
    "Buoyancy",
    "Dissipation",
    "GridFlow",
    "GridFluid",
    "ParticleSource",
    "PoissonSolver",
    "SolveReport",
    "Solver",
    "Source",
    "Wall",
]
