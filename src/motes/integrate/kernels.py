"""The fused step kernel: field forces, integration, collisions, ageing and kill flags.

One pass over memory per step: for each particle the kernel reads its state once,
evaluates the velocity-only forces inline, adds the accumulated force buffer, advances
it with the chosen scheme, resolves every collider, ages it and writes whether it lives.

Kernels are built per *structure* (scheme, collider kinds and responses, which optional
arrays exist) by :func:`step_kernel`; the structure is baked in as closure constants so
the collider loop unrolls and the particle loop vectorises. Numba keys its disk cache on
closure contents, so each structure compiles once per machine.

``params`` (store dtype) holds, in order: gravity (3) [m/s^2], linear drag k [kg/s],
sum of k·wind (3) [N], quadratic drag c [kg/m], quadratic wind (3) [m/s], dt [s],
Verlet damping [1], the constant 1 (kernels take constants from here: a Python
literal would promote float32 arithmetic to float64), then the gap [m] a swept
collider leaves between a particle it stops and its surface (:data:`GAP`).
"""

from __future__ import annotations

from enum import IntEnum
from functools import cache

import numpy as np
from numba import prange

from .._jit import block_bounds, block_count, called, called_copy, device, parallel_kernel
from ..collide.colliders import Friction, Response
from ..collide.response import respond as respond_inlined
from ..geometry.distance import mesh_distance
from ..geometry.distance import signed_distance as signed_distance_inlined
from ..geometry.layout import FRICTION, RESTITUTION, Kind
from ..geometry.sweep import first_hit, mesh_first_hit

# Called, not inlined: the collider loop indexes its kinds at run time, so inlined, every
# kind's distance and response were compiled into each of the kernel's variants (6 s of
# compiling each, 3 s called; the same speed but for about 5 % on one thread for one
# plane at 1M particles).
signed_distance = called_copy(signed_distance_inlined)
respond = called_copy(respond_inlined)

_MESH = int(Kind.MESH)
_EVENT = int(Response.EVENT)
_KILL = int(Response.KILL)
_STICK = int(Response.STICK)
_DEPTH = int(Friction.DEPTH)
#: Gap left between a particle stopped by a swept collider and the surface [m] (keeps
#: it on the free side after round-off; ``params[GAP_AT]``).
GAP = 1e-6


class Scheme(IntEnum):
    """Integration schemes the fused kernel implements (multi-stage ones pass NONE)."""

    NONE = 0  #: positions already advanced; collide, age and kill only
    EXPLICIT_EULER = 1
    SEMI_IMPLICIT_EULER = 2
    VERLET = 3


PARAM_COUNT = 15
ONE = 13
GAP_AT = 14


@device
def field_acceleration(vx, vy, vz, w, params, quadratic):
    """Acceleration [m/s^2] of the velocity-only forces for inverse mass ``w`` [1/kg]."""
    # Gravity moves every particle that can move; w = 0 pins it.
    g = (w > 0) * params[ONE]
    k = params[3]
    ax = g * params[0] + w * (params[4] - k * vx)
    ay = g * params[1] + w * (params[5] - k * vy)
    az = g * params[2] + w * (params[6] - k * vz)
    if quadratic:
        ux = vx - params[8]
        uy = vy - params[9]
        uz = vz - params[10]
        c = w * params[7] * np.sqrt(ux * ux + uy * uy + uz * uz)
        ax -= c * ux
        ay -= c * uy
        az -= c * uz
    return ax, ay, az


