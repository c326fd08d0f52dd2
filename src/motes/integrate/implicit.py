r"""Implicit Euler: Baraff & Witkin 1998, "Large steps in cloth simulation", SIGGRAPH.

One step of backward Euler, linearised about the current state (their eq. 15-16)::

    (M - h ∂f/∂v - h² ∂f/∂x) Δv = h (f0 + h ∂f/∂x v0)
    v1 = v0 + Δv,   x1 = x0 + h v1

solved by preconditioned conjugate gradients with constraint filtering (their §5.3):
pinned or partly constrained particles have a projection ``S_i`` onto their free
directions and a prescribed velocity change ``z_i`` in the others, so constraints hold
exactly, whatever the residual of the solve.

Which forces are implicit
-------------------------
- :class:`~motes.forces.springs.Springs` are assembled by a compiled kernel
  (:func:`~motes.integrate.implicit_kernels.spring_system_kernel`): the fast path.
- Any other :class:`~motes.forces.base.Force` whose ``jacobian`` returns a
  :class:`~motes.forces.base.ForceJacobian` is assembled from its blocks (NumPy). The
  conjugate gradient method needs ``A`` symmetric positive definite: such a force's
  ``∂f/∂x`` and ``∂f/∂v`` must be symmetric and negative semi-definite (true of
  conservative, dissipative forces; :meth:`Springs.jacobian
  <motes.forces.springs.Springs.jacobian>` gives such a form by default, the true
  derivative being indefinite for compressed springs).
- Forces whose ``jacobian`` returns None, and the ``external`` forces passed to
  :meth:`ImplicitEuler.step` (gravity, wind), are explicit: evaluated once at the start
  of the step and held constant through it.
- A linear drag ``-c v`` (``damping``) is implicit: it adds ``h c`` to the diagonal.

How ``A`` is stored, for speed: a 64×64 cloth needs 20-100 conjugate gradient
iterations per step, each one product with ``A``. The springs' part is kept per spring
as ``α I + β u uᵀ`` (five numbers computed once per step, with the square root and
division), and a product applies it to both ends of each spring: 18 multiply-adds per
spring instead of 36 for its two assembled 3×3 off-diagonal blocks, and a third of the
memory (measured: 0.065 ms against 0.14 ms for the fully assembled block-CSR product of a
64×64 cloth). Diagonal blocks are assembled (the block-Jacobi preconditioner needs their
inverses anyway), and so are other forces' Jacobians, in block-CSR form.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import _validate as check
from ..forces.springs import Springs
from .implicit_kernels import (
    assemble_kernel,
    gather_rhs_kernel,
    pcg_kernel,
    product_kernel,
    rows_product_kernel,
    spring_system_kernel,
)
from .multigrid import Hierarchy, strong_springs
from .multigrid_kernels import galerkin_kernel

#: Preconditioners of the conjugate gradient solve (see :class:`ImplicitEuler`).
PRECONDITIONERS = ("multigrid", "jacobi")

_IDENTITY = np.eye(3).ravel()

#: Bodies stepped implicitly (cloth, hair) run on one thread below this many particles.
#: The solve itself is serial (see ``pcg_kernel``); the few parallel passes around it
#: then only wake the thread pool, whose OpenMP workers spin after each region and
#: compete with the serial solve for the cores. Measured on the shared 2-core machine,
#: 2,000 hair strands (20,000 particles): 38 ms per step on one thread, 105 ms on two.
SERIAL_BELOW = 1 << 16


class SolverError(RuntimeError):
    """The conjugate gradient solve did not reach its tolerance (see ``report``)."""

    def __init__(self, message: str, report: SolveReport):
        super().__init__(message)
        self.report = report


@dataclass(frozen=True)
class SolveReport:
    """Outcome of one implicit step's linear solve.

    Attributes
    ----------
    iterations : int
        Conjugate gradient iterations taken.
    residual : float
        Final preconditioned residual relative to the initial one,
        ``sqrt(rᵀP⁻¹r / r0ᵀP⁻¹r0)`` (0 when the initial residual was 0).
    converged : bool
        ``residual <= tolerance`` and the iteration did not break down.
    constraint_impulse : ndarray of shape (3,)
        Total impulse [N s] the constraints applied over the step: the sum over
        constrained directions of ``A Δv - b`` (Baraff & Witkin §5.3: the residual on the
        constrained components is the constraint force times ``h``).
    """

    iterations: int
    residual: float
    converged: bool
    constraint_impulse: np.ndarray


class ConstraintFilter:
    """Per-particle constraints for :class:`ImplicitEuler` (Baraff & Witkin §5.3).

    Each particle has a projection ``S_i`` onto its free directions: ``I`` (free),
    ``I - p pᵀ`` (one direction ``p`` constrained), ``0`` (pinned). Constrained
    directions take the velocity given in ``velocity`` (0 by default: held still).

    Parameters
    ----------
    n : int
        Number of particles.
    """

    def __init__(self, n: int):
        self.n = check.integer("n", n, low=0)
        self.filter = np.tile(_IDENTITY, (self.n, 1))
        #: Target velocity [m/s] of constrained directions, shape (3, n).
        self.velocity = np.zeros((3, self.n))
        self._constrained = np.zeros(self.n, dtype=bool)

    def _index(self, indices) -> np.ndarray:
        idx = np.atleast_1d(np.asarray(indices))
        if idx.size == 0:
            return idx.astype(np.int64)
        if idx.dtype.kind not in "iu":
            raise TypeError(f"indices must be integers, got dtype {idx.dtype}")
        if idx.min() < 0 or idx.max() >= self.n:
            raise ValueError(f"indices must be in [0, {self.n - 1}]")
        return idx.astype(np.int64)

    def pin(self, indices, velocity=None) -> None:
        """Constrain every direction of ``indices``; they move at ``velocity`` (3,) or
        (k, 3) [m/s] (default: still)."""
        idx = self._index(indices)
        self.filter[idx] = 0.0
        self._constrained[idx] = True
        if velocity is not None:
            self.velocity[:, idx] = np.broadcast_to(
                np.asarray(velocity, dtype=np.float64), (idx.size, 3)
            ).T

    def restrict(self, indices, direction) -> None:
        """Constrain one more direction (3,) of ``indices``: ``S_i <- S_i (I - p pᵀ)``
        with ``p`` ``direction`` made orthogonal to what is already constrained."""
        idx = self._index(indices)
        p = check.unit_vector("direction", direction)
        s = self.filter[idx].reshape(-1, 3, 3)
        free = s @ p  # component of p still free, per particle
        norm = np.linalg.norm(free, axis=1, keepdims=True)
        free = np.where(norm > 1e-12, free / np.maximum(norm, 1e-300), 0.0)
        s = s - free[:, :, None] * free[:, None, :]
        self.filter[idx] = s.reshape(-1, 9)
        self._constrained[idx] = True

    def release(self, indices) -> None:
        """Free ``indices`` again."""
        idx = self._index(indices)
        self.filter[idx] = _IDENTITY
        self.velocity[:, idx] = 0.0
        self._constrained[idx] = False

    @property
    def constrained(self) -> np.ndarray:
        """Bool (n,): particles with at least one constrained direction."""
        return self._constrained.copy()

    def target_change(self, velocity: np.ndarray) -> np.ndarray:
        """``z = (I - S)(v_target - v0)`` as an ``(n, 3)`` array (0 where free)."""
        idx = np.flatnonzero(self._constrained)
        z = np.zeros((self.n, 3))
        z[idx] = self.free_part(idx, (self.velocity[:, idx] - velocity[:, idx]).T, complement=True)
        return z

    def free_part(self, idx: np.ndarray, v: np.ndarray, *, complement: bool = False):
        """``S_i v_i`` (or ``(I - S_i) v_i``) for particles ``idx`` and rows ``v`` (k, 3)."""
        sv = np.einsum("kij,kj->ki", self.filter[idx].reshape(-1, 3, 3), v)
        return v - sv if complement else sv


class _Pattern:
    """Sparsity of ``A`` and the source lists that assemble it (built in NumPy, cached).

    Springs keep their part of ``A`` per spring (``coef``); other forces' Jacobian blocks
    are summed into a diagonal block per particle and block-CSR off-diagonal slots.
    """

    def __init__(self, n: int, spring_pairs: np.ndarray, rows: np.ndarray, cols: np.ndarray):
        m = spring_pairs.shape[0]
        self.n, self.m = n, m
        self.pairs = np.ascontiguousarray(spring_pairs, dtype=np.int64)
        self.generic_rows, self.generic_cols = rows, cols
        ends = self.pairs.ravel()  # entry e: spring e >> 1, end e & 1
        order = np.argsort(ends, kind="stable")
        self.incident = order.astype(np.int64)
        self.incident_ptr = _pointers(ends[order], n)
        # Generic diagonal sources, by particle.
        diagonal = rows == cols
        g_diag = np.flatnonzero(diagonal)
        o = np.argsort(rows[g_diag], kind="stable")
        self.diag_src = g_diag[o].astype(np.int64)
        self.diag_ptr = _pointers(rows[g_diag][o], n)
        # Generic off-diagonal sources, by (row, col) slot.
        g_off = np.flatnonzero(~diagonal)
        o_row, o_col = rows[g_off], cols[g_off]
        o = np.lexsort((o_col, o_row))
        o_row, o_col, o_src = o_row[o], o_col[o], g_off[o]
        key = o_row * n + o_col
        first = np.ones(key.shape[0], dtype=bool)
        first[1:] = key[1:] != key[:-1]
        starts = np.flatnonzero(first)
        self.cols = o_col[starts].astype(np.int64)
        self.row_ptr = _pointers(o_row[starts], n)
        self.slot_ptr = np.append(starts, key.shape[0]).astype(np.int64)
        self.slot_src = o_src.astype(np.int64)
        self.coef = np.empty((m, 5))
        self.sources = np.empty((rows.shape[0], 9))
        self.diag = np.empty((n, 9))
        self.inv_diag = np.empty((n, 9))
        self.off = np.empty((self.cols.shape[0], 9))
        self.spring_rhs = np.empty((3, m))
        self.work = np.empty((5, n, 3))
        self._hierarchy: Hierarchy | None = None

    @property
    def hierarchy(self) -> Hierarchy:
        """Multigrid levels of this sparsity, built on first use, with their scratch."""
        if self._hierarchy is None:
            slot_rows = np.repeat(np.arange(self.n, dtype=np.int64), np.diff(self.row_ptr))
            strong = strong_springs(self.n, self.pairs, self.coef)
            h = self._hierarchy = Hierarchy(self.n, self.pairs, slot_rows, self.cols, strong)
            self.row_coef = np.empty((2 * self.m, 5), dtype=np.float32)
            self.gdiag = np.empty((self.n, 6), dtype=np.float32)
            self.cdiag = np.empty((h.nodes, 9))
            self.cinv = np.empty((h.nodes, 9))
            self.coff = np.empty((h.ccols.shape[0], 9))
            self.crhs = np.empty((h.nodes, 3))
            self.cx = np.empty((h.nodes, 3))
        return self._hierarchy

    def multigrid(self, filt: np.ndarray, held: np.ndarray) -> tuple:
        """This step's multigrid operands for ``pcg_kernel``: the fine level's blocks row
        by row, ``G_i = Ã_ii⁻¹ S_i`` and the coarse matrices (after assembly)."""
        h = self.hierarchy
        galerkin_kernel(
            filt,
            self.inv_diag,
            self.gdiag,
            self.diag,
            self.off,
            self.row_ptr,
            self.cols,
            self.pairs,
            self.coef,
            held,
            h.agg,
            h.spring_slot,
            h.off_slot,
            h.level_start,
            h.crow_ptr,
            h.cagg,
            h.cslot,
            h.entry_spring,
            self.row_coef,
            self.cdiag,
            self.coff,
            self.cinv,
        )
        fine = (
            h.entry_ptr,
            h.row_mid,
            h.row_other,
            self.row_coef,
            self.row_ptr,
            self.cols,
            self.off,
            self.gdiag,
            held,
            h.agg,
        )
        coarse = (h.level_start, h.crow_ptr, h.ccols, self.coff, self.cdiag, self.cinv, h.cagg)
        return fine, coarse, self.crhs, self.cx

    def matches(self, n, spring_pairs, rows, cols) -> bool:
        return (
            n == self.n
            and np.array_equal(spring_pairs, self.pairs)
            and np.array_equal(rows, self.generic_rows)
            and np.array_equal(cols, self.generic_cols)
        )

    def product(self, v: np.ndarray) -> np.ndarray:
        """``A v`` for an (n, 3) float64 vector."""
        out = np.empty_like(v)
        product_kernel(self.diag, self.off, self.row_ptr, self.cols, self.pairs, self.coef, v, out)
        return out

    def product_rows(self, rows: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``(A v)[rows]`` (k, 3) for an (n, 3) float64 vector and int64 ``rows``."""
        out = np.empty((rows.shape[0], 3))
        rows_product_kernel(
            rows, self.diag, self.off, self.row_ptr, self.cols, self.pairs, self.coef,
            self.incident_ptr, self.incident, v, out,
        )  # fmt: skip
        return out


