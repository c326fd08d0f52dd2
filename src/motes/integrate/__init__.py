"""Time integration: the schemes a system can use, and the kernels that run them."""

from __future__ import annotations

from enum import StrEnum

from .kernels import Scheme


class Integrator(StrEnum):
    """Integration scheme of a :class:`~motes.ParticleSystem`.

    ========================  ==================================================  =====
    value                     update (h = dt, a = a(x, v))                         order
    ========================  ==================================================  =====
    ``explicit_euler``        x += h v;  v += h a  (both from the old state)       1
    ``semi_implicit_euler``   v += h a;  x += h v  (new v moves x; symplectic)     1
    ``verlet``                x' = x + (x - x_prev)(1 - damping) + h² a            2
                              (position Verlet, Jakobsen 2001; v = (x' - x)/h)
    ``velocity_verlet``       x += h v + h²/2 a;  v += h/2 (a + a(x'))             2
    ``rk4``                   classical Runge-Kutta on (x, v)                      4
    ``implicit_euler``        (M - h ∂f/∂v - h² ∂f/∂x) Δv = h (f + h ∂f/∂x v)      1
                              (Baraff & Witkin 1998; see :mod:`.implicit`)
    ========================  ==================================================  =====

    Position Verlet is run in its velocity form: the stored velocity stands for
    ``(x - x_prev)/h`` and is updated to ``(x' - x)/h``, which is the same sequence of
    positions as Jakobsen's update, while letting collisions (and users) change
    velocities directly without a ``prev_position`` buffer.

    The first three run in the single fused kernel; the last two evaluate forces several
    times per step. For velocity-dependent forces, ``velocity_verlet`` evaluates ``a(x')``
    at the predicted velocity ``v + h a`` (exact for position-only forces); with forces
    of the positions alone a system carries that end acceleration to its next step, so
    the leapfrog then costs one evaluation per step.
    """

    EXPLICIT_EULER = "explicit_euler"
    SEMI_IMPLICIT_EULER = "semi_implicit_euler"
    VERLET = "verlet"
    VELOCITY_VERLET = "velocity_verlet"
    RK4 = "rk4"
    IMPLICIT_EULER = "implicit_euler"

    @property
    def fused_scheme(self) -> Scheme:
        """The scheme the fused kernel runs (NONE for multi-stage integrators)."""
        return _FUSED[self]


_FUSED = {
    Integrator.EXPLICIT_EULER: Scheme.EXPLICIT_EULER,
    Integrator.SEMI_IMPLICIT_EULER: Scheme.SEMI_IMPLICIT_EULER,
    Integrator.VERLET: Scheme.VERLET,
    Integrator.VELOCITY_VERLET: Scheme.NONE,
    Integrator.RK4: Scheme.NONE,
    Integrator.IMPLICIT_EULER: Scheme.NONE,
}


__all__ = ["Integrator", "Scheme"]
