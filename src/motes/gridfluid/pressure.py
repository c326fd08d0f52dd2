"""The pressure solve: conjugate gradients preconditioned by a multigrid V-cycle
(McAdams, Sifakis & Teran 2010, "A parallel multigrid Poisson solver for fluids
simulation on large grids").

The V-cycle coarsens every axis longer than one cell by two (a 2D grid, one cell thick,
stays one thick), smooths with red-black Gauss-Seidel (red then black going down, black
then red coming up, so that the cycle is a symmetric operator, as conjugate gradients
needs), interpolates piecewise-constantly and restricts with its transpose, the average
(tried against trilinear interpolation, it took fewer iterations: 9 against 13 at 512²,
7 against 9 at 128³), and solves the coarsest level (at most 64 cells) exactly, with the
inverse of its operator. Its iteration count hardly grows with the grid (tested: 32² to
128²).

Each red-black sweep is one pass over memory (:func:`.pressure_kernels.sweep`), and the
residual is computed inside the restriction (:func:`.pressure_kernels.restrict_residual`):
a level costs two kernel calls each way.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import _validate as check
from .._jit import threads_for
from . import pressure_kernels as kern

#: Coarsening stops at a level of at most this many cells (8² in 2D, 4³ in 3D), solved
#: exactly: the inverse of its operator is made with the levels (a 64-cell inverse takes
#: microseconds; an obstacle that moves rebuilds it every step).
COARSEST = 64
#: Gauss-Seidel sweeps (red + black) before and after the coarse correction.
SMOOTHING = 2
#: Levels of fewer cells run on one thread. A level costs about ten parallel launches a
#: cycle, each 0.02-0.2 ms on two cores (more while other processes load them): below
#: this size that is more than the level's work (as for a whole grid fluid, whose
#: ``SERIAL_BELOW`` this is).
SERIAL_BELOW = 65536


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
        while self.levels[-1].solid.size > COARSEST:
            fine = self.levels[-1].solid
            factors = np.array([2 if n > 1 else 1 for n in fine.shape[::-1]], np.int64)
            shape = tuple(-(-n // f) for n, f in zip(fine.shape, factors[::-1], strict=True))
            coarse = np.empty(shape, np.uint8)
            kern.coarsen_solid(fine, factors, coarse)
            self.levels.append(_level(coarse, self.open_faces, factors))
        self._coarsest = _dense_inverse(self.levels[-1])
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
        # the first level small enough for one thread (see threads_for)
        self._split = next(
            (d for d, level in enumerate(self.levels) if level.solid.size < SERIAL_BELOW),
            len(self.levels) - 1,
        )

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
        kern.apply_operator(x, top.diag, top.inv_diag, top.zero, r, partial)
        np.subtract(b, r, out=r)  # b - A x, 0 on solid cells (b is 0 there)
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
        z[...] = 0.0
        self._cycle(0, r, z)
        self._remove_mean(z)

    def _cycle(self, depth: int, b: np.ndarray, x: np.ndarray) -> None:
        # from the first level small enough on, one thread (see threads_for)
        if depth == self._split:
            with threads_for(0):
                self._level_cycle(depth, b, x)
        else:
            self._level_cycle(depth, b, x)

    def _level_cycle(self, depth: int, b: np.ndarray, x: np.ndarray) -> None:
        level = self.levels[depth]
        if depth == len(self.levels) - 1:  # solved exactly
            cells, inverse = self._coarsest
            x.ravel()[cells] = inverse @ b.ravel()[cells]
            return
        kern.sweep(x, b, level.inv_diag, 0, level.r, SMOOTHING)
        coarse = self.levels[depth + 1]
        # The operator is h^2 times the Laplacian: on a level of twice the cell size the
        # right-hand side is 4 times the restricted (averaged) residual.
        scale = np.float32(4.0 / float(coarse.factors.prod()))
        kern.restrict_residual(
            x, b, level.diag, level.r, coarse.solid, coarse.factors, scale, coarse.b, coarse.x
        )
        self._cycle(depth + 1, coarse.b, coarse.x)
        kern.prolong_add(coarse.x, coarse.factors, level.fluid, x)
        kern.sweep(x, b, level.inv_diag, 1, level.r, SMOOTHING)


def _dense_inverse(level: Level) -> tuple[np.ndarray, np.ndarray]:
    """The fluid cells (flat indices) of a small level and the inverse of the operator
    over them (the pseudo-inverse where all walls are closed and it is singular): the
    coarsest level's solve, exact and symmetric, in one product (relaxing it took 64
    kernel launches a cycle, most of the cycle's time on grids of 128² and less)."""
    solid = level.solid
    cells = np.flatnonzero(solid.ravel() == 0)
    number = np.full(solid.size, -1)
    number[cells] = np.arange(cells.size)
    number = number.reshape(solid.shape)
    matrix = np.diag(level.diag.ravel()[cells].astype(np.float64))
    for axis in range(3):
        ahead = [slice(None)] * 3
        behind = [slice(None)] * 3
        ahead[axis], behind[axis] = slice(1, None), slice(None, -1)
        a, b = number[tuple(behind)].ravel(), number[tuple(ahead)].ravel()
        both = (a >= 0) & (b >= 0)
        matrix[a[both], b[both]] = -1.0
        matrix[b[both], a[both]] = -1.0
    inverse = np.linalg.pinv(matrix, hermitian=True) if cells.size else matrix
    return cells, inverse.astype(np.float32)


def _level(solid: np.ndarray, open_faces: np.ndarray, factors: np.ndarray) -> Level:
    diag = np.empty(solid.shape, np.float32)
    inv_diag = np.empty(solid.shape, np.float32)
    kern.diagonal(solid, open_faces, diag, inv_diag)
    zeros = [np.zeros(solid.shape, np.float32) for _ in range(3)]
    zero_row = np.zeros(solid.shape[2], np.float32)
    level = Level(solid, diag, inv_diag, zero_row, *zeros, (solid == 0).astype(np.float32), factors)
    return level