def _no_multigrid() -> tuple:
    """Empty operands of ``pcg_kernel``'s multigrid, typed as the real ones (one
    compiled kernel serves both preconditioners)."""
    ints = np.empty(0, dtype=np.int64)
    blocks = np.empty((0, 9))
    vectors = np.empty((0, 3))
    held = np.empty(0, dtype=np.bool_)
    fine = (
        ints,
        ints,
        np.empty(0, dtype=np.int32),
        np.empty((0, 5), dtype=np.float32),
        ints,
        ints,
        blocks,
        np.empty((0, 6), dtype=np.float32),
        held,
        ints,
    )
    coarse = (ints, ints, ints, blocks, blocks, blocks, ints)
    return fine, coarse, vectors, vectors


_NO_MULTIGRID = _no_multigrid()


def _pointers(sorted_owner: np.ndarray, n: int) -> np.ndarray:
    """CSR offsets (n + 1,) of a sorted owner array."""
    counts = np.bincount(sorted_owner, minlength=n) if sorted_owner.size else np.zeros(n, int)
    return np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)


class ImplicitEuler:
    """Linearised backward Euler step (Baraff & Witkin 1998), solved by filtered PCG.

    Parameters
    ----------
    tolerance : float
        Relative preconditioned residual at which conjugate gradients stop, in (0, 1).
    max_iterations : int
        Iteration cap (>= 1).
    warm_start : bool
        Start conjugate gradients from the previous step's ``Δv`` (in the free
        directions) when the particle count is unchanged: far fewer iterations for
        smooth motion. The result still meets ``tolerance``.
    on_failure : {"raise", "accept"}
        When the solve misses ``tolerance``: raise :class:`SolverError`, or keep the
        last iterate (``last_report`` says so). A breakdown (``A`` not positive
        definite, or non-finite values) always raises.
    preconditioner : {"multigrid", "jacobi"}
        ``"multigrid"``: one aggregation multigrid cycle per iteration
        (:mod:`motes.integrate.multigrid`), whose iteration count stays about flat as a
        cloth gets finer; ``"jacobi"``: the inverse of ``A``'s diagonal blocks, cheaper
        per iteration but needing iterations in proportion to the cloth's side. The
        stopping test is in the preconditioner's norm, which for multigrid is close to
        the error's energy norm: at the same ``tolerance`` it stops nearer the exact
        solution.

    Attributes
    ----------
    last_report : SolveReport or None
        The latest step's solve.
    """

    def __init__(
        self,
        *,
        tolerance: float = 1e-3,
        max_iterations: int = 500,
        warm_start: bool = True,
        on_failure: str = "raise",
        preconditioner: str = "multigrid",
    ):
        self.preconditioner = check.choice("preconditioner", preconditioner, PRECONDITIONERS)
        self.tolerance = check.real("tolerance", tolerance, low=0.0, high=1.0, low_open=True)
        self.max_iterations = check.integer("max_iterations", max_iterations, low=1)
        self.on_failure = check.choice("on_failure", on_failure, ("raise", "accept"))
        if not isinstance(warm_start, bool):
            raise TypeError(f"warm_start must be True or False, got {warm_start!r}")
        self.warm_start = warm_start
        self._previous: np.ndarray | None = None
        self.last_report: SolveReport | None = None
        self._pattern: _Pattern | None = None

    def __repr__(self) -> str:
        return (
            f"ImplicitEuler(tolerance={self.tolerance}, max_iterations={self.max_iterations}, "
            f"preconditioner={self.preconditioner!r})"
        )

    @property
    def previous_change(self) -> np.ndarray | None:
        """``Δv`` [m/s], (n, 3), of the latest successful step, where the next solve
        starts (with ``warm_start``); None before the first.

        It belongs to the state of what the solver steps, not to its settings: the
        cloth and hair states carry it and set it back before each step, so that
        restoring a state reproduces the run bit for bit.
        """
        return self._previous

    @previous_change.setter
    def previous_change(self, value: np.ndarray | None) -> None:
        if value is not None:
            value = np.asarray(value, dtype=np.float64)
            if value.ndim != 2 or value.shape[1] != 3:
                raise ValueError(f"previous_change must have shape (n, 3), got {value.shape}")
        self._previous = value

    def step(
        self,
        position: np.ndarray,
        velocity: np.ndarray,
        mass: np.ndarray,
        dt: float,
        *,
        forces=(),
        external: np.ndarray | None = None,
        damping: float | np.ndarray = 0.0,
        constraints: ConstraintFilter | None = None,
        store=None,
        time: float = 0.0,
    ) -> SolveReport:
        """Advance ``position`` and ``velocity`` in place by one step of ``dt``.

        Parameters
        ----------
        position, velocity : float64 arrays of shape (3, n)
            [m], [m/s]; rows contiguous (a ``(3, n)`` C-ordered array or row slices).
        mass : float64 array of shape (n,)
            Particle masses [kg], > 0 (a pinned particle may have any positive mass).
        dt : float
            Step ``h`` [s].
        forces : sequence of Force
            Springs (implicit, compiled), forces with Jacobians (implicit), others
            (explicit).
        external : (3, n) array, optional
            Explicit forces [N] held over the step (gravity, wind).
        damping : float or (n,) array
            Linear drag coefficient ``c`` [kg/s] of ``f = -c v``, treated implicitly.
        constraints : ConstraintFilter, optional
        store : optional
            Passed to the forces' ``accumulate`` / ``jacobian`` (a ParticleStore).
        time : float
            Simulation time [s] at the start of the step.
        """
        h = check.positive("dt", dt)
        n = position.shape[1]
        if position.dtype != np.float64 or velocity.dtype != np.float64:
            raise TypeError("position and velocity must be float64 (the solve needs it)")
        if velocity.shape != position.shape or position.shape[0] != 3:
            raise ValueError(
                f"position and velocity must both have shape (3, n), got {position.shape} "
                f"and {velocity.shape}"
            )
        mass = np.ascontiguousarray(mass, dtype=np.float64)
        if mass.shape != (n,) or not np.all(mass > 0) or not np.all(np.isfinite(mass)):
            raise ValueError(f"mass must be finite and > 0 with shape ({n},)")
        springs = [f for f in forces if isinstance(f, Springs)]
        others = [f for f in forces if not isinstance(f, Springs)]
        # Explicit part of f0 and the generic Jacobians.
        f0 = np.zeros((3, n))
        if external is not None:
            f0 += external
        damping = np.asarray(damping, dtype=np.float64)
        f0 -= damping * velocity  # the drag at v0; its derivative -c I goes in A
        jacobians = []
        for force in others:
            force.accumulate(store, position, velocity, time, f0)
            jac = force.jacobian(store, position, velocity)
            if jac is not None:
                jacobians.append(jac)
        pairs = (
            np.concatenate([s.pairs for s in springs])
            if springs
            else np.empty((0, 2), dtype=np.int64)
        )
        if pairs.size and pairs.max() >= n:
            raise ValueError(f"springs join particle {pairs.max()} but only {n} are given")
        rows, cols, dfdx, dfdv = _generic(jacobians)
        pattern = self._pattern_for(n, springs, pairs, rows, cols)

        # Per-spring blocks and right-hand sides, then the generic blocks.
        offset = 0
        for s in springs:
            k = s.spring_count
            spring_system_kernel(
                *position,
                *velocity,
                s.pairs,
                s.rest_length,
                s.stiffness,
                s.damping,
                h,
                pattern.coef[offset : offset + k],
                pattern.spring_rhs[:, offset : offset + k],
            )
            offset += k
        if rows.size:
            pattern.sources[:] = (-h * dfdv - h * h * dfdx).reshape(-1, 9)
        extra = np.broadcast_to(np.asarray(damping, dtype=np.float64) * h, (n,))
        assemble_kernel(
            mass,
            np.ascontiguousarray(extra),
            pattern.coef,
            pattern.incident_ptr,
            pattern.incident,
            pattern.sources,
            pattern.diag_ptr,
            pattern.diag_src,
            pattern.row_ptr,
            pattern.slot_ptr,
            pattern.slot_src,
            pattern.diag,
            pattern.off,
            pattern.inv_diag,
        )
        b = np.ascontiguousarray((h * f0).T)
        if rows.size:
            dv_cols = velocity.T[cols]
            np.add.at(b, rows, h * h * np.einsum("kij,kj->ki", dfdx, dv_cols))
        gather_rhs_kernel(pattern.spring_rhs, pattern.incident_ptr, pattern.incident, b)

        if constraints is None:
            filt = np.tile(_IDENTITY, (n, 1))
            held = np.zeros(n, dtype=bool)
            start = np.zeros((n, 3))
        else:
            if constraints.n != n:
                raise ValueError(f"constraints are for {constraints.n} particles, not {n}")
            filt = constraints.filter
            held = constraints._constrained
            start = constraints.target_change(velocity)
        previous = self._previous
        if self.warm_start and previous is not None and previous.shape == (n, 3):
            start += previous  # S = I where free
            if constraints is not None:
                idx = np.flatnonzero(held)
                start[idx] -= constraints.free_part(idx, previous[idx], complement=True)
        dv = np.empty((n, 3))
        multigrid = self.preconditioner == "multigrid"
        operands = pattern.multigrid(filt, held) if multigrid else _NO_MULTIGRID
        iterations, delta0, delta = pcg_kernel(
            pattern.diag,
            pattern.off,
            pattern.row_ptr,
            pattern.cols,
            pattern.pairs,
            pattern.coef,
            pattern.inv_diag,
            filt,
            held,
            b,
            start,
            self.tolerance,
            self.max_iterations,
            dv,
            pattern.work,
            multigrid,
            *operands,
        )
        broke = not np.isfinite(delta) or not np.all(np.isfinite(dv))
        residual = float(np.sqrt(delta / delta0)) if delta0 > 0 and not broke else 0.0
        converged = not broke and residual <= self.tolerance
        impulse = np.zeros(3)
        if constraints is not None and not broke:
            idx = np.flatnonzero(held)
            e = pattern.product_rows(idx, dv) - b[idx]
            impulse = constraints.free_part(idx, e, complement=True).sum(axis=0)
        report = SolveReport(int(iterations), residual, converged, impulse)
        self.last_report = report
        if broke:
            raise SolverError(
                "implicit step broke down: the system matrix is not positive definite on "
                "the free directions, or the state is not finite (check stiffness, masses "
                "and forces' Jacobians)",
                report,
            )
        if not converged and self.on_failure == "raise":
            raise SolverError(
                f"conjugate gradients reached residual {residual:.3g} > tolerance "
                f"{self.tolerance:g} after {iterations} iterations; raise max_iterations "
                "or use a smaller step",
                report,
            )
        self._previous = dv
        velocity += dv.T
        position += h * velocity
        return report

    def _pattern_for(self, n, springs, pairs, rows, cols) -> _Pattern:
        p = self._pattern
        if p is None or not p.matches(n, pairs, rows, cols):
            p = self._pattern = _Pattern(n, pairs, rows, cols)
        return p


