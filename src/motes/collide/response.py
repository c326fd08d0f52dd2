"""The response of a particle to a collider it penetrates, whatever the collider's kind.

Detection is :func:`motes.geometry.distance.signed_distance` (the penetration depth is
minus the signed distance); :func:`respond` is what every kind shares: push-out,
restitution, friction by scale or by depth, stick, kill or event. It is inlined into
the fused step kernel (``motes.integrate.kernels``), where ``response`` and
``friction_model`` are compile-time constants, and into cloth's collision kernel. Bounce
is written with selects rather than branches so the particle loop still vectorises, and
every constant comes in as ``one`` (the store's dtype): a Python literal would promote
float32 math to float64.
"""

from __future__ import annotations

import numpy as np

from .._jit import device
from ..geometry.layout import FRICTION, RESTITUTION
from .colliders import Friction, Response

_STICK = int(Response.STICK)
_KILL = int(Response.KILL)
_EVENT = int(Response.EVENT)
_DEPTH = int(Friction.DEPTH)


@device
def respond(response, friction_model, px, py, pz, vx, vy, vz, depth, nx, ny, nz, table, c, dt, one):
    """Push-out and velocity response to a penetration ``depth`` [m] along the unit
    normal ``n`` out of collider row ``c`` of ``table``.

    Returns the new position [m] and velocity [m/s], and the (hit, kill) flags.
    """
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
    restitution = table[c, RESTITUTION]
    mu = table[c, FRICTION]
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
