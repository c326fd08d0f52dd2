"""Liquids as particles: position-based fluids (Macklin & Müller 2013) with SPH kernels
(Müller, Charypar & Gross 2003), walls by signed distance, the lecture's viscosity,
cohesion and adhesion (Akinci et al. 2013), friction, and non-mixing phases."""

from .boundaries import Box, MeshWall, Plane, Sphere, Tank
from .fluid import Fluid, FluidState, lattice, lattice_cells
from .model import FluidModel, Phase

__all__ = [
    "Box",
    "Fluid",
    "FluidModel",
    "FluidState",
    "MeshWall",
    "Phase",
    "Plane",
    "Sphere",
    "Tank",
    "lattice",
    "lattice_cells",
]
