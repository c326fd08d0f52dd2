r"""Compiled pieces of the implicit (Baraff & Witkin 1998) step.

The linear system ``A Δv = b`` with ``A = M - h ∂f/∂v - h² ∂f/∂x`` is held in three
parts, all 3×3 blocks row-major:

- one assembled diagonal block per particle (``diag``, shape ``(n, 9)``);
- the springs' off-diagonal blocks, kept per spring: spring ``k`` contributes
  ``C_k = α I + β u uᵀ`` (``coef[k] = (α, β, u)``) at ``(a, a)`` and ``(b, b)`` and
  ``-C_k`` at ``(a, b)`` and ``(b, a)``. Products use the five numbers directly: half the
  arithmetic and a third of the memory of two assembled 3×3 blocks;
- other forces' off-diagonal blocks in block-CSR form (``row_ptr`` (n + 1,), ``cols``,
  ``off`` (nnz, 9)).

The diagonal and the block-CSR part are assembled without scattering: each block is a
sum of sources listed for it in a CSR incidence list built once in NumPy, and one
parallel pass over particles sums them in a fixed order. Vectors are ``(n, 3)`` float64:
the solve needs float64 (stiff springs make ``A``'s condition number ~ h²k/m ≈ 1e4-1e6,
and conjugate gradients in float32 stall near a relative residual of 1e-4).

The solve is serial (see :func:`pcg_kernel`), so it is the same for any thread count; its
dot products are still summed per ``BLOCK`` of particles, then the partials in order.
"""

from __future__ import annotations

import numba
import numpy as np

from .._jit import block_bounds, block_count, called, device, parallel_kernel, serial_kernel
from .blocks import apply, inverse3, spring_apply
from .multigrid_kernels import vcycle


@parallel_kernel
def spring_system_kernel(x, y, z, vx, vy, vz, pairs, rest, ks, kd, h, coef, rhs):
    """Per-spring part of ``A`` and right-hand side term.

    With unit vector ``u`` from ``b`` to ``a``, length ``L`` and ``r = max(0, 1 - s/L)``,
    the stiffness Jacobian used is ``K = -k_s (r I + (1 - r) u uᵀ)`` (Baraff & Witkin 1998
    eq. 13 with the transverse term clamped at zero for compressed springs, Choi & Ko
    2002, so that ``A`` stays symmetric positive definite; the damping force's position
    derivative is dropped as in Baraff & Witkin §5.2) and ``∂f/∂v = -k_d u uᵀ``.

    Writes ``coef[k] = (α, β, u_x, u_y, u_z)`` with ``-h ∂f_a/∂v_a - h² ∂f_a/∂x_a =
    α I + β u uᵀ``, and ``rhs[:, k]`` = ``h (f_a + h K (v_a - v_b))`` [N s]; end ``b``
    gets the negative (gathered by :func:`gather_rhs_kernel`).
    """
    m = pairs.shape[0]
    for block in numba.prange(block_count(m)):
        start, stop = block_bounds(block, m)
        for k in range(start, stop):
            a = pairs[k, 0]
            b = pairs[k, 1]
            dx = x[a] - x[b]
            dy = y[a] - y[b]
            dz = z[a] - z[b]
            length = np.sqrt(dx * dx + dy * dy + dz * dz)
            if length > 0.0:
                ux = dx / length
                uy = dy / length
                uz = dz / length
                r = max(0.0, 1.0 - rest[k] / length)
            else:  # no direction: K = -k_s I, no force (matches Springs)
                ux = uy = uz = 0.0
                r = 1.0
            wx = vx[a] - vx[b]
            wy = vy[a] - vy[b]
            wz = vz[a] - vz[b]
            closing = wx * ux + wy * uy + wz * uz
            magnitude = ks[k] * (length - rest[k]) + kd[k] * closing
            coef[k, 0] = h * h * ks[k] * r
            coef[k, 1] = h * kd[k] + h * h * ks[k] * (1.0 - r)
            coef[k, 2] = ux
            coef[k, 3] = uy
            coef[k, 4] = uz
            # K w = -k_s (r w + (1 - r) u (u·w))
            along = (1.0 - r) * closing
            gx = -ks[k] * (r * wx + along * ux)
            gy = -ks[k] * (r * wy + along * uy)
            gz = -ks[k] * (r * wz + along * uz)
            rhs[0, k] = h * (-magnitude * ux + h * gx)
            rhs[1, k] = h * (-magnitude * uy + h * gy)
            rhs[2, k] = h * (-magnitude * uz + h * gz)


