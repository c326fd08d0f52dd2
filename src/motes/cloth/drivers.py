"""What drives a cloth from outside: keyframed handle paths and gusty wind."""

from __future__ import annotations

import numpy as np

from .. import _validate as check


class Keyframes:
    """A piecewise-linear translation through keyframes, held before the first and after
    the last.

    Parameters
    ----------
    times : (k,) array_like
        Keyframe times [s], strictly increasing, k >= 1.
    offsets : (k, 3) array_like
        Translation [m] at each keyframe.
    """

    def __init__(self, times, offsets):
        t = np.atleast_1d(np.asarray(times, dtype=np.float64))
        if t.ndim != 1 or t.size == 0 or not np.all(np.isfinite(t)):
            raise ValueError("times must be a non-empty 1-D array of finite numbers [s]")
        if np.any(np.diff(t) <= 0):
            raise ValueError("times must be strictly increasing")
        o = check.points("offsets", offsets)
        if len(o) != len(t):
            raise ValueError(f"offsets must have one row per time ({len(t)}), got {len(o)}")
        self.times = t
        self.offsets = o

    def __call__(self, time: float) -> np.ndarray:
        """Translation (3,) [m] at ``time`` [s]."""
        return np.array([np.interp(time, self.times, self.offsets[:, k]) for k in range(3)])

    def __repr__(self) -> str:
        return f"Keyframes({len(self.times)} keyframes, {self.times[0]:g}-{self.times[-1]:g} s)"


class Airflow:
    """Air moving at ``velocity`` with travelling gusts, for the aerodynamic forces.

    The wind at a point ``c`` and time ``t`` is ``velocity · g(t - c·û/|u|)`` with
    ``g(s) = 1 + gust · mean_i sin(2π f_i s + φ_i)``: gusts travel downwind at the wind
    speed. Frequencies are drawn log-uniformly in [0.2, 2] Hz and phases uniformly from
    ``seed``.

    Parameters
    ----------
    velocity : (3,) array_like
        Mean wind [m/s].
    gust : float
        Relative gust amplitude, in [0, 1].
    gusts : int
        Number of sine components (>= 0).
    air_density : float
        ρ > 0 [kg/m³] (1.2 for air at sea level).
    drag, lift : float
        Drag and lift coefficients ``C_d``, ``C_l`` >= 0 (a flat plate: about 1 and 0.5..1).
    seed : int
    """

    def __init__(
        self,
        velocity=(0.0, 0.0, 0.0),
        *,
        gust: float = 0.0,
        gusts: int = 3,
        air_density: float = 1.2,
        drag: float = 1.0,
        lift: float = 0.6,
        seed: int = 0,
    ):
        self.velocity = check.vector("velocity", velocity)
        self.gust = check.unit_interval("gust", gust)
        count = check.integer("gusts", gusts, low=0)
        self.air_density = check.positive("air_density", air_density)
        self.drag = check.non_negative("drag", drag)
        self.lift = check.non_negative("lift", lift)
        rng = np.random.default_rng(check.integer("seed", seed, low=0))
        self.frequencies = np.exp(rng.uniform(np.log(0.2), np.log(2.0), count))
        self.phases = rng.uniform(0.0, 2 * np.pi, count)

    def packed(self) -> np.ndarray:
        """``(ρ, C_d, C_l, gust)`` as the kernel reads them."""
        return np.array([self.air_density, self.drag, self.lift, self.gust])

    def __repr__(self) -> str:
        return f"Airflow({self.velocity.tolist()}, gust={self.gust})"
