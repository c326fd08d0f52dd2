"""Steering behaviours (Reynolds 1999) a :class:`~motes.flock.Flock` adds to its rules.

Each behaviour turns into a desired velocity ``u`` and adds ``weight · (u - v)`` [m/s²]
to a boid's steering, or, for the pushes (flee, containment, avoidance), an
acceleration ``weight · max_speed · strength`` along the push direction; ``weight`` is
always [1/s]. Three families:

- **targets** packed as rows of one table that the step kernel reads per boid:
  :class:`Seek`, :class:`Flee`, :class:`Arrive`, :class:`Wander`, :class:`Contain`,
  :class:`FollowPath`;
- **other flocks** (:class:`Pursue`, :class:`Evade`, :class:`Avoid`,
  :class:`FollowLeader`), each a pass of its own over a grid of the other flock;
- **colliders** (:class:`AvoidColliders`): the scene's planes, spheres, boxes and
  capsules, by the one signed distance (:mod:`motes.geometry.distance`).

A behaviour's fields may be changed between steps (a moving target): the table is packed
at every step.

References
----------
Reynolds, C. W. (1999). Steering behaviors for autonomous characters. Game Developers
Conference, 763-782.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import IntEnum

import numpy as np

from .. import _validate as check
from ..collide.colliders import Collider
from ..collide.contact import pack

#: Floats in a target row: kind, weight, then eight parameters.
WIDTH = 10


class Code(IntEnum):
    """Kind code of a target row (column 0)."""

    SEEK = 0
    FLEE = 1
    ARRIVE = 2
    WANDER = 3
    CONTAIN = 4
    PATH = 5


class Mode(IntEnum):
    """What one flock does about another (the interaction pass)."""

    AVOID = 0  # strangers: keep apart, as separation does within a flock
    EVADE = 1  # prey: flee the predicted positions of predators
    PURSUE = 2  # predator: chase the predicted position of the nearest prey
    FOLLOW = 3  # follower: arrive at a point behind the nearest leader


def _row(code: Code, weight: float, *params) -> np.ndarray:
    row = np.zeros(WIDTH)
    row[0], row[1] = code, weight
    row[2 : 2 + len(params)] = params
    return row


@dataclass
class Seek:
    """Steer toward ``target`` [m] at full speed; ``weight`` [1/s]."""

    target: tuple = (0.0, 0.0, 0.0)
    weight: float = 1.0

    def __post_init__(self):
        self.target = check.vector("target", self.target)
        self.weight = check.non_negative("weight", self.weight)

    def row(self, path_base: int) -> np.ndarray:
        return _row(Code.SEEK, self.weight, *self.target)


@dataclass
class Flee:
    """Steer away from ``target`` [m] when within ``radius`` [m], harder the closer."""

    target: tuple = (0.0, 0.0, 0.0)
    radius: float = 5.0
    weight: float = 1.0

    def __post_init__(self):
        self.target = check.vector("target", self.target)
        self.radius = check.positive("radius", self.radius)
        self.weight = check.non_negative("weight", self.weight)

    def row(self, path_base: int) -> np.ndarray:
        return _row(Code.FLEE, self.weight, *self.target, self.radius)


@dataclass
class Arrive:
    """Seek ``target`` [m], slowing linearly to rest inside ``slowing_radius`` [m]."""

    target: tuple = (0.0, 0.0, 0.0)
    slowing_radius: float = 5.0
    weight: float = 1.0

    def __post_init__(self):
        self.target = check.vector("target", self.target)
        self.slowing_radius = check.positive("slowing_radius", self.slowing_radius)
        self.weight = check.non_negative("weight", self.weight)

    def row(self, path_base: int) -> np.ndarray:
        return _row(Code.ARRIVE, self.weight, *self.target, self.slowing_radius)


@dataclass
class Wander:
    """Seek a point that drifts on a sphere ahead of the boid (Reynolds 1999).

    The point lies on a sphere of ``radius`` [m] whose centre is ``distance`` [m] ahead;
    each step its direction takes a random kick of ``jitter · sqrt(dt)`` [1/sqrt(s)]
    (a random walk on the sphere, so the wandering does not depend on the step size).
    The kicks come from a counter-based hash of the flock's seed, the boid's id and the
    step number: the same on any thread count.
    """

    radius: float = 1.0
    distance: float = 2.0
    jitter: float = 2.0
    weight: float = 1.0

    def __post_init__(self):
        self.radius = check.positive("radius", self.radius)
        self.distance = check.non_negative("distance", self.distance)
        self.jitter = check.non_negative("jitter", self.jitter)
        self.weight = check.non_negative("weight", self.weight)

    def row(self, path_base: int) -> np.ndarray:
        return _row(Code.WANDER, self.weight, self.radius, self.distance, self.jitter)


@dataclass
class Contain:
    """Stay in the axis-aligned box ``[low, high]`` [m]: within ``margin`` [m] of a face
    (or beyond it) a boid is pushed back in, in proportion to ``depth / margin``."""

    low: tuple = (-10.0, -10.0, -10.0)
    high: tuple = (10.0, 10.0, 10.0)
    margin: float = 2.0
    weight: float = 2.0

    def __post_init__(self):
        self.low = check.vector("low", self.low)
        self.high = check.vector("high", self.high)
        if np.any(self.high <= self.low):
            raise ValueError(f"high must exceed low on every axis, got {self.low} and {self.high}")
        self.margin = check.positive("margin", self.margin)
        self.weight = check.non_negative("weight", self.weight)

    def row(self, path_base: int) -> np.ndarray:
        return _row(Code.CONTAIN, self.weight, *self.low, *self.high, self.margin)


@dataclass
class FollowPath:
    """Follow a polyline (Reynolds 1999, path following).

    A boid predicts where it will be ``lookahead`` [s] from now; when that point is more
    than ``radius`` [m] from the path it seeks the nearest point of the path moved
    ``lead`` [m] further along it, otherwise it only steers along the path's direction.

    Parameters
    ----------
    points : (m, 3) array_like
        The path's vertices [m], m >= 2, followed from first to last.
    """

    points: np.ndarray = field(default_factory=lambda: np.zeros((2, 3)))
    radius: float = 1.0
    lookahead: float = 0.5
    lead: float = 2.0
    weight: float = 1.0

    def __post_init__(self):
        self.points = check.points("points", self.points, min_rows=2)
        self.radius = check.positive("radius", self.radius)
        self.lookahead = check.non_negative("lookahead", self.lookahead)
        self.lead = check.non_negative("lead", self.lead)
        self.weight = check.non_negative("weight", self.weight)

    def row(self, path_base: int) -> np.ndarray:
        return _row(
            Code.PATH, self.weight, path_base, len(self.points), self.radius, self.lookahead,
            self.lead,
        )  # fmt: skip


TARGETS = (Seek, Flee, Arrive, Wander, Contain, FollowPath)


def pack_targets(behaviors) -> tuple[np.ndarray, np.ndarray]:
    """The target rows (k, WIDTH) float64 and the concatenated path points (3, m) float32."""
    rows, paths, base = [], [], 0
    for b in behaviors:
        rows.append(b.row(base))
        if isinstance(b, FollowPath):
            paths.append(b.points)
            base += len(b.points)
    table = np.array(rows, dtype=np.float64).reshape(len(rows), WIDTH)
    points = np.concatenate(paths) if paths else np.zeros((0, 3))
    return table, np.ascontiguousarray(points.T, dtype=np.float32)


@dataclass
class Interaction:
    """What a flock does about ``other`` (another :class:`~motes.flock.Flock`).

    Parameters
    ----------
    other : Flock
        The other flock; its state at the moment this flock steps is used.
    radius : float
        Its boids count within this distance [m], > 0.
    weight : float
        Strength [1/s], >= 0.
    """

    other: object
    radius: float = 5.0
    weight: float = 2.0
    mode = Mode.AVOID

    def __post_init__(self):
        if not (hasattr(self.other, "position") and hasattr(self.other, "limits")):
            raise TypeError(f"other must be a Flock, got {type(self.other).__name__}")
        self.radius = check.positive("radius", self.radius)
        self.weight = check.non_negative("weight", self.weight)

    @property
    def extra(self) -> float:
        return 0.0


class Avoid(Interaction):
    """Strangers: keep away from ``other``'s boids within ``radius`` as separation does."""

    mode = Mode.AVOID


