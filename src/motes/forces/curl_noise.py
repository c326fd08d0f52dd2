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
from .._jit import BLOCK, block_bounds, block_count, device, fma, parallel_kernel, serial_kernel
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


def corner_tables(permutations: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The permutation tables repacked for the kernels: two int32 arrays of shape (3, 512).

    ``hash_pairs[k, i] = perm[i] | perm[i + 1] << 8``: Perlin's hash always reads
    ``perm[i]`` and ``perm[i + 1]`` together, so one load serves both.
    ``ramp_pairs[k, i] = code(perm[i]) | code(perm[i + 1]) << 6`` with the 6-bit code
    ``code(h) = (g_x + 1) | (g_y + 1) << 2 | (g_z + 1) << 4`` of the gradient
    ``g = perlin_gradients()[h & 15]``: the last hash level and the gradient lookup in
    one load, for a corner and its neighbour along z. Entry 511 (``perm[512]``) is never
    read: hashed indices stay below 511.
    """
    perm = np.asarray(permutations, dtype=np.int64)
    following = np.roll(perm, -1, axis=1)
    g = perlin_gradients().astype(np.int64) + 1
    code = g[:, 0] | g[:, 1] << 2 | g[:, 2] << 4
    hash_pairs = perm | following << 8
    ramp_pairs = code[perm & 15] | code[following & 15] << 6
    return hash_pairs.astype(np.int32), ramp_pairs.astype(np.int32)


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
        self._hash_pairs, self._ramp_pairs = corner_tables(self.permutations)

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
            self._hash_pairs,
            self._ramp_pairs,
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
            self._hash_pairs,
            self._ramp_pairs,
            real(1.0 / self.scale),
            real(self._shift(time)),
            self.octaves,
            psi,
            gradient,
        )
        return psi, gradient


# Both kernels evaluate the field from the same helpers; ``_curl_noise_kernel`` arranges
# them in passes so that LLVM vectorises the arithmetic (its docstring says how).
#
# The small helpers are ordinary compiled functions, which LLVM inlines anyway; inlining
# them at the Numba IR level too (``device``) doubled the compile time for no speed-up.
# ``_noise`` stays ``device``: left as a call, it is too large for LLVM to inline, and a
# call in the loop blocks vectorisation. The lerps, ramps and fades are written with
# ``fma`` (``motes._jit.fma``): the kernels' flags do not let LLVM fuse a multiply and
# an add by itself, and the field is mostly multiply-adds (13 % faster fused).
@serial_kernel
def _lattice_cell(p, real):
    """Lattice cell ``floor(p) mod 256`` of coordinate ``p``, as an int in 0..255.

    The modulo is taken in floating point, where it is exact, so the conversion to int32
    (which vectorises, unlike the conversion to int64) cannot overflow however far ``p``
    lies from the origin.
    """
    cell = np.floor(p)
    return np.int32(cell - real(PERIOD) * np.floor(cell * real(1 / PERIOD))) & 255


@serial_kernel
def _fraction(p, real):
    """Fractional coordinate ``t = p - floor(p)`` and Perlin's quintic fade of it.

    Returns ``t``, ``6t^5 - 15t^4 + 10t^3`` and its derivative ``30 t^2 (t - 1)^2``.
    """
    t = p - np.floor(p)
    s = t * (t - real(1))
    return t, t * t * t * fma(t, fma(t, real(6), real(-15)), real(10)), real(30) * s * s


@serial_kernel
def _hash(hash_pairs, ramp_pairs, k, cx, cy, cz):
    """Perlin's hash ``perm[perm[perm[X] + Y] + Z]`` of the eight corners of a cell.

    Returns two words of four 6-bit gradient codes (:func:`corner_tables`): the corners
    ``(X, Y, Z), (X, Y, Z+1), (X, Y+1, Z), (X, Y+1, Z+1)`` and the same at ``X + 1``.
    The ``& 255`` masks are no-ops that tell LLVM the indices are not negative, so it
    drops Numba's negative-index wraparound.
    """
    e = hash_pairs[k, cx]
    a = (e & 255) + cy
    b = ((e >> 8) & 255) + cy
    ea = hash_pairs[k, a]
    eb = hash_pairs[k, b]
    aa = (ea & 255) + cz
    ab = ((ea >> 8) & 255) + cz
    ba = (eb & 255) + cz
    bb = ((eb >> 8) & 255) + cz
    low = ramp_pairs[k, aa] | (ramp_pairs[k, ab] << 12)
    high = ramp_pairs[k, ba] | (ramp_pairs[k, bb] << 12)
    return low, high


@serial_kernel
def _ramp(code, x, y, z, real):
    """Gradient ``g`` of 6-bit code ``code`` (its low bits) and the ramp ``g · (x, y, z)``."""
    # int32 before the conversion to float: int64 -> float does not vectorise on AVX2.
    gx = real(np.int32(code & 3)) - real(1)
    gy = real(np.int32((code >> 2) & 3)) - real(1)
    gz = real(np.int32((code >> 4) & 3)) - real(1)
    return gx, gy, gz, fma(gx, x, fma(gy, y, gz * z))


@serial_kernel
def _lerp(t, a, b):
    return fma(t, b - a, a)  # a + t (b - a)


@serial_kernel
def _trilerp(u, v, w, c000, c100, c010, c110, c001, c101, c011, c111):
    """Trilinear blend of eight corner values with weights ``u, v, w`` along x, y, z."""
    return _lerp(
        w,
        _lerp(v, _lerp(u, c000, c100), _lerp(u, c010, c110)),
        _lerp(v, _lerp(u, c001, c101), _lerp(u, c011, c111)),
    )


@device
def _noise(low, high, x, y, z, u, v, w, du, dv, dw, real):
    """Value and gradient of Perlin's improved noise in one lattice cell.

    ``low, high`` are the corner codes from :func:`_hash`; ``x, y, z`` the fractional
    coordinates, ``u, v, w`` their fades and ``du, dv, dw`` the fades' derivatives
    (:func:`_fraction`). The noise is ``n = trilerp(u, v, w; n_c)``: the blend of the
    corner ramps ``n_c = g_c · (p - c)``. By the product rule
    ``∂n/∂x = trilerp(u, v, w; g_c,x) + fade'(x) ∂trilerp/∂u``, where ``∂trilerp/∂u`` is
    the bilinear blend over ``(v, w)`` of the differences ``n_1yz - n_0yz`` along x.
    """
    one = real(1)
    x1 = x - one
    y1 = y - one
    z1 = z - one
    g000x, g000y, g000z, n000 = _ramp(low, x, y, z, real)
    g001x, g001y, g001z, n001 = _ramp(low >> 6, x, y, z1, real)
    g010x, g010y, g010z, n010 = _ramp(low >> 12, x, y1, z, real)
    g011x, g011y, g011z, n011 = _ramp(low >> 18, x, y1, z1, real)
    g100x, g100y, g100z, n100 = _ramp(high, x1, y, z, real)
    g101x, g101y, g101z, n101 = _ramp(high >> 6, x1, y, z1, real)
    g110x, g110y, g110z, n110 = _ramp(high >> 12, x1, y1, z, real)
    g111x, g111y, g111z, n111 = _ramp(high >> 18, x1, y1, z1, real)
    value = _trilerp(u, v, w, n000, n100, n010, n110, n001, n101, n011, n111)
    dndu = _lerp(w, _lerp(v, n100 - n000, n110 - n010), _lerp(v, n101 - n001, n111 - n011))
    dndv = _lerp(w, _lerp(u, n010 - n000, n110 - n100), _lerp(u, n011 - n001, n111 - n101))
    dndw = _lerp(v, _lerp(u, n001 - n000, n101 - n100), _lerp(u, n011 - n010, n111 - n110))
    gx = fma(du, dndu, _trilerp(u, v, w, g000x, g100x, g010x, g110x, g001x, g101x, g011x, g111x))
    gy = fma(dv, dndv, _trilerp(u, v, w, g000y, g100y, g010y, g110y, g001y, g101y, g011y, g111y))
    gz = fma(dw, dndw, _trilerp(u, v, w, g000z, g100z, g010z, g110z, g001z, g101z, g011z, g111z))
    return value, gx, gy, gz


@serial_kernel
def _hash_cells(hash_pairs, ramp_pairs, k, cells, low, high, count):
    """``low[j], high[j]``: the corner codes of the packed cells ``cells[j]``, j < count.

    Pass 2 of :func:`_curl_noise_kernel`, one potential (table row ``k``) at a time.
    """
    for j in range(count):
        c = cells[j]
        a, b = _hash(hash_pairs, ramp_pairs, k, c & 255, (c >> 8) & 255, (c >> 16) & 255)
        low[j] = a
        high[j] = b


@parallel_kernel
def _curl_noise_kernel(
    x, y, z, mass, hash_pairs, ramp_pairs, strength, inv_scale, shift, octaves, out_x, out_y, out_z
):
    """``out[:, i] += m_i strength (∇_p × ψ)(x_i / scale)``.

    Each block of particles runs in three passes per octave, through per-block scratch
    arrays, so that LLVM vectorises the floating-point work. Table lookups (gathers) do
    not vectorise well: in one loop doing everything, LLVM emulated most of the SIMD lane
    by lane, which took twice the time of these passes (AMD Zen 3, AVX2):

    1. the lattice cells of the three potentials' sample points, packed 8 bits per axis
       (vectorised);
    2. Perlin's hash of each cell's corners: table lookups, scalar (:func:`_hash_cells`);
    3. fades, ramps and noise gradients, summed over octaves (vectorised).

    Each pass loops over the block's particles, so which of them take a vectorised body
    and which its scalar remainder depends on ``BLOCK`` only (see :mod:`motes._jit`).
    """
    real = x.dtype.type
    uniform = mass.shape[0] == 0
    n = x.shape[0]
    for block in numba.prange(block_count(n)):
        start, stop = block_bounds(block, n)
        count = stop - start
        cells = np.empty((3, BLOCK), dtype=np.int32)
        corners = np.empty((6, BLOCK), dtype=np.int32)
        # The four components of ∇ψ_k the curl uses: ∂0/∂y ∂0/∂z ∂1/∂x ∂1/∂z ∂2/∂x ∂2/∂y.
        grad = np.zeros((6, BLOCK), dtype=x.dtype)
        frequency = real(1)
        amplitude = real(1)
        for _ in range(octaves):
            for j in range(count):
                i = start + j
                px = x[i] * inv_scale
                py = y[i] * inv_scale
                pz = z[i] * inv_scale
                # Potential k drifts along axis k (module docstring).
                cx = _lattice_cell(frequency * px, real)
                cy = _lattice_cell(frequency * py, real)
                cz = _lattice_cell(frequency * pz, real)
                sx = _lattice_cell(frequency * (px + shift), real)
                sy = _lattice_cell(frequency * (py + shift), real)
                sz = _lattice_cell(frequency * (pz + shift), real)
                cells[0, j] = sx | (cy << 8) | (cz << 16)
                cells[1, j] = cx | (sy << 8) | (cz << 16)
                cells[2, j] = cx | (cy << 8) | (sz << 16)
            for k in range(3):
                _hash_cells(
                    hash_pairs, ramp_pairs, k, cells[k], corners[2 * k], corners[2 * k + 1], count
                )
            # One potential at a time: one inlined copy of the noise (three made the
            # kernel slow to compile). Potential k is shifted along axis k and gives the
            # two components of its gradient that the curl uses.
            for k in range(3):
                for j in range(count):
                    i = start + j
                    px = x[i] * inv_scale
                    py = y[i] * inv_scale
                    pz = z[i] * inv_scale
                    fx, ux, dux = _fraction(frequency * (px + shift if k == 0 else px), real)
                    fy, uy, duy = _fraction(frequency * (py + shift if k == 1 else py), real)
                    fz, uz, duz = _fraction(frequency * (pz + shift if k == 2 else pz), real)
                    _, gx, gy, gz = _noise(
                        corners[2 * k, j], corners[2 * k + 1, j], fx, fy, fz, ux, uy, uz, dux,
                        duy, duz, real,
                    )  # fmt: skip
                    # ∂0/∂y ∂0/∂z, ∂1/∂x ∂1/∂z, ∂2/∂x ∂2/∂y
                    first = gy if k == 0 else gx
                    second = gy if k == 2 else gz
                    grad[2 * k, j] = fma(amplitude, first, grad[2 * k, j])
                    grad[2 * k + 1, j] = fma(amplitude, second, grad[2 * k + 1, j])
            frequency += frequency
            amplitude *= real(0.5)
        for j in range(count):
            i = start + j
            scale = strength
            if not uniform:
                scale *= mass[i]
            out_x[i] += scale * (grad[5, j] - grad[3, j])
            out_y[i] += scale * (grad[1, j] - grad[4, j])
            out_z[i] += scale * (grad[2, j] - grad[0, j])


@parallel_kernel
def _potential_kernel(x, y, z, hash_pairs, ramp_pairs, inv_scale, shift, octaves, psi, gradient):
    """``psi[k, i] = ψ_k(p_i)`` and ``gradient[k, j, i] = ∂ψ_k/∂p_j`` at ``p = x / scale``.

    The plain per-particle form of the field: for diagnostics, and a check on the passes
    of :func:`_curl_noise_kernel`, which evaluates it from the same helpers.
    ``ψ_k = Σ_o 4^-o N_k(2^o p)``, so its gradient is ``Σ_o 2^-o ∇N_k(2^o p)``.
    """
    real = x.dtype.type
    zero = real(0)
    n = x.shape[0]
    for block in numba.prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            px = x[i] * inv_scale
            py = y[i] * inv_scale
            pz = z[i] * inv_scale
            for k in range(3):
                qx = px + (shift if k == 0 else zero)
                qy = py + (shift if k == 1 else zero)
                qz = pz + (shift if k == 2 else zero)
                frequency = real(1)
                amplitude = real(1)  # of the gradient; the value's is amplitude / frequency
                value = zero
                gx = zero
                gy = zero
                gz = zero
                for _ in range(octaves):
                    low, high = _hash(
                        hash_pairs,
                        ramp_pairs,
                        k,
                        _lattice_cell(frequency * qx, real),
                        _lattice_cell(frequency * qy, real),
                        _lattice_cell(frequency * qz, real),
                    )
                    fx, ux, dux = _fraction(frequency * qx, real)
                    fy, uy, duy = _fraction(frequency * qy, real)
                    fz, uz, duz = _fraction(frequency * qz, real)
                    nv, nx, ny, nz = _noise(low, high, fx, fy, fz, ux, uy, uz, dux, duy, duz, real)
                    value = fma(amplitude / frequency, nv, value)
                    gx = fma(amplitude, nx, gx)  # as _curl_noise_kernel adds them
                    gy = fma(amplitude, ny, gy)
                    gz = fma(amplitude, nz, gz)
                    frequency += frequency
                    amplitude *= real(0.5)
                psi[k, i] = value
                gradient[k, 0, i] = gx
                gradient[k, 1, i] = gy
                gradient[k, 2, i] = gz
