r"""Compiled cloth passes: aerodynamic forces and collisions.

All take float64 ``(3, n)`` rows (``*position``) like the implicit solver they feed.
Per-triangle quantities are gathered per vertex through a vertex -> triangle CSR list
(``first``, ``tris``), never scattered, so results do not depend on the thread count.
Strain limiting is in :mod:`motes.cloth.strain`.
"""

from __future__ import annotations

import numba
import numpy as np

from .._jit import block_bounds, block_count, device, parallel_kernel
from ..collide.response import respond
from ..geometry.distance import row_signed_distance
from ..geometry.layout import FRICTION_MODEL, RESPONSE


@device
def _gust(t, frequencies, phases, amplitude):
    """``1 + amplitude · mean_i sin(2π f_i t + φ_i)``: the wind's relative strength."""
    g = 0.0
    count = frequencies.shape[0]
    for i in range(count):
        g += np.sin(2.0 * np.pi * frequencies[i] * t + phases[i])
    if count:
        g /= count
    return 1.0 + amplitude * g


@parallel_kernel
def aero_triangle_kernel(x, y, z, vx, vy, vz, faces, wind, air, time, frequencies, phases, out):
    """Drag and lift on each triangle [N], written to ``out`` (3, f).

    ``wind`` = (u_x, u_y, u_z) [m/s]; ``air`` = (ρ [kg/m³], C_d, C_l, gust amplitude).
    The wind at a triangle's centroid ``c`` is ``u · g(t - (c·û)/|u|)``: gusts travel
    with the wind, so different parts of a flag feel them at different times.

    With relative wind ``w = u_c - v_tri`` (``v_tri`` the mean vertex velocity), unit
    normal ``n`` turned to face ``w``, ``cos θ = n·ŵ`` and area ``A`` (Keckeisen et al.
    2004, "Interactive cloth simulation in virtual environments"; the flat-plate forces)::

        drag = ½ ρ C_d A |w|² cos θ ŵ               (projected area facing the wind)
        lift = ½ ρ C_l A |w|² cos θ (n - cos θ ŵ)   (|n - cos θ ŵ| = sin θ)

    Lift vanishes face-on and edge-on and pushes a tilted panel across the wind: with
    the cloth's own dynamics this is what makes a flag flutter rather than just lean.
    """
    f = faces.shape[0]
    speed = np.sqrt(wind[0] * wind[0] + wind[1] * wind[1] + wind[2] * wind[2])
    inv_speed = 1.0 / speed if speed > 0.0 else 0.0
    half_rho = 0.5 * air[0]
    for block in numba.prange(block_count(f)):
        start, stop = block_bounds(block, f)
        for t in range(start, stop):
            a = faces[t, 0]
            b = faces[t, 1]
            c = faces[t, 2]
            ex = x[b] - x[a]
            ey = y[b] - y[a]
            ez = z[b] - z[a]
            gx = x[c] - x[a]
            gy = y[c] - y[a]
            gz = z[c] - z[a]
            nx = ey * gz - ez * gy
            ny = ez * gx - ex * gz
            nz = ex * gy - ey * gx
            twice_area = np.sqrt(nx * nx + ny * ny + nz * nz)
            cx = (x[a] + x[b] + x[c]) / 3.0
            cy = (y[a] + y[b] + y[c]) / 3.0
            cz = (z[a] + z[b] + z[c]) / 3.0
            lag = (cx * wind[0] + cy * wind[1] + cz * wind[2]) * inv_speed * inv_speed
            g = _gust(time - lag, frequencies, phases, air[3])
            wx = g * wind[0] - (vx[a] + vx[b] + vx[c]) / 3.0
            wy = g * wind[1] - (vy[a] + vy[b] + vy[c]) / 3.0
            wz = g * wind[2] - (vz[a] + vz[b] + vz[c]) / 3.0
            w2 = wx * wx + wy * wy + wz * wz
            if twice_area <= 0.0 or w2 <= 0.0:
                out[0, t] = 0.0
                out[1, t] = 0.0
                out[2, t] = 0.0
                continue
            w = np.sqrt(w2)
            nx /= twice_area
            ny /= twice_area
            nz /= twice_area
            cos = (nx * wx + ny * wy + nz * wz) / w
            if cos < 0.0:
                nx = -nx
                ny = -ny
                nz = -nz
                cos = -cos
            scale = half_rho * 0.5 * twice_area * w2 * cos
            drag = scale * air[1] / w
            lift = scale * air[2]
            out[0, t] = drag * wx + lift * (nx - cos * wx / w)
            out[1, t] = drag * wy + lift * (ny - cos * wy / w)
            out[2, t] = drag * wz + lift * (nz - cos * wz / w)


@parallel_kernel
def gather_triangles_kernel(tri_force, first, tris, out_x, out_y, out_z):
    """``out[:, i] +=`` a third of the force of each triangle of vertex ``i``."""
    n = first.shape[0] - 1
    for block in numba.prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            sx = 0.0
            sy = 0.0
            sz = 0.0
            for j in range(first[i], first[i + 1]):
                t = tris[j]
                sx += tri_force[0, t]
                sy += tri_force[1, t]
                sz += tri_force[2, t]
            out_x[i] += sx / 3.0
            out_y[i] += sy / 3.0
            out_z[i] += sz / 3.0


@parallel_kernel
def collide_kernel(x, y, z, vx, vy, vz, movable, table, dt):
    """Push movable particles out of every collider and apply its velocity response.

    ``table`` (k, ROW) float64: packed collider rows (:mod:`motes.geometry.layout`,
    thickness already added, :func:`motes.geometry.layout.grown`), whose kind, inside,
    response and friction model are read at run time so one compiled kernel serves any
    set of colliders. Same distance and response functions as the fused particle kernel
    (:func:`motes.geometry.distance.signed_distance`,
    :func:`motes.collide.response.respond`). Writes in place.
    """
    n = x.shape[0]
    k = table.shape[0]
    one = 1.0
    for block in numba.prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            if not movable[i]:
                continue
            px = x[i]
            py = y[i]
            pz = z[i]
            ux = vx[i]
            uy = vy[i]
            uz = vz[i]
            for c in range(k):
                dist, nx, ny, nz = row_signed_distance(table, c, px, py, pz, one)
                if dist < 0.0:
                    px, py, pz, ux, uy, uz, _, _ = respond(
                        int(table[c, RESPONSE]),
                        int(table[c, FRICTION_MODEL]),
                        px,
                        py,
                        pz,
                        ux,
                        uy,
                        uz,
                        -dist,
                        nx,
                        ny,
                        nz,
                        table,
                        c,
                        dt,
                        one,
                    )
            x[i] = px
            y[i] = py
            z[i] = pz
            vx[i] = ux
            vy[i] = uy
            vz[i] = uz
