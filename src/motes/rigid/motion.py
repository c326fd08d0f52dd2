"""Sets of particles seen as rigid bodies: their motion, and what an impulse does to them.

A body of a rigid world is a set of particles of masses ``m_k``, positions ``x_k`` and
velocities ``v_k``. As a rigid body it has

- mass ``M = Σ m_k`` and centre of mass ``c = Σ m_k x_k / M``;
- linear velocity ``V = Σ m_k v_k / M`` (momentum ``P = M V``);
- angular momentum about ``c``, ``L = Σ m_k ρ_k × v_k`` with ``ρ_k = x_k - c``;
- inertia ``I = Σ m_k (|ρ_k|² 1 - ρ_k ρ_kᵀ)`` and angular velocity ``ω = I⁻¹ L``, so the
  velocity of a point ``p`` moving with it is ``V + ω × (p - c)``.

An impulse ``J`` [N s] through ``c`` and an angular impulse ``A`` [N m s] about ``c``
change ``P`` and ``L`` by exactly ``J`` and ``A`` when every particle gets

    Δv_k = J / M + (I⁻¹ A) × ρ_k,

since ``Σ m_k Δv_k = J + (I⁻¹ A) × Σ m_k ρ_k = J`` and
``Σ m_k ρ_k × ((I⁻¹ A) × ρ_k) = I I⁻¹ A = A``; an impulse ``J`` at a point ``p`` is
``J`` through ``c`` with ``A = (p - c) × J``. So the momentum of the particles changes by
``J`` and their angular momentum about any fixed point ``o`` by ``(p - o) × J``.
Everything is taken at the positions ``x_k`` now: a position-Verlet world adds the
``Δv_k`` to the velocity ``(x - x*)/h`` it carries at those positions.

A set that cannot turn about some axis (a stick, one particle) has a singular inertia;
the pseudo-inverse gives it the part of ``A`` it can take (none for one particle).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class RigidMotion:
    """Particle sets as rigid bodies at one instant (k sets)."""

    centre: np.ndarray
    """Centres of mass [m], shape (k, 3)."""
    velocity: np.ndarray
    """Velocities of the centres [m/s], shape (k, 3)."""
    angular_velocity: np.ndarray
    """Angular velocities ``I⁻¹ L`` [rad/s], shape (k, 3)."""
    inverse_mass: np.ndarray
    """``1 / M`` [1/kg], 0 for a set that cannot move, shape (k,)."""
    inverse_inertia: np.ndarray
    """``I⁻¹`` (pseudo-inverse) about the centre, world axes [1/(kg m²)], 0 for a set that
    cannot move, shape (k, 3, 3)."""


def _layout(groups):
    """Concatenated members, start offsets (k + 1,) and owner of each member."""
    groups = [np.asarray(g, dtype=np.int64).ravel() for g in groups]
    sizes = np.array([len(g) for g in groups], dtype=np.int64)
    if np.any(sizes == 0):
        raise ValueError("groups must each hold at least one particle")
    members = np.concatenate(groups) if groups else np.zeros(0, np.int64)
    start = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
    return members, start, np.repeat(np.arange(len(groups)), sizes)


def _frame(position, mass, members, start, owner):
    """Masses (k,), centres (k, 3), offsets ρ (e, 3) and inverse inertias (k, 3, 3)."""
    first = start[:-1]
    x = position[:, members].T
    m = mass[members]
    total = np.add.reduceat(m, first)
    centre = np.add.reduceat(m[:, None] * x, first, axis=0) / total[:, None]
    rho = x - centre[owner]
    spread = (rho * rho).sum(axis=1)[:, None, None] * np.eye(3) - rho[:, :, None] * rho[:, None, :]
    inertia = np.add.reduceat(m[:, None, None] * spread, first, axis=0)
    # Pseudo-inverse by eigen-decomposition: axes a set cannot turn about (a stick's,
    # every axis of one particle) have zero inertia and take no angular impulse. Zero up
    # to round-off: offsets from a centre |c| from the origin round at ~1e-16 |c|.
    w, v = np.linalg.eigh(inertia)
    noise = total * (1e-13 * (1.0 + np.linalg.norm(centre, axis=1))) ** 2  # [kg m²]
    keep = (w > 1e-12 * w.max(axis=1, keepdims=True)) & (w > noise[:, None])
    inv_w = np.where(keep, 1.0 / np.where(keep, w, 1.0), 0.0)
    inverse = np.einsum("kij,kj,klj->kil", v, inv_w, v)
    return total, centre, rho, inverse


def rigid_motion(position, velocity, mass, groups, movable) -> RigidMotion:
    """Each particle set of ``groups`` as a rigid body.

    Parameters
    ----------
    position, velocity : (3, n) float64
        Particle positions [m] and velocities [m/s].
    mass : (n,) float64
        Particle masses [kg].
    groups : sequence of int arrays
        Particle indices of each set (non-empty).
    movable : (n,) bool
        Particles that move; a set with any that does not gets zero inverse mass and
        inertia (pins hold it).
    """
    members, start, owner = _layout(groups)
    if len(start) == 1:
        empty = np.zeros((0, 3))
        return RigidMotion(empty, empty, empty, np.zeros(0), np.zeros((0, 3, 3)))
    first = start[:-1]
    total, centre, rho, inverse = _frame(position, mass, members, start, owner)
    m = mass[members]
    v = velocity[:, members].T
    linear = np.add.reduceat(m[:, None] * v, first, axis=0) / total[:, None]
    angular = np.add.reduceat(m[:, None] * np.cross(rho, v), first, axis=0)
    free = np.logical_and.reduceat(np.asarray(movable)[members], first)
    return RigidMotion(
        centre,
        linear,
        np.einsum("kij,kj->ki", inverse, angular),
        np.where(free, 1.0 / total, 0.0),
        inverse * free[:, None, None],
    )


def impulse_velocities(position, mass, groups, impulse, angular_impulse=None):
    """Velocity changes ``Δv_k = J/M + (I⁻¹ A) × ρ_k`` of the members of every set.

    Parameters
    ----------
    position : (3, n) float64
        Particle positions [m].
    mass : (n,) float64
        Particle masses [kg].
    groups : sequence of int arrays
        Particle indices of each set (k sets).
    impulse : (k, 3) array_like
        Impulse ``J`` through each set's centre of mass [N s].
    angular_impulse : (k, 3) array_like, optional
        Angular impulse ``A`` about each centre [N m s]; none by default.

    Returns
    -------
    members : (e,) int64
        The sets' particles, set after set.
    change : (e, 3) float64
        Their velocity changes [m/s].
    """
    members, start, owner = _layout(groups)
    k = len(start) - 1
    if k == 0:
        return members, np.zeros((0, 3))
    total, _, rho, inverse = _frame(position, mass, members, start, owner)
    impulse = np.broadcast_to(np.asarray(impulse, dtype=np.float64), (k, 3))
    change = (impulse / total[:, None])[owner]
    if angular_impulse is not None:
        angular = np.broadcast_to(np.asarray(angular_impulse, dtype=np.float64), (k, 3))
        omega = np.einsum("kij,kj->ki", inverse, angular)
        change = change + np.cross(omega[owner], rho)
    return members, change
