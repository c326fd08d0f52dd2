"""Multi-stage integrators: velocity Verlet and RK4.

They advance ``position`` and ``velocity`` in place for the live particles; collisions,
ageing and kills then run in the fused kernel with ``Scheme.NONE``. Each stage calls
``acceleration(x, v, t, out)`` with ``(3, n)`` arrays.
"""

from __future__ import annotations

import numpy as np


def velocity_verlet(x, v, t, dt, acceleration, *, start=None) -> np.ndarray:
    """x' = x + h v + h²/2 a(x, v);  v' = v + h/2 (a(x, v) + a(x', v + h a)).

    ``start``: ``a(x, v)`` when the caller already has it (the end acceleration of the
    previous step, for forces of the position alone: then each step evaluates the forces
    once, not twice). Returns the end acceleration ``a(x', v + h a)`` (a new array).
    """
    if start is None:
        a0 = np.empty_like(x)
        acceleration(x, v, t, a0)
    else:
        a0 = start
    x += dt * v + (0.5 * dt * dt) * a0
    predicted = v + dt * a0
    a1 = np.empty_like(x)
    acceleration(x, predicted, t + dt, a1)
    v += (0.5 * dt) * (a0 + a1)
    return a1


def rk4(x, v, t, dt, acceleration) -> None:
    """Classical fourth-order Runge-Kutta on the first-order system (x' = v, v' = a)."""
    a = np.empty_like(x)
    acceleration(x, v, t, a)
    k1x, k1v = v.copy(), a.copy()
    acceleration(x + 0.5 * dt * k1x, v + 0.5 * dt * k1v, t + 0.5 * dt, a)
    k2x, k2v = v + 0.5 * dt * k1v, a.copy()
    acceleration(x + 0.5 * dt * k2x, v + 0.5 * dt * k2v, t + 0.5 * dt, a)
    k3x, k3v = v + 0.5 * dt * k2v, a.copy()
    acceleration(x + dt * k3x, v + dt * k3v, t + dt, a)
    k4x, k4v = v + dt * k3v, a
    x += (dt / 6) * (k1x + 2 * k2x + 2 * k3x + k4x)
    v += (dt / 6) * (k1v + 2 * k2v + 2 * k3v + k4v)
