"""One hair step as a function of its model, state and control.

:func:`step` advances a :class:`~motes.hair.state.HairState` in place: the follicles
take the head's motion over the step (constraint filtering); one implicit Euler solve
(Baraff & Witkin 1998) for all strands; a Provot stretch limit on the stretch springs;
collisions with the scalp and the other colliders. The model is only read.
"""

from __future__ import annotations

from .. import _validate as check
from .._jit import threads_for
from ..cloth.kernels import collide_kernel
from ..cloth.stepping import implicit_solve
from ..collide.colliders import Sphere, pack
from ..geometry.layout import grown
from ..integrate.implicit import SERIAL_BELOW, SolveReport
from .model import HairModel
from .state import HairControl, HairState


def step(model: HairModel, state: HairState, control: HairControl, dt: float) -> SolveReport:
    """Advance ``state`` in place by ``dt`` [s] (> 0); returns the implicit solve's
    :class:`~motes.integrate.implicit.SolveReport`. Below ``SERIAL_BELOW`` particles it
    runs on one thread."""
    h = check.positive("dt", dt)
    with threads_for(model.particle_count, SERIAL_BELOW):
        return advance(model, state, control, h)


def advance(model: HairModel, state: HairState, control: HairControl, h: float) -> SolveReport:
    """:func:`step` on the current thread count, ``h`` [s] unchecked."""
    head = model.head
    roots = model.root_indices
    r, c = head.pose(state.time + h)
    target = (model.root_local @ r.T + c).T
    control.constraints.velocity[:, roots] = (target - state.positions[:, roots]) / h
    mass = model.particle_mass
    external = mass[None, :] * model.gravity[:, None]
    report = implicit_solve(model, state, mass, h, external, control.constraints)
    free = model.particle_free
    if model.strain_limiter is not None:
        model.strain_limiter.apply(state.positions, state.velocities, mass, ~free, h)
    scalp = Sphere(c, head.radius + model.thickness, restitution=0.0, friction=head.friction)
    # The scalp sphere already includes the thickness; the other colliders grow by it.
    table, _ = pack([scalp, *model.colliders])
    table[1:] = grown(table[1:], model.thickness)
    collide_kernel(*state.positions, *state.velocities, free, table, h)
    state.time += h
    return report
