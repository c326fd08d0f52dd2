"""Constraint sets: sticks, ropes, distance and angle limits, pins; built, coloured, relaxed.

A :class:`ConstraintBuilder` collects constraints in the order they are added;
:meth:`ConstraintBuilder.build` colours them once (:mod:`.graph`) and returns a
:class:`ConstraintSet` whose :meth:`~ConstraintSet.relax` runs compiled sweeps
(:mod:`.kernels`, where the projection and both stiffness models are written out).

Two stiffness models, chosen per constraint:

- ``stiffness`` k in (0, 1] (position based dynamics, Müller et al. 2007): each
  projection moves the particles by k times the full correction. The effective
  stiffness depends on the iteration count and the time step (n iterations remove a
  fraction 1 - (1 - k)^n of the error).
- ``compliance`` α >= 0 [m/N] (XPBD, Macklin, Müller & Chentanez 2016): the inverse of
  a spring stiffness, so a constraint behaves like a spring of stiffness 1/α [N/m]
  whatever the iteration count and the step (given enough iterations to converge).
  The multipliers λ accumulate over the iterations of a step: call
  :meth:`ConstraintSet.reset_multipliers` at the start of each step.
"""

from __future__ import annotations

import numpy as np

from .. import _validate as check
from .._jit import threads_for
from .graph import color_constraints
from .kernels import ANGLE, DISTANCE, SIDE, apply_pins, relax_sweep


def _pairs(name, value, width, *, distinct=True):
    arr = np.asarray(value)
    if arr.size == 0:
        return np.zeros((0, width), dtype=np.int64)
    if arr.ndim != 2 or arr.shape[1] != width or not np.issubdtype(arr.dtype, np.integer):
        raise ValueError(
            f"{name} must be an (m, {width}) integer array, got {arr.dtype} {arr.shape}"
        )
    if arr.min() < 0:
        raise ValueError(f"{name} must hold particle indices >= 0")
    if distinct and np.any([len(set(row)) < width for row in arr.tolist()]):
        raise ValueError(f"{name}: the particles of one constraint must be distinct")
    return arr.astype(np.int64)


def _per(name, value, m, *, low=0.0, high=None, low_open=False):
    arr = np.broadcast_to(np.asarray(value, dtype=np.float64), (m,)).copy()
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite")
    if np.any(arr < low) or (low_open and np.any(arr == low)):
        raise ValueError(f"{name} must be {'>' if low_open else '>='} {low}")
    if high is not None and np.any(arr > high):
        raise ValueError(f"{name} must be <= {high}")
    return arr


