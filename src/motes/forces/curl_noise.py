"""Curl noise: divergence-free procedural turbulence.

Bridson, Hourihan & Nordenstam (2007), "Curl-noise for procedural fluid flow", ACM TOG
26(3), §2: the curl of a vector potential is divergence free, ``∇·(∇×ψ) = 0``, so a
velocity (here: acceleration) field ``∇×ψ`` neither gathers particles into sinks nor
spreads them from sources. The three components of ``ψ`` are independent gradient-noise
fields: Perlin (2002), "Improving noise", ACM TOG 21(3), 681-682, with its quintic fade
``6t^5 - 15t^4 + 10t^3`` (C2 continuous, so the curl is C1) and its 12 edge gradients.

The curl is taken from the analytic derivative of the noise (product rule on Perlin's
trilinear blend of corner ramps), never by finite differences, so the field is exactly
divergence free up to rounding.

Field definition, with ``p = x / scale`` [noise lattice units], ``N_k`` the noise with
permutation table ``k`` and ``O`` octaves::

    ψ_k(p) = Σ_{o<O} 4^-o N_k(2^o (p + τ t e_k))
    a(x)   = strength · (∇_p × ψ)(p)         [m/s^2]

so octave ``o`` adds detail at twice the frequency and half the acceleration of the one
before (its potential has a quarter of the amplitude). ``τ = time_scale``: potential
``k`` drifts along axis ``k``, so the pattern evolves rather than translating rigidly.
"""

from __future__ import annotations

import numba
import numpy as np

from .. import _validate as check
from .._jit import block_bounds, block_count, device, parallel_kernel, serial_kernel
from .base import Force, check_buffers, particle_mass

#: Perlin noise repeats every 256 lattice cells along each axis.
PERIOD = 256
#: Upper bound on octaves: past ~16, float32 lattice coordinates carry no fraction.
MAX_OCTAVES = 16


def perlin_gradients() -> np.ndarray:
    """Perlin's (2002) gradient table as vectors, shape (16, 3).

    Row ``h`` is the vector ``g`` with ``grad(h, x, y, z) = g · (x, y, z)`` for the bit
    tricks of the reference implementation: the 12 cube-edge directions and 4 repeats.
    """

    def grad(h: int, x: float, y: float, z: float) -> float:
        u = x if h < 8 else y
        v = y if h < 4 else (x if h in (12, 14) else z)
        return (u if h & 1 == 0 else -u) + (v if h & 2 == 0 else -v)

    return np.array([[grad(h, *e) for e in np.eye(3)] for h in range(16)])


def permutation_tables(seed: int) -> np.ndarray:
    """Three independent permutations of 0..255, each repeated twice: shape (3, 512).

    The repeat lets the hash ``perm[perm[perm[X] + Y] + Z]`` index without wrapping.
    """
    rng = np.random.default_rng(seed)
    tables = np.stack([rng.permutation(PERIOD) for _ in range(3)])
    return np.concatenate([tables, tables], axis=1).astype(np.int64)


