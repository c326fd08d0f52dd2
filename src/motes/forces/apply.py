"""Forces on any kind of particles: one evaluation for cloth, hair, liquids and worlds.

An emitter system folds its :class:`~motes.forces.base.FieldForce` objects into the
fused step kernel and runs each :class:`~motes.forces.base.Force` over its store. Other
kinds keep their particles in arrays of their own; :func:`add_forces` evaluates any list
of forces on such arrays, into a ``(3, n)`` float64 buffer of newtons:

- a field force's terms as the fused kernel evaluates them, times the mass:
  ``f = m g + Σ k_i w_i - k v - c |v - u| (v - u)`` (``FieldTerms``), one force at a
  time, so quadratic drags toward different winds may act together here;
- a ``Force`` through its ``accumulate``, with a :class:`~motes.state.ParticleState`
  holding the masses in place of the store (``has("mass")`` / ``raw("mass")``, the only
  attribute the built-in forces read).

Implicitly stepped kinds (cloth, hair) use :func:`split_implicit` instead, which leaves
the ``Force`` objects to :meth:`~motes.integrate.implicit.ImplicitEuler.step` (implicit
where they have a Jacobian) and the linear drag to its implicit ``damping``.
"""

from __future__ import annotations

import numpy as np

from ..state import Field, ParticleState
from .base import FieldForce, FieldTerms, Force

__all__ = ["add_field_terms", "add_forces", "check_force", "force_state", "split_implicit"]


def check_force(force):
    """``force`` itself if it is a :class:`Force` or :class:`FieldForce`, else TypeError."""
    if not isinstance(force, Force | FieldForce):
        raise TypeError(f"expected a motes.forces Force or FieldForce, got {type(force).__name__}")
    return force


def force_state(position: np.ndarray, velocity: np.ndarray, mass: np.ndarray) -> ParticleState:
    """The :class:`ParticleState` forces read as their store.

    Parameters
    ----------
    position, velocity : float arrays of shape (3, n)
        [m], [m/s].
    mass : float array of shape (n,)
        [kg], the ``mass`` field.
    """
    n = position.shape[1]
    fields = {"mass": Field(mass, "kg", "particle mass")}
    return ParticleState(np.arange(n), position, velocity, np.zeros(n), fields)


def add_field_terms(
    terms: FieldTerms,
    velocity: np.ndarray,
    mass: np.ndarray,
    out: np.ndarray,
    *,
    linear_drag: bool = True,
) -> None:
    """Add the force [N] of field coefficients to ``out``.

    ``f = m g + Σ k_i w_i - k v - c |v - u| (v - u)``: the fused kernel's acceleration
    (:class:`FieldTerms`) times the mass.

    Parameters
    ----------
    terms : FieldTerms
    velocity : float64 array of shape (3, n)
        [m/s].
    mass : float64 array of shape (n,)
        [kg].
    out : float64 array of shape (3, n)
        Force accumulator [N].
    linear_drag : bool
        Include ``-k v``; an implicit integrator that treats it as damping leaves it out.
    """
    gravity = np.asarray(terms.gravity, dtype=np.float64)
    if gravity.any():
        out += mass * gravity[:, None]
    if any(terms.linear_drag_wind):
        out += np.asarray(terms.linear_drag_wind, dtype=np.float64)[:, None]
    if linear_drag and terms.linear_drag:
        out -= terms.linear_drag * velocity
    if terms.quadratic_drag:
        wind = np.zeros(3) if terms.quadratic_wind is None else terms.quadratic_wind
        relative = velocity - np.asarray(wind, dtype=np.float64)[:, None]
        out -= terms.quadratic_drag * np.sqrt((relative * relative).sum(axis=0)) * relative


def add_forces(
    forces,
    position: np.ndarray,
    velocity: np.ndarray,
    mass: np.ndarray,
    time: float,
    out: np.ndarray | None = None,
) -> np.ndarray:
    """Add every force [N] on ``n`` particles into ``out`` and return it.

    Parameters
    ----------
    forces : sequence of Force or FieldForce
    position, velocity : float arrays of shape (3, n)
        Positions [m] and velocities [m/s]; converted to float64 (no copy when they
        are), so the force kernels compile once for every kind.
    mass : float array of shape (n,)
        Masses [kg].
    time : float
        Simulation time [s] (curl noise evolves with it; callbacks receive it).
    out : float64 array of shape (3, n), optional
        Accumulator; a new zero array by default.

    Returns
    -------
    out : float64 array of shape (3, n)
    """
    position = np.ascontiguousarray(position, dtype=np.float64)
    velocity = np.ascontiguousarray(velocity, dtype=np.float64)
    n = position.shape[1]
    mass = np.ascontiguousarray(mass, dtype=np.float64)
    if position.shape != (3, n) or velocity.shape != (3, n) or mass.shape != (n,):
        raise ValueError(
            f"position and velocity must be (3, n) and mass (n,), got {position.shape}, "
            f"{velocity.shape} and {mass.shape}"
        )
    if out is None:
        out = np.zeros((3, n))
    elif out.shape != (3, n) or out.dtype != np.float64:
        raise ValueError(f"out must be a float64 array of shape (3, {n}), got {out.shape}")
    store = None
    for force in forces:
        if isinstance(force, FieldForce):
            add_field_terms(force.terms(), velocity, mass, out)
        else:
            if store is None:
                store = force_state(position, velocity, mass)
            check_force(force).accumulate(store, position, velocity, time, out)
    return out


def split_implicit(
    forces, velocity: np.ndarray, mass: np.ndarray, external: np.ndarray
) -> tuple[list[Force], float]:
    """Share forces out for :meth:`~motes.integrate.implicit.ImplicitEuler.step`.

    Field forces are added to ``external`` (explicit: held over the step), except their
    linear drag ``-k v``, whose summed coefficient ``k`` [kg/s] is returned for the
    solve's implicit ``damping``. The :class:`Force` objects are returned for its
    ``forces``: the solver evaluates them at the start of the step and assembles the
    Jacobian of those that have one (radial fields, springs), the others staying
    explicit (vortices, curl noise, callbacks).

    Parameters
    ----------
    forces : sequence of Force or FieldForce
    velocity : float64 array of shape (3, n)
        [m/s].
    mass : float64 array of shape (n,)
        [kg].
    external : float64 array of shape (3, n)
        The solve's explicit forces [N], added to in place.

    Returns
    -------
    others : list of Force
    linear_drag : float
        ``Σ k`` [kg/s].
    """
    others, drag = [], 0.0
    for force in forces:
        if isinstance(force, FieldForce):
            terms = force.terms()
            add_field_terms(terms, velocity, mass, external, linear_drag=False)
            drag += terms.linear_drag
        else:
            others.append(check_force(force))
    return others, drag
