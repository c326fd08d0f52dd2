"""Where air is mixed into a liquid: Ihmsen et al.'s (2012) potentials for foam and spray.

"Unified spray, foam and bubbles for particle-based fluids" (Ihmsen, Akinci, Akinci &
Teschner, The Visual Computer 28, 2012) measures, per particle and from its neighbours
within the kernel support ``h``,

- the *trapped-air* potential: neighbours moving toward or past each other at speed,
  ``sum_j |v_ij| (1 - v̂_ij · x̂_ij) W(x_ij)``, large where a jet plunges into a pool or a
  wave folds over;
- the *wave-crest* potential: the surface's convexity, ``sum_j (1 - n̂_i · n̂_j) W(x_ij)``
  over surface neighbours behind the tangent plane (``x̂_ji · n̂_i < 0``), counted only
  where the particle moves out along its normal (``v̂_i · n̂_i >= 0.6``);
- the kinetic energy per unit mass, ``|v|^2 / 2``;

with ``W(x) = 1 - |x| / h`` and the surface normal ``n̂_i`` the normalised
``sum_j x_ij W(x_ij)`` (pointing out of the liquid) where that sum exceeds a tenth of
``h sum_j W(x_ij)`` (none inside the liquid, where the offsets cancel). Where Ihmsen et
al. spawn new diffuse particles at a rate ``Φ(E_k) (k_ta Φ(I_ta) + k_wc Φ(I_wc))``, motes marks the
liquid's own particles with that product (each Φ clamped to [0, 1] between two
thresholds) as a foam value, which the renderer draws as white froth.
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from .. import _validate as check
from .._jit import parallel_kernel
from ..spatial.grid import UniformGrid


@parallel_kernel
def _potentials(x, y, z, vx, vy, vz, offsets, indices, h, trapped, crest):
    n = x.shape[0]
    inv_h = np.float32(1.0) / h
    zero = np.float32(0.0)
    one = np.float32(1.0)
    normals = np.zeros((3, n), np.float32)
    for i in prange(n):
        sx = sy = sz = zero
        air = weights = zero
        for k in range(offsets[i], offsets[i + 1]):
            j = indices[k]
            dx, dy, dz = x[i] - x[j], y[i] - y[j], z[i] - z[j]
            r = math.sqrt(dx * dx + dy * dy + dz * dz)
            w = max(one - r * inv_h, zero)
            weights += w
            sx += dx * w
            sy += dy * w
            sz += dz * w
            ux, uy, uz = vx[i] - vx[j], vy[i] - vy[j], vz[i] - vz[j]
            u = math.sqrt(ux * ux + uy * uy + uz * uz)
            if u > zero and r > zero:
                # 1 - cos of the angle between the relative velocity and the offset: 0 for
                # particles moving apart along their line, 2 for head-on.
                facing = one - (ux * dx + uy * dy + uz * dz) / (u * r)
                air += u * facing * w
        trapped[i] = air
        length = math.sqrt(sx * sx + sy * sy + sz * sz)
        # Inside the liquid the offsets cancel out: only a particle whose neighbours lie
        # to one side (the mean offset over a tenth of h) is on the surface.
        if length > np.float32(0.1) * h * weights:
            normals[0, i], normals[1, i], normals[2, i] = sx / length, sy / length, sz / length
    for i in prange(n):
        nx, ny, nz = normals[0, i], normals[1, i], normals[2, i]
        speed = math.sqrt(vx[i] * vx[i] + vy[i] * vy[i] + vz[i] * vz[i])
        outward = speed > zero and (vx[i] * nx + vy[i] * ny + vz[i] * nz) >= 0.6 * speed
        curve = zero
        if outward:
            for k in range(offsets[i], offsets[i + 1]):
                j = indices[k]
                dx, dy, dz = x[j] - x[i], y[j] - y[i], z[j] - z[i]
                mx, my, mz = normals[0, j], normals[1, j], normals[2, j]
                on_surface = mx * mx + my * my + mz * mz > zero
                # a surface neighbour behind the tangent plane: the surface bends away
                if on_surface and dx * nx + dy * ny + dz * nz < zero:
                    r = math.sqrt(dx * dx + dy * dy + dz * dz)
                    w = max(one - r * inv_h, zero)
                    curve += (one - (nx * mx + ny * my + nz * mz)) * w
        crest[i] = curve


def potentials(positions, velocities, h: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Trapped-air [m/s], wave-crest [1] and kinetic-energy [m^2/s^2] potentials, each
    (n,) float32, of particles at ``positions`` (3, n) [m] moving at ``velocities``
    (3, n) [m/s], over neighbours within ``h`` [m] (see the module docstring)."""
    h = check.positive("h", h)
    pos = np.ascontiguousarray(positions, dtype=np.float32)
    vel = np.ascontiguousarray(velocities, dtype=np.float32)
    if pos.ndim != 2 or pos.shape[0] != 3 or vel.shape != pos.shape:
        raise ValueError(
            f"positions and velocities must both have shape (3, n), got {pos.shape} and {vel.shape}"
        )
    n = pos.shape[1]
    trapped = np.zeros(n, np.float32)
    crest = np.zeros(n, np.float32)
    if n:
        lists = UniformGrid(h).build(pos).neighbors(h)
        _potentials(*pos, *vel, lists.offsets, lists.indices, np.float32(h), trapped, crest)
    kinetic = 0.5 * (vel * vel).sum(axis=0)
    return trapped, crest, kinetic


def ramp(values, low: float, high: float) -> np.ndarray:
    """Ihmsen et al.'s clamp Φ: 0 at or below ``low``, 1 at or above ``high``, linear
    between (``low < high``)."""
    if not low < high:
        raise ValueError(f"foam thresholds need low < high, got [{low}, {high}]")
    return np.clip((np.asarray(values, np.float32) - low) / (high - low), 0.0, 1.0)


def foam(positions, velocities, h: float, *, trapped_air=(2.0, 8.0), wave_crest=(0.5, 2.0),
         kinetic=(0.5, 4.0)) -> np.ndarray:  # fmt: skip
    """Foam value in [0, 1] per particle: ``Φ(E_k) · min(1, Φ(I_ta) + Φ(I_wc))`` with
    each Φ between the given ``(low, high)`` thresholds of :func:`potentials`' units."""
    ta, wc, ek = potentials(positions, velocities, h)
    mixed = np.minimum(ramp(ta, *trapped_air) + ramp(wc, *wave_crest), 1.0)
    return (ramp(ek, *kinetic) * mixed).astype(np.float32)
