r"""Damped Hooke springs between pairs of particles.

For a spring joining particles ``a`` and ``b`` with ``d = x_a - x_b``, ``ḋ = v_a - v_b``,
rest length ``s``, stiffness ``k_s`` and damping ``k_d``, the damped spring of Witkin,
"Particle System Dynamics", in Witkin & Baraff, *Physically Based Modeling*, SIGGRAPH
2001 course notes (the Jacobians follow Baraff & Witkin 1998, "Large steps in cloth
simulation", SIGGRAPH):

.. math:: f_a = -\left(k_s (|d| - s) + k_d \frac{ḋ · d}{|d|}\right) \frac{d}{|d|},
   \qquad f_b = -f_a

The damping acts only along the spring, so the pair's momentum and angular momentum are
conserved and rigid motions are not damped. A zero-length spring (``d = 0``) has no
direction and exerts no force.

Determinism
-----------
Scattering per-spring forces into the particles from parallel iterations would race.
Instead one parallel pass writes each spring's force into a scratch ``(3, m)`` array,
and a second parallel pass over the particles that have springs sums them in a fixed
order, read from a particle -> (spring, end) incidence list in CSR form built once in
NumPy. The result is bitwise independent of the number of threads.
"""

from __future__ import annotations

import numba
import numpy as np

from .._jit import block_bounds, block_count, parallel_kernel
from .base import Force, ForceJacobian, check_buffers