class ConstraintBuilder:
    """Collects constraints over particles ``0 .. n - 1``, in order.

    Every ``add_*`` method takes ``stiffness`` (k in (0, 1], PBD) and ``compliance``
    (α >= 0 [m/N], XPBD), each a number or one per constraint; a constraint with
    α > 0 must keep k = 1 (the two models do not combine). Each returns the indices of
    the added constraints in the order of addition.
    """

    def __init__(self):
        self._ends: list[np.ndarray] = []
        self._kind: list[np.ndarray] = []
        self._lo: list[np.ndarray] = []
        self._hi: list[np.ndarray] = []
        self._compliance: list[np.ndarray] = []
        self._stiffness: list[np.ndarray] = []
        self._count = 0

    def __len__(self) -> int:
        return self._count

    def _add(self, ends, kind, lo, hi, stiffness, compliance) -> np.ndarray:
        m = len(ends)
        k = _per("stiffness", stiffness, m, low=0.0, high=1.0, low_open=True)
        a = _per("compliance", compliance, m)
        if np.any((a > 0) & (k < 1)):
            raise ValueError("stiffness must be 1 where compliance > 0 (use one model)")
        self._ends.append(ends)
        self._kind.append(np.full(m, kind, dtype=np.int8))
        self._lo.append(lo)
        self._hi.append(hi)
        self._stiffness.append(k)
        self._compliance.append(a)
        self._count += m
        return np.arange(self._count - m, self._count)

    def add_distance(self, pairs, min_length, max_length, *, stiffness=1.0, compliance=0.0):
        """Keep ``min_length <= |x_j - x_i| <= max_length`` [m] for each pair ``(i, j)``."""
        pairs = _pairs("pairs", pairs, 2)
        m = len(pairs)
        lo = _per("min_length", min_length, m)
        hi = _per("max_length", max_length, m)
        if np.any(hi < lo):
            raise ValueError("max_length must be >= min_length")
        ends = np.concatenate([pairs, np.full((m, 3), -1, dtype=np.int64)], axis=1)
        return self._add(ends, DISTANCE, lo, hi, stiffness, compliance)

    def add_sticks(self, pairs, rest_length, *, stiffness=1.0, compliance=0.0):
        """Sticks: ``|x_j - x_i| = rest_length`` [m] (Jakobsen 2001, §3)."""
        return self.add_distance(
            pairs, rest_length, rest_length, stiffness=stiffness, compliance=compliance
        )

    def add_ropes(self, pairs, length, *, stiffness=1.0, compliance=0.0):
        """Ropes: ``|x_j - x_i| <= length`` [m]; slack (no force) when shorter."""
        return self.add_distance(pairs, 0.0, length, stiffness=stiffness, compliance=compliance)

    def add_angle_limits(
        self, triples, min_angle, max_angle=np.pi, *, stiffness=1.0, compliance=0.0
    ):
        """Keep the angle at ``pivot`` between its arms to ``i`` and ``j`` in range [rad].

        ``triples`` holds ``(pivot, i, j)`` rows; the angle is in ``[0, π]``. Enforced
        by a temporary rod between ``i`` and ``j`` (Jakobsen 2001, §5; see
        :mod:`.kernels`), which moves ``i`` and ``j`` only.
        """
        triples = _pairs("triples", triples, 3)
        m = len(triples)
        lo = _per("min_angle", min_angle, m, high=np.pi)
        hi = _per("max_angle", max_angle, m, high=np.pi)
        if np.any(hi < lo):
            raise ValueError("max_angle must be >= min_angle")
        ends = np.concatenate([triples[:, [1, 2, 0]], np.full((m, 2), -1, np.int64)], axis=1)
        return self._add(ends, ANGLE, np.cos(lo), np.cos(hi), stiffness, compliance)

    def add_hinge_sides(self, rows, orientation, offset=0.0, *, stiffness=1.0, recovery=3.0):
        """Keep hinges from bending backwards; ``rows`` are ``(i, k, l, r, j)``.

        ``i -> k`` is the bone before the joint ``k`` (a thigh), ``l -> r`` the hinge
        axis (hip to hip), and ``j`` (the ankle) is kept where
        ``(x_j - x_k) · n̂ <= offset`` [m] with ``n = orientation (x_k - x_i) × (x_r - x_l)``;
        ``orientation`` (+1 or -1 per row) picks the forbidden side
        (``World.add_hinge_sides`` chooses it from the current pose). Where the bone is
        within 30° of the axis the plane is ill-defined and the limit rests.
        A violation present at the start of a step is undone at no more than
        ``recovery`` [m/s] (> 0; see :mod:`.kernels`).
        """
        rows = _pairs("rows", rows, 5, distinct=False)
        if (
            np.any(rows[:, 0] == rows[:, 1])
            or np.any(rows[:, 2] == rows[:, 3])
            or np.any(rows[:, [0, 1, 2, 3]] == rows[:, 4:5])
        ):
            raise ValueError("rows: i != k, l != r, and j distinct from the others")
        m = len(rows)
        lo = _per("offset", offset, m, low=-np.inf)
        sign = np.broadcast_to(np.asarray(orientation, dtype=np.float64), (m,)).copy()
        if not np.all(np.abs(sign) == 1.0):
            raise ValueError("orientation must be +1 or -1")
        speed = check.positive("recovery", recovery)
        ends = rows[:, [0, 4, 1, 2, 3]]  # i, j, k, l, r: j is the moved end, k the joint
        return self._add(ends, SIDE, lo, sign * speed, stiffness, 0.0)

    def build(self, particle_count: int) -> ConstraintSet:
        """The coloured, compiled-ready set over ``particle_count`` particles."""
        n = check.integer("particle_count", particle_count, low=0)
        ends = np.concatenate(self._ends) if self._ends else np.zeros((0, 5), np.int64)
        if ends.size and ends.max() >= n:
            raise ValueError(f"constraints index particle {ends.max()}, but there are {n}")
        order, color_start = color_constraints(ends, n)

        def cat(parts, dtype):
            return np.concatenate(parts).astype(dtype)[order] if parts else np.zeros(0, dtype)

        return ConstraintSet(
            n,
            np.ascontiguousarray(ends[order]),
            cat(self._kind, np.int8),
            cat(self._lo, np.float64),
            cat(self._hi, np.float64),
            cat(self._compliance, np.float64),
            cat(self._stiffness, np.float64),
            order,
            color_start,
        )


