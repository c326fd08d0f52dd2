"""Liquids and rigid bodies acting on each other: boxes that float, sink and displace.

Each coupled body of a rigid :class:`~motes.rigid.World` (a box made of particles) is
also a solid wall of a :class:`~motes.fluids.Fluid`: an oriented box boundary that
follows the body's transform. One step of the pair:

1. the walls take the bodies' current centres and rotations
   (:meth:`motes.rigid.World.transforms`);
2. the liquid steps; its walls push it (the push-out and the walls' part of every
   density correction), and :class:`~motes.fluids.reaction.WallReaction` sums, per wall,
   the opposite of what each push gave the liquid: the impulse ``J`` [N s] and angular
   impulse ``L`` [N m s] about the centre that the liquid gave the body in that step;
3. each body's particles get the velocity change of that impulse, as a rigid body
   (:meth:`motes.rigid.World.add_impulse`): ``Δv_p = J / M + (I⁻¹ L) × r_p`` with ``M``
   and ``I`` the mass and inertia tensor of its particles about the centre, ``r_p`` a
   particle's offset from it. The angular part is what rights a tilted plank: the
   walls turn with the body, so the liquid displaced on the low side pushes harder.
   With ``turn=False`` it is left out and bodies keep their orientation against the
   liquid (as when the walls were upright boxes, which could tip a plank but never
   right it);
4. the world steps (gravity, constraints, its own colliders).

Whatever the liquid gains from a wall the body loses, so liquid and bodies together
change momentum only through gravity and the fixed walls. Buoyancy is not put in: it is
the net of the pressure the density solve builds under a body, so a body lighter than
the liquid rises until the displaced liquid weighs what it does, and a denser one sinks.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..fluids.boundaries import Box as BoxWall
from ..fluids.reaction import WallReaction


class FloatingBodies:
    """Box bodies of a rigid world coupled both ways with a liquid.

    Parameters
    ----------
    fluid : Fluid
        The liquid. The walls of the bodies are added to its model (a new
        :class:`~motes.fluids.FluidModel` with the extra boundaries).
    world : motes.rigid.World
        The rigid world holding the bodies (give it the liquid's container as colliders
        too, so that a sinking body comes to rest on the floor).
    bodies : sequence of (Body, size)
        Each body, as ``World.add_body`` returned it, with the full edge lengths (3,) [m]
        of the box the liquid sees (the body's box shape) along the x, y and z axes of
        the body's rest frame (build the box unrotated and turn its particles to place
        it tilted).
    turn : bool
        Apply the liquid's torque (see the module docstring; default). ``False`` keeps
        the bodies' orientations against the liquid.
    """

    def __init__(self, fluid, world, bodies, *, turn: bool = True):
        self.turn = bool(turn)
        self.fluid = fluid
        self.world = world
        self.bodies = [body for body, _ in bodies]
        sizes = [np.asarray(size, dtype=np.float64) for _, size in bodies]
        for size in sizes:
            if size.shape != (3,) or np.any(size <= 0):
                raise ValueError(f"size must be three lengths > 0 [m], got {size.tolist()}")
        if not self.bodies:
            raise ValueError("bodies must name at least one body")
        # Thinner than two kernel supports, a body lets the liquid's particles in between
        # its walls, whose push-out then flings it (seen: a plank 3.3 spacings thick).
        thinnest = 2.0 * fluid.model.h
        for k, size in enumerate(sizes):
            if size.min() < thinnest * (1 - 1e-9):
                raise ValueError(
                    f"size of body {k} must be at least two kernel supports of the liquid "
                    f"(2 h = {thinnest:g} m) along every edge, got {size.tolist()}"
                )
        _check_upright(world, self.bodies)
        centers, rotations = world.transforms()
        self.walls = [
            BoxWall(centers[body.index], size / 2, rotation=rotations[body.index])
            for body, size in zip(self.bodies, sizes, strict=True)
        ]
        fluid.model = dataclasses.replace(
            fluid.model, boundaries=(*fluid.model.boundaries, *self.walls)
        )
        self.reaction = WallReaction(self.walls)
        fluid.add_reaction(self.reaction)
        #: Force [N] the liquid exerted on each body over the last step, (k, 3).
        self.force = np.zeros((len(self.bodies), 3))

    def _follow(self) -> None:
        centers, rotations = self.world.transforms()
        for wall, body in zip(self.walls, self.bodies, strict=True):
            wall.center = centers[body.index].copy()
            wall.rotation = rotations[body.index].copy()

    def step(self, dt: float) -> None:
        """Advance liquid and bodies by ``dt`` [s], exchanging the liquid's push."""
        self._follow()
        self.fluid.step(dt)
        impulse, angular = self.reaction.impulse, self.reaction.angular_impulse
        self.force = impulse / dt
        self.world.add_impulse(
            [body.particles for body in self.bodies], impulse, angular if self.turn else None
        )
        self.world.step(dt)


def _check_upright(world, bodies) -> None:
    """The walls are boxes along the bodies' rest axes: refuse box bodies whose shape was
    built rotated (their rest frame is not the box's)."""
    index, _, _, axes = world.boxes()
    _, rotations = world.transforms()
    where = {int(b): k for k, b in enumerate(index)}
    for k, body in enumerate(bodies):
        if body.index not in where:
            continue
        rest = axes[where[body.index]] @ rotations[body.index]  # rows: the rest axes
        if not np.allclose(np.abs(rest).max(axis=1), 1.0, atol=1e-6):
            raise ValueError(
                f"bodies: body {k} is a box built rotated; build it along x, y and z and "
                "turn its particles instead (the liquid's wall follows its rest axes)"
            )
