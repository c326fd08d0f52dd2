"""Compiled kernels of the position-based fluid solver.

Every kernel gathers over a particle's own neighbour list (``nbr[begin[i]:end[i]]``, in
the grid's sorted slots: CSR lists, or the rows a grid search left in its buffer), so no
two threads write the same particle. Pairwise exchanges
(viscosity, XSPH, cohesion, phase repulsion) read the velocities of the step before and
evaluate each pair's term from quantities symmetric in ``i`` and ``j``: the term of
``j`` on ``i`` is exactly minus that of ``i`` on ``j``, so momentum is conserved to
round-off.

Boundary rows are packed by ``boundaries.pack`` in the collider layout of every solver
(:mod:`motes.geometry.layout`) and measured by its one signed distance: positive on the
fluid side, the normal pointing into the fluid.

Sums over a neighbour list run in chunks of ``CHUNK`` neighbours and three loops: the
neighbours' fields are gathered into a small buffer (:func:`gather`), each neighbour's
terms are computed from it into a second buffer, and the terms are added by
:func:`~motes._jit.ordered_sum`. The kernels may not reassociate floats
(:data:`~motes._jit.FASTMATH`), so a running sum would keep the loop scalar; and a loop
that loads through the list while storing terms does not vectorise either (LLVM cannot
rule out that the stores alias the loaded arrays). The middle loop reads and writes
contiguous buffers only and vectorises. For 100,000 particles on one thread:
``density_lambda`` 18.4 -> 10.5 ms, ``correction`` 19.2 -> 11.4 ms, ``exchange`` (XSPH)
16.7 -> 12.9 ms, against a running sum in one loop (11.8, 12.5 and 15.2 ms when the
flags still let LLVM reassociate it).

The density and correction passes (four of each per step) compute their pair terms in
float32 from the dimensionless shapes of :mod:`.sph` (``poly6_shape``,
``spiky_gradient_shape``), and give the float64 sums their units once per particle:
eight lanes a vector instead of four, the positions being float32 already. One thread,
100,000 particles: ``density_lambda`` 15.4 -> 11.1 ms, ``correction`` 15.6 -> 12.8 ms;
densities move by 2e-7 relative, the dam break's deviations from Martin & Moyce by
less than their run-to-run spread.
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from .._jit import block_bounds, block_count, called, device, ordered_sum, parallel_kernel
from ..geometry.distance import row_signed_distance
from ..geometry.layout import ADHESION, FRICTION, FRICTION_MODEL
from ..spatial.kernels import CHUNK, cell_coordinate
from .sph import (
    POLY6,
    SPIKY_GRAD,
    poly6,
    poly6_shape,
    spiky,
    spiky_gradient_scale,
    spiky_gradient_shape,
    wall_share,
)

#: Akinci et al. 2013, eq. 2: cohesion spline normalisation, 32 / π.
COHESION = 32.0 / math.pi
#: Akinci et al. 2013, eq. 7: adhesion spline normalisation, 0.007.
ADHESION_SCALE = 0.007
#: The wall passes (``walls``, ``push_out``) are called, not inlined (``_jit.called``):
#: each is used by several kernels, and inlining every copy (each with the distance of
#: every boundary kind inlined) tripled the kernels' compile time.
boundary_function = called

#: Quadrature nodes over the wall plane for the adhesion of a flat wall.
_WALL_NODES = 8


@boundary_function
def walls(rows, x, y, z, h, spacing, scale):
    """The part of a particle's kernel that lies inside the walls, and its gradient.

    Each wall alone takes :func:`wall_share` ``f_b`` of the kernel (``spacing`` [m] and
    ``scale`` [-] as there). Several walls (a
    tank's edge or corner) overlap; treating them as independent, the kernel left free
    is ``Q = Π_b (1 - f_b)``, exact for one wall and at a tank's corner (1/8 free) and
    within a few % between. Returns ``Q`` and ``∇(1 - Q)`` [1/m].
    """
    free = 1.0
    gx = gy = gz = 0.0
    for b in range(rows.shape[0]):
        d, nx, ny, nz = row_signed_distance(rows, b, x, y, z, 1.0)
        if d < h:
            f, slope = wall_share(d, spacing, h, scale)
            # ∇(1 - Q·(1 - f)) = (1 - f) ∇(1 - Q) + Q f' n.
            gx = (1.0 - f) * gx + free * slope * nx
            gy = (1.0 - f) * gy + free * slope * ny
            gz = (1.0 - f) * gz + free * slope * nz
            free *= 1.0 - f
    return free, gx, gy, gz


@boundary_function
def push_out(rows, radius, x, y, z):
    """The point moved to at least ``radius`` [m] from every boundary, and the largest
    push [m]. Boundaries are visited in order; a tank's planes are axis-aligned, so this
    clamps into the box exactly, corners included."""
    deepest = 0.0
    for b in range(rows.shape[0]):
        d, nx, ny, nz = row_signed_distance(rows, b, x, y, z, 1.0)
        push = radius - d
        if push > 0.0:
            x += push * nx
            y += push * ny
            z += push * nz
            deepest = max(deepest, push)
    return x, y, z, deepest


@parallel_kernel
def project(px, py, pz, rows, radius, depth):
    """Push particles closer than ``radius`` [m] to a boundary back to that distance.

    ``depth[i]`` receives the largest push-out of particle ``i`` [m] (friction by depth).
    """
    n = px.shape[0]
    for block in prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            x, y, z, deepest = push_out(
                rows, radius, np.float64(px[i]), np.float64(py[i]), np.float64(pz[i])
            )
            px[i], py[i], pz[i] = x, y, z
            depth[i] = deepest


@device
def gather(nbr, first, size, x, y, z, value, far, near, with_value=True):
    """Copy ``x, y, z`` and ``value`` of the neighbours ``nbr[first : first + size]``
    into rows 0-3 of ``near`` (float32, (4, CHUNK)); returns the count padded to a
    multiple of 8.

    The padding entries are the point ``far`` (a tuple, farther than ``h`` from the
    particle, so that every kernel term of it is exactly zero) with value 0: the
    kernel's loop over the entries then runs in whole vectors of 8, with no scalar
    remainder (5 % faster at ~27 neighbours, where the remainder was ~3 of them).
    Without ``with_value``, row 3 is left as it is: a kernel whose ``value`` is one
    number for every particle (:func:`uniform`) fills it once, and each neighbour costs
    three copies instead of four.
    """
    for t in range(size):
        # Unsigned: Numba then skips the negative-index wraparound (25 % of this loop).
        j = np.uint64(nbr[first + t])
        near[0, t] = x[j]
        near[1, t] = y[j]
        near[2, t] = z[j]
        if with_value:
            near[3, t] = value[j]
    padded = (size + np.uint64(7)) // np.uint64(8) * np.uint64(8)
    for t in range(size, padded):
        near[0, t] = far[0]
        near[1, t] = far[1]
        near[2, t] = far[2]
        if with_value:
            near[3, t] = 0.0
    return padded


@device
def uniform(values):
    """Whether every entry of ``values`` (1-D, at least one) equals the first: a liquid
    of one phase has one weight and one mass, and its gathers skip them."""
    first = values[0]
    for i in range(values.shape[0]):  # noqa: SIM110 (a generator does not compile)
        if values[i] != first:
            return False
    return True


@parallel_kernel
def density_lambda(
    px, py, pz, begin, end, nbr, weight, rows, h, spacing, wall_scale, inv_delta0, eps, delta, lam,
    wall_gradient,
):  # fmt: skip
    """Number density and the Lagrange multiplier of each density constraint.

    Macklin & Müller 2013, eqs. 1-11, with the constraint ``C_i = δ_i / δ₀ - 1`` on the
    number density ``δ_i = Σ_j W_poly6(p_i - p_j) + δ₀ (1 - Q)`` [1/m³] (the walls'
    share, :func:`walls`), clamped at 0 so that the free surface does not pull
    particles together, and masses entering as weights ``weight = m_ref / m``:
    ``λ_i = -C_i / (Σ_k w_k |∇_k C_i|² + ε)``. ``wall_gradient`` (float64, (3, n))
    receives ``∇(1 - Q)`` [1/m] for :func:`correction` at the same positions.
    """
    n = px.shape[0]
    inv_h2 = np.float32(1.0 / (h * h))
    # The float32 pair terms are dimensionless shapes (sph.poly6_shape and
    # spiky_gradient_shape); their sums take the units here, in float64.
    density_scale = POLY6 / h**3
    gradient_scale = SPIKY_GRAD / h**5 * inv_delta0
    step = np.uint64(CHUNK)
    # One phase: one weight, filled into the neighbours' row once (see gather).
    same_weight = n > 0 and uniform(weight)
    for block in prange(block_count(n)):
        start, stop = block_bounds(block, n)
        near = np.empty((4, CHUNK), np.float32)
        if same_weight:
            near[3, :] = weight[0]
        terms = np.empty((5, CHUNK), np.float32)
        for i in range(start, stop):
            xi, yi, zi = px[i], py[i], pz[i]
            far = (xi + np.float32(2.0 * h), yi, zi)
            shapes = 1.0  # the particle's own poly6 shape
            gx = gy = gz = 0.0
            sum_g2 = 0.0
            first, last = np.uint64(begin[i]), np.uint64(end[i])
            while first < last:
                size = min(last - first, step)
                # Gathered, computed and summed in three loops: the middle one vectorises
                # (see the module docstring).
                count = gather(nbr, first, size, px, py, pz, weight, far, near, not same_weight)
                for t in range(count):
                    rx, ry, rz = xi - near[0, t], yi - near[1, t], zi - near[2, t]
                    r2 = rx * rx + ry * ry + rz * rz
                    q2 = r2 * inv_h2
                    s = spiky_gradient_shape(np.sqrt(q2))
                    terms[0, t] = poly6_shape(q2)
                    terms[1, t] = s * rx
                    terms[2, t] = s * ry
                    terms[3, t] = s * rz
                    terms[4, t] = near[3, t] * s * s * r2
                shapes += ordered_sum(terms[0], count)
                gx += ordered_sum(terms[1], count)
                gy += ordered_sum(terms[2], count)
                gz += ordered_sum(terms[3], count)
                sum_g2 += ordered_sum(terms[4], count)
                first += size
            density = shapes * density_scale
            gx *= gradient_scale
            gy *= gradient_scale
            gz *= gradient_scale
            sum_g2 *= gradient_scale * gradient_scale
            free, wx, wy, wz = walls(rows, xi, yi, zi, h, spacing, wall_scale)
            wall_gradient[0, i] = wx
            wall_gradient[1, i] = wy
            wall_gradient[2, i] = wz
            density += (1.0 - free) / inv_delta0
            gx += wx
            gy += wy
            gz += wz
            delta[i] = density
            c = max(density * inv_delta0 - 1.0, 0.0)
            lam[i] = -c / (sum_g2 + weight[i] * (gx * gx + gy * gy + gz * gz) + eps)


@parallel_kernel
def correction(
    px, py, pz, begin, end, nbr, weight, lam, rows, h, wall_gradient, inv_delta0, k_corr,
    inv_wq, radius, out,
):  # fmt: skip
    """Corrected positions ``p_i + Δp_i`` [m] (Macklin & Müller 2013, eqs. 12-14), pushed
    out of the boundaries to ``radius`` [m]; ``out`` has shape (3, n).

    ``Δp_i = w_i / δ₀ Σ_j (λ_i + λ_j + s_corr) ∇W_spiky(p_i - p_j) + w_i λ_i ∇(1 - Q)``
    with the tensile term ``s_corr = -k (W(p_i - p_j) / W(Δq))⁴`` [m²]
    (``inv_wq = 1 / W(Δq)``) and ``∇(1 - Q)`` the walls' gradient :func:`density_lambda`
    left in ``wall_gradient`` at these positions. Jacobi: every particle reads the
    positions before the correction, so ``out`` must not alias them.
    """
    n = px.shape[0]
    inv_h2 = np.float32(1.0 / (h * h))
    # float32 shapes in the pair loop, units on the float64 sums (as density_lambda).
    ratio_scale = np.float32(POLY6 / h**3 * inv_wq)
    tensile = np.float32(k_corr)
    gradient_scale = SPIKY_GRAD / h**5 * inv_delta0
    step = np.uint64(CHUNK)
    for block in prange(block_count(n)):
        start, stop = block_bounds(block, n)
        near = np.empty((4, CHUNK), np.float32)
        terms = np.empty((3, CHUNK), np.float32)
        for i in range(start, stop):
            xi, yi, zi = px[i], py[i], pz[i]
            far = (xi + np.float32(2.0 * h), yi, zi)
            li = lam[i]
            ax = ay = az = 0.0
            first, last = np.uint64(begin[i]), np.uint64(end[i])
            while first < last:
                size = min(last - first, step)
                # Gathered, computed and summed in three loops: the middle one vectorises.
                count = gather(nbr, first, size, px, py, pz, lam, far, near)
                for t in range(count):
                    rx, ry, rz = xi - near[0, t], yi - near[1, t], zi - near[2, t]
                    q2 = (rx * rx + ry * ry + rz * rz) * inv_h2
                    ratio = ratio_scale * poly6_shape(q2)
                    ratio *= ratio
                    s = (li + near[3, t] - tensile * ratio * ratio) * spiky_gradient_shape(
                        np.sqrt(q2)
                    )
                    terms[0, t] = s * rx
                    terms[1, t] = s * ry
                    terms[2, t] = s * rz
                ax += ordered_sum(terms[0], count)
                ay += ordered_sum(terms[1], count)
                az += ordered_sum(terms[2], count)
                first += size
            wi = weight[i]
            ax *= wi * gradient_scale
            ay *= wi * gradient_scale
            az *= wi * gradient_scale
            ax += wi * li * wall_gradient[0, i]
            ay += wi * li * wall_gradient[1, i]
            az += wi * li * wall_gradient[2, i]
            x, y, z, _ = push_out(rows, radius, xi + ax, yi + ay, zi + az)
            out[0, i] = x
            out[1, i] = y
            out[2, i] = z


@device
def cohesion_spline(r, h):
    """Akinci et al. 2013, eq. 2: ``C(r)`` [1/m³], attracting for r > h/2."""
    if r > h or r <= 0.0:
        return 0.0
    a = (h - r) * r
    a = a * a * a
    if 2.0 * r > h:
        return COHESION / h**9 * a
    return COHESION / h**9 * (2.0 * a - h**6 / 64.0)


@parallel_kernel
def exchange(
    px, py, pz, vx, vy, vz, begin, end, nbr, phase, mass, delta, normals, gamma, coefficients, out
):
    """Pairwise velocity exchanges over neighbours within ``h``; ``out`` (3, n) = new v.

    ``coefficients`` = (h [m], dt [s], xsph [-], k [1/s], 1/(2σ²) [1/m²],
    repulsion [m/s²], δ₀ [1/m³]); ``gamma`` per phase [m⁶/(kg s²)]. Per pair ``i, j``:

    - the lecture's viscosity: ``m_i Δv_i = k G(d) Δt (m_j v_j - m_i v_i)`` with the
      Gaussian ``G(d) = exp(-d² / 2σ²)``;
    - XSPH (Macklin & Müller 2013, eq. 17) symmetrised: ``m_i Δv_i = c μ_ij W̃ (v_j - v_i)``
      with ``W̃ = 2 W_poly6 / (δ_i + δ_j)`` and ``μ_ij = 2 m_i m_j / (m_i + m_j)``;
    - surface tension (Akinci et al. 2013, eqs. 1-5), same phase only: cohesion
      ``-γ m_i m_j C(d) d̂`` plus curvature ``-γ m_i (n_i - n_j)`` (``normals`` from
      :func:`surface_normals`), both times ``K_ij = 2 δ₀ / (δ_i + δ_j)``;
    - repulsion between different phases: ``F = a μ_ij W_spiky(d) / δ₀ d̂``.
    """
    n = px.shape[0]
    h, dt, xsph, k_visc, inv_two_sigma2, repulsion, delta0 = (
        coefficients[0], coefficients[1], coefficients[2], coefficients[3],
        coefficients[4], coefficients[5], coefficients[6],
    )  # fmt: skip
    h2 = h * h
    # XSPH in float32 (the masses, densities and velocities are), from poly6's shape.
    inv_h2 = np.float32(1.0 / h2)
    xsph_scale = np.float32(xsph * 4.0 * POLY6 / h**3)
    lecture_on = k_visc > 0.0
    pairs_on = repulsion > 0.0 or gamma.max() > 0.0
    nx, ny, nz = normals[0], normals[1], normals[2]
    step = np.uint64(CHUNK)
    same_mass = n > 0 and uniform(mass)
    for block in prange(block_count(n)):
        start, stop = block_bounds(block, n)
        near = np.empty((4, CHUNK), np.float32)  # x, y, z, δ of each neighbour
        moving = np.empty((4, CHUNK), np.float32)  # v, m
        if same_mass:
            moving[3, :] = mass[0]
        surface = np.empty((4, CHUNK), np.float32)  # n, phase
        terms = np.empty((3, CHUNK))
        for i in range(start, stop):
            xi, yi, zi = px[i], py[i], pz[i]
            ui, wi, si = vx[i], vy[i], vz[i]
            mi = mass[i]
            pi = phase[i]
            di = delta[i]
            far = (xi + np.float32(2.0 * h), yi, zi)
            fx = fy = fz = 0.0  # momentum change [kg m/s]
            first, last = np.uint64(begin[i]), np.uint64(end[i])
            while first < last:
                size = min(last - first, step)
                # Gathered, computed and summed in three loops (see the module docstring);
                # padding entries lie beyond h (and have mass 0 unless every mass is
                # one): all their terms are 0.
                count = gather(nbr, first, size, px, py, pz, delta, far, near)
                gather(nbr, first, size, vx, vy, vz, mass, far, moving, not same_mass)
                # XSPH, in a loop of its own so that it vectorises; the terms that may be
                # off are added in loops of their own (the exponential, the square root
                # and the phase test would keep XSPH's loop scalar).
                for t in range(count):
                    rx, ry, rz = xi - near[0, t], yi - near[1, t], zi - near[2, t]
                    r2 = rx * rx + ry * ry + rz * rz
                    mj = moving[3, t]
                    # xsph μ_ij 2 W / (δ_i + δ_j) with one division; symmetric in i, j.
                    mimj = mi * mj
                    smooth = (xsph_scale * mimj * poly6_shape(r2 * inv_h2)
                              / ((mi + mj) * (di + near[3, t])))  # fmt: skip
                    terms[0, t] = smooth * (moving[0, t] - ui)
                    terms[1, t] = smooth * (moving[1, t] - wi)
                    terms[2, t] = smooth * (moving[2, t] - si)
                if lecture_on:
                    for t in range(count):
                        rx, ry, rz = xi - near[0, t], yi - near[1, t], zi - near[2, t]
                        r2 = rx * rx + ry * ry + rz * rz
                        # Pairs beyond h (the lists are from the predicted positions): 0.
                        lecture = k_visc * math.exp(-r2 * inv_two_sigma2) * dt * (r2 <= h2)
                        mj = moving[3, t]
                        terms[0, t] += lecture * (mj * moving[0, t] - mi * ui)
                        terms[1, t] += lecture * (mj * moving[1, t] - mi * wi)
                        terms[2, t] += lecture * (mj * moving[2, t] - mi * si)
                if pairs_on:
                    gather(nbr, first, size, nx, ny, nz, phase, far, surface)
                    for t in range(count):
                        rx, ry, rz = xi - near[0, t], yi - near[1, t], zi - near[2, t]
                        r2 = rx * rx + ry * ry + rz * rz
                        r = math.sqrt(r2)
                        inv_r = (r > 0.0) / max(r, 1e-30 * h)
                        mj = moving[3, t]
                        kij = 2.0 * delta0 / (di + near[3, t])
                        if surface[3, t] == pi:
                            s = -gamma[pi] * mi * mj * kij * cohesion_spline(r, h) * dt * inv_r
                            # Curvature: masses are equal within a phase, so m_i here is
                            # symmetric and the pair's terms cancel.
                            c = -gamma[pi] * mi * kij * dt * ((r2 <= h2) & (r > 0.0))
                            terms[0, t] += c * (nx[i] - surface[0, t])
                            terms[1, t] += c * (ny[i] - surface[1, t])
                            terms[2, t] += c * (nz[i] - surface[2, t])
                        else:
                            mu = 2.0 * (mi * mj) / (mi + mj)
                            s = repulsion * mu * spiky(r, h) / delta0 * dt * inv_r
                        terms[0, t] += s * rx
                        terms[1, t] += s * ry
                        terms[2, t] += s * rz
                fx += ordered_sum(terms[0], count)
                fy += ordered_sum(terms[1], count)
                fz += ordered_sum(terms[2], count)
                first += size
            out[0, i] = ui + fx / mi
            out[1, i] = wi + fy / mi
            out[2, i] = si + fz / mi


@parallel_kernel
def surface_normals(px, py, pz, begin, end, nbr, phase, delta, h, out):
    """Akinci et al. 2013, eq. 5: ``n_i = h Σ_j ∇W_poly6(p_i - p_j) / δ_j`` [-].

    Over neighbours of the same phase (each liquid has its own surface), with the volume
    ``m_j / ρ_j = 1 / δ_j``. It is 0 inside a liquid and about 1 in length at its
    surface, pointing into the liquid. ``out`` has shape (3, n).
    """
    n = px.shape[0]
    scale = -6.0 * 315.0 / (64.0 * math.pi * h**9) * h
    h2 = h * h
    for block in prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            xi, yi, zi = px[i], py[i], pz[i]
            pi = phase[i]
            ax = ay = az = 0.0
            for k in range(np.uint64(begin[i]), np.uint64(end[i])):
                j = nbr[k]
                rx, ry, rz = xi - px[j], yi - py[j], zi - pz[j]
                d = max(h2 - (rx * rx + ry * ry + rz * rz), 0.0)
                s = scale * d * d / delta[j] * (phase[j] == pi)
                ax += s * rx
                ay += s * ry
                az += s * rz
            out[0, i] = ax
            out[1, i] = ay
            out[2, i] = az


@device
def adhesion_spline(r, h):
    """Akinci et al. 2013, eq. 7: ``A(r)`` [1/m³ · m^0.25 ...], nonzero for h/2 < r <= h."""
    if 2.0 * r <= h or r > h:
        return 0.0
    return ADHESION_SCALE / h**3.25 * (-4.0 * r * r / h + 6.0 * r - 2.0 * h) ** 0.25


@device
def wall_adhesion(d, h):
    """``∫_plane A(|x|) dA`` [m²/m³] over a flat wall at distance ``d`` [m].

    The wall is a continuum of boundary samples; the plane integral is
    ``2π ∫_{max(d, h/2)}^{h} A(r) r dr`` (polar coordinates around the foot point),
    taken by the midpoint rule on a few nodes (the spline is smooth there).
    """
    lo = max(d, 0.5 * h)
    if lo >= h:
        return 0.0
    step = (h - lo) / _WALL_NODES
    total = 0.0
    for q in range(_WALL_NODES):
        r = lo + (q + 0.5) * step
        total += adhesion_spline(r, h) * r
    return 2.0 * math.pi * total * step


@parallel_kernel
def boundary_velocity(px, py, pz, vx, vy, vz, depth, rows, coefficients):
    """Adhesion toward boundaries and friction along them, on velocities in place.

    ``coefficients`` = (h [m], particle radius [m], dt [s], ρ₀ · spacing [kg/m²]).
    Adhesion (Akinci et al. 2013, eq. 6) integrates a wall's boundary samples, one per
    spacing² of its surface with ``Ψ = ρ₀ spacing³``:
    ``Δv = -Δt β ρ₀ spacing ∫A dA n``. Friction acts on particles in contact (within
    1.25 radii): ``"scale"`` multiplies the tangential velocity by ``1 - μ``, ``"depth"``
    removes up to ``μ · depth / Δt`` of it (Coulomb, ``depth`` the step's push-out).
    """
    n = px.shape[0]
    h, radius, dt, wall_mass = coefficients[0], coefficients[1], coefficients[2], coefficients[3]
    for block in prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            x, y, z = np.float64(px[i]), np.float64(py[i]), np.float64(pz[i])
            u, v, w = np.float64(vx[i]), np.float64(vy[i]), np.float64(vz[i])
            for b in range(rows.shape[0]):
                d, nx, ny, nz = row_signed_distance(rows, b, x, y, z, 1.0)
                if d >= h:
                    continue
                beta = rows[b, ADHESION]
                if beta > 0.0:
                    a = dt * beta * wall_mass * wall_adhesion(d, h)
                    u -= a * nx
                    v -= a * ny
                    w -= a * nz
                mu = rows[b, FRICTION]
                if mu > 0.0 and d <= 1.25 * radius:
                    vn = u * nx + v * ny + w * nz
                    tx, ty, tz = u - vn * nx, v - vn * ny, w - vn * nz
                    if rows[b, FRICTION_MODEL] == 0.0:
                        keep = 1.0 - mu
                    else:
                        speed = math.sqrt(tx * tx + ty * ty + tz * tz)
                        keep = max(0.0, 1.0 - mu * depth[i] / dt / max(speed, 1e-30))
                    u, v, w = vn * nx + keep * tx, vn * ny + keep * ty, vn * nz + keep * tz
            vx[i], vy[i], vz[i] = u, v, w


@parallel_kernel
def cell_density(sx, sy, sz, cell_start, origin, inv_cell, dims, h, out):
    """Number density ``Σ_j W_poly6`` [1/m³] of grid-sorted points, by cell traversal.

    No neighbour list: each point visits the cell rows its box ``[p - h, p + h]``
    touches. The rows' terms are appended to a small buffer in loops that vectorise
    (nothing is summed in them), and the buffer is added in a fixed order by
    :func:`ordered_sum` when full and at the end (a plain running sum would not
    vectorise: the kernels may not reassociate floats). One sum per point rather than
    one per row: a row holds ~30 points, and each sum's scalar tail of up to 7 additions
    cost 1.3x in all. ``out`` in sorted order.
    """
    n = sx.shape[0]
    nx, ny, nz = dims[0], dims[1], dims[2]
    h2 = np.float32(h * h)
    reach = h * (1.0 + 1e-7)
    step = np.uint64(CHUNK)
    for block in prange(block_count(n)):
        start, stop = block_bounds(block, n)
        terms = np.empty(CHUNK, np.float32)
        for q in range(start, stop):
            px, py, pz = sx[q], sy[q], sz[q]
            x0 = cell_coordinate(px - reach, origin[0], inv_cell, nx)
            x1 = cell_coordinate(px + reach, origin[0], inv_cell, nx)
            y0 = cell_coordinate(py - reach, origin[1], inv_cell, ny)
            y1 = cell_coordinate(py + reach, origin[1], inv_cell, ny)
            z0 = cell_coordinate(pz - reach, origin[2], inv_cell, nz)
            z1 = cell_coordinate(pz + reach, origin[2], inv_cell, nz)
            total = np.float32(0.0)
            filled = np.uint64(0)
            for cz in range(z0, z1 + 1):
                for cy in range(y0, y1 + 1):
                    row = nx * (cy + ny * cz)
                    chunk = np.uint64(cell_start[row + x0])
                    end = np.uint64(cell_start[row + x1 + 1])
                    while chunk < end:
                        size = min(end - chunk, step - filled)
                        for t in range(size):
                            s = chunk + t
                            dx = sx[s] - px
                            dy = sy[s] - py
                            dz = sz[s] - pz
                            d = max(h2 - (dx * dx + dy * dy + dz * dz), np.float32(0.0))
                            terms[filled + t] = d * d * d
                        filled += size
                        chunk += size
                        if filled == step:
                            total += ordered_sum(terms, filled)
                            filled = np.uint64(0)
            total += ordered_sum(terms, filled)
            out[q] = total * np.float32(poly6(0.0, h) / h**6)


@parallel_kernel
def vorticity(px, py, pz, vx, vy, vz, begin, end, nbr, delta, h, out):
    """Vorticity ``ω_i = Σ_j V_j ∇_i W_ij × (v_j - v_i)`` [1/s] (Macklin & Müller 2013,
    eq. 15, with the volume ``V_j = 1 / δ_j``: the SPH curl, exact to the kernel's
    discretisation for a rigid rotation, ``ω = 2Ω``); spiky gradients, ``out`` (3, n).
    """
    n = px.shape[0]
    for block in prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            xi, yi, zi = px[i], py[i], pz[i]
            ui, wi, si = vx[i], vy[i], vz[i]
            ax = ay = az = 0.0
            for k in range(np.uint64(begin[i]), np.uint64(end[i])):
                j = nbr[k]
                rx, ry, rz = xi - px[j], yi - py[j], zi - pz[j]
                g = spiky_gradient_scale(math.sqrt(rx * rx + ry * ry + rz * rz), h) / delta[j]
                du, dv, dw = vx[j] - ui, vy[j] - wi, vz[j] - si
                ax += g * (ry * dw - rz * dv)
                ay += g * (rz * du - rx * dw)
                az += g * (rx * dv - ry * du)
            out[0, i] = ax
            out[1, i] = ay
            out[2, i] = az


@parallel_kernel
def confinement(px, py, pz, vx, vy, vz, begin, end, nbr, delta, omega, h, scale, out):
    """Velocities after vorticity confinement (Fedkiw, Stam & Jensen 2001, eqs. 9-11, as
    Macklin & Müller 2013, eq. 16 use it): ``v_i + scale (N_i × ω_i)`` with
    ``N = η / |η|``, ``η_i = Σ_j V_j (|ω_j| - |ω_i|) ∇_i W_ij`` (the SPH gradient of
    ``|ω|``, pointing toward the vortex cores) and ``scale = Δt ε spacing`` [m].
    ``out`` (3, n) must not alias the velocities.
    """
    n = px.shape[0]
    for block in prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            xi, yi, zi = px[i], py[i], pz[i]
            oi = math.sqrt(omega[0, i] ** 2 + omega[1, i] ** 2 + omega[2, i] ** 2)
            ex = ey = ez = 0.0
            for k in range(np.uint64(begin[i]), np.uint64(end[i])):
                j = nbr[k]
                rx, ry, rz = xi - px[j], yi - py[j], zi - pz[j]
                g = spiky_gradient_scale(math.sqrt(rx * rx + ry * ry + rz * rz), h) / delta[j]
                oj = math.sqrt(omega[0, j] ** 2 + omega[1, j] ** 2 + omega[2, j] ** 2)
                ex += g * (oj - oi) * rx
                ey += g * (oj - oi) * ry
                ez += g * (oj - oi) * rz
            length = math.sqrt(ex * ex + ey * ey + ez * ez)
            fx = fy = fz = 0.0
            if length > 0.0:  # a flat |ω| has no direction to confine toward
                ex, ey, ez = ex / length, ey / length, ez / length
                wx, wy, wz = omega[0, i], omega[1, i], omega[2, i]
                fx, fy, fz = ey * wz - ez * wy, ez * wx - ex * wz, ex * wy - ey * wx
            out[0, i] = vx[i] + scale * fx
            out[1, i] = vy[i] + scale * fy
            out[2, i] = vz[i] + scale * fz
