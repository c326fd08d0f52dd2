"""The force interface.

Two kinds of force exist, for speed:

- :class:`FieldForce` (gravity, drag, wind): forces that depend only on a particle's own
  velocity. They are folded into a handful of coefficients (:class:`FieldTerms`) that the
  fused integration kernel evaluates inline, so they cost no memory pass of their own.
- :class:`Force` (everything else: attractors, vortices, curl noise, springs, user
  callbacks): each adds its force [N] into a shared ``(3, n)`` buffer before the
  integration kernel runs.

Forces that know their derivatives also return them as block-sparse
:class:`ForceJacobian` objects, for implicit integration.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from .._tracked import Tracked

Vec3 = tuple[float, float, float]
_ZERO3: Vec3 = (0.0, 0.0, 0.0)


def _add3(a: Vec3, b: Vec3) -> Vec3:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@dataclass
class FieldTerms:
    """Coefficients of the velocity-only forces acting on every particle.

    The acceleration they produce on a particle with inverse mass ``w`` and velocity ``v``
    is ``gravity + w (linear_drag_wind - linear_drag v - quadratic_drag |v - u| (v - u))``
    with ``u = quadratic_wind``. ``linear_drag_wind`` is ``sum_i k_i w_i``, so any number
    of linear drags toward different winds combine exactly. Plain tuples, not arrays:
    these are rebuilt every step, where small-array allocations would dominate.
    """

    gravity: Vec3 = _ZERO3  # [m/s^2]
    linear_drag: float = 0.0  # [kg/s]
    linear_drag_wind: Vec3 = _ZERO3  # [N s/m · m/s]
    quadratic_drag: float = 0.0  # [kg/m]
    quadratic_wind: Vec3 | None = None  # [m/s]

    def add(self, other: FieldTerms) -> None:
        """Accumulate ``other`` into these terms."""
        self.gravity = _add3(self.gravity, other.gravity)
        self.linear_drag += other.linear_drag
        self.linear_drag_wind = _add3(self.linear_drag_wind, other.linear_drag_wind)
        if other.quadratic_drag:
            if self.quadratic_drag and self.quadratic_wind != other.quadratic_wind:
                raise ValueError(
                    "quadratic drags toward different wind velocities cannot be combined; "
                    "use one QuadraticDrag per system"
                )
            self.quadratic_drag += other.quadratic_drag
            self.quadratic_wind = other.quadratic_wind

    def packed(self) -> list[float]:
        """The 11 coefficients in the order the kernel reads them (``integrate.kernels``)."""
        wind = _ZERO3 if self.quadratic_wind is None else self.quadratic_wind
        return [*self.gravity, self.linear_drag, *self.linear_drag_wind, self.quadratic_drag, *wind]


@dataclass
class ForceJacobian:
    """Block-sparse force derivatives: ``sum`` of ``blocks[k]`` at ``(rows[k], cols[k])``.

    ``dfdx[k]`` and ``dfdv[k]`` have shape ``(3, 3)``: the derivative of the force on
    particle ``rows[k]`` with respect to the position / velocity of particle ``cols[k]``
    [N/m] and [N s/m]. Repeated (row, col) pairs add up.
    """

    rows: np.ndarray  # int64 (m,)
    cols: np.ndarray  # int64 (m,)
    dfdx: np.ndarray  # (m, 3, 3)
    dfdv: np.ndarray  # (m, 3, 3)

    def dense(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        """Dense ``(3n, 3n)`` matrices ∂f/∂x and ∂f/∂v (for tests and small systems)."""
        dx = np.zeros((3 * n, 3 * n))
        dv = np.zeros((3 * n, 3 * n))
        for blocks, out in ((self.dfdx, dx), (self.dfdv, dv)):
            r = (3 * self.rows[:, None, None] + np.arange(3)[None, :, None]).repeat(3, axis=2)
            c = (3 * self.cols[:, None, None] + np.arange(3)[None, None, :]).repeat(3, axis=1)
            np.add.at(out, (r, c), blocks)
        return dx, dv


class FieldForce(Tracked, ABC):
    """A force that depends only on each particle's own velocity (folded into the kernel)."""

    #: Attributes this force reads; the system allocates them.
    reads: tuple[str, ...] = ("velocity",)

    @abstractmethod
    def terms(self) -> FieldTerms:
        """This force's contribution to the field coefficients."""

    def jacobian(self, velocity: np.ndarray, inv_mass: np.ndarray | None) -> ForceJacobian:
        """Derivatives of this force for live particles; ``velocity`` has shape (n, 3)."""
        n = velocity.shape[0]
        idx = np.arange(n)
        zeros = np.zeros((n, 3, 3))
        return ForceJacobian(idx, idx, zeros, zeros.copy())


class Force(ABC):
    """A force evaluated into the shared force buffer.

    Subclasses implement :meth:`accumulate`; those that can also implement
    :meth:`jacobian`. ``reads`` lists the attributes used, so the store allocates them.
    """

    reads: tuple[str, ...] = ("position",)

    def bind(self, store) -> None:
        """Called once when added to a system; allocate what the force needs."""
        store.require(*self.reads)

    @abstractmethod
    def accumulate(
        self, store, position: np.ndarray, velocity: np.ndarray, time: float, out: np.ndarray
    ) -> None:
        """Add this force [N] on each live particle into ``out``.

        Parameters
        ----------
        store : ParticleStore
            For other attributes (mass, ids); ``position`` and ``velocity`` may be
            trial states of a multi-stage integrator, so use them rather than the store's.
        position, velocity : arrays of shape (3, n)
            Particle positions [m] and velocities [m/s].
        time : float
            Simulation time [s].
        out : array of shape (3, n)
            Force accumulator [N].
        """

    def jacobian(self, store, position: np.ndarray, velocity: np.ndarray) -> ForceJacobian | None:
        """Block-sparse ∂f/∂x and ∂f/∂v, or None when this force has no Jacobian."""
        return None

    def remap(self, new_index: np.ndarray) -> None:  # noqa: B027 (optional hook)
        """Particles died and the store compacted; ``new_index[old] = new or -1``.

        Only forces that hold particle indices (springs) override this.
        """


def particle_mass(store, n: int, dtype) -> np.ndarray:
    """Masses [kg] of the first ``n`` particles, or an empty array meaning "all 1 kg".

    The empty array lets the kernels skip a memory pass over a vector of ones.
    """
    if store.has("mass"):
        return np.asarray(store.raw("mass")[:n], dtype=dtype)
    return np.empty(0, dtype=dtype)


def check_buffers(position: np.ndarray, out: np.ndarray) -> None:
    """Raise ``ValueError`` unless ``position`` is ``(3, n)`` and ``out`` matches it.

    Launchers pass such arrays to kernels row by row (``*position``): a row of the
    store's ``(3, capacity)`` buffer is contiguous, while the ``(3, n)`` slice itself is
    not, and a kernel compiled for a non-contiguous 2D array does not vectorise (3-6x
    slower here).
    """
    if position.ndim != 2 or position.shape[0] != 3:
        raise ValueError(f"position must have shape (3, n), got {position.shape}")
    if out.shape != position.shape:
        raise ValueError(f"out must have the shape of position {position.shape}, got {out.shape}")
