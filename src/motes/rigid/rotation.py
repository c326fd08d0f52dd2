"""Rotations of particle bodies, refined in compiled code during contact solving."""

from __future__ import annotations

import numpy as np

from .._jit import serial_kernel


@serial_kernel
def matmul3(a, b, out):
    """out = a b for 3 × 3 matrices (out distinct from a and b)."""
    for i in range(3):
        for j in range(3):
            out[i, j] = a[i, 0] * b[0, j] + a[i, 1] * b[1, j] + a[i, 2] * b[2, j]


@serial_kernel
def update_rotations(px, py, pz, body_start, body_particles, mass_fraction, rest, rotation, sweeps):
    """Refine each body's rotation toward the rotation part of ``A = Σ f (x - c) r^T``.

    Müller, Bender, Chentanez & Macklin 2016, "A robust method to extract the rotational
    part of deformations" (eq. 7): ``ω = Σ_i r_i × a_i / (|Σ_i r_i · a_i| + ε)`` over
    the columns of R and A, then R <- rot(ω) R, warm-started from the last rotation.
    Unlike a polar decomposition it needs no inverse, so flat bodies (a triangle) work.
    """
    for b in range(body_start.shape[0] - 1):
        cx = cy = cz = 0.0
        for e in range(body_start[b], body_start[b + 1]):
            k = body_particles[e]
            cx += mass_fraction[e] * px[k]
            cy += mass_fraction[e] * py[k]
            cz += mass_fraction[e] * pz[k]
        a = np.zeros((3, 3))
        for e in range(body_start[b], body_start[b + 1]):
            k = body_particles[e]
            d = (px[k] - cx, py[k] - cy, pz[k] - cz)
            for i in range(3):
                for j in range(3):
                    a[i, j] += mass_fraction[e] * d[i] * rest[e, j]
        r = rotation[b]
        for _ in range(sweeps):
            wx = wy = wz = 0.0
            dot = 0.0
            for j in range(3):
                wx += r[1, j] * a[2, j] - r[2, j] * a[1, j]
                wy += r[2, j] * a[0, j] - r[0, j] * a[2, j]
                wz += r[0, j] * a[1, j] - r[1, j] * a[0, j]
                dot += r[0, j] * a[0, j] + r[1, j] * a[1, j] + r[2, j] * a[2, j]
            scale = 1.0 / (abs(dot) + 1e-12)
            wx, wy, wz = wx * scale, wy * scale, wz * scale
            angle = np.sqrt(wx * wx + wy * wy + wz * wz)
            if angle < 1e-12:
                break
            ux, uy, uz = wx / angle, wy / angle, wz / angle
            c, s = np.cos(angle), np.sin(angle)
            t = 1.0 - c
            m = np.empty((3, 3))
            m[0, 0], m[0, 1], m[0, 2] = c + ux * ux * t, ux * uy * t - uz * s, ux * uz * t + uy * s
            m[1, 0], m[1, 1], m[1, 2] = uy * ux * t + uz * s, c + uy * uy * t, uy * uz * t - ux * s
            m[2, 0], m[2, 1], m[2, 2] = uz * ux * t - uy * s, uz * uy * t + ux * s, c + uz * uz * t
            matmul3(m, r.copy(), r)
