r"""Bending linear in the angle, as springs the implicit integrator assembles directly.

For three consecutive particles ``i, j, k`` of a strand the energy

.. math:: E = \tfrac{1}{2} k_b \, |x_i - 2 x_j + x_k|^2

penalises the discrete curvature: for segments of length ``s`` meeting at angle ``θ``,
``|x_i - 2x_j + x_k| = 2 s sin(θ/2) ≈ s θ``, so the bending force is proportional to the
angle between the segments (and also evens out unequal segments). It is quadratic in the
positions, and by the parallelogram identity

.. math:: |a - b|^2 = 2|a|^2 + 2|b|^2 - |a + b|^2, \quad a = x_i - x_j,\ b = x_j - x_k

it is exactly the energy of three zero-rest-length springs: ``2 k_b`` on ``(i, j)`` and
on ``(j, k)``, and ``-k_b`` on ``(i, k)``. A zero-rest-length spring is linear
(``f = -k d``), so the three springs reproduce the force and its constant Jacobian
``-k_b [1, -2, 1]ᵀ[1, -2, 1] ⊗ I`` exactly, and the sum is positive semi-definite even
though one spring is negative. :class:`StencilSprings` lets such signed springs through
``Springs``' compiled paths (forces, and the implicit solver's per-spring fast path).
"""

from __future__ import annotations

import numpy as np

from ..forces.springs import Springs, _pairs


class StencilSprings(Springs):
    """:class:`~motes.forces.springs.Springs` whose stiffness may be negative.

    Only for springs that are terms of a positive semi-definite sum (see
    :func:`angle_bending`); damping must still be >= 0.
    """

    def __init__(self, pairs, rest_length, stiffness, damping):
        pairs = _pairs(pairs)
        m = pairs.shape[0]
        arrays = []
        for name, value in (
            ("rest_length", rest_length),
            ("stiffness", stiffness),
            ("damping", damping),
        ):
            arr = np.broadcast_to(np.asarray(value, dtype=np.float64), (m,)).copy()
            if not np.all(np.isfinite(arr)):
                raise ValueError(f"{name} must be finite")
            arrays.append(arr)
        if np.any(arrays[0] < 0) or np.any(arrays[2] < 0):
            raise ValueError("rest_length and damping must be >= 0")
        self._set(pairs, *arrays)


def angle_bending(triples: np.ndarray, stiffness: float, damping: float):
    """Pairs, rest lengths, stiffnesses and dampings of the springs that realise
    ``½ k_b |x_i - 2x_j + x_k|²`` for each row ``(i, j, k)`` of ``triples``.

    ``damping`` [N s/m] acts along ``(i, k)`` only (a positive damper: dissipative).
    """
    t = np.asarray(triples, dtype=np.int64)
    count = len(t)
    pairs = np.concatenate([t[:, [0, 1]], t[:, [1, 2]], t[:, [0, 2]]])
    rest = np.zeros(3 * count)
    k = np.concatenate([np.full(2 * count, 2.0 * stiffness), np.full(count, -stiffness)])
    kd = np.concatenate([np.zeros(2 * count), np.full(count, damping)])
    return pairs, rest, k, kd
