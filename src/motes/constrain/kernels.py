r"""Compiled relaxation of distance and angle-limit constraints, one colour at a time.

Every constraint joins two particles ``i``, ``j`` (``d = x_j - x_i``) and keeps their
distance in ``[lo, hi]`` (equal bounds: a stick; ``lo = 0``: a rope that goes slack).
An angle limit also names a pivot ``k`` and keeps the angle at ``k`` between the arms
``x_i - x_k`` and ``x_j - x_k`` in ``[θ_min, θ_max]``: with the arm lengths ``a``, ``b``
the law of cosines turns it into distance bounds between ``i`` and ``j``,

.. math:: |d|^2 = a^2 + b^2 - 2ab\cos θ,

which is Jakobsen's dot-product limit :math:`(x_i - x_k)·(x_j - x_k) < α` enforced by a
temporary rod between ``i`` and ``j`` (Jakobsen 2001, §5): the rod acts only while the
limit is violated and moves only ``i`` and ``j``.

Projection (Macklin, Müller & Chentanez 2016, "XPBD", eq. 18 and 17): with
``C = |d| - clamp(|d|, lo, hi)``, inverse masses ``w``, ``α̃ = α / h²``,

.. math:: Δλ = k \frac{-C - α̃ λ}{w_i + w_j + α̃}, \qquad
   Δx_j = w_j Δλ \hat d, \quad Δx_i = -w_i Δλ \hat d .

``α = 0, k = 1`` is Jakobsen's projection; ``k < 1`` is the stiffness of Müller et al.
2007 (position based dynamics), whose effect depends on the iteration count;
``α > 0`` (then ``k = 1``) is XPBD compliance, whose effect does not.

With ``shake`` a distance constraint pushes along the direction ``ĝ`` its pair had at
the start of the step (positions ``q``) instead of the current one, with ``w_i + w_j``
replaced by ``(w_i + w_j)(\hat d · ĝ)`` (the constraint's derivative along ``ĝ``):
iterated, this converges to SHAKE (Ryckaert, Ciccotti & Berendsen 1977), which with
position Verlet conserves energy to O(h²) without drift. Projecting along the current
direction (Jakobsen, PBD) shortens the implied velocity's chord every step: a 60°
pendulum at h = 1/60 s loses more than half of its swing energy in four seconds. Angle
limits always use the current direction.

A hinge side limit (``SIDE``) keeps a joint from bending backwards, which an angle
limit cannot tell from bending forwards: with the bone ``i -> k`` (thigh) and the hinge
axis ``l -> r`` (hip to hip), ``n = σ (x_k - x_i) × (x_r - x_l)`` with an orientation
σ = ±1, and the particle ``j`` (ankle) is kept where ``(x_j - x_k) · n̂ <= lo``
(a one-sided temporary constraint in Jakobsen's sense). Column ``hi`` holds ``σ v_r``.
The violation is shared by ``j`` and the joint ``k`` by inverse mass (moving ``j`` alone
pushed the limb without a reaction: momentum from nowhere). A violation already there
at the start of the step (``q``) is undone at no more than the recovery speed ``v_r``:
it appears when the bone leaves the 30° cone around the axis where the limit rests, or
when contacts held the limb past the plane, and undoing it in one step is a velocity of
``violation / h`` (a knee woke up 0.2 m past its plane was thrown back at 13 m/s and
more). Without previous positions (``relax`` of a static set) ``q`` is the current
position and a side limit moves ``v_r h`` per sweep.

With ``sqrt_approximation`` a rigid (``α = 0``) distance constraint replaces the exact
``(|d| - r)/|d|`` by Jakobsen's square-root-free ``(|d|^2 - r^2)/(|d|^2 + r^2)``, its
first-order Taylor expansion about ``|d| = r``: for ``|d| = r(1 + e)`` the correction
overshoots the exact one by ``(e^2/2)|d| + O(e^3)`` (a relative error ``e/2``: one
projection of a stick stretched by 10 % leaves it 0.45 % short), and its fixed point is
still ``|d| = r``.
"""

from __future__ import annotations

import numba
import numpy as np

from .._jit import BLOCK, device, parallel_kernel, serial_kernel

#: Constraint kinds (column ``kind``).
DISTANCE = 0
ANGLE = 1
SIDE = 2
RECOVER = 10.0


