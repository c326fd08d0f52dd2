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
                  size=0.2, tilt: float = 0.0, turn: bool = True):  # fmt: skip
    """Water ``depth`` [m] deep in a square tank ``width`` [m] across, and a box of edges
    ``size`` [m] (one number for a cube) and ``ratio`` times water's density held just
    above the surface, turned by ``tilt`` [deg] about z (its particles turned about its
    centre, so that its rest frame stays upright)."""
    model = FluidModel(spacing=spacing, boundaries=(Tank((0, 0, 0), (width, 1, width)),), xsph=0.1)
    water = Fluid(model, lattice((0, 0, 0), (width, depth, width), spacing))
    world = World(gravity=(0, -9.81, 0), substeps=4, iterations=4, damping=0.5)
    walls = (((0, 1, 0), (0, 0, 0)), ((1, 0, 0), (0, 0, 0)), ((-1, 0, 0), (width, 0, 0)),
             ((0, 0, 1), (0, 0, 0)), ((0, 0, -1), (0, 0, width)))  # fmt: skip
    for normal, point in walls:
        world.add_collider(mo.colliders.Plane(normal, point=point))
    size = np.broadcast_to(np.asarray(size, dtype=np.float64), (3,))
    mass = ratio * 1000.0 * np.prod(size)
    a = np.radians(tilt)
    turned = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0, 0, 1]])
    corners = (np.array([[i & 1, i >> 1 & 1, i >> 2 & 1] for i in range(8)]) - 0.5) * size
    center = np.array([width / 2, depth + 0.01 - (corners @ turned.T)[:, 1].min(), width / 2])
    body = world.add_body(BodyShape.box(center, size, mass))
    world.position[body.particles] = center + (world.position[body.particles] - center) @ turned.T
    world.previous[body.particles] = world.position[body.particles]
    return FloatingBodies(water, world, [(body, size)], turn=turn)


def tilt(world, body: int = 0) -> float:
    """Angle [deg] between a body's rest y axis and the vertical."""
    _, rotation = world.transforms()
    return float(np.degrees(np.arccos(np.clip(rotation[body][1, 1], -1.0, 1.0))))


def surface(water, spacing: float, away_from, clear: float) -> float:
    """Height [m] of the free surface: the top layer of particles farther than ``clear``
    [m] (horizontally) from ``away_from``, plus half a spacing."""
    p = water.state.positions
    far = np.hypot(p[0] - away_from[0], p[2] - away_from[2]) > clear
    top = np.sort(p[1][far])[-max(10, far.sum() // 50) :]
    return float(top.mean() + spacing / 2)
