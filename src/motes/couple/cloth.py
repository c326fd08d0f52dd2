"""Emitter particles against a cloth, momentum passing both ways (rain on a flag).

After an emitter system moves, each particle's path over the step, the segment from
``x - v Δt`` to ``x``, is tested against the cloth's triangles as they are now
(Möller & Trumbore 1997); a particle whose path crosses none but that ends closer than
``thickness`` to the cloth touches it too (a drop resting on a sagging sheet). A
touching particle is put back on its own side at ``thickness`` from the surface, and the
particle and the three vertices of the triangle exchange an impulse ``J`` at the contact
point, whose barycentric weights ``w`` spread it over the vertices (Bridson, Fedkiw &
Anderson 2002, §7.1):

- normal: ``j_n = -(1 + e) v_n / (1/m_p + Σ w_k² / m_k)`` when approaching, where ``v_n``
  is the normal velocity of the particle relative to the cloth point;
- tangent: Coulomb friction, ``|j_t| <= μ j_n``, never reversing the sliding;
- the particle gets ``+J / m_p``, vertex ``k`` gets ``-w_k J / m_k``. Since ``Σ w_k = 1``
  the total momentum of particle and cloth is unchanged (pinned vertices, of infinite
  mass, take what they are given from the world).

The impulses are applied serially in particle order (no two particles race for a
vertex, and the result does not depend on the thread count); detection, the costly
part, runs in parallel blocks over a triangle grid rebuilt every step. The cloth is
taken at its state at the start of the exchange: a scene steps its emitter systems
before its bodies (``docs/architecture.md``), so the cloth integrates the impulses in
the same substep.
"""

from __future__ import annotations

import numpy as np
from numba import prange

from .. import _validate as check
from .._jit import block_bounds, block_count, device, parallel_kernel, serial_kernel
from ..collide.between import KindContact
from ..geometry.distance import closest_on_triangle, segment_triangle, triangle_normal
from ..spatial.triangles import TriangleGrid

RESPONSES = ("bounce", "kill")


@device
def _cell_span(lo, hi, origin, inv_cell, dim):
    """First and last cell index a coordinate interval overlaps (may be empty)."""
    return int(np.floor((lo - origin) * inv_cell)), min(
        int(np.floor((hi - origin) * inv_cell)), dim - 1
    )


@parallel_kernel
def _detect(
    n, x, v, dt, tri, origin, inv_cell, dims, cell_start, cell_tris, thickness, out_t, out_p, out_n
):
    """Per particle: the triangle touched (or -1), the contact point and the normal
    toward the particle's own side."""
    for block in prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            px, py, pz = float(x[0, i]), float(x[1, i]), float(x[2, i])
            dx, dy, dz = float(v[0, i]) * dt, float(v[1, i]) * dt, float(v[2, i]) * dt
            qx, qy, qz = px - dx, py - dy, pz - dz
            i0, i1 = _cell_span(min(px, qx) - thickness, max(px, qx) + thickness,
                                origin[0], inv_cell, dims[0])  # fmt: skip
            j0, j1 = _cell_span(min(py, qy) - thickness, max(py, qy) + thickness,
                                origin[1], inv_cell, dims[1])  # fmt: skip
            k0, k1 = _cell_span(min(pz, qz) - thickness, max(pz, qz) + thickness,
                                origin[2], inv_cell, dims[2])  # fmt: skip
            out_t[i] = -1
            if i1 < 0 or j1 < 0 or k1 < 0:
                continue
            i0, j0, k0 = max(i0, 0), max(j0, 0), max(k0, 0)
            best_s = np.inf
            best_t = -1
            near_d2 = thickness * thickness
            near_t = -1
            cx = cy = cz = 0.0
            for a in range(i0, i1 + 1):
                for b in range(j0, j1 + 1):
                    for c in range(k0, k1 + 1):
                        cell = (a * dims[1] + b) * dims[2] + c
                        for e in range(cell_start[cell], cell_start[cell + 1]):
                            t = cell_tris[e]
                            s = segment_triangle(qx, qy, qz, dx, dy, dz, tri, t)
                            if s < best_s:
                                best_s, best_t = s, t
                            if best_t < 0:
                                hx, hy, hz = closest_on_triangle(px, py, pz, tri, t)
                                d2 = (px - hx) ** 2 + (py - hy) ** 2 + (pz - hz) ** 2
                                if d2 < near_d2:
                                    near_d2, near_t = d2, t
                                    cx, cy, cz = hx, hy, hz
            if best_t >= 0:
                fx, fy, fz = triangle_normal(tri, best_t)
                side = -1.0 if dx * fx + dy * fy + dz * fz > 0.0 else 1.0
                out_t[i] = best_t
                out_p[0, i], out_p[1, i], out_p[2, i] = (
                    qx + best_s * dx,
                    qy + best_s * dy,
                    qz + best_s * dz,
                )
                out_n[0, i], out_n[1, i], out_n[2, i] = side * fx, side * fy, side * fz
            elif near_t >= 0:
                fx, fy, fz = triangle_normal(tri, near_t)
                dist = np.sqrt(near_d2)
                if dist > 1e-9 * thickness:
                    fx, fy, fz = (px - cx) / dist, (py - cy) / dist, (pz - cz) / dist
                elif (qx - cx) * fx + (qy - cy) * fy + (qz - cz) * fz < 0.0:
                    fx, fy, fz = -fx, -fy, -fz
                out_t[i] = near_t
                out_p[0, i], out_p[1, i], out_p[2, i] = cx, cy, cz
                out_n[0, i], out_n[1, i], out_n[2, i] = fx, fy, fz


