r"""Vortex: swirl about an axis line, with an optional pull toward the axis.

The acceleration has the smoothed Rankine profile of the Scully (Kaufmann) vortex, the
``n = 1`` member of Vatistas, Kozel & Mih (1991), "A simpler model for concentrated
vortices", Experiments in Fluids 11, 73-76 (their tangential velocity profile, used
here as an acceleration):

.. math:: a(x) = \frac{s \, \hat a × r_⊥ - p \, r_⊥}{|r_⊥|^2 + R^2}

with ``r_⊥`` the offset of ``x`` from the axis line. The swirl's magnitude
``|s| ρ / (ρ^2 + R^2)`` (``ρ = |r_⊥|``) grows linearly in the core like a solid-body
rotation, peaks at ``ρ = R`` with ``|s| / (2R)``, and decays as ``1/ρ`` outside like a
free (potential) vortex; unlike the Rankine vortex it is smooth at ``ρ = R`` and finite
everywhere.
"""

from __future__ import annotations

import numba

from .. import _validate as check
from .._jit import block_bounds, block_count, parallel_kernel
from .base import Force, check_buffers, particle_mass


class Vortex(Force):
    """Swirl about the line through ``center`` along ``axis``.

    Parameters
    ----------
    center : (3,) array_like
        A point on the vortex axis [m].
    axis : (3,) array_like
        Direction of the axis (normalised here); positive ``strength`` swirls
        counter-clockwise seen from the tip of ``axis`` (right-hand rule).
    strength : float
        ``s`` [m^2/s^2]: tangential acceleration ``s ρ / (ρ^2 + R^2)`` at distance ``ρ``
        [m] from the axis; its peak is ``s / (2R)`` [m/s^2] at ``ρ = R``.
    radius : float
        Core radius ``R`` > 0 [m].
    pull : float
        ``p`` [m^2/s^2]: radial acceleration ``p ρ / (ρ^2 + R^2)`` toward the axis (away
        from it when negative). It has the tangential profile, so the field lines are
        logarithmic spirals that cross every circle about the axis at ``atan(p / s)``.

    Notes
    -----
    The field is an acceleration multiplied by each particle's mass (1 kg for stores
    without a ``mass`` attribute), so the motion is mass independent. Motion along the
    axis is left alone.
    """

    reads = ("position",)

    def __init__(self, center, axis, strength: float, *, radius: float = 1.0, pull: float = 0.0):
        self.center = check.vector("center", center)
        self.axis = check.unit_vector("axis", axis)
        self.strength = check.real("strength", strength)
        self.radius = check.positive("radius", radius)
        self.pull = check.real("pull", pull)

    def __repr__(self) -> str:
        return (
            f"Vortex({self.center.tolist()}, {self.axis.tolist()}, {self.strength}, "
            f"radius={self.radius}, pull={self.pull})"
        )

    def accumulate(self, store, position, velocity, time, out) -> None:
        check_buffers(position, out)
        real = position.dtype.type
        _vortex_kernel(
            *position,
            particle_mass(store, position.shape[1], position.dtype),
            self.center.astype(position.dtype),
            self.axis.astype(position.dtype),
            real(self.strength),
            real(self.pull),
            real(self.radius**2),
            *out,
        )


@parallel_kernel
def _vortex_kernel(x, y, z, mass, center, axis, strength, pull, radius2, out_x, out_y, out_z):
    """``out[:, i] += m_i (s â × r_⊥ - p r_⊥) / (|r_⊥|^2 + R^2)``."""
    uniform = mass.shape[0] == 0
    one = x.dtype.type(1)  # a float64 literal would promote float32 arithmetic
    ax, ay, az = axis[0], axis[1], axis[2]
    n = x.shape[0]
    for block in numba.prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            rx = x[i] - center[0]
            ry = y[i] - center[1]
            rz = z[i] - center[2]
            along = rx * ax + ry * ay + rz * az
            px = rx - along * ax
            py = ry - along * ay
            pz = rz - along * az
            scale = one / (px * px + py * py + pz * pz + radius2)
            if not uniform:
                scale *= mass[i]
            out_x[i] += scale * (strength * (ay * pz - az * py) - pull * px)
            out_y[i] += scale * (strength * (az * px - ax * pz) - pull * py)
            out_z[i] += scale * (strength * (ax * py - ay * px) - pull * pz)