class Springs(Force):
    r"""Damped Hooke springs between particle pairs.

    Parameters
    ----------
    pairs : int array_like of shape (m, 2)
        Live particle indices ``(a, b)`` of each spring, ``a != b``.
    rest_length : float or array_like of shape (m,)
        Rest length ``s`` >= 0 [m].
    stiffness : float or array_like of shape (m,)
        ``k_s`` >= 0 [N/m].
    damping : float or array_like of shape (m,)
        ``k_d`` >= 0 [N s/m], along the spring only.

    Attributes
    ----------
    pairs : int64 array of shape (m, 2)
    rest_length, stiffness, damping : float64 arrays of shape (m,)
        Read-only: build a new ``Springs`` to change them (the kernels keep copies in the
        store's precision).
    """

    reads = ("position", "velocity")

    def __init__(self, pairs, rest_length, stiffness, damping):
        pairs = _pairs(pairs)
        m = pairs.shape[0]
        self._set(
            pairs,
            _per_spring("rest_length", rest_length, m),
            _per_spring("stiffness", stiffness, m),
            _per_spring("damping", damping, m),
        )

    def _set(self, pairs, rest_length, stiffness, damping) -> None:
        for array in (pairs, rest_length, stiffness, damping):
            array.flags.writeable = False
        self.pairs = pairs
        self.rest_length = rest_length
        self.stiffness = stiffness
        self.damping = damping
        self._touched, self._offsets, self._entries = _incidence(pairs)
        self._end = int(pairs.max()) + 1 if pairs.shape[0] else 0
        self._typed: dict[np.dtype, tuple[np.ndarray, ...]] = {}

    @property
    def spring_count(self) -> int:
        """Number of springs ``m``."""
        return self.pairs.shape[0]

    def __repr__(self) -> str:
        return f"Springs(<{self.spring_count} springs>)"

    def _check(self, position: np.ndarray, velocity: np.ndarray, out: np.ndarray) -> None:
        check_buffers(position, out)
        if velocity.shape != position.shape:
            raise ValueError(
                f"velocity must have the shape of position {position.shape}, got {velocity.shape}"
            )
        if self._end > position.shape[1]:
            raise ValueError(
                f"springs join particle {self._end - 1} but only {position.shape[1]} particles "
                "are live; remap the springs when particles die"
            )

    def _parameters(self, dtype) -> tuple[np.ndarray, ...]:
        """Rest lengths, stiffnesses, dampings in ``dtype`` and a (3, m) scratch."""
        dtype = np.dtype(dtype)
        if dtype not in self._typed:
            self._typed[dtype] = (
                self.rest_length.astype(dtype),
                self.stiffness.astype(dtype),
                self.damping.astype(dtype),
                np.empty((3, self.spring_count), dtype=dtype),
            )
        return self._typed[dtype]

    def accumulate(self, store, position, velocity, time, out) -> None:
        self._check(position, velocity, out)
        rest_length, stiffness, damping, spring_force = self._parameters(position.dtype)
        _spring_force_kernel(
            *position, *velocity, self.pairs, rest_length, stiffness, damping, spring_force
        )
        _gather_kernel(
            spring_force, self._touched, self._offsets[:-1], self._offsets[1:], self._entries, *out
        )

    def jacobian(self, store, position, velocity, *, exact: bool = False) -> ForceJacobian:
        """∂f/∂x [N/m] and ∂f/∂v [N s/m] (float64), four blocks per spring.

        With ``d̂ = d/|d|``, ``P = d̂d̂ᵀ``, ``Q = I - P`` and blocks ``(a, a)``, ``(b, b)``
        equal to ``+K`` and ``(a, b)``, ``(b, a)`` to ``-K``.

        By default (``exact=False``) the form Baraff & Witkin 1998 (§5.2) and Choi & Ko
        2002 ("Stable but responsive cloth", §4) use for implicit integration, which the
        implicit integrator's compiled spring path also uses::

            ∂f_a/∂x_a = -k_s [P + max(0, 1 - s/|d|) Q],   ∂f_a/∂v_a = -k_d P

        Two terms of the true derivative are dropped: the transverse stiffness of a
        *compressed* spring (``|d| < s`` makes ``1 - s/|d|`` negative: the true ∂f/∂x
        is then indefinite, the buckling instability Choi & Ko describe), and the
        damping force's position derivative (not symmetric). What is left is symmetric
        and negative semi-definite (each spring's ``K`` is positive semi-definite and
        ``[[K, -K], [-K, K]] = [[1, -1], [-1, 1]] ⊗ K``), so ``M - h ∂f/∂v - h² ∂f/∂x``
        is symmetric positive definite and conjugate gradients apply. It equals the
        true derivative for springs at rest length or longer that are not changing
        length or turning (``ḋ = 0``).

        ``exact=True`` gives the true derivative (for Newton's method or checks)::

            ∂f_a/∂x_a = -k_s [P + (1 - s/|d|) Q] - (k_d/|d|) [d̂ (Q ḋ)ᵀ + (ḋ·d̂) Q]

        A zero-length spring gets ``∂f/∂x = -k_s I`` (exact for ``s = 0``) and
        ``∂f/∂v = 0``.
        """
        self._check(position, velocity, position)
        a, b = self.pairs[:, 0], self.pairs[:, 1]
        x = np.asarray(position, dtype=np.float64)
        v = np.asarray(velocity, dtype=np.float64)
        d = (x[:, a] - x[:, b]).T  # (m, 3)
        length = np.linalg.norm(d, axis=1)
        nonzero = length > 0
        safe = np.where(nonzero, length, 1.0)
        unit = d / safe[:, None]
        eye = np.eye(3)
        p = unit[:, :, None] * unit[:, None, :]
        q = eye - p
        ks = self.stiffness[:, None, None]
        kd = self.damping[:, None, None]
        ratio = 1.0 - self.rest_length / safe
        if exact:
            dv = (v[:, a] - v[:, b]).T
            closing = np.einsum("ij,ij->i", dv, unit)
            q_dv = np.einsum("kij,kj->ki", q, dv)
            dfdx = -ks * (p + ratio[:, None, None] * q) - kd / safe[:, None, None] * (
                unit[:, :, None] * q_dv[:, None, :] + closing[:, None, None] * q
            )
        else:
            dfdx = -ks * (p + np.maximum(ratio, 0.0)[:, None, None] * q)
        dfdx[~nonzero] = -self.stiffness[~nonzero, None, None] * eye
        dfdv = -kd * p
        rows = np.concatenate([a, a, b, b])
        cols = np.concatenate([a, b, a, b])
        return ForceJacobian(
            rows,
            cols,
            np.concatenate([dfdx, -dfdx, -dfdx, dfdx]),
            np.concatenate([dfdv, -dfdv, -dfdv, dfdv]),
        )

    def energy(self, position: np.ndarray) -> float:
        """Elastic potential energy ``Σ ½ k_s (|d| - s)^2`` [J] at ``position`` (3, n) [m]."""
        x = np.asarray(position, dtype=np.float64)
        d = x[:, self.pairs[:, 0]] - x[:, self.pairs[:, 1]]
        stretch = np.linalg.norm(d, axis=0) - self.rest_length
        return float(0.5 * np.sum(self.stiffness * stretch**2))

    def remap(self, new_index: np.ndarray | None) -> None:
        """Drop springs with a dead end (``new_index == -1``) and renumber the rest.

        ``new_index`` is what :meth:`ParticleStore.compact` returns; None (nobody died)
        changes nothing.
        """
        if new_index is None:
            return
        new_index = np.asarray(new_index, dtype=np.int64)
        if self._end > new_index.shape[0]:
            raise ValueError(
                f"new_index has {new_index.shape[0]} entries but springs join particle "
                f"{self._end - 1}"
            )
        ends = new_index[self.pairs]
        keep = np.all(ends >= 0, axis=1)
        self._set(ends[keep], self.rest_length[keep], self.stiffness[keep], self.damping[keep])