@parallel_kernel
def gather_rhs_kernel(rhs, incident_ptr, incident, out):
    """``out[i] +=`` the spring terms of particle ``i``; end ``b`` (``e & 1``) negated.

    ``incident[incident_ptr[i]:incident_ptr[i + 1]]`` holds ``e = 2 k + end`` in spring
    order; ``out`` has shape ``(n, 3)``.
    """
    n = out.shape[0]
    for block in numba.prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            sx = 0.0
            sy = 0.0
            sz = 0.0
            for j in range(incident_ptr[i], incident_ptr[i + 1]):
                e = incident[j]
                k = e >> 1
                sign = 1.0 - 2.0 * (e & 1)
                sx += sign * rhs[0, k]
                sy += sign * rhs[1, k]
                sz += sign * rhs[2, k]
            out[i, 0] += sx
            out[i, 1] += sy
            out[i, 2] += sz


@parallel_kernel
def assemble_kernel(
    mass,
    diag_extra,
    coef,
    incident_ptr,
    incident,
    sources,
    diag_ptr,
    diag_src,
    row_ptr,
    slot_ptr,
    slot_src,
    diag,
    off,
    inv_diag,
):
    """Assemble ``A``'s diagonal and block-CSR blocks and invert the diagonal (block Jacobi).

    ``diag[i] = (mass[i] + diag_extra[i]) I + Σ_k C_k + Σ sources[diag_src[...]]`` over
    the springs ``k = e >> 1`` of ``incident[incident_ptr[i]:incident_ptr[i + 1]]`` and
    the generic diagonal sources of particle ``i``; off-diagonal slot ``s`` (row ``i``
    owns slots ``row_ptr[i]:row_ptr[i + 1]``) is the sum of ``sources[slot_src[...]]``
    over ``slot_ptr[s]:slot_ptr[s + 1]``.
    """
    n = mass.shape[0]
    for block in numba.prange(block_count(n)):
        start, stop = block_bounds(block, n)
        acc = np.empty(9)
        for i in range(start, stop):
            for c in range(9):
                acc[c] = 0.0
            d = mass[i] + diag_extra[i]
            for j in range(incident_ptr[i], incident_ptr[i + 1]):
                k = incident[j] >> 1
                alpha = coef[k, 0]
                beta = coef[k, 1]
                ux = coef[k, 2]
                uy = coef[k, 3]
                uz = coef[k, 4]
                d += alpha
                acc[0] += beta * ux * ux
                acc[1] += beta * ux * uy
                acc[2] += beta * ux * uz
                acc[4] += beta * uy * uy
                acc[5] += beta * uy * uz
                acc[8] += beta * uz * uz
            acc[3] = acc[1]
            acc[6] = acc[2]
            acc[7] = acc[5]
            acc[0] += d
            acc[4] += d
            acc[8] += d
            for j in range(diag_ptr[i], diag_ptr[i + 1]):
                s = diag_src[j]
                for c in range(9):
                    acc[c] += sources[s, c]
            for c in range(9):
                diag[i, c] = acc[c]
            inverse3(acc, inv_diag, i)
            for slot in range(row_ptr[i], row_ptr[i + 1]):
                for c in range(9):
                    acc[c] = 0.0
                for j in range(slot_ptr[slot], slot_ptr[slot + 1]):
                    s = slot_src[j]
                    for c in range(9):
                        acc[c] += sources[s, c]
                for c in range(9):
                    off[slot, c] = acc[c]


@device
def _filter(filt, held, i, vx, vy, vz):
    """``S_i v``: the identity for free particles (most of them), the projection else."""
    if held[i]:
        return apply(filt, i, vx, vy, vz)
    return vx, vy, vz