@device
def _barycentric(px, py, pz, tri, t):
    """Weights (w0, w1, w2) of a point on (or near) triangle ``t`` (Ericson 2005 §3.4)."""
    e0x, e0y, e0z = tri[t, 3] - tri[t, 0], tri[t, 4] - tri[t, 1], tri[t, 5] - tri[t, 2]
    e1x, e1y, e1z = tri[t, 6] - tri[t, 0], tri[t, 7] - tri[t, 1], tri[t, 8] - tri[t, 2]
    e2x, e2y, e2z = px - tri[t, 0], py - tri[t, 1], pz - tri[t, 2]
    d00 = e0x * e0x + e0y * e0y + e0z * e0z
    d01 = e0x * e1x + e0y * e1y + e0z * e1z
    d11 = e1x * e1x + e1y * e1y + e1z * e1z
    d20 = e2x * e0x + e2y * e0y + e2z * e0z
    d21 = e2x * e1x + e2y * e1y + e2z * e1z
    denom = d00 * d11 - d01 * d01
    if denom <= 0.0:
        return 1.0 / 3.0, 1.0 / 3.0, 1.0 / 3.0
    w1 = min(max((d11 * d20 - d01 * d21) / denom, 0.0), 1.0)
    w2 = min(max((d00 * d21 - d01 * d20) / denom, 0.0), 1.0 - w1)
    return 1.0 - w1 - w2, w1, w2


@device
def _push(cloth_v, k, share, jx, jy, jz):
    """Vertex ``k`` takes its share of the reaction ``-J``."""
    cloth_v[0, k] -= jx * share
    cloth_v[1, k] -= jy * share
    cloth_v[2, k] -= jz * share


@serial_kernel
def _respond(
    n, x, v, mass, mass_stride, faces, tri, cloth_v, cloth_inv_m, hit_t, hit_p, hit_n,
    restitution, friction, thickness, kill, keep, hits, track, hit_index,
):  # fmt: skip
    """Exchange impulses in particle order; returns the number of particles killed."""
    killed = 0
    for i in range(n):
        t = hit_t[i]
        if t < 0:
            continue
        px, py, pz = hit_p[0, i], hit_p[1, i], hit_p[2, i]
        nx, ny, nz = hit_n[0, i], hit_n[1, i], hit_n[2, i]
        w0, w1, w2 = _barycentric(px, py, pz, tri, t)
        a, b, c = faces[t, 0], faces[t, 1], faces[t, 2]
        ux = w0 * cloth_v[0, a] + w1 * cloth_v[0, b] + w2 * cloth_v[0, c]
        uy = w0 * cloth_v[1, a] + w1 * cloth_v[1, b] + w2 * cloth_v[1, c]
        uz = w0 * cloth_v[2, a] + w1 * cloth_v[2, b] + w2 * cloth_v[2, c]
        rx, ry, rz = float(v[0, i]) - ux, float(v[1, i]) - uy, float(v[2, i]) - uz
        vn = rx * nx + ry * ny + rz * nz
        inv_p = 1.0 / float(mass[i * mass_stride])
        inv_c = w0 * w0 * cloth_inv_m[a] + w1 * w1 * cloth_inv_m[b] + w2 * w2 * cloth_inv_m[c]
        inv_sum = inv_p + inv_c
        e = 0.0 if kill else restitution
        jn = -(1.0 + e) * vn / inv_sum if vn < 0.0 else 0.0
        tx, ty, tz = rx - vn * nx, ry - vn * ny, rz - vn * nz
        vt = np.sqrt(tx * tx + ty * ty + tz * tz)
        jt = min(vt / inv_sum, friction * jn) / vt if vt > 0.0 else 0.0
        jx, jy, jz = jn * nx - jt * tx, jn * ny - jt * ty, jn * nz - jt * tz
        v[0, i] += jx * inv_p
        v[1, i] += jy * inv_p
        v[2, i] += jz * inv_p
        _push(cloth_v, a, w0 * cloth_inv_m[a], jx, jy, jz)
        _push(cloth_v, b, w1 * cloth_inv_m[b], jx, jy, jz)
        _push(cloth_v, c, w2 * cloth_inv_m[c], jx, jy, jz)
        x[0, i] = px + thickness * nx
        x[1, i] = py + thickness * ny
        x[2, i] = pz + thickness * nz
        if kill:
            keep[i] = False
            killed += 1
        if track:
            hits[i] = hit_index
    return killed