def _pairs(value) -> np.ndarray:
    """Validated spring pairs as a fresh int64 (m, 2) array."""
    arr = np.asarray(value)
    if arr.size == 0:
        return np.empty((0, 2), dtype=np.int64)
    if arr.dtype.kind not in "iu":
        raise TypeError(f"pairs must be integer particle indices, got dtype {arr.dtype}")
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ValueError(f"pairs must have shape (m, 2), got shape {arr.shape}")
    arr = arr.astype(np.int64)
    if arr.min() < 0:
        raise ValueError(f"pairs must hold particle indices >= 0, got {arr.min()}")
    same = np.flatnonzero(arr[:, 0] == arr[:, 1])
    if same.size:
        k = int(same[0])
        raise ValueError(
            f"pairs must join two different particles; spring {k} joins particle "
            f"{arr[k, 0]} to itself"
        )
    return arr


def _per_spring(name: str, value, m: int) -> np.ndarray:
    """A finite, non-negative float64 (m,) array from a scalar or an (m,) array_like."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a number or an array of numbers, got {value!r}") from None
    if arr.ndim > 1 or (arr.ndim == 1 and arr.shape[0] not in (1, m)):
        raise ValueError(f"{name} must be a scalar or have shape ({m},), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite (no NaN or inf)")
    if np.any(arr < 0):
        raise ValueError(f"{name} must be >= 0, got {arr.min()}")
    return np.broadcast_to(arr, (m,)).copy()


def _incidence(pairs: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Particle -> spring-end incidence in CSR form.

    Returns ``touched`` (u,): the particles with springs, ascending; ``offsets`` (u + 1,);
    ``entries`` (2m,): particle ``touched[t]`` is end ``e & 1`` (0 = a, 1 = b) of spring
    ``e >> 1`` for each ``e`` in ``entries[offsets[t]:offsets[t + 1]]``, in increasing
    spring order (a stable sort), which fixes the summation order.
    """
    ends = pairs.ravel()  # end e of the flat array is spring e // 2, side e % 2
    entries = np.argsort(ends, kind="stable").astype(np.int64)
    touched, starts = np.unique(ends[entries], return_index=True)
    offsets = np.append(starts, ends.shape[0]).astype(np.int64)
    return touched.astype(np.int64), offsets, entries


@parallel_kernel
def _spring_force_kernel(x, y, z, vx, vy, vz, pairs, rest_length, stiffness, damping, spring_force):
    """``spring_force[:, k]`` = force on end ``a`` of spring ``k`` [N]."""
    zero = x.dtype.type(0)
    one = x.dtype.type(1)
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
            # A zero-length spring has no direction: a zero unit vector, so no force and no NaN.
            inv_length = one / length if length > zero else zero
            ux = dx * inv_length
            uy = dy * inv_length
            uz = dz * inv_length
            closing = (vx[a] - vx[b]) * ux + (vy[a] - vy[b]) * uy + (vz[a] - vz[b]) * uz
            magnitude = stiffness[k] * (length - rest_length[k]) + damping[k] * closing
            spring_force[0, k] = -magnitude * ux
            spring_force[1, k] = -magnitude * uy
            spring_force[2, k] = -magnitude * uz


@parallel_kernel
def _gather_kernel(spring_force, touched, first, last, entries, out_x, out_y, out_z):
    """``out[:, touched[t]] +=`` the signed forces of its springs, in spring order.

    Its spring ends are ``entries[first[t]:last[t]]`` (CSR offsets split in two).
    """
    zero = spring_force.dtype.type(0)
    u = touched.shape[0]
    for block in numba.prange(block_count(u)):
        start, stop = block_bounds(block, u)
        for t in range(start, stop):
            fx = zero
            fy = zero
            fz = zero
            for j in range(first[t], last[t]):
                e = entries[j]
                k = e >> 1
                if e & 1:  # end b feels -f_a
                    fx -= spring_force[0, k]
                    fy -= spring_force[1, k]
                    fz -= spring_force[2, k]
                else:
                    fx += spring_force[0, k]
                    fy += spring_force[1, k]
                    fz += spring_force[2, k]
            i = touched[t]
            out_x[i] += fx
            out_y[i] += fy
            out_z[i] += fz