@device
def _product(diag, off, row_ptr, cols, pairs, coef, v, out):
    """``out = A v`` (serial: the spring loop adds into both of its ends)."""
    n = v.shape[0]
    for i in range(n):
        sx, sy, sz = apply(diag, i, v[i, 0], v[i, 1], v[i, 2])
        # Unsigned indices: Numba then skips negative-index wraparound (_jit.block_bounds).
        for slot in range(np.uint64(row_ptr[i]), np.uint64(row_ptr[i + 1])):
            j = np.uint64(cols[slot])
            ax, ay, az = apply(off, slot, v[j, 0], v[j, 1], v[j, 2])
            sx += ax
            sy += ay
            sz += az
        out[i, 0] = sx
        out[i, 1] = sy
        out[i, 2] = sz
    for k in range(pairs.shape[0]):
        a = np.uint64(pairs[k, 0])
        b = np.uint64(pairs[k, 1])
        # Off-diagonal blocks -C_k: out_a -= C_k v_b, out_b -= C_k v_a.
        cx, cy, cz = spring_apply(coef, k, v, b)
        out[a, 0] -= cx
        out[a, 1] -= cy
        out[a, 2] -= cz
        cx, cy, cz = spring_apply(coef, k, v, a)
        out[b, 0] -= cx
        out[b, 1] -= cy
        out[b, 2] -= cz


@serial_kernel
def product_kernel(diag, off, row_ptr, cols, pairs, coef, v, out):
    """``out = A v`` for ``(n, 3)`` vectors."""
    _product(diag, off, row_ptr, cols, pairs, coef, v, out)


@serial_kernel
def rows_product_kernel(
    rows, diag, off, row_ptr, cols, pairs, coef, incident_ptr, incident, v, out
):  # fmt: skip
    """``out[k] = (A v)[rows[k]]``: a few rows of the product, each read through the
    particle's springs (``incident``) and block-CSR entries, not the whole product."""
    for k in range(rows.shape[0]):
        i = rows[k]
        sx, sy, sz = apply(diag, i, v[i, 0], v[i, 1], v[i, 2])
        for slot in range(row_ptr[i], row_ptr[i + 1]):
            j = cols[slot]
            ax, ay, az = apply(off, slot, v[j, 0], v[j, 1], v[j, 2])
            sx += ax
            sy += ay
            sz += az
        for e in range(incident_ptr[i], incident_ptr[i + 1]):
            spring = incident[e] >> 1
            cx, cy, cz = spring_apply(coef, spring, v, pairs[spring, 1 - (incident[e] & 1)])
            sx -= cx
            sy -= cy
            sz -= cz
        out[k, 0] = sx
        out[k, 1] = sy
        out[k, 2] = sz


@called
def _precondition(multigrid, inv_diag, filt, held, fine, coarse, r, s, crhs, cx):
    """``s = P⁻¹ r`` in the free directions: ``S`` times block Jacobi's ``diag(A)⁻¹ r``,
    or one multigrid cycle (:func:`~motes.integrate.multigrid_kernels.vcycle`).
    Returns ``rᵀ s``."""
    n = r.shape[0]
    if multigrid:
        vcycle(fine, coarse, r, s, crhs, cx)
    else:
        for i in range(n):
            px, py, pz = apply(inv_diag, i, r[i, 0], r[i, 1], r[i, 2])
            s[i, 0], s[i, 1], s[i, 2] = _filter(filt, held, i, px, py, pz)
    return _dot(r, s)


@device
def _dot(u, v):
    """``uᵀ v`` of ``(n, 3)`` vectors, summed per ``BLOCK`` of particles, then in order."""
    n = u.shape[0]
    total = 0.0
    for blk in range(block_count(n)):
        first, stop = block_bounds(blk, n)
        partial = 0.0
        for i in range(first, stop):
            partial += u[i, 0] * v[i, 0] + u[i, 1] * v[i, 1] + u[i, 2] * v[i, 2]
        total += partial
    return total


