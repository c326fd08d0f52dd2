"""One cloth step as a function of its model, state and control.

:func:`step` advances a :class:`~motes.cloth.state.ClothState` in place:

1. handles set their particles' target velocities for the step;
2. explicit forces: gravity, the wind's per-triangle drag and lift, and the model's
   added forces (those with a Jacobian go to the implicit solve);
3. the integrator: implicit Euler (Baraff & Witkin 1998) with the springs and the air
   damping implicit, pins and handles as constraint filters, or an explicit scheme;
4. strain limiting (Provot 1995): over-stretched structural springs are shortened;
5. collisions with planes, spheres and boxes (push-out, restitution, friction), then
   with triangle meshes (swept, then projected out).

The model is only read: stepping never rebuilds it.
"""

from __future__ import annotations

import numpy as np

from .. import _validate as check
from .._jit import threads_for
from ..collide import contact
from ..collide.colliders import pack
from ..collide.contact import project_contacts
from ..collide.swept import sweep_contacts
from ..forces.apply import add_forces, force_state, split_implicit
from ..geometry.layout import grown
from ..integrate.implicit import SERIAL_BELOW, SolveReport
from .kernels import aero_triangle_kernel, collide_kernel, gather_triangles_kernel
from .model import ClothModel, Scheme
from .state import ClothControl, ClothState


def step(
    model: ClothModel, state: ClothState, control: ClothControl, dt: float
) -> SolveReport | None:
    """Advance ``state`` in place by ``dt`` [s] (> 0); returns the implicit solve's
    :class:`~motes.integrate.implicit.SolveReport`, or None with an explicit scheme.

    Below ``SERIAL_BELOW`` vertices the step runs on one thread (waking the pool costs
    more than the work).
    """
    h = check.positive("dt", dt)
    with threads_for(model.vertex_count, SERIAL_BELOW):
        return advance(model, state, control, h)


def advance(
    model: ClothModel, state: ClothState, control: ClothControl, h: float
) -> SolveReport | None:
    """:func:`step` on the current thread count, ``h`` [s] unchecked."""
    constraints = control.constraints
    for handle in control.handles:
        target = handle.anchor + handle.weights * handle.path(state.time + h)[:, None]
        idx = handle.indices
        constraints.velocity[:, idx] = (target - state.positions[:, idx]) / h
    external = external_force(model, state)
    start = state.positions.copy() if model.collider_meshes else None
    report = None
    mass = model.vertex_mass
    if model.scheme == Scheme.IMPLICIT_EULER:
        report = implicit_solve(model, state, mass, h, external, constraints)
    else:
        add_forces(model.forces, state.positions, state.velocities, mass, state.time, external)
        _explicit(model, state, constraints, h, external)
    free = ~constraints.constrained
    if model.strain_limiter is not None:
        # Provot 1995: shorten structural springs stretched past the limit, ordered from
        # the pins out; the velocities get the same change / h.
        model.strain_limiter.apply(state.positions, state.velocities, mass, ~free, h)
    if model.collider_shapes:
        table, _ = pack(model.collider_shapes)
        collide_kernel(*state.positions, *state.velocities, free, grown(table, model.thickness), h)
    if model.collider_meshes:
        _collide_meshes(model, state, h, free, start)
    state.time += h
    return report


def external_force(model: ClothModel, state: ClothState) -> np.ndarray:
    """Gravity and wind on each vertex [N], float64 (3, n), at ``state``."""
    f = model.vertex_mass[None, :] * model.gravity[:, None]
    w = model.wind
    if w is not None:
        per_triangle = np.empty((3, len(model.faces)))
        aero_triangle_kernel(
            *state.positions,
            *state.velocities,
            model.faces,
            w.velocity,
            w.packed(),
            state.time,
            w.frequencies,
            w.phases,
            per_triangle,
        )
        gather_triangles_kernel(
            per_triangle, model.vertex_triangle_start, model.vertex_triangles, *f
        )
    return f


def total_force(model: ClothModel, state: ClothState) -> np.ndarray:
    """Springs, gravity, wind, air damping and the model's forces on each vertex [N],
    float64 (3, n), at ``state`` (pins and handles excluded)."""
    mass = model.vertex_mass
    f = external_force(model, state) - model.air_damping * mass * state.velocities
    model.springs.accumulate(None, state.positions, state.velocities, state.time, f)
    return add_forces(model.forces, state.positions, state.velocities, mass, state.time, f)


def energy(model: ClothModel, state: ClothState) -> float:
    """Kinetic + spring + gravitational potential energy [J] at ``state``."""
    mass = model.vertex_mass
    kinetic = 0.5 * float(np.sum(mass * state.velocities**2))
    gravity = -float(np.sum(mass * (model.gravity @ state.positions)))
    return kinetic + model.springs.energy(state.positions) + gravity


def _explicit(model, state, constraints, h: float, external: np.ndarray) -> None:
    mass = model.vertex_mass
    f = external - model.air_damping * mass * state.velocities
    model.springs.accumulate(None, state.positions, state.velocities, state.time, f)
    a = f / mass
    held = constraints.constrained
    target = constraints.velocity
    if model.scheme == Scheme.EXPLICIT_EULER:
        v_move = np.where(held, target, state.velocities)
        state.velocities = np.where(held, target, state.velocities + h * a)
    else:
        state.velocities = np.where(held, target, state.velocities + h * a)
        v_move = state.velocities
    state.positions += h * v_move


def _collide_meshes(model, state, h: float, free: np.ndarray, start: np.ndarray) -> None:
    """Triangle meshes are thin shells, which a particle can cross within one step:
    each path ``start -> position`` is swept against them first (stopping at the first
    hit and reflecting with the mesh's restitution,
    :func:`motes.collide.swept.sweep_contacts`), then what still lies within
    ``thickness`` is projected out with depth friction
    (:func:`motes.collide.contact.project_contacts`). A particle that touched takes
    the velocity of its corrected travel."""
    meshes = list(model.collider_meshes)
    table, tri, cell_start, cell_tris = contact.pack(
        meshes, [contact.Detection.PRIORI] * len(meshes)
    )
    n = model.vertex_count
    previous = start.copy()  # rewritten by the sweep for particles that hit
    hits = np.zeros(n, dtype=np.int64)
    radius = np.full(n, model.thickness)
    movable = free.astype(np.float64)
    mesh_data = (table, tri, cell_start, cell_tris, hits)
    sweep_contacts(*state.positions, *previous, radius, movable, *mesh_data)
    project_contacts(*state.positions, *previous, radius, movable, *mesh_data)
    touched = hits > 0
    state.velocities[:, touched] = (state.positions[:, touched] - previous[:, touched]) / h


def implicit_solve(model, state, mass, h, external, constraints):
    """One implicit Euler solve (Baraff & Witkin 1998) of a mass-spring body, cloth or
    hair: its springs and the forces with a Jacobian implicit, air damping and the linear
    part of field drags implicit, the rest in ``external`` (3, n) [N]. ``model`` gives
    ``solver``, ``springs``, ``forces`` and ``air_damping``; the solver's warm start is
    taken from and written back to ``state``. Returns the solver's report."""
    others, drag = split_implicit(model.forces, state.velocities, mass, external)
    solver = model.solver
    solver.previous_change = state.warm_start
    report = solver.step(
        state.positions,
        state.velocities,
        mass,
        h,
        forces=[model.springs, *others],
        external=external,
        damping=model.air_damping * mass + drag,
        constraints=constraints,
        store=force_state(state.positions, state.velocities, mass),
        time=state.time,
    )
    state.warm_start = solver.previous_change
    return report
