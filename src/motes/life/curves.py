"""Over-life curves: colour, size and speed as functions of normalised age ``age / lifetime``."""

from __future__ import annotations

import numpy as np
from numba import prange

from .. import _validate as check
from .._jit import BLOCK, block_bounds, block_count, parallel_kernel
from ..color import parse_color


class Curve:
    """Piecewise-linear curve over normalised age t in [0, 1].

    Parameters
    ----------
    keys : sequence of (t, value)
        t increasing in [0, 1]; values are numbers, vectors or colours. Outside the first
        and last key the end values hold.
    """

    def __init__(self, keys, *, components: int):
        keys = list(keys)
        if not keys:
            raise ValueError("keys must hold at least one (t, value) pair")
        self.times = np.array([check.unit_interval("key time", t) for t, _ in keys])
        if np.any(np.diff(self.times) < 0):
            raise ValueError(f"key times must increase, got {self.times.tolist()}")
        rows = []
        for _, value in keys:
            v = (
                parse_color(value)
                if components == 4
                else np.atleast_1d(np.asarray(value, dtype=np.float64))
            )
            if v.shape != (components,) or not np.all(np.isfinite(v)):
                raise ValueError(f"key value {value!r} must be {components} finite numbers")
            rows.append(v)
        self.values = np.array(rows)  # (k, components)

    def __call__(self, t) -> np.ndarray:
        """Values at normalised ages ``t`` (n,) -> (n, components)."""
        t = np.asarray(t, dtype=np.float64)
        return np.stack(
            [np.interp(t, self.times, self.values[:, c]) for c in range(self.values.shape[1])],
            axis=-1,
        )


@parallel_kernel
def _apply_curve(n, age, lifetime, times, values, slopes, base, multiply, out):
    """``out[c, i] = curve(age_i / lifetime_i)[c]``, times ``base[c, i]`` if ``multiply``.

    ``values[c, k]`` is component c at key k and ``slopes[c, k]`` the slope of segment k
    (0 for the last key), so evaluating the piecewise-linear curve is a branch-free key
    count and one multiply-add. Each block runs in passes whose innermost loop is over
    particles (normalised ages, key counts, then one component at a time), so LLVM
    vectorises each; the segment index is unsigned because Numba's wraparound check on a
    signed index blocks that (one loop over everything per particle ran 2x slower).
    """
    keys = times.shape[0]
    first = times[0]
    final = times[keys - 1]
    for block in prange(block_count(n)):
        start, stop = block_bounds(block, n)
        count = stop - start
        segment = np.zeros(BLOCK, dtype=np.uint32)
        along = np.empty(BLOCK, dtype=times.dtype)
        for j in range(count):
            along[j] = min(max(age[start + j] / lifetime[start + j], first), final)
        for key in range(1, keys):
            at = times[key]
            for j in range(count):
                segment[j] += np.uint32(along[j] >= at)
        for j in range(count):
            along[j] -= times[segment[j]]
        for c in range(out.shape[0]):
            value = values[c]
            slope = slopes[c]
            if multiply:
                for j in range(count):
                    k = segment[j]
                    out[c, start + j] = (value[k] + along[j] * slope[k]) * base[c, start + j]
            else:
                for j in range(count):
                    k = segment[j]
                    out[c, start + j] = value[k] + along[j] * slope[k]


def segment_slopes(times: np.ndarray, values: np.ndarray) -> np.ndarray:
    """Slope of each segment of a piecewise-linear curve, (k, c); 0 after the last key."""
    slopes = np.zeros_like(values)
    span = np.diff(times)[:, None]
    rise = np.diff(values, axis=0)
    np.divide(rise, span, out=slopes[:-1], where=span > 0)
    return slopes


class _OverLife:
    attribute = ""
    components = 1

    def __init__(self, keys, *, multiply: bool):
        self.curve = Curve(keys, components=self.components)
        self.multiply = multiply

    @property
    def reads(self) -> tuple[str, ...]:
        base = (f"birth_{self.attribute}",) if self.multiply else ()
        return ("age", "lifetime", self.attribute, *base)

    def bind(self, store) -> None:
        store.require(*self.reads)
        # Keys in the store's precision, cast once: per step the cast would cost more
        # than the kernel in a small system.
        self._times = self.curve.times.astype(store.dtype)
        # Component-major (c, k): the kernel reads one component's keys at a time.
        self._values = np.ascontiguousarray(self.curve.values.T, dtype=store.dtype)
        slopes = segment_slopes(self.curve.times, self.curve.values)
        self._slopes = np.ascontiguousarray(slopes.T, dtype=store.dtype)

    def apply(self, store) -> None:
        n = store.count
        if n == 0:
            return
        out = store.raw(self.attribute)
        out2d = out if out.ndim == 2 else out.reshape(1, -1)
        base = store.raw(f"birth_{self.attribute}") if self.multiply else out2d
        base2d = base if base.ndim == 2 else base.reshape(1, -1)
        self._evaluate(store, n, base2d, self.multiply, out2d)

    def _evaluate(self, store, n, base, multiply, out) -> None:
        """``out`` (c, ≥ n) = curve(normalised age), times ``base`` if ``multiply``."""
        _apply_curve(
            n,
            store.raw("age"),
            store.raw("lifetime"),
            self._times,
            self._values,
            self._slopes,
            base,
            multiply,
            out,
        )


class ColorOverLife(_OverLife):
    """Colour (RGBA) over normalised age.

    Parameters
    ----------
    keys : sequence of (t, colour)
        e.g. ``[(0, "#fff3b0"), (0.4, "#ff7a1a"), (1, "#30303000")]``.
    multiply : bool
        Multiply each particle's birth colour by the curve instead of replacing it
        (default False: the curve is the colour, so an emitter's ``color`` only matters
        with ``multiply=True``). :class:`SizeOverLife` multiplies by default, since sizes
        are usually given per particle and scaled over life.
    """

    attribute = "color"
    components = 4

    def __init__(self, keys, *, multiply: bool = False):
        super().__init__(keys, multiply=multiply)


class SizeOverLife(_OverLife):
    """Size as birth size × curve(normalised age) (or the curve itself with ``multiply=False``)."""

    attribute = "size"

    def __init__(self, keys, *, multiply: bool = True):
        super().__init__(keys, multiply=multiply)
        if np.any(self.curve.values < 0):
            raise ValueError(f"keys must hold sizes >= 0, got {self.curve.values.min()}")


@parallel_kernel
def _set_speed(n, vel, speed):
    for block in prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            s = np.sqrt(vel[0, i] ** 2 + vel[1, i] ** 2 + vel[2, i] ** 2)
            f = speed[i] / s if s > 0 else s * 0
            vel[0, i] *= f
            vel[1, i] *= f
            vel[2, i] *= f


class SpeedOverLife(_OverLife):
    """Speed as birth speed × curve(normalised age); the direction of motion is kept."""

    attribute = "speed"

    def __init__(self, keys):
        super().__init__(keys, multiply=True)

    @property
    def reads(self):
        return ("age", "lifetime", "velocity", "birth_speed")

    def apply(self, store) -> None:
        n = store.count
        if n == 0:
            return
        speed = np.empty((1, n), dtype=store.dtype)
        base = store.raw("birth_speed")[:n].reshape(1, -1)
        self._evaluate(store, n, base, True, speed)
        _set_speed(n, store.raw("velocity"), speed[0])
