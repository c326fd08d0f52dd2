"""A rigid world's step as a function of its model, state and control.

:func:`step` advances a :class:`~motes.rigid.state.WorldState` in place by ``dt`` in
the model's substeps; each substep of ``h`` (Jakobsen 2001, §2–4) launches, in order:

1. the control's velocity changes (position Verlet carries velocity as ``x - x*``: a
   velocity ``v`` puts ``x*`` at ``x - v h``);
2. position Verlet, ``x' = x + e^{-c h}(x - x*) + h² (g + F/m)`` (:func:`.kernels.verlet`,
   then the forces' ``h² F/m`` evaluated at the start of the substep);
3. swept tests of every path ``x* -> x'`` against a-priori colliders
   (:mod:`motes.collide.swept`);
4. ``iterations`` times: the constraint sweep (:mod:`motes.constrain`), the projection
   out of colliders (:mod:`motes.collide.contact`), the sphere contacts
   (:mod:`motes.collide.sphere_kernels`), the body contacts
   (:mod:`motes.rigid.body_contacts`) and the pins;
5. the velocity pass giving contacts their restitution (Müller et al. 2020, §3.5;
   :mod:`motes.rigid.restitution`).
"""

from __future__ import annotations

import math

import numpy as np

from .. import _validate as check
from .._jit import threads_for
from ..collide.contact import project_contacts
from ..collide.sphere_kernels import project_pairs, restitute_pairs
from ..collide.swept import sweep_contacts
from ..forces.apply import add_forces
from .body_contacts import body_contacts
from .kernels import verlet
from .model import WorldModel
from .restitution import restitute_contacts
from .state import WorldControl, WorldState, WorldWorkspace
from .transform import body_transforms

#: The sphere contacts' stacking direction: none (true masses).
_NO_UP = np.zeros(3)


def step(
    model: WorldModel,
    state: WorldState,
    control: WorldControl,
    dt: float,
    *,
    workspace: WorldWorkspace | None = None,
) -> WorldWorkspace:
    """Advance ``state`` in place by ``dt`` [s] in ``model.parameters.substeps`` substeps.

    ``control``'s changes are applied in the first substep and then cleared.
    ``workspace`` (buffers for ``model.particle_count`` particles) is reused when given;
    the one used is returned, its ``particle_hits`` the contacts of this step.
    """
    dt = check.positive("dt", dt)
    n = model.particle_count
    _check_state(model, state)
    if workspace is None or workspace.particle_hits.shape != (n,):
        workspace = WorldWorkspace.zeros(n)
    if state.body_rotation is None:
        state.body_rotation = exact_rotations(model, state)
    h = dt / model.parameters.substeps
    with threads_for(n):
        workspace.particle_hits[:] = 0
        for _ in range(model.parameters.substeps):
            _substep(model, state, control, workspace, h)
    return workspace


def _check_state(model: WorldModel, state: WorldState) -> None:
    """Refuse a state the kernels would read out of bounds or copy."""
    n, b = model.particle_count, model.body_count
    for name in ("particle_position", "particle_previous"):
        rows = getattr(state, name)
        if rows.shape != (3, n) or rows.dtype != np.float64 or not rows.flags.c_contiguous:
            raise ValueError(
                f"state.{name} must be a C-contiguous float64 (3, {n}) array for this "
                f"model, got {rows.dtype} {rows.shape}"
            )
    rotation = state.body_rotation
    if rotation is not None and (
        rotation.shape != (b, 3, 3)
        or rotation.dtype != np.float64
        or not rotation.flags.c_contiguous
    ):
        raise ValueError(
            f"state.body_rotation must be None or a C-contiguous float64 ({b}, 3, 3) array "
            f"for this model, got {rotation.dtype} {rotation.shape}"
        )


def transforms(model: WorldModel, state: WorldState) -> tuple[np.ndarray, np.ndarray]:
    """Centres of mass ``(b, 3)`` [m] and rotations ``(b, 3, 3)`` of every body, exact
    (:func:`~motes.rigid.transform.body_transforms`)."""
    return body_transforms(
        state.particle_position,
        model.body_start,
        model.body_particles,
        model.body_fraction,
        model.body_rest,
    )


def exact_rotations(model: WorldModel, state: WorldState) -> np.ndarray:
    """The bodies' rotations now, C-contiguous ``(b, 3, 3)``: the warm start of a state
    that has none."""
    return np.ascontiguousarray(transforms(model, state)[1])


