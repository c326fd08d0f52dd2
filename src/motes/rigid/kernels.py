"""The compiled position-Verlet step of a rigid world (Jakobsen 2001, eq. 1)."""

from __future__ import annotations

import numba

from .._jit import block_bounds, block_count, parallel_kernel


@parallel_kernel
def verlet(px, py, pz, qx, qy, qz, inv_mass, gx, gy, gz, keep, h2):
    """``x' = x + keep (x - x*) + h² g``; ``x* <- x`` (previous positions ``q``).

    ``keep = exp(-damping h)`` damps the velocity ``(x - x*)/h``. Particles with zero
    inverse mass (pinned, static) stay where they are.
    """
    n = px.shape[0]
    for b in numba.prange(block_count(n)):
        start, stop = block_bounds(b, n)
        for p in range(start, stop):
            moving = inv_mass[p] > 0.0
            x = px[p] + moving * (keep * (px[p] - qx[p]) + h2 * gx)
            y = py[p] + moving * (keep * (py[p] - qy[p]) + h2 * gy)
            z = pz[p] + moving * (keep * (pz[p] - qz[p]) + h2 * gz)
            qx[p] = px[p]
            qy[p] = py[p]
            qz[p] = pz[p]
            px[p] = x
            py[p] = y
            pz[p] = z
