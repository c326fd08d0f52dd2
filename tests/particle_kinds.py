"""Small instances of the six kinds of particle simulation, for the state and cache tests."""

from __future__ import annotations

import motes as mo
from motes.flock import Flock
from motes.fluids import Fluid, FluidModel, Tank, lattice

DT = 1 / 60


def make_system():
    system = mo.ParticleSystem(1_000, seed=1)
    system.add(
        mo.Emitter(mo.shapes.Disc(0.1), mo.PerFrame(20), speed=1.0, color="#ff8000", size=0.02),
        mo.Gravity(),
    )
    return system


def make_fluid():
    model = FluidModel(spacing=0.05, boundaries=(Tank((0, 0, 0), (0.5, 1, 0.5)),))
    return Fluid(model, lattice((0, 0, 0), (0.2, 0.2, 0.2), 0.05))


def make_cloth():
    cloth = mo.Cloth.grid(6, 5, size=(0.5, 0.4), origin=(0, 1, 0))
    cloth.pin(cloth.grid_index(0, slice(None)))
    return cloth


def make_hair():
    return mo.Hair(mo.Head((0, 1.6, 0), 0.1), strands=8, particles=5)


def make_world():
    world = mo.RigidWorld()
    world.add_particles([[0.0, 1.0, 0.0]], radius=0.1)
    world.add_body(mo.BodyShape.box((1.0, 1.0, 0.0), (0.2, 0.2, 0.2), 1.0))
    return world


def make_flock():
    return Flock.in_box(300, (-0.5, 0.5, -0.5), (0.5, 1.5, 0.5), speed=1.0, seed=2)


#: kind -> (builder, its fields with their units, its radius [m] when constant)
KINDS = {
    "system": (make_system, {"age": "s", "lifetime": "s", "color": "1"}, None),
    "fluid": (make_fluid, {"phase": "", "density": "kg/m³", "pressure": "Pa", "mass": "kg"}, 0.025),
    "cloth": (make_cloth, {"mass": "kg", "pinned": ""}, 0.005),
    "hair": (make_hair, {"mass": "kg", "strand": ""}, 0.004),
    "world": (make_world, {"mass": "kg", "previous": "m"}, None),
    "flock": (make_flock, {"heading": "1", "bank": "rad", "flap": "rad", "neighbors": ""}, 0.1),
}