def next_velocity(state: WorldState, control: WorldControl) -> np.ndarray:
    """(3, n) velocities [m/s] the next substep starts from: the last substep's
    ``(x - x*)/h`` (zero before one) with the control's changes applied in the order
    :func:`step` applies them."""
    n = state.particle_count
    v = np.zeros((3, n))
    if state.last_substep is not None:
        v = (state.particle_position - state.particle_previous) / state.last_substep
    for idx, value in control.particle_velocity_sets:
        v[:, idx] = value.T
    for idx, change in control.particle_velocity_changes:
        np.add.at(v, (slice(None), idx), change.T)
    return v


def _apply_control(state: WorldState, control: WorldControl, h: float) -> None:
    x, q = state.particle_position, state.particle_previous
    for idx, v in control.particle_velocity_sets:
        q[:, idx] = x[:, idx] - v.T * h
    # Position Verlet carries velocity as x - x*: a change dv moves x* by -dv h.
    for idx, dv in control.particle_velocity_changes:
        np.subtract.at(q, (slice(None), idx), dv.T * h)
    control.clear()


def _force_move(model: WorldModel, state: WorldState, h: float) -> np.ndarray:
    """``h² F / m`` [m], (3, n), of the model's forces at the start of the substep
    (taken before the Verlet kernel overwrites the previous positions)."""
    x = state.particle_position
    velocity = (x - state.particle_previous) / h
    force = add_forces(model.parameters.forces, x, velocity, model.particle_mass, state.time)
    return (h * h) * model.particle_inv_mass * force


def _restitute(model: WorldModel, state: WorldState, before: np.ndarray, h: float) -> None:
    """Velocity pass (Müller et al. 2020, §3.5): restitution of the contacts."""
    x, q = state.particle_position, state.particle_previous
    radius, inv_mass = model.particle_radius, model.particle_inv_mass
    rest = 2.0 * float(np.linalg.norm(model.parameters.gravity)) * h * h  # 2 |g| h, times h
    if len(model.collider_table):
        restitute_contacts(
            *x, *q, *before, radius, inv_mass, model.collider_table,
            model.mesh_triangles, model.mesh_cell_start, model.mesh_cell_triangles, rest,
        )  # fmt: skip
    if len(model.sphere_pairs):
        restitute_pairs(
            *x, *q, *before, inv_mass, radius, model.sphere_pairs,
            model.sphere_pair_restitution, rest,
        )  # fmt: skip


def _substep(
    model: WorldModel,
    state: WorldState,
    control: WorldControl,
    workspace: WorldWorkspace,
    h: float,
) -> None:
    p = model.parameters
    x, q = state.particle_position, state.particle_previous
    _apply_control(state, control, h)
    inv_mass, radius = model.particle_inv_mass, model.particle_radius
    table, tri = model.collider_table, model.mesh_triangles
    cell_start, cell_tris = model.mesh_cell_start, model.mesh_cell_triangles
    hits = workspace.particle_hits
    g = p.gravity
    push = _force_move(model, state, h) if p.forces else None
    verlet(*x, *q, inv_mass, g[0], g[1], g[2], math.exp(-p.damping * h), h * h)
    if push is not None:
        x += push
    if model.swept:
        sweep_contacts(*x, *q, radius, inv_mass, table, tri, cell_start, cell_tris, hits)
    if model.bounce:
        workspace.particle_before[:] = x  # for the velocity pass (restitution)
    constraints = model.constraints
    constraints.reset_multipliers()
    spheres = model.sphere_pairs
    shake = p.projection == "shake"
    for _ in range(p.iterations):
        if len(constraints):
            constraints.sweep(
                x,
                inv_mass,
                h,
                sqrt_approximation=p.sqrt_approximation,
                previous=q,
                shake=shake,
            )
        if len(table):
            project_contacts(*x, *q, radius, inv_mass, table, tri, cell_start, cell_tris, hits)
        if len(spheres):  # no friction, true masses (stacking 0)
            project_pairs(*x, *q, inv_mass, radius, spheres, 0.0, _NO_UP, 0.0, hits)
        if model.solid:
            body_contacts(
                *x,
                *q,
                inv_mass,
                radius,
                model.body_start,
                model.body_particles,
                model.body_fraction,
                model.body_rest,
                model.body_inv_mass,
                model.body_inertia_inv,
                model.body_plane_start,
                model.body_planes,
                model.body_group,
                state.body_rotation,
                model.body_edge_start,
                model.body_edges,
                p.body_friction,
                hits,
            )
        if model.pins is not None:
            model.pins.apply(x)
    if model.bounce:
        _restitute(model, state, workspace.particle_before, h)
    state.last_substep = h
    state.time += h
