"""Parameters of a flock: Reynolds' three rules and the limits of a boid's motion.

Reynolds (1987) steers each boid by three rules over its neighbours, each neighbour
being another boid within the rule's radius and inside its field of view:

- **separation**: move away from crowding neighbours;
- **alignment**: match the neighbours' mean velocity;
- **cohesion**: move toward the neighbours' centre.

Each rule has its own radius [m], weight [1/s] and field of view [degrees]. Weights are
inverse response times: a rule whose desired velocity is ``u`` adds the steering
acceleration ``weight · (u - v)`` [m/s²] (Reynolds 1999, "steering = desired velocity
minus velocity"), so a weight of 2/s closes half the gap in about 0.35 s.

References
----------
Reynolds, C. W. (1987). Flocks, herds and schools: a distributed behavioral model.
SIGGRAPH '87, 25-34.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .. import _validate as check


@dataclass(frozen=True)
class Rule:
    """One of Reynolds' rules: who counts as a neighbour, and how strongly it steers.

    Parameters
    ----------
    radius : float
        Neighbours are the boids within this distance [m], > 0.
    weight : float
        Strength [1/s], >= 0 (0 turns the rule off).
    fov : float
        Field of view [degrees], in (0, 360]: a boid sees a neighbour whose direction is
        within ``fov / 2`` of its heading (360: all around).
    """

    radius: float = 1.0
    weight: float = 1.0
    fov: float = 270.0

    def __post_init__(self):
        object.__setattr__(self, "radius", check.positive("radius", self.radius))
        object.__setattr__(self, "weight", check.non_negative("weight", self.weight))
        fov = check.real("fov", self.fov, low=0.0, high=360.0, low_open=True)
        object.__setattr__(self, "fov", fov)

    @property
    def cos_half_fov(self) -> float:
        """``cos(fov / 2)``: a neighbour at offset ``d`` is seen when ``d · h >= this · |d|``."""
        return -1.0 if self.fov >= 360.0 else math.cos(math.radians(self.fov) / 2)


@dataclass(frozen=True)
class Limits:
    """Limits of a boid's motion (Reynolds 1999: a vehicle's maximum force and speed).

    Parameters
    ----------
    min_speed, max_speed : float
        Speed range [m/s], 0 <= min_speed <= max_speed, max_speed > 0 (birds cannot hover:
        give them a minimum speed).
    max_acceleration : float
        Largest steering acceleration [m/s²], > 0: the sum of every rule and behaviour is
        clipped to it.
    max_turn_rate : float
        Largest rate at which the heading turns [degrees/s], > 0.
    """

    min_speed: float = 0.0
    max_speed: float = 10.0
    max_acceleration: float = 20.0
    max_turn_rate: float = 360.0

    def __post_init__(self):
        low = check.non_negative("min_speed", self.min_speed)
        high = check.positive("max_speed", self.max_speed)
        if low > high:
            raise ValueError(f"min_speed must be <= max_speed ({high}), got {low}")
        object.__setattr__(self, "min_speed", low)
        object.__setattr__(self, "max_speed", high)
        object.__setattr__(
            self, "max_acceleration", check.positive("max_acceleration", self.max_acceleration)
        )
        object.__setattr__(
            self, "max_turn_rate", check.positive("max_turn_rate", self.max_turn_rate)
        )