class ClothContact(KindContact):
    """A cloth that an emitter system's particles hit, and push.

    Parameters
    ----------
    cloth : Cloth
        The cloth (its current positions, velocities and masses are used; its velocities
        receive the particles' impulses).
    restitution : float
        Fraction of the relative normal speed kept on bounce, in [0, 1].
    friction : float
        Coulomb coefficient μ >= 0 of the tangential impulse.
    thickness : float
        Distance > 0 [m] kept between particles and the cloth's mid-surface.
    response : str
        ``"bounce"`` or ``"kill"`` (the particle gives up its normal momentum relative to
        the cloth, as with restitution 0, and dies: a rain drop that splashes).
    particle_mass : float, optional
        Mass of every particle [kg]; by default each particle's ``mass`` attribute.
    """

    def __init__(
        self,
        cloth,
        *,
        restitution: float = 0.0,
        friction: float = 0.0,
        thickness: float = 0.01,
        response: str = "bounce",
        particle_mass: float | None = None,
    ):
        for name in ("position", "velocity", "mass", "faces", "pinned"):
            if not hasattr(cloth, name):
                raise TypeError(f"cloth must be a motes Cloth, got {type(cloth).__name__}")
        self.cloth = cloth
        self.restitution = check.unit_interval("restitution", restitution)
        self.friction = check.non_negative("friction", friction)
        self.thickness = check.positive("thickness", thickness)
        self.response = check.choice("response", response, RESPONSES)
        self.particle_mass = (
            None if particle_mass is None else check.positive("particle_mass", particle_mass)
        )
        self.reads = () if particle_mass is not None else ("mass",)
        self.faces = np.ascontiguousarray(cloth.faces, dtype=np.int64)
        self._grid = TriangleGrid()
        self._buffers: tuple | None = None
        self._no_hits = np.empty(1, np.int32)

    def _scratch(self, capacity: int) -> tuple:
        if self._buffers is None or self._buffers[0].shape[0] < capacity:
            self._buffers = (
                np.empty(capacity, np.int64),
                np.empty((3, capacity)),
                np.empty((3, capacity)),
            )
        return self._buffers

    def resolve(self, store, n, dt, hits, hit_index) -> int:
        if n == 0:
            return 0
        cloth = self.cloth
        tri = np.ascontiguousarray(cloth.position.T[self.faces].reshape(-1, 9))
        grid = self._grid.build(tri, self.thickness)
        hit_t, hit_p, hit_n = self._scratch(store.capacity)
        x, v = store.raw("position"), store.raw("velocity")
        _detect(n, x, v, float(dt), tri, grid.origin, grid.inv_cell, grid.dims,
                grid.cell_start, grid.cell_tris, self.thickness, hit_t, hit_p, hit_n)  # fmt: skip
        if not (hit_t[:n] >= 0).any():
            return 0
        if self.particle_mass is None:
            mass, stride = store.raw("mass"), 1
        else:
            mass, stride = np.full(1, self.particle_mass), 0
        inv_m = np.where(cloth.pinned, 0.0, 1.0 / cloth.mass)
        track = hits is not None
        if not track:
            hits = self._no_hits
        return int(
            _respond(
                n, x, v, mass, stride, self.faces, tri, cloth.velocity, inv_m, hit_t, hit_p,
                hit_n, self.restitution, self.friction, self.thickness,
                self.response == "kill", store.keep, hits, track, hit_index,
            )
        )  # fmt: skip