@device
def _project_side(c, px, py, pz, qx, qy, qz, inv_mass, ends, lo, hi, stiffness, lam, dt):
    """Keep j on one side of a hinge (see the module docstring); moves j and k."""
    i = np.uint64(ends[c, 0])  # unsigned: see relax_sweep
    j = np.uint64(ends[c, 1])
    k = np.uint64(ends[c, 2])
    left = np.uint64(ends[c, 3])
    right = np.uint64(ends[c, 4])
    # Bone i -> k and hinge axis left -> right: their cross product is the side's normal.
    bx, by, bz = px[k] - px[i], py[k] - py[i], pz[k] - pz[i]
    ax, ay, az = px[right] - px[left], py[right] - py[left], pz[right] - pz[left]
    nx = by * az - bz * ay
    ny = bz * ax - bx * az
    nz = bx * ay - by * ax
    norm = np.sqrt(nx * nx + ny * ny + nz * nz)
    b2 = bx * bx + by * by + bz * bz
    a2 = ax * ax + ay * ay + az * az
    if norm * norm <= 0.25 * b2 * a2:
        return  # bone and axis within 30° of parallel: the plane is ill-defined
    # hi holds orientation × recovery speed: its sign picks the forbidden side.
    sign = 1.0 if hi[c] > 0.0 else -1.0
    nx, ny, nz = sign * nx / norm, sign * ny / norm, sign * nz / norm
    side = (px[j] - px[k]) * nx + (py[j] - py[k]) * ny + (pz[j] - pz[k]) * nz - lo[c]
    if side <= 0.0:
        return
    # Where j already was past the plane at the start of the step (the limit just woke
    # up as the bone left the axis, or contacts held it there), only ``recover`` of that
    # is undone per step: undoing all of it in one step is a velocity of violation / h.
    # The side at the start is measured across the plane of the start (a plane swept
    # past j by the bone turning is a new violation, undone in full), unless the limit
    # was resting then (bone near the axis): then the current plane wakes it up.
    ux, uy, uz = qx[k] - qx[i], qy[k] - qy[i], qz[k] - qz[i]
    vx, vy, vz = qx[right] - qx[left], qy[right] - qy[left], qz[right] - qz[left]
    mx = uy * vz - uz * vy
    my = uz * vx - ux * vz
    mz = ux * vy - uy * vx
    m2 = mx * mx + my * my + mz * mz
    if m2 > 0.25 * (ux * ux + uy * uy + uz * uz) * (vx * vx + vy * vy + vz * vz):
        m = sign / np.sqrt(m2)
        mx, my, mz = m * mx, m * my, m * mz
    else:
        mx, my, mz = nx, ny, nz
    before = (qx[j] - qx[k]) * mx + (qy[j] - qy[k]) * my + (qz[j] - qz[k]) * mz - lo[c]
    allowed = max(before - abs(hi[c]) * dt, 0.0)
    if side <= allowed:
        return
    # The limit as a bend of the joint: to first order, moving j by -δn lowers the side
    # by δ, moving i by -δn by c δ and k by +δn by (1 + c) δ, where
    # c = (x_j - x_k)·b⊥/|b⊥|² with b⊥ the bone's part perpendicular to the axis (the
    # bone turns the plane about the axis). The gradients sum to zero: no net momentum,
    # and the reaction turns the bone before the joint. c is near -1 for a folded joint,
    # where moving k no longer helps (clamping c at 0 lifted folded knees off the
    # ground step after step).
    sx, sy, sz = px[j] - px[k], py[j] - py[k], pz[j] - pz[k]
    sb = sx * bx + sy * by + sz * bz
    sa = sx * ax + sy * ay + sz * az
    ab = ax * bx + ay * by + az * bz
    c_i = (a2 * sb - sa * ab) / (norm * norm)
    wj = inv_mass[j]
    wi = inv_mass[i] * c_i * c_i
    wk = inv_mass[k] * (1.0 + c_i) * (1.0 + c_i)
    w = wj + wi + wk
    if w <= 0.0:
        return
    # Fade in from 30° to 45° between bone and axis: near the axis the plane turns fast
    # (as 1/sin) and a plane swept past j in one step is not a bend of the joint.
    fade = min((norm / np.sqrt(b2 * a2) - 0.5) / (np.sqrt(0.5) - 0.5), 1.0)
    # The step's correction budget is the violation found the first time (kept in lam,
    # offset by 1 so that 0 means unset): contacts that push j back through the plane
    # in later iterations would otherwise pump the joint a little further each time
    # (a foot held by the ground threw the knee at 20 m/s).
    if lam[c] == 0.0:
        lam[c] = 1.0 + (side - allowed)
    amount = min(side - allowed, lam[c] - 1.0)
    if amount <= 0.0:
        return
    lam[c] -= amount
    s = fade * stiffness[c] * amount / w
    px[j] -= inv_mass[j] * s * nx
    py[j] -= inv_mass[j] * s * ny
    pz[j] -= inv_mass[j] * s * nz
    px[i] -= inv_mass[i] * c_i * s * nx
    py[i] -= inv_mass[i] * c_i * s * ny
    pz[i] -= inv_mass[i] * c_i * s * nz
    px[k] += inv_mass[k] * (1.0 + c_i) * s * nx
    py[k] += inv_mass[k] * (1.0 + c_i) * s * ny
    pz[k] += inv_mass[k] * (1.0 + c_i) * s * nz


