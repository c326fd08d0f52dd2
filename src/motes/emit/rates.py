"""How many particles an emitter creates each step (Reeves 1983, section 2.1).

A *frame* here is one call to ``ParticleSystem.step``. Counts are integers; a real-valued
expected count ``x`` becomes ``floor(x)`` or ``floor(x) + 1`` with probability
``frac(x)`` (stochastic rounding), which keeps the mean exact.
"""

from __future__ import annotations

import math

import numpy as np

from .. import _validate as check


def stochastic_round(rng: np.random.Generator, x: float) -> int:
    """``floor(x) + Bernoulli(frac(x))``: an integer with expectation ``x`` (x >= 0)."""
    base = math.floor(x)
    return int(base + (rng.random() < x - base))


class Rate:
    """Base class: ``count(rng, frame, time, dt, emitter) -> int`` for one step."""

    def count(self, rng, frame: int, time: float, dt: float, emitter=None) -> int:
        raise TypeError(f"{type(self).__name__} is abstract")

    def reset(self) -> None:
        """Forget accumulated state (fractions carried across steps)."""


class PerFrame(Rate):
    """Reeves' stochastic count: ``N_f = mean_f + U(-1, 1) · variance_f``.

    The mean and variance may ramp linearly with the frame number (Reeves' ``DeltaMeanParts``):
    ``mean_f = mean + delta_mean · (f - start_frame)`` for ``f >= start_frame``, and likewise
    for the variance. A ramped mean is clamped at 0, so counts never go negative.

    Parameters
    ----------
    mean, variance : float
        Particles per frame, ``0 <= variance <= mean`` (a larger variance could ask for a
        negative count). Following Reeves (``MeanParts``, ``VarParts``), ``variance`` is
        the half-width of the uniform spread, not a statistical variance: the count's
        variance is ``variance² / 3`` (plus 1/6 on average from rounding).
    delta_mean, delta_variance : float
        Change of mean and variance per frame.
    start_frame : int
        Frame from which the ramp runs (and before which nothing is emitted).
    """

    def __init__(
        self,
        mean: float,
        variance: float = 0.0,
        *,
        delta_mean: float = 0.0,
        delta_variance: float = 0.0,
        start_frame: int = 0,
    ):
        self.mean = check.non_negative("mean", mean)
        self.variance = check.non_negative("variance", variance)
        if self.variance > self.mean:
            raise ValueError(
                f"variance must be <= mean so counts stay >= 0, got variance={self.variance} "
                f"> mean={self.mean}"
            )
        self.delta_mean = check.real("delta_mean", delta_mean)
        self.delta_variance = check.real("delta_variance", delta_variance)
        self.start_frame = check.integer("start_frame", start_frame, low=0)

    def expected(self, frame: int) -> tuple[float, float]:
        """(mean, variance) at ``frame``, after ramps and clamping."""
        steps = frame - self.start_frame
        mean = max(0.0, self.mean + self.delta_mean * steps)
        variance = min(mean, max(0.0, self.variance + self.delta_variance * steps))
        return mean, variance

    def count(self, rng, frame, time, dt, emitter=None):
        if frame < self.start_frame:
            return 0
        mean, variance = self.expected(frame)
        # One draw of two numbers: U(-1, 1) for the count, U(0, 1) for its rounding.
        u, r = rng.random(2)
        x = mean + (2.0 * u - 1.0) * variance
        base = math.floor(x)
        return int(base + (r < x - base))


class PerSecond(Rate):
    """A steady rate [particles/s]; the fractional part carries over to the next step.

    Over any run of steps, the total emitted is ``floor(rate · elapsed time)`` or one less,
    whatever the step size (deterministic: no randomness). ``stop`` [s]: no births from
    that time on (a tap turned off); None runs for ever.
    """

    def __init__(self, rate: float, *, stop: float | None = None):
        self.rate = check.non_negative("rate", rate)
        self.stop = None if stop is None else check.non_negative("stop", stop)
        self._carry = 0.0

    def count(self, rng, frame, time, dt, emitter=None):
        if self.stop is not None:
            dt = min(dt, max(self.stop - time, 0.0))  # only the part before the stop
        total = self._carry + self.rate * dt
        whole = math.floor(total + 1e-9)
        self._carry = total - whole
        return int(whole)

    def reset(self):
        self._carry = 0.0


class Burst(Rate):
    """``count`` particles at time ``at`` [s], then again every ``every`` seconds if given.

    A burst fires on the first step whose interval ``[time, time + dt)`` contains it.
    ``repeat`` limits the number of bursts (``None``: unlimited when ``every`` is set).
    """

    def __init__(
        self, count: int, *, at: float = 0.0, every: float | None = None, repeat: int | None = None
    ):
        self.size = check.integer("count", count, low=0)
        self.at = check.non_negative("at", at)
        self.every = None if every is None else check.positive("every", every)
        self.repeat = None if repeat is None else check.integer("repeat", repeat, low=1)

    def _fired_before(self, t: float) -> int:
        """Number of bursts with firing time < t."""
        if t <= self.at:
            return 0
        fired = 1 if self.every is None else math.floor((t - self.at) / self.every - 1e-12) + 1
        return fired if self.repeat is None else min(fired, self.repeat)

    def count(self, rng, frame, time, dt, emitter=None):
        bursts = self._fired_before(time + dt) - self._fired_before(time)
        return bursts * self.size


class ScreenScaled(Rate):
    """Level of detail: scale another rate by the fraction of the screen the system covers.

    Reeves: ``N = (mean + rand·variance) · ScreenArea``. The covered area is that of the
    emitter's bounding sphere (its shape's bounding radius plus ``margin`` [m]) projected
    by ``camera``. Counts are rounded stochastically, so the mean is scaled exactly.
    """

    def __init__(self, rate: Rate, camera, *, margin: float = 0.0):
        if not isinstance(rate, Rate):
            raise TypeError(f"rate must be a Rate, got {rate!r}")
        if not hasattr(camera, "screen_fraction"):
            raise TypeError("camera must provide screen_fraction(center, radius)")
        self.rate = rate
        self.camera = camera
        self.margin = check.non_negative("margin", margin)

    def count(self, rng, frame, time, dt, emitter=None):
        base = self.rate.count(rng, frame, time, dt, emitter)
        if emitter is None:
            return base
        radius = emitter.shape.bounding_radius + self.margin
        fraction = self.camera.screen_fraction(emitter.position_at(time), radius)
        return stochastic_round(rng, base * fraction)

    def reset(self):
        self.rate.reset()
