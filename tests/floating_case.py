"""A box dropped into a tank of water, for the floating tests and benchmark."""

from __future__ import annotations

import numpy as np

import motes as mo
from motes.couple.fluid_rigid import FloatingBodies
from motes.fluids import FluidModel, Tank, lattice
from motes.fluids.fluid import Fluid
from motes.rigid import World
from motes.rigid.shapes import BodyShape


def tank_with_box(ratio: float, *, spacing: float, width: float = 0.5, depth: float = 0.3,
                  size: float = 0.2):  # fmt: skip
    """Water ``depth`` [m] deep in a square tank ``width`` [m] across, and a cube of edge
    ``size`` [m] and ``ratio`` times water's density held just above the surface."""
    model = FluidModel(spacing=spacing, boundaries=(Tank((0, 0, 0), (width, 1, width)),), xsph=0.1)
    water = Fluid(model, lattice((0, 0, 0), (width, depth, width), spacing))
    world = World(gravity=(0, -9.81, 0), substeps=4, iterations=4, damping=0.5)
    walls = (((0, 1, 0), (0, 0, 0)), ((1, 0, 0), (0, 0, 0)), ((-1, 0, 0), (width, 0, 0)),
             ((0, 0, 1), (0, 0, 0)), ((0, 0, -1), (0, 0, width)))  # fmt: skip
    for normal, point in walls:
        world.add_collider(mo.colliders.Plane(normal, point=point))
    mass = ratio * 1000.0 * size**3
    center = (width / 2, depth + size / 2 + 0.01, width / 2)
    body = world.add_body(BodyShape.box(center, (size, size, size), mass))
    return FloatingBodies(water, world, [(body, (size, size, size))])


def surface(water, spacing: float, away_from, clear: float) -> float:
    """Height [m] of the free surface: the top layer of particles farther than ``clear``
    [m] (horizontally) from ``away_from``, plus half a spacing."""
    p = water.state.positions
    far = np.hypot(p[0] - away_from[0], p[2] - away_from[2]) > clear
    top = np.sort(p[1][far])[-max(10, far.sum() // 50) :]
    return float(top.mean() + spacing / 2)