# Called, not inlined: inlined into the parallel loop it quadrupled the kernel's
# compile time (38 s against 9 s for one swept plane), and the swept loop does not
# vectorise either way. It lives at module level and takes the structure as arguments:
# a function made inside step_kernel would be a closure cell of the kernel, which
# Numba's disk cache keys by a pickle that differs in every process (no cache hit).
@called
def sweep(
    structure, x0, y0, z0, px, py, pz, vx, vy, vz, ax, ay, az,
    params, table, tri, cell_start, cell_tris, dt, one,
):  # fmt: skip
    """The step's path against the swept colliders: at the earliest entry the
    particle responds at that time and moves on for the rest of the step.

    ``structure`` is ``(kinds, insides, responses, frictions, sweeps, explicit)`` as
    :func:`step_kernel` unpacks it. Returns position, velocity, the
    collider hit (-1: none) and whether it dies."""
    kinds, insides, responses, frictions, sweeps, explicit = structure
    zero = one - one
    half = one / (one + one)
    dx = px - x0
    dy = py - y0
    dz = pz - z0
    # The path under the constant acceleration a: x(f) = x0 + (d - b) f + b f².
    bend = half * dt * dt
    bx = ax * bend
    by = ay * bend
    bz = az * bend
    best = one + one
    hit = -1
    nx = ny = nz = off = zero
    for c in range(len(sweeps)):
        if sweeps[c]:
            if kinds[c] == _MESH:
                f, mx, my, mz, mo = mesh_first_hit(
                    table[c], tri, cell_start, cell_tris,
                    float(x0), float(y0), float(z0), float(dx), float(dy), float(dz), 0.0,
                )  # fmt: skip
            else:
                f, mx, my, mz = first_hit(
                    kinds[c], insides[c], table, c,
                    x0, y0, z0, dx, dy, dz, bx, by, bz, zero, one,
                )  # fmt: skip
                mo = zero
            if f < best:
                best, hit, nx, ny, nz, off = f, c, mx, my, mz, mo
    if hit < 0:
        return px, py, pz, vx, vy, vz, -1, False
    response = responses[hit]
    if response == _EVENT:
        return px, py, pz, vx, vy, vz, hit, False
    # Entry point on the path, a gap (and a mesh shell's stand-off) off the surface.
    stand = off + params[GAP_AT]
    hx = x0 + (dx - bx) * best + bx * best * best + stand * nx
    hy = y0 + (dy - by) * best + by * best * best + stand * ny
    hz = z0 + (dz - bz) * best + bz * best * best + stand * nz
    if response == _KILL:
        return hx, hy, hz, vx, vy, vz, hit, True
    if response == _STICK:
        return hx, hy, hz, zero, zero, zero, hit, False
    # Velocity at the entry: the path's start velocity (d - b)/dt plus a t.
    t = best * dt
    wx = (dx - bx) / dt + ax * t
    wy = (dy - by) / dt + ay * t
    wz = (dz - bz) / dt + az * t
    wn = wx * nx + wy * ny + wz * nz
    tx = wx - wn * nx
    ty = wy - wn * ny
    tz = wz - wn * nz
    e = table[hit, RESTITUTION]
    mu = table[hit, FRICTION]
    wn = min(wn, zero)
    if frictions[hit] == _DEPTH:
        # Coulomb: the tangential speed drops by mu times the normal speed change.
        vt = np.sqrt(tx * tx + ty * ty + tz * tz)
        scale = max(vt + mu * (one + e) * wn, zero) / (vt + (vt == zero) * one)
    else:
        scale = one - mu
    ux = tx * scale - e * wn * nx
    uy = ty * scale - e * wn * ny
    uz = tz * scale - e * wn * nz
    # The rest of the step, on the new parabola from the entry point.
    rest = dt - t
    px = hx + ux * rest + half * ax * rest * rest
    py = hy + uy * rest + half * ay * rest * rest
    pz = hz + uz * rest + half * az * rest * rest
    # The stored velocity is the scheme's own: the mean velocity over the step just
    # ended (semi-implicit Euler, Verlet) or over the next one (explicit Euler), so
    # the next step continues on the same parabola.
    lag = rest + half * dt if explicit else rest - half * dt
    vx = ux + ax * lag
    vy = uy + ay * lag
    vz = uz + az * lag
    # A slow particle pulled back within the same step (coming to rest) stays on the
    # contact's tangent plane rather than crossing a shell no later test would find.
    back = min((px - hx) * nx + (py - hy) * ny + (pz - hz) * nz, zero)
    vn = min(vx * nx + vy * ny + vz * nz, zero)
    return (
        px - back * nx,
        py - back * ny,
        pz - back * nz,
        vx - vn * nx,
        vy - vn * ny,
        vz - vn * nz,
        hit,
        False,
    )


