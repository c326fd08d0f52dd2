"""Compiled collision detection and response for one particle against one collider.

Both functions are inlined into the fused step kernel (``motes.integrate.kernels``);
``kind``, ``inside``, ``response`` and ``friction_model`` are compile-time constants
there, so each collider costs only its own arithmetic. Bounce is written with selects
rather than branches so the particle loop still vectorises, and every constant comes in
as ``one`` (the store's dtype): a Python literal would promote float32 math to float64.
"""

from __future__ import annotations

import numpy as np

from .._jit import device
from .colliders import Friction, Kind, Response

_PLANE = int(Kind.PLANE)
_SPHERE = int(Kind.SPHERE)
_BOX = int(Kind.BOX)
_STICK = int(Response.STICK)
_KILL = int(Response.KILL)
_EVENT = int(Response.EVENT)
_DEPTH = int(Friction.DEPTH)


@device
def penetration(kind, inside, px, py, pz, table, c, one):
    """Penetration depth [m] (> 0 when inside the solid) and unit push-out normal."""
    if kind == _PLANE:
        nx = table[c, 2]
        ny = table[c, 3]
        nz = table[c, 4]
        return table[c, 5] - (px * nx + py * ny + pz * nz), nx, ny, nz
    if kind == _SPHERE:
        dx = px - table[c, 2]
        dy = py - table[c, 3]
        dz = pz - table[c, 4]
        dist = np.sqrt(dx * dx + dy * dy + dz * dz)
        # A particle exactly at the centre is pushed out along +y.
        safe = dist if dist > 0 else one
        nx = dx / safe
        ny = dy / safe if dist > 0 else safe
        nz = dz / safe
        if inside:
            return dist - table[c, 5], -nx, -ny, -nz
        return table[c, 5] - dist, nx, ny, nz
    # Oriented box: local coordinates along the axes u, v, w (rows 8..16 of the table).
    dx = px - table[c, 2]
    dy = py - table[c, 3]
    dz = pz - table[c, 4]
    lu = dx * table[c, 8] + dy * table[c, 9] + dz * table[c, 10]
    lv = dx * table[c, 11] + dy * table[c, 12] + dz * table[c, 13]
    lw = dx * table[c, 14] + dy * table[c, 15] + dz * table[c, 16]
    hu = table[c, 5]
    hv = table[c, 6]
    hw = table[c, 7]
    if inside:
        # Clamp into the box; the push-out is the clamp displacement (handles corners).
        du = min(max(lu, -hu), hu) - lu
        dv = min(max(lv, -hv), hv) - lv
        dw = min(max(lw, -hw), hw) - lw
        depth = np.sqrt(du * du + dv * dv + dw * dw)
        if depth > 0:
            nu = du / depth
            nv = dv / depth
            nw = dw / depth
        else:
            nu = du
            nv = dv
            nw = dw
            depth = -min(hu - abs(lu), min(hv - abs(lv), hw - abs(lw)))
    else:
        # Solid box: leave through the face of least penetration.
        qu = abs(lu) - hu
        qv = abs(lv) - hv
        qw = abs(lw) - hw
        zero = one - one
        nu = nv = nw = zero
        if qu >= qv and qu >= qw:
            depth = -qu
            nu = one if lu >= 0 else -one
        elif qv >= qw:
            depth = -qv
            nv = one if lv >= 0 else -one
        else:
            depth = -qw
            nw = one if lw >= 0 else -one
    nx = nu * table[c, 8] + nv * table[c, 11] + nw * table[c, 14]
    ny = nu * table[c, 9] + nv * table[c, 12] + nw * table[c, 15]
    nz = nu * table[c, 10] + nv * table[c, 13] + nw * table[c, 16]
    return depth, nx, ny, nz


@device
def respond(response, friction_model, px, py, pz, vx, vy, vz, depth, nx, ny, nz, table, c, dt, one):
    """Push-out and velocity response. Returns the new state and (hit, kill) flags."""
    hit = depth > 0
    if response == _EVENT:
        return px, py, pz, vx, vy, vz, hit, False
    # Products with the boolean ``hit`` are selects the vectoriser understands.
    push = hit * depth
    px = px + push * nx
    py = py + push * ny
    pz = pz + push * nz
    if response == _KILL:
        return px, py, pz, vx, vy, vz, hit, hit
    if response == _STICK:
        free = one - hit * one
        return px, py, pz, vx * free, vy * free, vz * free, hit, False
    vn = vx * nx + vy * ny + vz * nz
    tx = vx - vn * nx
    ty = vy - vn * ny
    tz = vz - vn * nz
    restitution = table[c, 0]
    mu = table[c, 1]
    # Only an approaching particle bounces; one already separating keeps its normal speed.
    approaching = hit & (vn < 0)
    vn_out = vn - approaching * (one + restitution) * vn
    if friction_model == _DEPTH:
        vt = np.sqrt(tx * tx + ty * ty + tz * tz)
        slow = mu * push / dt
        kept = max(vt - slow, one - one) / (vt + (vt == 0) * one)
        scale = one - hit * (one - kept)
    else:
        scale = one - hit * mu
    return (
        px,
        py,
        pz,
        tx * scale + vn_out * nx,
        ty * scale + vn_out * ny,
        tz * scale + vn_out * nz,
        hit,
        False,
    )
