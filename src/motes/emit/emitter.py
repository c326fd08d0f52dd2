"""Emitters: where particles are born and with which initial attributes (Reeves 1983)."""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

from .. import _validate as check
from .directions import Cone, Direction
from .distributions import Constant, Distribution, as_distribution
from .rates import PerSecond, Rate
from .shapes import Point, Shape


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


def _lower_bound(dist: Distribution) -> float | None:
    if isinstance(dist, Constant):
        return float(dist.value.min())
    low = getattr(dist, "low", None)
    return None if low is None else float(np.min(low))


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
        self.lifetime = as_distribution("lifetime", lifetime)
        low = _lower_bound(self.lifetime)
        if low is not None and low <= 0:
            raise ValueError(f"lifetime must be > 0 [s], got a minimum of {low}")
        self.speed = as_distribution("speed", speed)
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
        if "mass" in self.initial:
            low = _lower_bound(self.initial["mass"])
            if low is not None and low <= 0:
                raise ValueError(f"mass must be > 0 [kg], got a minimum of {low}")
        for name, dist in (attributes or {}).items():
            self.initial[name] = as_distribution(name, dist)

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
        origin = self.position_at(time)
        base = np.broadcast_to(self.velocity_at(time, dt), (count, 3))
        return self.emit_at(system, np.broadcast_to(origin, (count, 3)), base)

    def emit_at(
        self,
        system,
        origins: np.ndarray,
        base_velocity: np.ndarray,
        inherited: Mapping[str, np.ndarray] | None = None,
    ) -> slice:
        """Create one particle per row of ``origins`` (k, 3), offset by a shape sample.

        ``base_velocity`` (k, 3) [m/s] is added times ``inherit_velocity``; ``inherited``
        maps attribute names to (k, c) values that replace the emitter's own (a parent's
        colour, say).
        """
        store, rng = system.store, system.rng
        count = origins.shape[0]
        new = store.spawn(count)
        made = new.stop - new.start
        if made == 0:
            return new
        origins = origins[:made]
        local, normals = self.shape.sample(rng, made)
        directions = self.direction.sample(rng, local, normals)
        speed = self.speed.sample(rng, made, 1)
        velocity = directions * speed + self.inherit_velocity * base_velocity[:made]
        lifetime = self.lifetime.sample(rng, made, 1)[:, 0]
        if np.any(~(lifetime > 0)):
            raise ValueError(f"lifetime must be > 0 [s], sampled {lifetime.min()}")
        store["position"][new] = origins + local
        store["velocity"][new] = velocity
        store["lifetime"][new] = lifetime
        for name, dist in self.initial.items():
            spec_components = store.raw(name).shape[0] if store.raw(name).ndim == 2 else 1
            values = dist.sample(rng, made, spec_components)
            if inherited is not None and name in inherited:
                values = np.asarray(inherited[name])[:made]
            store[name][new] = values if spec_components > 1 else values[:, 0]
        if inherited is not None:
            for name, values in inherited.items():
                if name not in self.initial and store.has(name):
                    store[name][new] = np.asarray(values)[:made]
        if "mass" in self.initial:
            mass = store["mass"][new]
            if np.any(~(mass > 0)):
                raise ValueError(f"mass must be > 0 [kg], sampled {mass.min()}")
            store["inv_mass"][new] = 1.0 / mass
        _record_birth_values(store, new)
        return new


def _record_birth_values(store, new: slice) -> None:
    """Copy initial colour / size / speed into the birth_* attributes over-life curves use."""
    if store.has("birth_color") and store.has("color"):
        store["birth_color"][new] = store["color"][new]
    if store.has("birth_size") and store.has("size"):
        store["birth_size"][new] = store["size"][new]
    if store.has("birth_speed"):
        store["birth_speed"][new] = np.linalg.norm(store["velocity"][new], axis=1)
