r"""A user pair force: any compiled function of distance, between every pair of particles.

``PairForce(force, cutoff=...)`` applies, to each particle ``i``,

.. math:: F_i = \sum_{j \ne i,\ r_{ij} < r_c} f(r_{ij}) \, (x_i - x_j) / r_{ij}

where ``f(r) = -dU/dr`` [N] is the radial force of a pair potential ``U(r)`` (positive
repels). With a cutoff ``r_c`` the pairs come from a spatial structure, the uniform grid
by default (:func:`motes.spatial.spatial_index`, CSR lists); without one, every pair is
summed.
Each pair's term is computed once from each side with the same distance and opposite
directions, so momentum is conserved to round-off, and each particle sums its pairs in a
fixed order (bit-identical for any thread count).

:func:`lennard_jones` builds ``f`` for the Lennard-Jones potential.
"""

from __future__ import annotations

import functools

import numba
import numpy as np
from numba.core.registry import CPUDispatcher

from .. import _validate as check
from .._jit import block_bounds, block_count, device, parallel_factory, threads_for
from ..spatial.index import STRUCTURES, spatial_index
from .base import Force, check_buffers


def lennard_jones(epsilon: float, sigma: float):
    r"""The radial force ``f(r) = 24 ε/r (2 (σ/r)^12 - (σ/r)^6)`` [N] of the Lennard-Jones
    potential ``U(r) = 4 ε ((σ/r)^12 - (σ/r)^6)`` (Jones 1924), as a compiled function.

    Parameters
    ----------
    epsilon : float
        Depth of the well ``ε`` > 0 [J].
    sigma : float
        Distance ``σ`` > 0 [m] at which ``U = 0``; the minimum is at ``2^{1/6} σ``.

    Examples
    --------
    >>> f = lennard_jones(1.0, 1.0)
    >>> abs(f(2 ** (1 / 6))) < 1e-12
    True
    """
    epsilon = check.positive("epsilon", epsilon)
    sigma = check.positive("sigma", sigma)

    @device
    def force(r):
        s6 = (sigma / r) ** 6
        return 24.0 * epsilon / r * (2.0 * s6 * s6 - s6)

    return force


class PairForce(Force):
    r"""Pair force ``f(r)`` [N] along the line between every two particles (``+`` repels).

    Parameters
    ----------
    force : numba-compiled function ``r -> f(r)``
        Radial force of the pair potential [N] at distance ``r`` [m], ``f = -dU/dr``;
        made with ``numba.njit`` (or :func:`lennard_jones`). It is called with float64
        distances > 0.
    cutoff : float or None
        Pairs farther apart than ``cutoff`` > 0 [m] are left out, and pairs are found with
        a spatial structure (O(n log n) at most for short-range forces); None sums every
        pair (O(n²)).
    structure : {"grid", "octree", "kdtree"}
        Where the pairs within ``cutoff`` are found (:func:`motes.spatial.spatial_index`):
        the uniform grid (fastest for evenly spread particles: a gas, a liquid) or a tree
        (for clustered ones, where most grid cells are empty and a few hold everything).

    Examples
    --------
    >>> import numpy as np
    >>> from motes.forces.apply import add_forces
    >>> lj = PairForce(lennard_jones(1.0, 1.0), cutoff=2.5)
    >>> position = np.array([[0.0, 1.0], [0.0, 0.0], [0.0, 0.0]])
    >>> f = add_forces([lj], position, np.zeros((3, 2)), np.ones(2), 0.0)
    >>> bool(f[0, 0] < 0 < f[0, 1])  # closer than 2^(1/6): they repel
    True
    """

    reads = ("position",)

    def __init__(self, force, *, cutoff: float | None = None, structure: str = "grid"):
        if not isinstance(force, CPUDispatcher):
            raise TypeError(
                "force must be a numba.njit-compiled function of the distance r [m] "
                f"returning the radial force [N], got {force!r}"
            )
        self.force = force
        self.cutoff = None if cutoff is None else check.positive("cutoff", cutoff)
        structure = check.choice("structure", structure, STRUCTURES)
        if cutoff is None:
            self._index = None
        elif structure == "grid":
            self._index = spatial_index(structure, cell_size=self.cutoff)
        else:
            self._index = spatial_index(structure)
        self.structure = structure

    def __repr__(self) -> str:
        name = getattr(self.force, "__name__", "force")
        return f"PairForce({name}, cutoff={self.cutoff}, structure={self.structure!r})"

    def accumulate(self, store, position, velocity, time, out) -> None:
        check_buffers(position, out)
        n = position.shape[1]
        if n < 2:
            return
        rows = [np.ascontiguousarray(r, dtype=np.float64) for r in position]
        neighbours, every_pair = _kernels(self.force)
        with threads_for(n):
            if self.cutoff is None:
                every_pair(*rows, *out)
            else:
                lists = self._index.build(np.stack(rows)).neighbors(self.cutoff)
                neighbours(*rows, lists.offsets, lists.indices, *out)


@functools.cache
def _kernels(force):
    """The two kernels for one compiled force function (compiled once per process:
    Numba cannot cache a kernel that closes over another compiled function)."""

    @device
    def term(xi, yi, zi, xj, yj, zj):
        dx = xi - xj
        dy = yi - yj
        dz = zi - zj
        r = np.sqrt(dx * dx + dy * dy + dz * dz)
        if r == 0.0:
            return 0.0, 0.0, 0.0
        s = force(r) / r
        return s * dx, s * dy, s * dz

    @parallel_factory
    def neighbours(x, y, z, offsets, indices, out_x, out_y, out_z):
        n = x.shape[0]
        for block in numba.prange(block_count(n)):
            lo, hi = block_bounds(block, n)
            for i in range(lo, hi):
                fx = fy = fz = 0.0
                for k in range(offsets[i], offsets[i + 1]):
                    j = indices[k]
                    tx, ty, tz = term(x[i], y[i], z[i], x[j], y[j], z[j])
                    fx += tx
                    fy += ty
                    fz += tz
                out_x[i] += fx
                out_y[i] += fy
                out_z[i] += fz

    @parallel_factory
    def every_pair(x, y, z, out_x, out_y, out_z):
        n = x.shape[0]
        for block in numba.prange(block_count(n)):
            lo, hi = block_bounds(block, n)
            for i in range(lo, hi):
                fx = fy = fz = 0.0
                for j in range(n):
                    tx, ty, tz = term(x[i], y[i], z[i], x[j], y[j], z[j])
                    fx += tx
                    fy += ty
                    fz += tz
                out_x[i] += fx
                out_y[i] += fy
                out_z[i] += fz

    return neighbours, every_pair