@serial_kernel
def pcg_kernel(
    diag,
    off,
    row_ptr,
    cols,
    pairs,
    coef,
    inv_diag,
    filt,
    held,
    b,
    start,
    tolerance,
    max_iterations,
    dv,
    work,
    multigrid,
    fine,
    coarse,
    crhs,
    cx,
):
    """Baraff & Witkin's modified preconditioned conjugate gradients (1998, §5.3).

    Solves ``S (A Δv - b) = 0`` with ``(I - S) Δv = (I - S) z``, where ``S`` (``filt``,
    ``(n, 9)``: one symmetric projection per particle, applied where ``held`` (n,) is
    True, the identity elsewhere) removes the constrained directions and ``z`` holds the
    prescribed velocity changes there. The preconditioner is one aggregation multigrid
    cycle where ``multigrid`` is True (``fine``, ``coarse``, ``crhs``, ``cx``: see
    :func:`~motes.integrate.multigrid_kernels.vcycle`), else the inverse of ``A``'s
    diagonal blocks (block Jacobi). ``start`` is the first iterate: it must equal ``z``
    in the constrained directions (any free part is a warm start). Stops when the
    preconditioned residual ``rᵀP⁻¹r`` falls below ``tolerance²`` times
    ``max((Sb)ᵀP⁻¹(Sb), r0ᵀP⁻¹r0)`` (Baraff & Witkin's criterion relative to the
    right-hand side, or to the first residual when a prescribed motion alone drives the
    system), or after ``max_iterations``.

    Serial on purpose: an iteration is a product and three short passes separated by
    reductions, and with other processes on the cores every parallel region waits for a
    time slice (measured on the shared 2-core machine: 2,000 hair strands took 500 ms per
    solve with two threads and 12 ms with one).

    ``work`` is scratch of shape ``(5, n, 3)``. Returns ``(iterations, delta0, delta)``;
    ``delta`` is NaN when the iteration broke down (a non-positive curvature ``cᵀAc``:
    ``A`` not positive definite on the free directions).
    """
    n = b.shape[0]
    r = work[0]
    c = work[1]
    q = work[2]
    s = work[3]
    product = work[4]
    # Reference: (Sb)ᵀ P⁻¹ (Sb).
    for i in range(n):
        r[i, 0], r[i, 1], r[i, 2] = _filter(filt, held, i, b[i, 0], b[i, 1], b[i, 2])
    reference = _precondition(multigrid, inv_diag, filt, held, fine, coarse, r, s, crhs, cx)
    # Δv = start; r = S (b - A Δv); c = S P⁻¹ r
    _product(diag, off, row_ptr, cols, pairs, coef, start, product)
    for i in range(n):
        for d in range(3):
            dv[i, d] = start[i, d]
        r[i, 0], r[i, 1], r[i, 2] = _filter(
            filt,
            held,
            i,
            b[i, 0] - product[i, 0],
            b[i, 1] - product[i, 1],
            b[i, 2] - product[i, 2],
        )
    delta = _precondition(multigrid, inv_diag, filt, held, fine, coarse, r, c, crhs, cx)
    delta0 = max(delta, reference)
    threshold = tolerance * tolerance * delta0
    iterations = 0
    while delta > threshold and iterations < max_iterations:
        # q = S A c; curvature cᵀq
        _product(diag, off, row_ptr, cols, pairs, coef, c, product)
        for i in range(n):
            q[i, 0], q[i, 1], q[i, 2] = _filter(
                filt, held, i, product[i, 0], product[i, 1], product[i, 2]
            )
        curvature = _dot(c, q)
        if not curvature > 0.0:
            return iterations, delta0, np.nan
        alpha = delta / curvature
        for i in range(n):
            for d in range(3):
                dv[i, d] += alpha * c[i, d]
                r[i, d] -= alpha * q[i, d]
        previous = delta
        delta = _precondition(multigrid, inv_diag, filt, held, fine, coarse, r, s, crhs, cx)
        beta = delta / previous
        for i in range(n):
            c[i, 0], c[i, 1], c[i, 2] = _filter(
                filt,
                held,
                i,
                s[i, 0] + beta * c[i, 0],
                s[i, 1] + beta * c[i, 1],
                s[i, 2] + beta * c[i, 2],
            )
        iterations += 1
    return iterations, delta0, delta


__all__ = [
    "assemble_kernel",
    "gather_rhs_kernel",
    "pcg_kernel",
    "product_kernel",
    "rows_product_kernel",
    "spring_system_kernel",
]
