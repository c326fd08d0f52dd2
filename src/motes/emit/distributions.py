"""Distributions of initial attribute values, sampled over whole arrays.

Each distribution has ``sample(rng, count, components) -> (count, components)`` float64.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .. import _validate as check
from ..color import parse_color


class Distribution:
    """Base class: a law of per-particle initial values."""

    components: int | None = None

    def sample(self, rng: np.random.Generator, count: int, components: int) -> np.ndarray:
        raise TypeError(f"{type(self).__name__} is abstract")

    def check_fits(self, name: str, components: int) -> None:
        """Raise ``ValueError`` (naming ``name``) if the values cannot fill an attribute
        of ``components`` values: at construction, not at the first emission."""

    @property
    def lowest(self) -> float | None:
        """The least value any component can take (``-inf`` if unbounded below), or None
        when it cannot be known before sampling."""
        return None

    @property
    def mean(self) -> np.ndarray:
        """Expected value (used for bounds and documentation)."""
        raise TypeError(f"{type(self).__name__} has no closed-form mean")


def _as_values(name, value) -> np.ndarray:
    arr = np.atleast_1d(
        np.asarray(parse_color(value) if isinstance(value, str) else value, dtype=np.float64)
    )
    if arr.ndim != 1 or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be a finite number or vector, got {value!r}")
    return arr


def _fit(name, values: np.ndarray, components: int) -> np.ndarray:
    if values.size == components:
        return values
    if values.size == 1:
        return np.repeat(values, components)
    if components == 4 and values.size == 3:  # RGB given for RGBA: opaque
        return np.append(values, 1.0)
    raise ValueError(f"{name} has {values.size} components, the attribute needs {components}")


class Constant(Distribution):
    """Every particle gets ``value`` (a number, a vector, or a colour like ``"#ff8800"``)."""

    def __init__(self, value):
        self.value = _as_values("value", value)

    def sample(self, rng, count, components):
        return np.broadcast_to(_fit("value", self.value, components), (count, components)).copy()

    def check_fits(self, name, components):
        _fit(name, self.value, components)

    @property
    def lowest(self):
        return float(self.value.min())

    @property
    def mean(self):
        return self.value


class Uniform(Distribution):
    """Uniform in ``[low, high)`` (per component for vectors)."""

    def __init__(self, low, high):
        self.low = _as_values("low", low)
        self.high = _as_values("high", high)
        if self.low.shape != self.high.shape or np.any(self.high < self.low):
            raise ValueError(f"Uniform needs high >= low, got low={low!r}, high={high!r}")

    def sample(self, rng, count, components):
        low = _fit("low", self.low, components)
        high = _fit("high", self.high, components)
        return low + (high - low) * rng.random((count, components))

    def check_fits(self, name, components):
        _fit(name, self.low, components)

    @property
    def lowest(self):
        return float(self.low.min())

    @property
    def mean(self):
        return (self.low + self.high) / 2


class Normal(Distribution):
    """Normal law (``mean``, standard deviation ``std``), clipped to ``[low, high]`` if given."""

    def __init__(self, mean, std, *, low=None, high=None):
        self._mean = _as_values("mean", mean)
        self.std = _as_values("std", std)
        if np.any(self.std < 0):
            raise ValueError(f"std must be >= 0, got {std!r}")
        self.low = None if low is None else _as_values("low", low)
        self.high = None if high is None else _as_values("high", high)

    def sample(self, rng, count, components):
        mean = _fit("mean", self._mean, components)
        values = mean + _fit("std", self.std, components) * rng.standard_normal((count, components))
        if self.low is not None or self.high is not None:
            low = None if self.low is None else _fit("low", self.low, components)
            high = None if self.high is None else _fit("high", self.high, components)
            values = np.clip(values, low, high)
        return values

    def check_fits(self, name, components):
        for values in (self._mean, self.std, self.low, self.high):
            if values is not None:
                _fit(name, values, components)

    @property
    def lowest(self):
        if self.low is not None:
            return float(self.low.min())
        return float(self._mean.min()) if np.all(self.std == 0) else -np.inf

    @property
    def mean(self):
        return self._mean


class Gradient(Distribution):
    """A random point along a colour (or value) gradient.

    Parameters
    ----------
    stops : sequence of (position, value)
        Positions in [0, 1], increasing; values are colours (``"#rrggbb[aa]"``, RGB or
        RGBA tuples) or vectors. Each particle draws ``u ~ U(0, 1)`` and takes the linear
        interpolation at ``u``.
    """

    def __init__(self, stops):
        stops = list(stops)
        if len(stops) < 2:
            raise ValueError(f"stops needs at least 2 (position, value) pairs, got {len(stops)}")
        self.positions = np.array([check.unit_interval("stop position", p) for p, _ in stops])
        if np.any(np.diff(self.positions) < 0):
            raise ValueError("stop positions must increase")
        values = [_as_values("stop value", v) for _, v in stops]
        width = max(v.size for v in values)
        self.values = np.array([_fit("stop value", v, width) for v in values])

    def sample(self, rng, count, components):
        u = rng.random(count)
        values = np.stack(
            [np.interp(u, self.positions, self.values[:, k]) for k in range(self.values.shape[1])],
            axis=1,
        )
        if values.shape[1] == components:
            return values
        if values.shape[1] == 3 and components == 4:
            return np.concatenate([values, np.ones((count, 1))], axis=1)
        raise ValueError(
            f"gradient values have {values.shape[1]} components, the attribute needs {components}"
        )

    def check_fits(self, name, components):
        width = self.values.shape[1]
        if width != components and not (width == 3 and components == 4):
            raise ValueError(f"{name} has {width} components, the attribute needs {components}")

    @property
    def lowest(self):
        return float(self.values.min())

    @property
    def mean(self):
        return self.values.mean(axis=0)


class Function(Distribution):
    """User function ``f(rng, count) -> array (count,) or (count, components)``."""

    def __init__(self, function: Callable):
        if not callable(function):
            raise TypeError(f"function must be callable, got {function!r}")
        self.function = function

    def sample(self, rng, count, components):
        values = np.asarray(self.function(rng, count), dtype=np.float64).reshape(count, -1)
        if values.shape[1] != components or not np.all(np.isfinite(values)):
            raise ValueError(
                f"Function distribution must return {count} finite values of {components} "
                f"components, got shape {values.shape}"
            )
        return values


def as_distribution(name: str, value) -> Distribution:
    """Accept a Distribution, or a plain number / vector / colour as a Constant."""
    if isinstance(value, Distribution):
        return value
    try:
        return Constant(value)
    except (TypeError, ValueError) as err:
        raise TypeError(f"{name} must be a Distribution or a constant value: {err}") from None