class Evade(Interaction):
    """Prey: flee the predicted positions of ``other``'s boids (the predators) within
    ``radius``, harder the closer (Reynolds 1999, evasion)."""

    mode = Mode.EVADE


class Pursue(Interaction):
    """Predator: chase the predicted position of the nearest of ``other``'s boids (the
    prey) within ``radius`` (Reynolds 1999, pursuit); the prediction looks ahead by the
    time the chaser needs to close the distance at its full speed."""

    mode = Mode.PURSUE


@dataclass
class FollowLeader(Interaction):
    """Arrive at a point ``behind`` [m] behind the nearest of ``other``'s boids (the
    leaders) within ``radius`` (Reynolds 1999, leader following), slowing over the last
    ``behind`` metres (at least 0.5 m)."""

    behind: float = 2.0
    mode = Mode.FOLLOW

    def __post_init__(self):
        super().__post_init__()
        self.behind = check.non_negative("behind", self.behind)

    @property
    def extra(self) -> float:
        return self.behind


@dataclass
class AvoidColliders:
    """Steer around colliders and never enter them (Reynolds 1999, obstacle avoidance).

    Each step a boid probes its path ``lookahead`` [s] ahead: where the probe comes
    within ``margin`` [m] of a collider, the boid steers sideways (the probe's normal
    less its part along the heading), and where the boid itself is within ``margin`` it
    is pushed straight out, both in proportion to ``(margin - distance) / margin``. After
    the move, a boid that would be closer than its radius to a collider is put back on
    that surface and loses the velocity into it: no boid ever enters.

    Parameters
    ----------
    colliders : sequence of Collider
        :class:`motes.colliders.Plane`, ``Sphere``, ``Box`` (``inside=True`` for a
        container), ``Capsule`` or ``TriangleMeshCollider`` (a thin shell: each move is
        swept against it, so no boid crosses it between two steps).
    """

    colliders: list = field(default_factory=list)
    lookahead: float = 1.0
    margin: float = 2.0
    weight: float = 4.0

    def __post_init__(self):
        for i, c in enumerate(self.colliders):
            if not isinstance(c, Collider):
                raise ValueError(
                    f"colliders[{i}] must be a plane, sphere, box, capsule or triangle-mesh "
                    f"collider, got {type(c).__name__}"
                )
        #: Packed rows and the meshes' triangles and grid lists (collide.contact.pack).
        self.table, *self.mesh = pack(self.colliders)
        self.lookahead = check.non_negative("lookahead", self.lookahead)
        self.margin = check.positive("margin", self.margin)
        self.weight = check.non_negative("weight", self.weight)
