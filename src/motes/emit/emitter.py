"""Emitters: where particles are born and with which initial attributes (Reeves 1983)."""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

from .. import _validate as check
from ..particles import BUILTIN
from .directions import Cone, Direction
from .distributions import Distribution, as_distribution
from .rates import PerSecond, Rate
from .shapes import Point, Shape

#: Newborn records drawn per batch (see :meth:`Emitter._take`).
RESERVOIR = 1024


class Path:
    """Piecewise-linear emitter trajectory through ``points`` (k, 3) [m] at ``times`` (k,) [s].

    Before the first time and after the last, the end points hold.
    """

    def __init__(self, times, points):
        self.times = np.asarray(times, dtype=np.float64)
        self.points = check.points("points", points)
        if self.times.shape != (self.points.shape[0],):
            raise ValueError(
                f"times must have one entry per point ({self.points.shape[0]}), "
                f"got shape {self.times.shape}"
            )
        if not np.all(np.isfinite(self.times)) or np.any(np.diff(self.times) <= 0):
            raise ValueError("times must be finite and strictly increasing")

    def __call__(self, t: float) -> np.ndarray:
        return np.array([np.interp(t, self.times, self.points[:, k]) for k in range(3)])


def _scalar_law(name: str, value, *, positive: bool = False, signed: bool = True) -> Distribution:
    """``value`` as a distribution of single numbers, > 0 if ``positive``, >= 0 unless
    ``signed``: a law one of whose samples could break that is refused here, so that no
    emission (or image) fails later."""
    law = as_distribution(name, value)
    law.check_fits(name, 1)
    low = law.lowest
    if low is not None and ((positive and not low > 0) or (not signed and not low >= 0)):
        bound = "> 0" if positive else ">= 0"
        raise ValueError(
            f"{name} must be {bound}, got a law whose least value is {low} (give it a low)"
        )
    return law