class CurlNoise(Force):
    """Divergence-free turbulence: the curl of a 3D Perlin-noise vector potential.

    Parameters
    ----------
    strength : float
        Acceleration scale [m/s^2]. The field's RMS magnitude is about 1.7 ``strength``
        with one octave and 2 ``strength`` with many (its maximum about 5 ``strength``).
    scale : float
        Size of the largest eddies [m] > 0: one noise lattice cell.
    seed : int
        Seed >= 0 of the permutation tables (``numpy.random.default_rng(seed)``).
    octaves : int
        Number of octaves, 1..16; each adds detail at twice the frequency and half the
        acceleration.
    time_scale : float
        Rate ``τ`` [lattice cells/s] at which the field evolves; 0 freezes it.

    Notes
    -----
    The field is an acceleration multiplied by each particle's mass (1 kg for stores
    without a ``mass`` attribute), so the motion is mass independent. See the module
    docstring for the equations.
    """

    reads = ("position",)

    def __init__(
        self,
        strength: float,
        scale: float,
        *,
        seed: int = 0,
        octaves: int = 1,
        time_scale: float = 0.0,
    ):
        self.strength = check.real("strength", strength)
        self.scale = check.positive("scale", scale)
        self.seed = check.integer("seed", seed, low=0)
        self.octaves = check.integer("octaves", octaves, low=1)
        if self.octaves > MAX_OCTAVES:
            raise ValueError(f"octaves must be <= {MAX_OCTAVES}, got {self.octaves}")
        self.time_scale = check.real("time_scale", time_scale)
        #: Permutation tables of the three potential components, int64 (3, 512).
        self.permutations = permutation_tables(self.seed)
        self._gradients = perlin_gradients()

    def __repr__(self) -> str:
        return (
            f"CurlNoise({self.strength}, {self.scale}, seed={self.seed}, "
            f"octaves={self.octaves}, time_scale={self.time_scale})"
        )

    def _shift(self, time: float) -> float:
        # Exact modulo the noise period, and keeps float32 lattice coordinates small.
        return float(self.time_scale * time) % PERIOD

    def accumulate(self, store, position, velocity, time, out) -> None:
        check_buffers(position, out)
        real = position.dtype.type
        _curl_noise_kernel(
            *position,
            particle_mass(store, position.shape[1], position.dtype),
            self.permutations,
            self._gradients.astype(position.dtype),
            real(self.strength),
            real(1.0 / self.scale),
            real(self._shift(time)),
            self.octaves,
            *out,
        )

    def potential(self, position: np.ndarray, time: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """The vector potential ψ and its gradient, for diagnostics and tests.

        Parameters
        ----------
        position : array of shape (3, n)
            Points [m].
        time : float
            Simulation time [s].

        Returns
        -------
        psi : array of shape (3, n)
            ``ψ_k`` [dimensionless].
        gradient : array of shape (3, 3, n)
            ``gradient[k, j] = ∂ψ_k/∂p_j`` with respect to the lattice coordinate
            ``p = x / scale``; the acceleration is ``strength · ∇_p × ψ``.
        """
        position = np.asarray(position)
        if position.ndim != 2 or position.shape[0] != 3:
            raise ValueError(f"position must have shape (3, n), got {position.shape}")
        real = position.dtype.type
        n = position.shape[1]
        psi = np.empty((3, n), dtype=position.dtype)
        gradient = np.empty((3, 3, n), dtype=position.dtype)
        _potential_kernel(
            *position,
            self.permutations,
            self._gradients.astype(position.dtype),
            real(1.0 / self.scale),
            real(self._shift(time)),
            self.octaves,
            psi,
            gradient,
        )
        return psi, gradient


# The small helpers below are ordinary compiled functions, which LLVM inlines anyway;
# inlining them at the Numba IR level too (``device``) doubled the compile time of the
# curl kernel (4.6 s -> 7 s) for no speed-up. ``_noise`` and ``_potential`` stay
# ``device``: left as calls, the kernel ran 30% slower.
@serial_kernel
def _fade(t, real):
    """Perlin's quintic ``6t^5 - 15t^4 + 10t^3`` and its derivative ``30 t^2 (t - 1)^2``."""
    s = t * (t - real(1))
    return t * t * t * (t * (t * real(6) - real(15)) + real(10)), real(30) * s * s


@serial_kernel
def _lerp(t, a, b):
    return a + t * (b - a)


@serial_kernel
def _trilerp(u, v, w, c000, c100, c010, c110, c001, c101, c011, c111):
    """Trilinear blend of eight corner values with weights ``u, v, w`` along x, y, z."""
    return _lerp(
        w,
        _lerp(v, _lerp(u, c000, c100), _lerp(u, c010, c110)),
        _lerp(v, _lerp(u, c001, c101), _lerp(u, c011, c111)),
    )


@serial_kernel
def _blend_gradients(u, v, w, grads, corners, j):
    """Component ``j`` of the corner gradients ``grads[corners]``, blended like values."""
    return _trilerp(
        u,
        v,
        w,
        grads[corners[0], j],
        grads[corners[1], j],
        grads[corners[2], j],
        grads[corners[3], j],
        grads[corners[4], j],
        grads[corners[5], j],
        grads[corners[6], j],
        grads[corners[7], j],
    )


@device
def _noise(px, py, pz, perm, k, grads, real):
    """Value and gradient of Perlin's improved noise with permutation row ``k`` at ``p``.

    The noise is ``n = trilerp(u, v, w; n_c)``: the blend, with fade weights
    ``u = fade(x)``, ``v = fade(y)``, ``w = fade(z)`` of the fractional coordinates, of
    the corner ramps ``n_c = g_c · (p - c)``. By the product rule
    ``∂n/∂x = trilerp(u, v, w; g_c,x) + fade'(x) ∂trilerp/∂u``, where ``∂trilerp/∂u`` is
    the bilinear blend over ``(v, w)`` of the differences ``n_1yz - n_0yz`` along x.
    """
    fx = np.floor(px)
    fy = np.floor(py)
    fz = np.floor(pz)
    x = px - fx
    y = py - fy
    z = pz - fz
    # Lattice cell modulo the period; `& 255` is a true modulo for negative cells too.
    cx = int(fx) & 255
    cy = int(fy) & 255
    cz = int(fz) & 255
    # Perlin's hash of the eight corners (the table repeats, so no index wraps).
    a = perm[k, cx] + cy
    aa = perm[k, a] + cz
    ab = perm[k, a + 1] + cz
    b = perm[k, cx + 1] + cy
    ba = perm[k, b] + cz
    bb = perm[k, b + 1] + cz
    h000 = perm[k, aa] & 15
    h100 = perm[k, ba] & 15
    h010 = perm[k, ab] & 15
    h110 = perm[k, bb] & 15
    h001 = perm[k, aa + 1] & 15
    h101 = perm[k, ba + 1] & 15
    h011 = perm[k, ab + 1] & 15
    h111 = perm[k, bb + 1] & 15
    one = real(1)
    x1 = x - one
    y1 = y - one
    z1 = z - one
    n000 = grads[h000, 0] * x + grads[h000, 1] * y + grads[h000, 2] * z
    n100 = grads[h100, 0] * x1 + grads[h100, 1] * y + grads[h100, 2] * z
    n010 = grads[h010, 0] * x + grads[h010, 1] * y1 + grads[h010, 2] * z
    n110 = grads[h110, 0] * x1 + grads[h110, 1] * y1 + grads[h110, 2] * z
    n001 = grads[h001, 0] * x + grads[h001, 1] * y + grads[h001, 2] * z1
    n101 = grads[h101, 0] * x1 + grads[h101, 1] * y + grads[h101, 2] * z1
    n011 = grads[h011, 0] * x + grads[h011, 1] * y1 + grads[h011, 2] * z1
    n111 = grads[h111, 0] * x1 + grads[h111, 1] * y1 + grads[h111, 2] * z1
    u, du = _fade(x, real)
    v, dv = _fade(y, real)
    w, dw = _fade(z, real)
    value = _trilerp(u, v, w, n000, n100, n010, n110, n001, n101, n011, n111)
    dndu = _lerp(w, _lerp(v, n100 - n000, n110 - n010), _lerp(v, n101 - n001, n111 - n011))
    dndv = _lerp(w, _lerp(u, n010 - n000, n110 - n100), _lerp(u, n011 - n001, n111 - n101))
    dndw = _lerp(v, _lerp(u, n001 - n000, n101 - n100), _lerp(u, n011 - n010, n111 - n110))
    corners = (h000, h100, h010, h110, h001, h101, h011, h111)
    gx = du * dndu + _blend_gradients(u, v, w, grads, corners, 0)
    gy = dv * dndv + _blend_gradients(u, v, w, grads, corners, 1)
    gz = dw * dndw + _blend_gradients(u, v, w, grads, corners, 2)
    return value, gx, gy, gz


@device
def _potential(px, py, pz, perm, k, grads, octaves, real):
    """``ψ_k = Σ_o 4^-o N_k(2^o p)`` and its gradient ``Σ_o 2^-o ∇N_k(2^o p)``."""
    half = real(0.5)
    frequency = real(1)
    amplitude = real(1)  # of the gradient; the value's is amplitude / frequency
    value = real(0)
    gx = real(0)
    gy = real(0)
    gz = real(0)
    for _ in range(octaves):
        n, nx, ny, nz = _noise(frequency * px, frequency * py, frequency * pz, perm, k, grads, real)
        value += amplitude / frequency * n
        gx += amplitude * nx
        gy += amplitude * ny
        gz += amplitude * nz
        frequency += frequency
        amplitude *= half
    return value, gx, gy, gz


@parallel_kernel
def _curl_noise_kernel(
    x, y, z, mass, perm, grads, strength, inv_scale, shift, octaves, out_x, out_y, out_z
):
    """``out[:, i] += m_i strength (∇_p × ψ)(x_i / scale)``."""
    real = x.dtype.type
    uniform = mass.shape[0] == 0
    n = x.shape[0]
    for block in numba.prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            px = x[i] * inv_scale
            py = y[i] * inv_scale
            pz = z[i] * inv_scale
            # Potential k drifts along axis k (module docstring); only its gradient is used.
            _, _, d0y, d0z = _potential(px + shift, py, pz, perm, 0, grads, octaves, real)
            _, d1x, _, d1z = _potential(px, py + shift, pz, perm, 1, grads, octaves, real)
            _, d2x, d2y, _ = _potential(px, py, pz + shift, perm, 2, grads, octaves, real)
            scale = strength
            if not uniform:
                scale *= mass[i]
            out_x[i] += scale * (d2y - d1z)
            out_y[i] += scale * (d0z - d2x)
            out_z[i] += scale * (d1x - d0y)


@parallel_kernel
def _potential_kernel(x, y, z, perm, grads, inv_scale, shift, octaves, psi, gradient):
    """``psi[k, i] = ψ_k(p_i)`` and ``gradient[k, j, i] = ∂ψ_k/∂p_j`` at ``p = x / scale``."""
    real = x.dtype.type
    n = x.shape[0]
    for block in numba.prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            px = x[i] * inv_scale
            py = y[i] * inv_scale
            pz = z[i] * inv_scale
            for k in range(3):
                value, gx, gy, gz = _potential(
                    px + (shift if k == 0 else real(0)),
                    py + (shift if k == 1 else real(0)),
                    pz + (shift if k == 2 else real(0)),
                    perm,
                    k,
                    grads,
                    octaves,
                    real,
                )
                psi[k, i] = value
                gradient[k, 0, i] = gx
                gradient[k, 1, i] = gy
                gradient[k, 2, i] = gz