@cache
def step_kernel(
    scheme: int,
    colliders: tuple,
    has_force: bool,
    has_inv_mass: bool,
    quadratic: bool,
    track_hits: bool,
):
    """Compile (or fetch) the fused step kernel for one structure.

    ``colliders`` holds one ``(kind, inside, response, friction_model, swept)`` tuple
    per collider (:attr:`motes.collide.Collider.structure`). The returned kernel has the
    signature ``kernel(n, pos, vel, age, life, inv_mass, force, params, table, tri,
    cell_start, cell_tris, keep, hits) -> dead`` with vectors ``(3, capacity)``, scalars
    ``(capacity,)``, and the triangle meshes' data as
    :func:`motes.collide.contact.pack` concatenates it; unused arrays may be any array of
    the right rank. ``keep[i]`` is written False for particles that die (age past
    lifetime, or a KILL collider); ``hits[i]`` gets the index of the last collider hit,
    or -1, when ``track_hits``. Returns the number of particles that die.
    """
    scheme = int(scheme)
    n_colliders = len(colliders)
    kinds = tuple(int(c[0]) for c in colliders) or (0,)
    insides = tuple(int(c[1]) for c in colliders) or (0,)
    responses = tuple(int(c[2]) for c in colliders) or (0,)
    frictions = tuple(int(c[3]) for c in colliders) or (0,)
    sweeps = tuple(int(c[4]) for c in colliders) or (0,)
    explicit = scheme == Scheme.EXPLICIT_EULER
    semi_implicit = scheme == Scheme.SEMI_IMPLICIT_EULER
    verlet = scheme == Scheme.VERLET
    moving = explicit or semi_implicit or verlet
    # Multi-stage schemes move the particles before the kernel: no path to sweep.
    any_swept = moving and any(sweeps)
    any_mesh = _MESH in kinds[:n_colliders]
    structure = (kinds, insides, responses, frictions, sweeps, explicit)

    @parallel_kernel
    def kernel(
        n,
        pos,
        vel,
        age,
        life,
        inv_mass,
        force,
        params,
        table,
        tri,
        cell_start,
        cell_tris,
        keep,
        hits,
    ):
        dt = params[11]
        one = params[ONE]
        zero = one - one
        retain = one - params[12]
        # Deaths per block, summed after the loop: a reduction variable in the prange
        # makes Numba deep-copy every statement that feeds it, each copy with the whole
        # (inlined) kernel's scope, which tripled the compile time.
        blocks = block_count(n)
        dead = np.zeros(blocks, dtype=np.int64)
        for block in prange(blocks):
            start, stop = block_bounds(block, n)
            died = 0
            for i in range(start, stop):
                px = pos[0, i]
                py = pos[1, i]
                pz = pos[2, i]
                vx = vel[0, i]
                vy = vel[1, i]
                vz = vel[2, i]
                x0 = px
                y0 = py
                z0 = pz
                ax = ay = az = zero
                w = inv_mass[i] if has_inv_mass else one
                if moving:
                    ax, ay, az = field_acceleration(vx, vy, vz, w, params, quadratic)
                    if has_force:
                        ax += w * force[0, i]
                        ay += w * force[1, i]
                        az += w * force[2, i]
                if explicit:
                    px += vx * dt
                    py += vy * dt
                    pz += vz * dt
                    vx += ax * dt
                    vy += ay * dt
                    vz += az * dt
                elif semi_implicit:
                    vx += ax * dt
                    vy += ay * dt
                    vz += az * dt
                    px += vx * dt
                    py += vy * dt
                    pz += vz * dt
                elif verlet:
                    # Jakobsen 2001: x' = x + (x - x_prev)(1 - damping) + a dt², with the
                    # stored velocity standing for (x - x_prev)/dt; then v = (x' - x)/dt.
                    vx = vx * retain + ax * dt
                    vy = vy * retain + ay * dt
                    vz = vz * retain + az * dt
                    px += vx * dt
                    py += vy * dt
                    pz += vz * dt
                killed = False
                last_hit = -1
                if any_swept:
                    px, py, pz, vx, vy, vz, swept_hit, swept_kill = sweep(
                        structure, x0, y0, z0, px, py, pz, vx, vy, vz, ax, ay, az,
                        params, table, tri, cell_start, cell_tris, dt, one,
                    )  # fmt: skip
                    killed |= swept_kill
                    if track_hits:
                        last_hit = swept_hit
                for c in range(n_colliders):
                    if any_mesh:
                        if kinds[c] == _MESH:
                            dist, nx, ny, nz = mesh_distance(
                                table[c],
                                tri,
                                cell_start,
                                cell_tris,
                                float(px),
                                float(py),
                                float(pz),
                                float(x0),
                                float(y0),
                                float(z0),
                                0.0,
                            )
                        else:
                            dist, nx, ny, nz = signed_distance(
                                kinds[c], insides[c], table, c, px, py, pz, one
                            )
                    else:
                        dist, nx, ny, nz = signed_distance(
                            kinds[c], insides[c], table, c, px, py, pz, one
                        )
                    px, py, pz, vx, vy, vz, hit, kill = respond(
                        responses[c],
                        frictions[c],
                        px,
                        py,
                        pz,
                        vx,
                        vy,
                        vz,
                        -dist,
                        nx,
                        ny,
                        nz,
                        table,
                        c,
                        dt,
                        one,
                    )
                    killed |= kill
                    if track_hits:
                        last_hit = c if hit else last_hit
                pos[0, i] = px
                pos[1, i] = py
                pos[2, i] = pz
                vel[0, i] = vx
                vel[1, i] = vy
                vel[2, i] = vz
                if track_hits:
                    hits[i] = last_hit
                a = age[i] + dt
                age[i] = a
                dies = killed or a >= life[i]
                keep[i] = not dies
                died += dies
            dead[block] = died
        return dead.sum()

    return kernel


@parallel_kernel
def acceleration_kernel(n, vel, inv_mass, has_inv_mass, force, has_force, params, quadratic, out):
    """Total acceleration [m/s^2] into ``out`` (3, n): field forces plus ``force``·w."""
    for block in prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            w = inv_mass[i] if has_inv_mass else params[ONE]
            ax, ay, az = field_acceleration(vel[0, i], vel[1, i], vel[2, i], w, params, quadratic)
            if has_force:
                ax += w * force[0, i]
                ay += w * force[1, i]
                az += w * force[2, i]
            out[0, i] = ax
            out[1, i] = ay
            out[2, i] = az


def empty_like_rank(dtype, rank: int) -> np.ndarray:
    """A 1-element placeholder for an array a kernel structure does not use."""
    return np.zeros((1,) * rank if rank == 1 else (3, 1), dtype=dtype)