class ConstraintSet:
    """Constraints sorted by colour, relaxed by compiled sweeps.

    Attributes
    ----------
    ends : (m, 5) int64
        ``i, j``, then the pivot of an angle limit, or the joint and the two axis
        particles of a hinge side limit (``-1`` where unused), in colour order.
    kind : (m,) int8
        ``DISTANCE`` (0), ``ANGLE`` (1) or ``SIDE`` (2).
    lo, hi : (m,) float64
        Distance bounds [m] or, for angle limits, cos of the min and max angle.
    compliance : (m,) float64
        XPBD compliance α [m/N].
    stiffness : (m,) float64
        PBD stiffness k.
    order : (m,) int64
        ``order[c]`` is the index (in order of addition) of the constraint in slot ``c``.
    color_start : (colors + 1,) int64
        Slots of each colour.
    """

    def __init__(self, n, ends, kind, lo, hi, compliance, stiffness, order, color_start):
        self.particle_count = n
        self.ends = ends
        self.kind = kind
        self.lo = lo
        self.hi = hi
        self.compliance = compliance
        self.stiffness = stiffness
        self.order = order
        self.color_start = color_start
        self.multipliers = np.zeros(len(ends))

    def __len__(self) -> int:
        return len(self.ends)

    @property
    def color_count(self) -> int:
        return len(self.color_start) - 1

    def __repr__(self) -> str:
        return f"ConstraintSet(<{len(self)} constraints, {self.color_count} colours>)"

    def reset_multipliers(self) -> None:
        """Zero the XPBD multipliers λ (at the start of every time step)."""
        self.multipliers[:] = 0.0

    def sweep(
        self,
        position: np.ndarray,
        inv_mass: np.ndarray,
        dt: float,
        *,
        sqrt_approximation: bool = False,
        previous: np.ndarray | None = None,
        shake: bool | None = None,
    ) -> None:
        """One relaxation sweep over every constraint, in place.

        Parameters
        ----------
        position : (3, n) float64 array
            Positions [m], changed in place.
        inv_mass : (n,) float64 array
            Inverse masses [1/kg]; 0 for immovable particles.
        dt : float
            Time step [s] (used by the XPBD compliance term).
        sqrt_approximation : bool
            Jakobsen's square-root-free projection for rigid sticks.
        previous : (3, n) float64 array, optional
            Positions at the start of the step [m]: given, distance constraints project
            along their direction there (SHAKE; see :mod:`.kernels`) unless ``shake`` is
            False, and hinge side limits recover old violations at their recovery speed.
        shake : bool, optional
            Default: whether ``previous`` is given.
        """
        shake = previous is not None if shake is None else bool(shake)
        if shake and previous is None:
            raise ValueError("shake needs the previous positions")
        q = position if previous is None else previous
        relax_sweep(
            position[0],
            position[1],
            position[2],
            q[0],
            q[1],
            q[2],
            inv_mass,
            self.kind,
            self.ends,
            self.lo,
            self.hi,
            self.compliance,
            self.stiffness,
            self.multipliers,
            self.color_start,
            float(dt),
            bool(sqrt_approximation),
            shake,
        )

    def relax(
        self,
        position,
        inv_mass,
        dt,
        *,
        iterations=10,
        pins=None,
        sqrt_approximation=False,
        previous=None,
    ) -> None:
        """``iterations`` sweeps (pins re-applied after each), starting with λ = 0."""
        check_state(position, inv_mass, self.particle_count)
        iterations = check.integer("iterations", iterations, low=1)
        self.reset_multipliers()
        with threads_for(self.particle_count):
            for _ in range(iterations):
                self.sweep(
                    position, inv_mass, dt, sqrt_approximation=sqrt_approximation, previous=previous
                )
                if pins is not None:
                    pins.apply(position)

    def lengths(self, position: np.ndarray) -> np.ndarray:
        """Current ``|x_j - x_i|`` of every constraint, in colour order [m]."""
        d = position[:, self.ends[:, 1]] - position[:, self.ends[:, 0]]
        return np.sqrt((d * d).sum(axis=0))


def check_state(position, inv_mass, n) -> None:
    """Position must be a (3, n) float64 array and inv_mass an (n,) float64 one."""
    if (
        not isinstance(position, np.ndarray)
        or position.dtype != np.float64
        or position.shape
        != (
            3,
            n,
        )
    ):
        raise ValueError(f"position must be a (3, {n}) float64 array")
    if (
        not isinstance(inv_mass, np.ndarray)
        or inv_mass.dtype != np.float64
        or inv_mass.shape != (n,)
    ):
        raise ValueError(f"inv_mass must be an ({n},) float64 array")


class Pins:
    """Particles held at target positions (Jakobsen 2001, §3: "pin" constraints).

    Parameters
    ----------
    indices : (p,) int array_like
        Pinned particles.
    targets : (p, 3) array_like
        Where they are held [m]; move them with :meth:`move`.
    """

    def __init__(self, indices, targets):
        idx = np.asarray(indices)
        if idx.ndim != 1 or not np.issubdtype(idx.dtype, np.integer) or np.any(idx < 0):
            raise ValueError("indices must be a 1-D array of particle indices >= 0")
        if len(np.unique(idx)) != len(idx):
            raise ValueError("indices must not repeat a particle")
        self.indices = idx.astype(np.int64)
        self.targets = np.ascontiguousarray(check.points("targets", targets, min_rows=len(idx)).T)
        if self.targets.shape[1] != len(idx):
            raise ValueError(f"targets must have {len(idx)} rows, one per index")

    def move(self, targets) -> None:
        """New targets, (p, 3) [m]."""
        self.targets[:] = check.points("targets", targets, min_rows=len(self.indices)).T

    def apply(self, position: np.ndarray) -> None:
        apply_pins(position[0], position[1], position[2], self.indices, self.targets)
