"""Velocity-only forces: gravity, drag and wind.

These are folded into :class:`~motes.forces.base.FieldTerms` and evaluated inline by
the fused integration kernel, so adding them costs no extra pass over memory.
"""

from __future__ import annotations

import numpy as np

from .. import _validate as check
from .base import FieldForce, FieldTerms, ForceJacobian


class Gravity(FieldForce):
    """Uniform acceleration, independent of mass.

    Parameters
    ----------
    acceleration : (3,) array_like
        [m/s^2]; y is up, so Earth gravity is ``(0, -9.81, 0)``. Buoyant fire uses a
        positive y.
    """

    reads = ()

    def __init__(self, acceleration=(0.0, -9.81, 0.0)):
        self.acceleration = check.vector("acceleration", acceleration)

    def terms(self) -> FieldTerms:
        return FieldTerms(gravity=tuple(self.acceleration.tolist()))

    def __repr__(self) -> str:
        return f"Gravity({self.acceleration.tolist()})"


class Drag(FieldForce):
    """Linear (Stokes) drag toward a wind velocity: ``f = -k (v - wind)`` [N].

    Parameters
    ----------
    coefficient : float
        ``k`` >= 0 [kg/s]. With mass 1 kg, ``1/k`` is the velocity relaxation time [s].
    wind : (3,) array_like
        Velocity of the surrounding air [m/s]; particles relax toward it.
    """

    def __init__(self, coefficient: float, *, wind=(0.0, 0.0, 0.0)):
        self.coefficient = check.non_negative("coefficient", coefficient)
        self.wind = check.vector("wind", wind)

    def terms(self) -> FieldTerms:
        return FieldTerms(
            linear_drag=self.coefficient,
            linear_drag_wind=tuple((self.coefficient * self.wind).tolist()),
        )

    def jacobian(self, velocity, inv_mass=None) -> ForceJacobian:
        n = velocity.shape[0]
        idx = np.arange(n)
        dfdv = np.broadcast_to(-self.coefficient * np.eye(3), (n, 3, 3)).copy()
        return ForceJacobian(idx, idx, np.zeros((n, 3, 3)), dfdv)


class Wind(Drag):
    """Air moving at ``velocity`` [m/s], acting by linear drag of ``coefficient`` [kg/s]."""

    def __init__(self, velocity, *, coefficient: float = 1.0):
        super().__init__(coefficient, wind=velocity)


class QuadraticDrag(FieldForce):
    """Quadratic (Newtonian) drag: ``f = -c |v - wind| (v - wind)`` [N].

    Parameters
    ----------
    coefficient : float
        ``c = ½ ρ C_d A`` >= 0 [kg/m].
    wind : (3,) array_like
        Velocity of the air [m/s].
    """

    def __init__(self, coefficient: float, *, wind=(0.0, 0.0, 0.0)):
        self.coefficient = check.non_negative("coefficient", coefficient)
        self.wind = check.vector("wind", wind)

    def terms(self) -> FieldTerms:
        return FieldTerms(quadratic_drag=self.coefficient, quadratic_wind=tuple(self.wind.tolist()))

    def jacobian(self, velocity, inv_mass=None) -> ForceJacobian:
        # d/du (-c |u| u) = -c (|u| I + u uᵀ / |u|), u = v - wind
        u = np.asarray(velocity, dtype=np.float64) - self.wind
        speed = np.linalg.norm(u, axis=1)
        safe = np.where(speed > 0, speed, 1.0)
        outer = u[:, :, None] * u[:, None, :] / safe[:, None, None]
        dfdv = -self.coefficient * (speed[:, None, None] * np.eye(3) + outer)
        n = u.shape[0]
        idx = np.arange(n)
        return ForceJacobian(idx, idx, np.zeros((n, 3, 3)), dfdv)
