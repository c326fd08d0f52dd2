"""What a liquid gives back to a wall: the impulse and angular impulse of a step.

A wall that moves with a rigid body (a floating box) must feel the liquid as the liquid
feels it. The solver moves particle ``i`` away from a wall ``b`` in two ways, and each
displacement ``Δp`` over a step of ``Δt`` is an impulse ``m_i Δp / Δt`` the wall gave
the particle (the step's velocity is the displacement over ``Δt``):

- the push-out that keeps particles a radius from the wall, before the density solve
  and after each of its iterations;
- the wall's part of each density correction (Macklin & Müller 2013, eq. 14, with the
  wall standing for the rest lattice continued beyond it): ``w_i λ_i ∂(1 - Q)/∂b``,
  where ``Q = Π_c (1 - f_c)`` is the free part of the kernel and the wall's own term of
  its gradient is ``Q / (1 - f_b) · f_b' n_b``.

The wall receives the opposite, ``-m_i Δp / Δt``, at the particle's position: summed,
the net force of the liquid over the step (the pressure that makes buoyancy included)
and its torque about the wall's centre. Particle-particle corrections are antisymmetric
and add nothing to the sum, so the momentum of liquid and body together changes only by
gravity and the other walls. Adhesion and friction are not counted: a reacting wall
must have neither (checked).
"""

from __future__ import annotations

import numpy as np
from numba import prange

from .._jit import block_bounds, block_count, parallel_kernel
from ..geometry.distance import row_signed_distance
from .boundaries import Boundary
from .kernels import boundary_function
from .sph import wall_share


@boundary_function
def _free_share(rows, x, y, z, h, spacing, scale):
    """``Q``, the part of the kernel no wall takes (as ``kernels.walls``)."""
    free = 1.0
    for b in range(rows.shape[0]):
        d = row_signed_distance(rows, b, x, y, z, 1.0)[0]
        if d < h:
            free *= 1.0 - wall_share(d, spacing, h, scale)[0]
    return free


@parallel_kernel
def wall_gradients(px, py, pz, rows, chosen, h, spacing, scale, out):
    """``out[k, :, i]``: the term of ``∇(1 - Q)`` at particle ``i`` due to row
    ``chosen[k]`` [1/m] (zero beyond the kernel)."""
    n = px.shape[0]
    for block in prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            x, y, z = np.float64(px[i]), np.float64(py[i]), np.float64(pz[i])
            free = -1.0
            for k in range(chosen.shape[0]):
                d, nx, ny, nz = row_signed_distance(rows, chosen[k], x, y, z, 1.0)
                gx = gy = gz = 0.0
                if d < h:
                    if free < 0.0:
                        free = _free_share(rows, x, y, z, h, spacing, scale)
                    f, slope = wall_share(d, spacing, h, scale)
                    others = free / max(1.0 - f, 1e-12)
                    gx, gy, gz = others * slope * nx, others * slope * ny, others * slope * nz
                out[k, 0, i], out[k, 1, i], out[k, 2, i] = gx, gy, gz


@parallel_kernel
def wall_pushes(px, py, pz, rows, chosen, radius, out):
    """``out[k, :, i]``: the push [m] that keeps particle ``i`` ``radius`` from row
    ``chosen[k]`` (zero when it is far enough)."""
    n = px.shape[0]
    for block in prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            x, y, z = np.float64(px[i]), np.float64(py[i]), np.float64(pz[i])
            for k in range(chosen.shape[0]):
                d, nx, ny, nz = row_signed_distance(rows, chosen[k], x, y, z, 1.0)
                push = max(radius - d, 0.0)
                out[k, 0, i], out[k, 1, i], out[k, 2, i] = push * nx, push * ny, push * nz


class WallReaction:
    """Collects, over each step of a fluid, what the liquid gives to some of its walls.

    Add it with :meth:`motes.Fluid.add_reaction`; after each ``Fluid.step``,
    :attr:`impulse` (k, 3) and :attr:`angular_impulse` (k, 3) hold, per wall, the
    momentum [N s] and the angular momentum about the wall's ``center`` [N m s] the
    liquid passed to it during that step.

    Parameters
    ----------
    walls : sequence of Boundary
        Walls of the fluid's model (each must have a ``center`` and neither adhesion nor
        friction: those exchanges are not counted).
    """

    def __init__(self, walls):
        self.walls = list(walls)
        for wall in self.walls:
            if not isinstance(wall, Boundary) or not hasattr(wall, "center"):
                raise TypeError(f"walls must be fluid boundaries with a center, got {wall!r}")
            if wall.adhesion or wall.friction:
                raise ValueError(
                    "a reacting wall must have adhesion = 0 and friction = 0 (their exchange "
                    f"with the liquid is not counted), got {wall.adhesion}, {wall.friction}"
                )
        k = len(self.walls)
        self.impulse = np.zeros((k, 3))
        self.angular_impulse = np.zeros((k, 3))
        self._chosen = np.zeros(0, np.int64)

    def start(self) -> None:
        """A call of ``Fluid.step`` begins: its internal steps add up from zero."""
        self.impulse = np.zeros((len(self.walls), 3))
        self.angular_impulse = np.zeros((len(self.walls), 3))

    def begin(self, boundaries, rows) -> None:
        """An internal step begins: find the walls' rows among the packed ``rows``."""
        firsts, first = {}, 0
        for boundary in boundaries:
            firsts[id(boundary)] = first
            first += len(boundary.rows())
        missing = [w for w in self.walls if id(w) not in firsts]
        if missing:
            raise ValueError(f"walls {missing!r} are not boundaries of this fluid")
        self._chosen = np.array([firsts[id(w)] for w in self.walls], np.int64)
        self._moved = np.zeros((len(self.walls), 3))  # Σ m Δp per wall [kg m]
        self._turned = np.zeros((len(self.walls), 3))  # Σ (p - c) × m Δp [kg m²]
        self._rows = rows

    def _add(self, positions, displacement, masses) -> None:
        """Add ``m Δp`` of every particle, (k, 3, n) displacements, to the sums."""
        centers = np.array([w.center for w in self.walls])
        for k in range(len(self.walls)):
            moved = displacement[k].astype(np.float64) * masses
            lever = positions.astype(np.float64) - centers[k][:, None]
            self._moved[k] += moved.sum(axis=1)
            self._turned[k] += np.cross(lever, moved, axis=0).sum(axis=1)

    def pushed(self, predicted, radius, masses) -> None:
        """Before the push-out: count what it will move (particles at ``predicted``)."""
        out = np.empty((len(self.walls), *predicted.shape), np.float32)
        wall_pushes(*predicted, self._rows, self._chosen, radius, out)
        self._add(predicted, out, masses)

    def corrected(self, before, after, lam, weight, masses, radius, h, spacing, scale) -> None:
        """An iteration moved particles from ``before`` to ``after`` (push-out not yet
        applied) with multipliers ``lam``: count the walls' corrections and the push-out
        that will follow."""
        k = len(self.walls)
        out = np.empty((k, *before.shape), np.float32)
        wall_gradients(*before, self._rows, self._chosen, h, spacing, scale, out)
        self._add(before, out * (weight * lam), masses)
        wall_pushes(*after, self._rows, self._chosen, radius, out)
        self._add(after, out, masses)

    def end(self, dt: float) -> None:
        """An internal step of ``dt`` [s] ends: the walls receive the opposite of what
        they gave."""
        self.impulse -= self._moved / dt
        self.angular_impulse -= self._turned / dt
