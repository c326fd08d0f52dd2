"""3×3 blocks stored row-major as rows of 9 numbers: the compiled helpers the implicit
solve and its multigrid preconditioner share."""

from __future__ import annotations

import numpy as np

from .._jit import device


@device
def apply(m, i, vx, vy, vz):
    """Row-major 3×3 block ``m[i]`` times (vx, vy, vz)."""
    return (
        m[i, 0] * vx + m[i, 1] * vy + m[i, 2] * vz,
        m[i, 3] * vx + m[i, 4] * vy + m[i, 5] * vz,
        m[i, 6] * vx + m[i, 7] * vy + m[i, 8] * vz,
    )


@device
def inverse3(m, out, i):
    """``out[i]`` = inverse of the row-major 3×3 ``m`` (cofactors / determinant)."""
    c0 = m[4] * m[8] - m[5] * m[7]
    c1 = m[5] * m[6] - m[3] * m[8]
    c2 = m[3] * m[7] - m[4] * m[6]
    det = m[0] * c0 + m[1] * c1 + m[2] * c2
    inv = 1.0 / det
    out[i, 0] = c0 * inv
    out[i, 1] = (m[2] * m[7] - m[1] * m[8]) * inv
    out[i, 2] = (m[1] * m[5] - m[2] * m[4]) * inv
    out[i, 3] = c1 * inv
    out[i, 4] = (m[0] * m[8] - m[2] * m[6]) * inv
    out[i, 5] = (m[2] * m[3] - m[0] * m[5]) * inv
    out[i, 6] = c2 * inv
    out[i, 7] = (m[1] * m[6] - m[0] * m[7]) * inv
    out[i, 8] = (m[0] * m[4] - m[1] * m[3]) * inv


@device
def spring_apply(coef, k, v, o):
    """``C_k v_o`` for a spring's block ``C_k = α I + β u uᵀ``, ``coef[k] = (α, β, u_x,
    u_y, u_z)`` (float64 or float32 rows; the product is float64)."""
    alpha = np.float64(coef[k, 0])
    beta = np.float64(coef[k, 1])
    ux = np.float64(coef[k, 2])
    uy = np.float64(coef[k, 3])
    uz = np.float64(coef[k, 4])
    along = beta * (ux * v[o, 0] + uy * v[o, 1] + uz * v[o, 2])
    return alpha * v[o, 0] + along * ux, alpha * v[o, 1] + along * uy, alpha * v[o, 2] + along * uz
