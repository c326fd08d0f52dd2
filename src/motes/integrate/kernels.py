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
Verlet damping [1], then the constant 1 (kernels take constants from here: a Python
literal would promote float32 arithmetic to float64).
"""

from __future__ import annotations

from enum import IntEnum
from functools import cache

import numpy as np
from numba import prange

from .._jit import block_bounds, block_count, device, parallel_kernel
from ..collide.response import respond
from ..geometry.distance import signed_distance


class Scheme(IntEnum):
    """Integration schemes the fused kernel implements (multi-stage ones pass NONE)."""

    NONE = 0  #: positions already advanced; collide, age and kill only
    EXPLICIT_EULER = 1
    SEMI_IMPLICIT_EULER = 2
    VERLET = 3


PARAM_COUNT = 14
ONE = 13


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

    The returned kernel has the signature
    ``kernel(n, pos, vel, age, life, inv_mass, force, params, table, keep, hits) -> dead``
    with vectors ``(3, capacity)``, scalars ``(capacity,)``; unused arrays may be any
    array of the right rank. ``keep[i]`` is written False for particles that die (age
    past lifetime, or a KILL collider); ``hits[i]`` gets the index of the last collider
    hit, or -1, when ``track_hits``. Returns the number of particles that die.
    """
    scheme = int(scheme)
    n_colliders = len(colliders)
    kinds = tuple(int(c[0]) for c in colliders) or (0,)
    insides = tuple(int(c[1]) for c in colliders) or (0,)
    responses = tuple(int(c[2]) for c in colliders) or (0,)
    frictions = tuple(int(c[3]) for c in colliders) or (0,)
    explicit = scheme == Scheme.EXPLICIT_EULER
    semi_implicit = scheme == Scheme.SEMI_IMPLICIT_EULER
    verlet = scheme == Scheme.VERLET

    @parallel_kernel
    def kernel(n, pos, vel, age, life, inv_mass, force, params, table, keep, hits):
        dt = params[11]
        one = params[ONE]
        retain = one - params[12]
        dead = 0
        for block in prange(block_count(n)):
            start, stop = block_bounds(block, n)
            for i in range(start, stop):
                px = pos[0, i]
                py = pos[1, i]
                pz = pos[2, i]
                vx = vel[0, i]
                vy = vel[1, i]
                vz = vel[2, i]
                w = inv_mass[i] if has_inv_mass else one
                if explicit or semi_implicit or verlet:
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
                for c in range(n_colliders):
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
                dead += dies
        return dead

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
