"""Over-life curves: colour, size and speed as functions of normalised age ``age / lifetime``."""

from __future__ import annotations

import numpy as np
from numba import prange

from .. import _validate as check
from .._jit import block_bounds, block_count, device, parallel_kernel
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


@device
def _lerp_index(t, times):
    # Last key with time <= t (keys are few; a linear scan beats a bisection here).
    k = 0
    for j in range(times.shape[0]):
        if times[j] <= t:
            k = j
    return k


@parallel_kernel
def _apply_curve(n, age, lifetime, times, values, base, multiply, out):
    """``out[c, i] = curve(age/lifetime)[c] (· base[c, i] if multiply)`` for vector attributes."""
    last = times.shape[0] - 1
    for block in prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for i in range(start, stop):
            t = age[i] / lifetime[i] if lifetime[i] > 0 else age[i] * 0
            k = _lerp_index(t, times)
            if k == last or t <= times[0]:
                k2 = k
                f = t * 0
            else:
                k2 = k + 1
                span = times[k2] - times[k]
                f = (t - times[k]) / span if span > 0 else t * 0
                f = min(f, f * 0 + 1)
            for c in range(out.shape[0]):
                v = values[k, c] + f * (values[k2, c] - values[k, c])
                out[c, i] = v * base[c, i] if multiply else v


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

    def apply(self, store) -> None:
        n = store.count
        if n == 0:
            return
        dtype = store.dtype
        out = store.raw(self.attribute)
        out2d = out if out.ndim == 2 else out.reshape(1, -1)
        base = store.raw(f"birth_{self.attribute}") if self.multiply else out2d
        base2d = base if base.ndim == 2 else base.reshape(1, -1)
        _apply_curve(
            n,
            store.raw("age"),
            store.raw("lifetime"),
            self.curve.times.astype(dtype),
            self.curve.values.astype(dtype),
            base2d,
            self.multiply,
            out2d,
        )


class ColorOverLife(_OverLife):
    """Colour (RGBA) over normalised age.

    Parameters
    ----------
    keys : sequence of (t, colour)
        e.g. ``[(0, "#fff3b0"), (0.4, "#ff7a1a"), (1, "#30303000")]``.
    multiply : bool
        Multiply each particle's birth colour by the curve instead of replacing it.
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
        _apply_curve(
            n,
            store.raw("age"),
            store.raw("lifetime"),
            self.curve.times.astype(store.dtype),
            self.curve.values.astype(store.dtype),
            base,
            True,
            speed,
        )
        _set_speed(n, store.raw("velocity"), speed[0])