class Emitter:
    """Creates particles each step and gives them initial attributes.

    Parameters
    ----------
    shape : Shape
        Generation region, in the emitter's frame (default: a point).
    rate : Rate
        Count per step (default ``PerSecond(100)``).
    position : (3,) array_like or callable ``t -> (3,)`` or Path
        Emitter origin [m]; a callable moves it over time, and its velocity (by finite
        difference over the step) is inherited in proportion to ``inherit_velocity``.
    lifetime : Distribution or float
        [s], must be > 0 (``inf`` for immortal particles).
    speed : Distribution or float
        Initial speed [m/s] along ``direction``.
    direction : Direction
        ``Cone`` about an axis (default: 30° about +y), ``ShapeNormal`` or ``Radial``.
    inherit_velocity : float
        Fraction of the emitter's own velocity added to each particle [1].
    color, size, mass, rotation : Distribution or value, optional
        Initial colour (RGBA), radius [m], mass [kg] (> 0) and sprite angle [rad]. Given
        ones are allocated in the store.
    attributes : mapping of name -> Distribution, optional
        Initial values of other (user-registered) attributes.
    """

    def __init__(
        self,
        shape: Shape | None = None,
        rate: Rate | None = None,
        *,
        position=(0.0, 0.0, 0.0),
        lifetime=1.0,
        speed=1.0,
        direction: Direction | None = None,
        inherit_velocity: float = 0.0,
        color=None,
        size=None,
        mass=None,
        rotation=None,
        attributes: Mapping[str, Distribution] | None = None,
    ):
        self.shape = Point() if shape is None else shape
        if not isinstance(self.shape, Shape):
            raise TypeError(f"shape must be a motes Shape, got {shape!r}")
        self.rate = PerSecond(100.0) if rate is None else rate
        if not isinstance(self.rate, Rate):
            raise TypeError(f"rate must be a Rate (PerFrame, PerSecond, Burst...), got {rate!r}")
        if callable(position):
            self._path: Callable | None = position
            self._position = None
        else:
            self._path = None
            self._position = check.vector("position", position)
        self.lifetime = _scalar_law("lifetime", lifetime, positive=True)
        self.speed = _scalar_law("speed", speed)
        self.direction = Cone() if direction is None else direction
        if not isinstance(self.direction, Direction):
            raise TypeError(
                f"direction must be a Direction (Cone, ShapeNormal, Radial), got {direction!r}"
            )
        self.inherit_velocity = check.real("inherit_velocity", inherit_velocity)
        self.initial: dict[str, Distribution] = {}
        for name, value in (
            ("color", color),
            ("size", size),
            ("mass", mass),
            ("rotation", rotation),
        ):
            if value is not None:
                self.initial[name] = as_distribution(name, value)
                self.initial[name].check_fits(name, BUILTIN[name].components)
        if "mass" in self.initial:
            _scalar_law("mass", self.initial["mass"], positive=True)
        if "size" in self.initial:  # a radius
            _scalar_law("size", self.initial["size"], signed=False)
        for name, dist in (attributes or {}).items():
            self.initial[name] = as_distribution(name, dist)
        self._pool: dict[str, np.ndarray] | None = None
        self._head = 0
        # Attributes emit_at always writes, so spawning need not fill their defaults.
        self._initialised = (
            frozenset((*self.writes, "id", "birth_color", "birth_size", "birth_speed"))
            - ({"birth_color"} if "color" not in self.initial else set())
            - ({"birth_size"} if "size" not in self.initial else set())
        )

    @property
    def writes(self) -> tuple[str, ...]:
        """Attributes this emitter initialises (the store allocates them)."""
        extra = ("inv_mass",) if "mass" in self.initial else ()
        return ("position", "velocity", "lifetime", *self.initial, *extra)

    def position_at(self, time: float) -> np.ndarray:
        """Emitter origin at ``time`` [s], shape (3,)."""
        if self._path is None:
            return self._position
        point = check.vector("emitter path position", self._path(time))
        return point

    def velocity_at(self, time: float, dt: float) -> np.ndarray:
        """Emitter velocity [m/s] over ``[time, time + dt]``."""
        if self._path is None:
            return np.zeros(3)
        return (self.position_at(time + dt) - self.position_at(time)) / dt

    def emit(self, system, frame: int, time: float, dt: float) -> slice:
        """Create this step's particles in ``system``; returns the slice of new ones."""
        count = self.rate.count(system.rng, frame, time, dt, self)
        if count == 0:
            return slice(system.store.count, system.store.count)
        origin = self.position_at(time)[None, :]
        base = self.velocity_at(time, dt)[None, :] if self._path is not None else None
        return self.emit_at(system, origin, base, count=count)

    def emit_at(
        self,
        system,
        origins: np.ndarray,
        base_velocity: np.ndarray | None,
        inherited: Mapping[str, np.ndarray] | None = None,
        *,
        count: int | None = None,
    ) -> slice:
        """Create particles at ``origins`` (k, 3) [m], each offset by a shape sample.

        ``base_velocity`` (k, 3) [m/s] (or None for zero) is added times
        ``inherit_velocity``; ``inherited`` maps attribute names to (k, c) values that
        replace the emitter's own (a parent's colour, say). ``count`` defaults to k; with
        k = 1 the single origin serves every new particle.
        """
        store = system.store
        count = origins.shape[0] if count is None else count
        new = store.spawn(count, initialised=self._initialised)
        made = new.stop - new.start
        if made == 0:
            return new
        rows = self._take(store, system.rng, made)
        position = rows["offset"] + origins[:made]
        velocity = rows["velocity"]
        if base_velocity is not None and self.inherit_velocity:
            velocity = velocity + self.inherit_velocity * base_velocity[:made]
        raw = store.raw
        raw("position")[:, new] = position.T
        raw("velocity")[:, new] = velocity.T
        raw("lifetime")[new] = rows["lifetime"]
        for name in self.initial:
            if inherited is None or name not in inherited:
                raw(name)[..., new] = rows[name].T
        if inherited is not None:
            for name, values in inherited.items():
                if store.has(name):
                    raw(name)[..., new] = np.asarray(values)[:made].T
        if "mass" in self.initial:
            mass = raw("mass")[new]
            if np.any(~(mass > 0)):
                raise ValueError(f"mass must be > 0 [kg], got {mass.min()}")
            raw("inv_mass")[new] = 1.0 / mass
        _record_birth_values(store, new)
        return new

    def _take(self, store, rng, count: int) -> dict[str, np.ndarray]:
        """``count`` newborn records from the reservoir, refilled from ``rng`` as needed.

        Drawing a few particles at a time costs dozens of tiny NumPy calls per step, so
        records are drawn in batches of at least :data:`RESERVOIR`; the sequence of records
        is still a deterministic function of the seed.
        """
        pool, head = self._pool, self._head
        available = 0 if pool is None else len(pool["lifetime"]) - head
        if available < count:
            fresh = self._draw(store, rng, max(count - available, RESERVOIR))
            if available:
                fresh = {k: np.concatenate([pool[k][head:], v]) for k, v in fresh.items()}
            pool, head = fresh, 0
        self._pool, self._head = pool, head + count
        return {k: v[head : head + count] for k, v in pool.items()}

    def _draw(self, store, rng, count: int) -> dict[str, np.ndarray]:
        """Sample ``count`` records: shape offset, velocity, lifetime and initial attributes."""
        local, normals = self.shape.sample(rng, count)
        directions = self.direction.sample(rng, local, normals)
        speed = self.speed.sample(rng, count, 1)
        lifetime = self.lifetime.sample(rng, count, 1)[:, 0]
        if np.any(~(lifetime > 0)):
            raise ValueError(f"lifetime must be > 0 [s], sampled {lifetime.min()}")
        rows = {"offset": local, "velocity": directions * speed, "lifetime": lifetime}
        for name, dist in self.initial.items():
            array = store.raw(name)
            values = dist.sample(rng, count, array.shape[0] if array.ndim == 2 else 1)
            rows[name] = values if array.ndim == 2 else values[:, 0]
        return rows


def _record_birth_values(store, new: slice) -> None:
    """Copy initial colour / size / speed into the birth_* attributes over-life curves use."""
    raw = store.raw
    if store.has("birth_color") and store.has("color"):
        raw("birth_color")[:, new] = raw("color")[:, new]
    if store.has("birth_size") and store.has("size"):
        raw("birth_size")[new] = raw("size")[new]
    if store.has("birth_speed"):
        v = raw("velocity")[:, new]
        raw("birth_speed")[new] = np.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2)