def _generic(jacobians) -> tuple[np.ndarray, ...]:
    """Concatenated rows, cols, ∂f/∂x, ∂f/∂v of generic force Jacobians."""
    if not jacobians:
        empty = np.empty((0, 3, 3))
        return np.empty(0, np.int64), np.empty(0, np.int64), empty, empty
    rows = np.concatenate([np.asarray(j.rows, dtype=np.int64) for j in jacobians])
    cols = np.concatenate([np.asarray(j.cols, dtype=np.int64) for j in jacobians])
    dfdx = np.concatenate([np.asarray(j.dfdx, dtype=np.float64) for j in jacobians])
    dfdv = np.concatenate([np.asarray(j.dfdv, dtype=np.float64) for j in jacobians])
    return rows, cols, dfdx, dfdv


def advance_store(
    solver: ImplicitEuler, store, forces, params: np.ndarray, n: int, dt: float, time: float
) -> SolveReport:
    """One implicit step of a :class:`~motes.ParticleSystem`'s first ``n`` particles.

    ``params`` are the fused kernel's packed field coefficients
    (:mod:`motes.integrate.kernels`): gravity and drag toward wind are explicit forces,
    the linear drag coefficient is also implicit (``h k`` on the diagonal). Particles
    with ``inv_mass == 0`` keep their velocity exactly (pinned, or moved by the user),
    as in the explicit schemes.
    """
    p = np.asarray(params, dtype=np.float64)
    x = store.raw("position")[:, :n].astype(np.float64)
    v = store.raw("velocity")[:, :n].astype(np.float64)
    w = store.raw("inv_mass")[:n].astype(np.float64) if store.has("inv_mass") else np.ones(n)
    free = w > 0
    mass = np.where(free, 1.0 / np.where(free, w, 1.0), 1.0)
    # Drag toward the wind: -k v is the implicit ``damping``, k·wind an explicit force.
    external = free * mass * p[0:3, None] + p[4:7, None]
    if p[7] > 0:
        rel = v - p[8:11, None]
        external -= p[7] * np.linalg.norm(rel, axis=0) * rel
    external *= free
    constraints = None
    if not free.all():
        constraints = ConstraintFilter(n)
        pinned = np.flatnonzero(~free)
        constraints.pin(pinned, velocity=v[:, pinned].T)
    report = solver.step(
        x,
        v,
        mass,
        dt,
        forces=forces,
        external=external,
        damping=p[3] * free,
        constraints=constraints,
        store=store,
        time=time,
    )
    store.raw("position")[:, :n] = x
    store.raw("velocity")[:, :n] = v
    return report