@device
def _project(
    c,
    px,
    py,
    pz,
    qx,
    qy,
    qz,
    inv_mass,
    kind,
    ends,
    lo,
    hi,
    compliance,
    stiffness,
    lam,
    dt2,
    approx,
    shake,
):
    if kind[c] == SIDE:
        _project_side(
            c, px, py, pz, qx, qy, qz, inv_mass, ends, lo, hi, stiffness, lam, np.sqrt(dt2)
        )
        return
    i = np.uint64(ends[c, 0])  # unsigned: see relax_sweep
    j = np.uint64(ends[c, 1])
    dx = px[j] - px[i]
    dy = py[j] - py[i]
    dz = pz[j] - pz[i]
    d2 = dx * dx + dy * dy + dz * dz
    if kind[c] == ANGLE:
        k = np.uint64(ends[c, 2])
        ax = px[i] - px[k]
        ay = py[i] - py[k]
        az = pz[i] - pz[k]
        bx = px[j] - px[k]
        by = py[j] - py[k]
        bz = pz[j] - pz[k]
        a2 = ax * ax + ay * ay + az * az
        b2 = bx * bx + by * by + bz * bz
        ab = np.sqrt(a2 * b2)
        # lo, hi hold cos(θ_min) and cos(θ_max): the smaller angle gives the shorter rod.
        t_lo = np.sqrt(max(a2 + b2 - 2.0 * ab * lo[c], 0.0))
        t_hi = np.sqrt(max(a2 + b2 - 2.0 * ab * hi[c], 0.0))
    else:
        t_lo = lo[c]
        t_hi = hi[c]
    if d2 <= 0.0:
        return  # coincident particles: no direction to push along
    d = np.sqrt(d2)
    target = min(max(d, t_lo), t_hi)
    if d == target:
        return
    wi = inv_mass[i]
    wj = inv_mass[j]
    w = wi + wj
    if w <= 0.0:
        return
    alpha = compliance[c] / dt2
    done = False
    if shake and kind[c] == DISTANCE:
        # SHAKE: push along the direction the pair had at the start of the step.
        gx = qx[j] - qx[i]
        gy = qy[j] - qy[i]
        gz = qz[j] - qz[i]
        g = np.sqrt(gx * gx + gy * gy + gz * gz)
        if g > 0.0:
            cos = (dx * gx + dy * gy + dz * gz) / (d * g)
            if cos > 0.5:  # else the pair turned far in one step: project as PBD
                dlam = stiffness[c] * (-(d - target) - alpha * lam[c]) / (w * cos + alpha)
                lam[c] += dlam
                s = -dlam / g
                dx, dy, dz = gx, gy, gz
                done = True
    if done:
        pass
    elif approx and alpha == 0.0 and kind[c] == DISTANCE:
        r2 = target * target
        s = stiffness[c] * (d2 - r2) / ((d2 + r2) * w)
    else:
        dlam = stiffness[c] * (-(d - target) - alpha * lam[c]) / (w + alpha)
        lam[c] += dlam
        s = -dlam / d
    # s (d_j - d_i) is the relative correction per unit inverse mass.
    px[i] += wi * s * dx
    py[i] += wi * s * dy
    pz[i] += wi * s * dz
    px[j] -= wj * s * dx
    py[j] -= wj * s * dy
    pz[j] -= wj * s * dz


@parallel_kernel
def relax_sweep(
    px,
    py,
    pz,
    qx,
    qy,
    qz,
    inv_mass,
    kind,
    ends,
    lo,
    hi,
    compliance,
    stiffness,
    lam,
    color_start,
    dt,
    approx,
    shake,
):
    """One Gauss–Seidel sweep: every colour in order, each colour's constraints in parallel.

    Constraints are stored sorted by colour (``color_start`` as from
    :func:`~motes.constrain.graph.color_constraints`). No two constraints of one colour
    share a particle, so the blocks of a colour may run on any threads in any order and
    the result is bitwise the same.

    Constraint and particle indices are unsigned (``np.uint64``): Numba then skips the
    negative-index wraparound of every array access, a select per access that also
    crowded the registers (the sweep of a 100,000-particle lattice ran 1.3x slower with
    signed indices).
    """
    dt2 = dt * dt
    for color in range(color_start.shape[0] - 1):
        start = color_start[color]
        stop = color_start[color + 1]
        blocks = (stop - start + BLOCK - 1) // BLOCK
        for b in numba.prange(blocks):
            first = start + b * BLOCK
            last = min(stop, first + BLOCK)
            for c in range(np.uint64(first), np.uint64(last)):
                _project(
                    c,
                    px,
                    py,
                    pz,
                    qx,
                    qy,
                    qz,
                    inv_mass,
                    kind,
                    ends,
                    lo,
                    hi,
                    compliance,
                    stiffness,
                    lam,
                    dt2,
                    approx,
                    shake,
                )


@serial_kernel
def apply_pins(px, py, pz, pinned, target):
    """Put pinned particles back on their targets ``target`` ((3, p) [m])."""
    for q in range(pinned.shape[0]):
        p = pinned[q]
        px[p] = target[0, q]
        py[p] = target[1, q]
        pz[p] = target[2, q]
