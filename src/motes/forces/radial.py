r"""Radial fields: softened inverse-square attractors and repellers, and linear pulls.

The inverse-square field is the softened gravitational acceleration of a point mass with
``strength = G M``: minus the gradient of the Plummer potential ``-s / sqrt(r^2 + ε^2)``
(Plummer 1911, MNRAS 71, 460; softening as used in N-body codes, Aarseth 2003,
*Gravitational N-Body Simulations*):

.. math:: a(x) = s \, (c - x) / (|c - x|^2 + ε^2)^{3/2}

The softening length ``ε`` keeps the acceleration finite at the centre (it peaks at
``|c - x| = ε / √2`` and falls linearly to 0 at the centre). The field is specified as an
acceleration and multiplied by each particle's mass, so the motion is mass independent.
"""

from __future__ import annotations

import numba
import numpy as np

from .. import _validate as check
from .._jit import block_bounds, block_count, parallel_kernel
from .base import Force, ForceJacobian, check_buffers, particle_mass

FALLOFFS = ("inverse_square", "linear")


class RadialField(Force):
    """Attractor (``strength > 0``) or repeller (``strength < 0``) centred on a point.

    Parameters
    ----------
    center : (3,) array_like
        Centre ``c`` of the field [m].
    strength : float
        ``s``. For ``falloff="inverse_square"`` it is ``G M`` [m^3/s^2]: the acceleration
        is ``s (c - x) / (|c - x|^2 + ε^2)^{3/2}`` [m/s^2]. For ``falloff="linear"`` it is
        a squared angular frequency [1/s^2]: the acceleration is ``s (c - x)``, a
        mass-independent spring to the centre (period ``2π / √s`` for ``s > 0``).
    softening : float
        Plummer softening length ``ε`` > 0 [m] (inverse-square falloff only).
    falloff : {"inverse_square", "linear"}
        Radial profile of the field.

    Notes
    -----
    The force on a particle of mass ``m`` [kg] is ``m a`` [N]; particles of a store
    without a ``mass`` attribute weigh 1 kg.
    """

    reads = ("position",)

    def __init__(
        self, center, strength: float, *, softening: float = 0.01, falloff: str = "inverse_square"
    ):
        self.center = check.vector("center", center)
        self.strength = check.real("strength", strength)
        self.softening = check.positive("softening", softening)
        self.falloff = check.choice("falloff", falloff, FALLOFFS)

    def __repr__(self) -> str:
        return (
            f"RadialField({self.center.tolist()}, {self.strength}, "
            f"softening={self.softening}, falloff={self.falloff!r})"
        )

    def accumulate(self, store, position, velocity, time, out) -> None:
        check_buffers(position, out)
        real = position.dtype.type
        center = self.center.astype(position.dtype)
        mass = particle_mass(store, position.shape[1], position.dtype)
        if self.falloff == "inverse_square":
            _inverse_square_kernel(
                *position, mass, center, real(self.strength), real(self.softening**2), *out
            )
        else:
            _linear_kernel(*position, mass, center, real(self.strength), *out)

    def jacobian(self, store, position, velocity) -> ForceJacobian:
        """Diagonal blocks ∂f_i/∂x_i [N/m] (float64); ∂f/∂v = 0.

        With ``r = x - c`` and ``D = |r|^2 + ε^2``, ``f = -m s r D^{-3/2}`` gives
        ``∂f/∂x = m s D^{-5/2} (3 r rᵀ - D I)``; the linear falloff gives ``-m s I``.
        """
        n = position.shape[1]
        r = np.asarray(position, dtype=np.float64).T - self.center  # (n, 3)
        mass = particle_mass(store, n, np.float64)
        mass = np.ones(n) if mass.shape[0] == 0 else mass
        eye = np.eye(3)
        if self.falloff == "inverse_square":
            d = np.einsum("ij,ij->i", r, r) + self.softening**2
            outer = r[:, :, None] * r[:, None, :]
            scale = mass * self.strength * d**-2.5
            dfdx = scale[:, None, None] * (3.0 * outer - d[:, None, None] * eye)
        else:
            dfdx = (-self.strength * mass)[:, None, None] * eye
        idx = np.arange(n)
        return ForceJacobian(idx, idx, dfdx, np.zeros((n, 3, 3)))


@parallel_kernel
def _inverse_square_kernel(x, y, z, mass, center, strength, softening2, out_x, out_y, out_z):
    """``out[:, i] += m_i s (c - x_i) / (|c - x_i|^2 + ε^2)^{3/2}``."""
    uniform = mass.shape[0] == 0
    n = x.shape[0]
    for block in numba.prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            dx = center[0] - x[i]
            dy = center[1] - y[i]
            dz = center[2] - z[i]
            d = dx * dx + dy * dy + dz * dz + softening2
            scale = strength / (d * np.sqrt(d))
            if not uniform:
                scale *= mass[i]
            out_x[i] += scale * dx
            out_y[i] += scale * dy
            out_z[i] += scale * dz


@parallel_kernel
def _linear_kernel(x, y, z, mass, center, strength, out_x, out_y, out_z):
    """``out[:, i] += m_i s (c - x_i)``."""
    uniform = mass.shape[0] == 0
    n = x.shape[0]
    for block in numba.prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            scale = strength
            if not uniform:
                scale *= mass[i]
            out_x[i] += scale * (center[0] - x[i])
            out_y[i] += scale * (center[1] - y[i])
            out_z[i] += scale * (center[2] - z[i])
