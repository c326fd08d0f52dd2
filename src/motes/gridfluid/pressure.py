"""The pressure solve: conjugate gradients preconditioned by a multigrid V-cycle
(McAdams, Sifakis & Teran 2010, "A parallel multigrid Poisson solver for fluids
simulation on large grids").

The V-cycle coarsens every axis longer than one cell by two (a 2D grid, one cell thick,
stays one thick), smooths with red-black Gauss-Seidel (red then black going down, black
then red coming up, so that the cycle is a symmetric operator, as conjugate gradients
needs), interpolates piecewise-constantly and restricts with its transpose, the average
(tried against trilinear interpolation, it took fewer iterations: 9 against 13 at 512²,
7 against 9 at 128³), and solves the coarsest level with more sweeps. Its iteration
count hardly grows with the grid (tested: 32² to 128²).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import _validate as check
from .._jit import threads_for
from . import pressure_kernels as kern

#: Coarsening stops once no axis is longer than this many cells.
COARSEST = 4
#: Gauss-Seidel sweeps (red + black) before and after the coarse correction.
SMOOTHING = 2
#: Sweeps on the coarsest level (each way).
COARSEST_SWEEPS = 16


@dataclass
class Level:
    """One multigrid level: its solid cells, operator diagonal and work arrays."""

    solid: np.ndarray  # (nz, ny, nx) uint8
    diag: np.ndarray  # (nz, ny, nx) float32
    inv_diag: np.ndarray  # (nz, ny, nx) float32, 0 where diag is
    zero: np.ndarray  # (nx,) float32 zeros: the row beyond the domain
    x: np.ndarray
    b: np.ndarray
    r: np.ndarray
    fluid: np.ndarray | None
    factors: np.ndarray  # (3,) int64: how this level was coarsened from the one above


@dataclass
class SolveReport:
    """What one solve did.

    Attributes
    ----------
    iterations : int
        Conjugate-gradient iterations.
    residual : float
        Final ``max |b - A x|`` relative to ``max |b|`` (0 when ``b`` is 0).
    converged : bool
        Whether the tolerance was reached within the iteration limit.
    """

    iterations: int
    residual: float
    converged: bool


class PoissonSolver:
    """Solve ``A x = b`` for the pressure-like ``x`` on a cell grid (see
    :mod:`.pressure_kernels` for ``A``).

    Parameters
    ----------
    solid : (nz, ny, nx) uint8 array
        1 on solid cells.
    open_faces : (6,) sequence of bool
        Open domain faces, in the order -x, +x, -y, +y, -z, +z.
    tolerance : float
        Stop when ``max |r| <= tolerance * max |b|``, in (0, 1).
    max_iterations : int
        At most this many iterations (then the report says ``converged=False``).
    """

    def __init__(self, solid, open_faces, *, tolerance: float = 1e-5, max_iterations: int = 200):
        self.tolerance = check.real("tolerance", tolerance, low=0.0, high=1.0, low_open=True)
        self.max_iterations = check.integer("max_iterations", max_iterations, low=1)
        self.open_faces = np.asarray(open_faces, dtype=np.uint8).reshape(6)
        self.levels: list[Level] = []
        self.set_solid(solid)

    def set_solid(self, solid) -> None:
        """Rebuild the levels for new solid cells (an obstacle moved)."""
        solid = np.ascontiguousarray(solid, dtype=np.uint8)
        self.levels = [_level(solid, self.open_faces, np.ones(3, np.int64))]
        while max(self.levels[-1].solid.shape) > COARSEST:
            fine = self.levels[-1].solid
            factors = np.array([2 if n > 1 else 1 for n in fine.shape[::-1]], np.int64)
            shape = tuple(-(-n // f) for n, f in zip(fine.shape, factors[::-1], strict=True))
            coarse = np.empty(shape, np.uint8)
            kern.coarsen_solid(fine, factors, coarse)
            self.levels.append(_level(coarse, self.open_faces, factors))
        # Without an open face the operator is singular (pressure up to a constant):
        # residuals and corrections are kept free of the constant.
        self.singular = not self.open_faces.any()
        top = self.levels[0]
        rows = top.solid.shape[0] * top.solid.shape[1]
        self._partial = np.empty(rows, np.float64)
        self._r = np.zeros_like(top.x)
        self._z = np.zeros_like(top.x)
        self._d = np.zeros_like(top.x)
        self._ad = np.zeros_like(top.x)
        self._fluid_cells = int(np.count_nonzero(top.solid == 0))

    @property
    def shape(self) -> tuple[int, int, int]:
        return self.levels[0].solid.shape

    def solve(self, b: np.ndarray, x: np.ndarray) -> SolveReport:
        """Solve in place: ``x`` (nz, ny, nx) float32 holds the first guess (the previous
        step's answer is a good one) and receives the solution; ``b`` is not changed."""
        top = self.levels[0]
        partial = self._partial
        r, z, d, ad = self._r, self._z, self._d, self._ad
        x[top.solid.astype(bool)] = 0.0
        kern.residual(x, b, top.diag, top.inv_diag, top.zero, r)
        self._remove_mean(r)
        scale = float(np.abs(b).max()) if b.size else 0.0
        if not math.isfinite(scale):
            return SolveReport(0, math.nan, False)
        target = self.tolerance * scale
        size = float(np.abs(r).max())
        if size <= target or scale == 0.0:
            return SolveReport(0, size / scale if scale else 0.0, True)
        self._precondition(r, z)
        d[...] = z
        kern.dot_rows(r, z, partial)
        rz = float(partial.sum())
        for it in range(1, self.max_iterations + 1):
            kern.apply_operator(d, top.diag, top.inv_diag, top.zero, ad, partial)
            dad = float(partial.sum())
            if dad <= 0.0:  # d is in the null space: nothing left to remove
                return SolveReport(it, size / scale, size <= target)
            kern.cg_update(x, r, d, ad, rz / dad, partial)
            size = float(partial.max())
            if size <= target:
                return SolveReport(it, size / scale, True)
            self._precondition(r, z)
            kern.dot_rows(r, z, partial)
            rz_new = float(partial.sum())
            kern.cg_direction(d, z, rz_new / rz)
            rz = rz_new
        return SolveReport(self.max_iterations, size / scale, False)

    def _remove_mean(self, v: np.ndarray) -> None:
        if self.singular and self._fluid_cells:
            solid = self.levels[0].solid
            kern.add_constant(
                v, solid, -float(v[solid == 0].sum(dtype=np.float64)) / self._fluid_cells
            )

    def _precondition(self, r: np.ndarray, z: np.ndarray) -> None:
        """``z = M r``: one V-cycle from a zero guess."""
        top = self.levels[0]
        z[...] = 0.0
        self._cycle(0, r, z)
        self._remove_mean(z)
        del top

    def _cycle(self, depth: int, b: np.ndarray, x: np.ndarray) -> None:
        level = self.levels[depth]
        with threads_for(level.solid.size):
            self._level_cycle(depth, level, b, x)

    def _level_cycle(self, depth: int, level: Level, b: np.ndarray, x: np.ndarray) -> None:
        if depth == len(self.levels) - 1:
            _sweeps(x, b, level, COARSEST_SWEEPS, (0, 1))
            _sweeps(x, b, level, COARSEST_SWEEPS, (1, 0))
            return
        _sweeps(x, b, level, SMOOTHING, (0, 1))
        kern.residual(x, b, level.diag, level.inv_diag, level.zero, level.r)
        coarse = self.levels[depth + 1]
        # The operator is h^2 times the Laplacian: on a level of twice the cell size the
        # right-hand side is 4 times the restricted (averaged) residual.
        scale = 4.0 / float(coarse.factors.prod())
        kern.restrict(level.r, coarse.solid, coarse.factors, scale, coarse.b)
        coarse.x[...] = 0.0
        self._cycle(depth + 1, coarse.b, coarse.x)
        kern.prolong_add(coarse.x, coarse.factors, level.fluid, x)
        _sweeps(x, b, level, SMOOTHING, (1, 0))


def _sweeps(x, b, level: Level, count: int, colors: tuple[int, int]) -> None:
    for _ in range(count):
        for color in colors:
            kern.smooth(x, b, level.diag, level.inv_diag, level.zero, color)


def _level(solid: np.ndarray, open_faces: np.ndarray, factors: np.ndarray) -> Level:
    diag = np.empty(solid.shape, np.float32)
    inv_diag = np.empty(solid.shape, np.float32)
    kern.diagonal(solid, open_faces, diag, inv_diag)
    zeros = [np.zeros(solid.shape, np.float32) for _ in range(3)]
    zero_row = np.zeros(solid.shape[2], np.float32)
    level = Level(solid, diag, inv_diag, zero_row, *zeros, (solid == 0).astype(np.float32), factors)
    return level
