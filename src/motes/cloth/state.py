"""What changes as a cloth steps (its state) and what drives it from outside (its control).

A :class:`ClothState` is everything a step reads and writes that a later step depends
on: positions, velocities, time, and the implicit solve's warm start. Restoring a copy
(``cloth.state = saved``) rewinds the cloth: the run from there repeats bit for bit.
A :class:`ClothControl` holds the pins and the moving handles.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from ..integrate.implicit import ConstraintFilter
from .drivers import Keyframes


@dataclass(eq=False)
class MassSpringState:
    """Per-particle state of a body stepped by the implicit solver (cloth, hair).

    The arrays are the ones the step updates in place (views taken of them, such as a
    :class:`~motes.state.ParticleState`, follow it); :meth:`copy` for a snapshot.
    """

    positions: np.ndarray
    """Positions [m], float64 (3, n), rows contiguous: the implicit solve's precision."""
    velocities: np.ndarray
    """Velocities [m/s], float64 (3, n), rows contiguous."""
    time: float = 0.0
    """Simulation time [s]."""
    warm_start: np.ndarray | None = None
    """The implicit solve's latest ``Δv`` [m/s], float64 (n, 3), where the next solve
    starts; None before the first implicit step."""

    @property
    def particle_count(self) -> int:
        """Number of particles ``n``."""
        return self.positions.shape[1]

    def copy(self):
        """A deep copy (the same class)."""
        return type(self)(
            self.positions.copy(),
            self.velocities.copy(),
            self.time,
            None if self.warm_start is None else self.warm_start.copy(),
        )

    def check_count(self, name: str, n: int) -> None:
        """Raise ValueError (naming ``name``) unless the arrays are float64 (3, ``n``)."""
        for label, a in (("positions", self.positions), ("velocities", self.velocities)):
            if not isinstance(a, np.ndarray) or a.shape != (3, n) or a.dtype != np.float64:
                shape = getattr(a, "shape", None)
                raise ValueError(
                    f"{name} must hold {n} particles, float64 (3, {n}) {label}, got {shape}"
                )
        w = self.warm_start
        if w is not None and (not isinstance(w, np.ndarray) or w.shape != (n, 3)):
            raise ValueError(
                f"{name} must hold {n} particles, a warm start of shape ({n}, 3) or None, "
                f"got {getattr(w, 'shape', w)}"
            )


@dataclass(eq=False)
class ClothState(MassSpringState):
    """A cloth's positions [m] and velocities [m/s] (float64 (3, n)), time [s] and the
    implicit solve's warm start (see :class:`MassSpringState`)."""


@dataclass(frozen=True, eq=False)
class Handle:
    """Particles that follow a path: particle ``indices[k]`` is at
    ``anchor[:, k] + weights[k] · path(t)`` at time ``t``."""

    indices: np.ndarray
    """Particle indices, int64 (k,)."""
    anchor: np.ndarray
    """Position [m] at a path offset of zero, float64 (3, k)."""
    path: Keyframes
    """Translation [m] over time [s]."""
    weights: np.ndarray
    """How much of the path each particle follows, float64 (k,)."""


@dataclass(eq=False)
class ClothControl:
    """Pins and handles: what holds and drives a cloth's particles from outside."""

    constraints: ConstraintFilter
    """Constraint filter of the implicit solve: held particles and their target
    velocities [m/s] (a handle's are set at the start of each step)."""
    handles: list[Handle] = field(default_factory=list)
    """Moving handles, in the order they were made."""

    @classmethod
    def free(cls, n: int) -> ClothControl:
        """Nothing held, for ``n`` particles."""
        return cls(ConstraintFilter(n))


class MassSpringFacade:
    """The state half of the :class:`~motes.cloth.Cloth` and :class:`~motes.hair.Hair`
    façades: positions, velocities and time read from and written to the live
    :class:`MassSpringState`, and the state swapped for a saved copy.

    A subclass sets ``_state``, an ``n`` property and ``_STATE`` (its state class) and
    ``_UNITS`` (what its particles are called in messages: "vertices", "particles").
    """

    _STATE: type = MassSpringState
    _UNITS = "particles"
    #: Fields of the model :meth:`retune` takes (set by each subclass).
    RETUNABLE: tuple[str, ...] = ()
    #: Fields of the model that say what the body is made of: equal in a model it may
    #: take values from (set by each subclass).
    SHAPE: tuple[str, ...] = ()

    def fits(self, model) -> bool:
        """Whether ``model`` is of this body's particles and topology (its ``SHAPE``
        fields equal this one's), so that :meth:`retune` may take values from it."""
        own = self._model
        return all(np.array_equal(getattr(model, k), getattr(own, k)) for k in self.SHAPE)

    def retune(self, model) -> None:
        """Take the model values named by ``RETUNABLE`` from ``model`` (the same body
        built with new values: stiffer springs, a heavier gravity, more air damping)
        from the next step on, keeping the state, pins and handles. ``model`` must
        :meth:`fits`; its springs join the same particles, but for spring families it
        turns on or off."""
        if not self.fits(model):
            raise ValueError(
                f"model is of other {self._UNITS} or topology than this {type(self).__name__}"
            )
        self._model = replace(self._model, **{k: getattr(model, k) for k in self.RETUNABLE})

    def _replace_state(self, value) -> None:
        if not isinstance(value, self._STATE):
            raise TypeError(f"state must be a {self._STATE.__name__}, got {type(value).__name__}")
        n = self.n
        if value.particle_count != n:
            raise ValueError(
                f"state must hold this {type(self).__name__.lower()}'s {n} {self._UNITS}, "
                f"got {value.particle_count}"
            )
        value.check_count("state", n)
        self._state = value.copy()

    @property
    def position(self) -> np.ndarray:
        """Positions [m], float64 (3, n): the state's array (assignable)."""
        return self._state.positions

    @position.setter
    def position(self, value) -> None:
        self._state.positions = self._rows("position", value)

    @property
    def velocity(self) -> np.ndarray:
        """Velocities [m/s], float64 (3, n): the state's array (assignable)."""
        return self._state.velocities

    @velocity.setter
    def velocity(self, value) -> None:
        self._state.velocities = self._rows("velocity", value)

    def _rows(self, name: str, value) -> np.ndarray:
        rows = np.ascontiguousarray(value, dtype=np.float64)
        if rows.shape != (3, self.n):
            raise ValueError(f"{name} must have shape (3, {self.n}), got {rows.shape}")
        if not np.isfinite(rows).all():
            raise ValueError(f"{name} must be finite (no NaN or inf)")
        return rows

    @property
    def time(self) -> float:
        """Simulation time [s]."""
        return self._state.time

    @time.setter
    def time(self, value: float) -> None:
        self._state.time = float(value)
