"""Smoothing kernels of Müller, Charypar & Gross (2003), "Particle-based fluid simulation
for interactive applications", SCA 2003, and the density a wall contributes to them.

All kernels have support radius ``h`` [m] and are normalised so that their integral over
space is 1 [1/m³ each, gradients 1/m⁴, Laplacians 1/m⁵]:

- poly6 (eq. 20): ``W(r) = 315 / (64 π h⁹) (h² - r²)³``, for densities;
- spiky (eq. 21): ``W(r) = 15 / (π h⁶) (h - r)³``, whose gradient
  ``∇W = -45 / (π h⁶) (h - r)² r̂`` does not vanish at ``r = 0`` (pressure);
- viscosity (eq. 22): ``W(r) = 15 / (2π h³) (-r³/2h³ + r²/h² + h/2r - 1)``, whose
  Laplacian ``∇²W = 45 / (π h⁶) (h - r)`` is positive everywhere.

Each is a device function (inlined into kernels, callable from Python for tests).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import device

POLY6 = 315.0 / (64.0 * math.pi)
SPIKY = 15.0 / math.pi
SPIKY_GRAD = -45.0 / math.pi
VISCOSITY = 15.0 / (2.0 * math.pi)
VISCOSITY_LAP = 45.0 / math.pi


@device
def poly6(r2, h):
    """Poly6 kernel [1/m³] at squared distance ``r2`` [m²]; 0 beyond ``h``."""
    d = max(h * h - r2, 0.0)
    return POLY6 / h**9 * d * d * d


@device
def spiky(r, h):
    """Spiky kernel [1/m³] at distance ``r`` [m]."""
    d = max(h - r, 0.0)
    return SPIKY / h**6 * d * d * d


@device
def spiky_gradient_scale(r, h):
    """``s`` with ``∇W_spiky(r⃗) = s · r⃗`` [1/m⁵] (0 at r = 0 and beyond h)."""
    d = max(h - r, 0.0)
    return SPIKY_GRAD / h**6 * d * d / max(r, 1e-30 * h) * (r > 0.0)


@device
def poly6_shape(q2):
    """``(1 - q²)³`` in float32 at ``q2 = r² / h²`` (float32), 0 beyond ``h``:
    ``W_poly6(r) = POLY6 / h³ · poly6_shape(r² / h²)``.

    The kernels' pair loops compute in float32 (eight lanes a vector rather than four)
    from dimensionless shapes, and scale the float64 sums by the units afterwards: the
    shapes stay within [0, 1] whatever ``h``, where ``POLY6 / h⁹`` alone leaves float32's
    range below h = 0.06 mm.
    """
    d = max(np.float32(1.0) - q2, np.float32(0.0))
    return d * d * d


@device
def spiky_gradient_shape(q):
    """``(1 - q)² / q`` in float32 at ``q = r / h`` (float32), 0 at ``q = 0`` and beyond 1:
    ``∇W_spiky(r⃗) = SPIKY_GRAD / h⁵ · spiky_gradient_shape(r / h) · r⃗`` [1/m⁴]."""
    zero = np.float32(0.0)
    d = max(np.float32(1.0) - q, zero)
    return d * d / max(q, np.float32(1e-30)) * np.float32(q > zero)


@device
def viscosity(r, h):
    """Viscosity kernel [1/m³] at distance ``r`` > 0 [m]."""
    if r >= h:
        return 0.0
    q = r / h
    return VISCOSITY / h**3 * (-0.5 * q * q * q + q * q + 0.5 / q - 1.0)


@device
def viscosity_laplacian(r, h):
    """Laplacian of the viscosity kernel [1/m⁵] at distance ``r`` [m]."""
    return VISCOSITY_LAP / h**6 * max(h - r, 0.0)


@device
def wall_fraction(d, h):
    """Integral of poly6 over the half-space beyond a wall at distance ``d`` [m].

    With ``u = d / h`` the plane slices of poly6 integrate to
    ``315 / (256 h) (1 - u²)⁴``, so the fraction is
    ``315/256 · (128/315 - (u - 4u³/3 + 6u⁵/5 - 4u⁷/7 + u⁹/9))``: 1/2 at the wall, 0 at
    ``d >= h``. A particle at ``d`` from a flat wall misses that fraction of its
    neighbourhood; the solver counts it as wall at rest density.
    """
    u = min(max(d / h, 0.0), 1.0)
    u2 = u * u
    f = u * (1.0 + u2 * (-4.0 / 3.0 + u2 * (6.0 / 5.0 + u2 * (-4.0 / 7.0 + u2 / 9.0))))
    return 315.0 / 256.0 * (128.0 / 315.0 - f)


@device
def wall_fraction_slope(d, h):
    """Derivative of :func:`wall_fraction` with respect to ``d`` [1/m]."""
    u = min(max(d / h, 0.0), 1.0)
    a = 1.0 - u * u
    return -315.0 / (256.0 * h) * a * a * a * a


@device
def wall_share(d, spacing, h, scale):
    """The fraction of the rest density a wall at distance ``d`` [m] stands for, and its
    derivative with respect to ``d`` [1/m].

    The wall stands for the rest lattice continued beyond it: planes of particles
    ``spacing`` apart, the first half a spacing behind the wall (where a block made by
    ``lattice`` would have its next layer), each plane smeared over its area. A plane at
    distance ``u`` holds ``spacing · 315 / (256 h) (1 - u²/h²)⁴`` of the kernel (poly6
    integrated over the plane, one plane per ``spacing``), so the share is the midpoint
    rule of :func:`wall_fraction` with nodes at the lattice's planes; ``scale`` [-] (from
    :func:`wall_scale`: 0.98 at ``h`` = 2 spacings, 1.11 at 1.5) corrects the smearing so
    that a particle of the rest lattice touching the wall reads exactly ``δ₀``. The continuous
    :func:`wall_fraction` instead over-counts a particle at half a spacing by 2.6 % of
    ``δ₀`` at ``h`` = 2 spacings (5.8 % at 1.5), which pushed the layers along every
    wall apart.
    """
    c = scale * 315.0 / (256.0 * h) * spacing
    share = 0.0
    slope = 0.0
    u = max(d, 0.0) + 0.5 * spacing
    while u < h:
        a = 1.0 - u * u / (h * h)
        share += a * a * a * a
        slope -= 8.0 * u / (h * h) * a * a * a
        u += spacing
    return c * share, c * slope


def wall_scale(spacing: float, h: float) -> float:
    """``scale`` of :func:`wall_share` [-]: the part of a particle's rest lattice sum
    that lies beyond a wall half a spacing away (the lattice's rows there) as a fraction
    of ``δ₀``, over the smeared planes' share at that distance."""
    reach = math.ceil(h / spacing)
    k = np.arange(-reach, reach + 1, dtype=np.float64) * spacing
    x, y, z = np.meshgrid(k, k, k, indexing="ij")
    w = POLY6 / h**9 * np.maximum(h * h - (x * x + y * y + z * z), 0.0) ** 3
    delta0 = w.sum()
    missing = w[y < -0.5 * spacing].sum()
    u = np.arange(1, reach + 1) * spacing
    planes = (np.maximum(1.0 - u * u / (h * h), 0.0) ** 4).sum() * 315.0 / (256.0 * h) * spacing
    return float(missing / (delta0 * planes))


def lattice_number_density(spacing: float, h: float) -> float:
    """``Σ_k W_poly6(|x_k|)`` [1/m³] over a cubic lattice of ``spacing`` [m], self included.

    The number density of fluid at rest sampled on the solver's own lattice: the
    solver's constraint is ``δ / δ₀ = 1`` with this ``δ₀``, so a resting block of
    particles at that spacing is exactly at rest density (the lattice sum differs from
    ``1 / spacing³`` by the kernel's discretisation error, about 1 % at h = 2 spacings).
    """
    reach = math.ceil(h / spacing)
    k = np.arange(-reach, reach + 1, dtype=np.float64) * spacing
    x, y, z = np.meshgrid(k, k, k, indexing="ij")
    r2 = x * x + y * y + z * z
    return float((POLY6 / h**9 * np.maximum(h * h - r2, 0.0) ** 3).sum())
