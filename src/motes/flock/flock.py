"""The :class:`Flock`: boids as a particle kind (orchestration; kernels in ``kernels``)."""

from __future__ import annotations

import numpy as np

from .. import _memory
from .. import _validate as check
from .._jit import threads_for
from ..geometry.layout import ROW
from ..spatial.grid import UniformGrid
from ..spatial.kernels import compact_rows, permute_rows
from ..spatial.neighbors import Neighbors
from ..state import Field, ParticleState
from . import kernels
from .behaviors import TARGETS, AvoidColliders, Interaction, Wander, pack_targets
from .rules import Limits, Rule

#: Bytes per boid of a flock's arrays: nine float32 (3, n) arrays (position, velocity,
#: heading, their next-step copies, the grid's sorted copy, the acceleration from other
#: flocks, the wander directions, a spare for reordering), ids and the grid's keys and
#: order (int64), bank, flap and neighbour count, and room for temporaries.
BYTES_PER_BOID = 4 * 3 * 9 + 8 * 3 + 4 * 3 + 32

#: Default rules (radius [m], weight [1/s], field of view [degrees]) and limits.
SEPARATION = Rule(0.5, 4.0, 300.0)
ALIGNMENT = Rule(1.5, 2.0, 270.0)
COHESION = Rule(2.0, 1.0, 270.0)
LIMITS = Limits()


class Flock:
    """A flock of boids (Reynolds 1987) steered by rules and behaviours (Reynolds 1999).

    Parameters
    ----------
    positions : (3, n) array_like
        Start positions [m].
    velocities : (3, n) array_like, optional
        Start velocities [m/s]; zero (with heading +x) when omitted. A boid's heading
        starts along its velocity.
    separation, alignment, cohesion : Rule
        Reynolds' three rules (radius [m], weight [1/s], field of view [degrees]).
    limits : Limits
        Speed, acceleration and turning-rate limits.
    radius : float
        A boid's size [m]: the sprite radius, half the drawn wingspan and the distance
        kept from colliders.
    flap_frequency : float
        Wing beats per second at full speed [Hz] (a drawing attribute: the phase
        advances in proportion to speed).
    bank_time : float
        Time [s] over which the bank angle follows a turn.
    seed : int
        Seed of the wander's random kicks.
    attributes : mapping of str to Field, optional
        User attributes, ``(components, n)`` or ``(n,)`` each; they travel with their
        boids (the flock reorders its arrays every step) and show in
        :meth:`particle_state`.

    Notes
    -----
    Each :meth:`step` sorts the boids into a :class:`~motes.spatial.UniformGrid` with
    cells as large as the largest rule radius and reorders every array to the grid's
    order (ids travel along), then runs the passes against other flocks, then one fused
    kernel: the three rules over the 27 cells around each boid, the target behaviours,
    obstacle avoidance, the limits, the move (semi-implicit Euler) and the collider
    keep-out.

    Examples
    --------
    >>> import numpy as np
    >>> from motes.flock import Flock, Rule
    >>> rng = np.random.default_rng(0)
    >>> flock = Flock(rng.uniform(-5, 5, (3, 500)), rng.normal(0, 1, (3, 500)),
    ...               alignment=Rule(2.0, 2.0, 360.0))
    >>> for _ in range(10):
    ...     flock.step(1 / 30)
    >>> flock.particle_state().count
    500
    """

    def __init__(
        self,
        positions,
        velocities=None,
        *,
        separation: Rule = SEPARATION,
        alignment: Rule = ALIGNMENT,
        cohesion: Rule = COHESION,
        limits: Limits = LIMITS,
        radius: float = 0.1,
        flap_frequency: float = 6.0,
        bank_time: float = 0.2,
        seed: int = 0,
        attributes=None,
    ):
        for name, rule in (
            ("separation", separation),
            ("alignment", alignment),
            ("cohesion", cohesion),
        ):
            if not isinstance(rule, Rule):
                raise TypeError(f"{name} must be a Rule, got {type(rule).__name__}")
        if not isinstance(limits, Limits):
            raise TypeError(f"limits must be Limits, got {type(limits).__name__}")
        pos = _rows("positions", positions)
        n = pos.shape[1]
        _memory.check(f"{n:,} boids", n * BYTES_PER_BOID, per=f"{BYTES_PER_BOID} B per boid")
        vel = np.zeros_like(pos) if velocities is None else _rows("velocities", velocities)
        if vel.shape != pos.shape:
            raise ValueError(f"velocities must have shape {pos.shape}, got {vel.shape}")
        self.separation, self.alignment, self.cohesion = separation, alignment, cohesion
        self.limits = limits
        self.radius = check.positive("radius", radius)
        self.flap_frequency = check.non_negative("flap_frequency", flap_frequency)
        self.bank_time = check.positive("bank_time", bank_time)
        self.seed = check.integer("seed", seed, low=0)
        self.position = pos
        self.velocity = vel
        speed = np.linalg.norm(vel, axis=0)
        self.heading = np.where(speed > 0, vel / np.where(speed > 0, speed, 1), [[1], [0], [0]])
        self.heading = self.heading.astype(np.float32)
        self.ids = np.arange(n, dtype=np.int64)
        rng = np.random.default_rng(self.seed)
        #: Wing-beat phase [rad], shape (n,).
        self.flap = rng.uniform(0, 2 * np.pi, n).astype(np.float32)
        #: Bank angle [rad], positive rolling the right wing down (into a right turn;
        #: the right is heading × y), shape (n,).
        self.bank = np.zeros(n, np.float32)
        #: Neighbours each boid saw in the last step, shape (n,) int32.
        self.neighbor_count = np.zeros(n, np.int32)
        self.wander = self.heading.copy()
        self.attributes: dict[str, Field] = {}
        for name, f in (attributes or {}).items():
            f = f if isinstance(f, Field) else Field(np.asarray(f))
            data = np.array(f.data)
            if data.ndim not in (1, 2) or data.shape[-1] != n:
                raise ValueError(f"attributes[{name!r}] must have shape (n,) or (c, n), n = {n}")
            self.attributes[name] = Field(data, f.unit, f.doc)
        self.targets: list = []
        self.interactions: list[Interaction] = []
        self.avoidance: AvoidColliders | None = None
        self.time = 0.0
        self.steps = 0
        self._grid = UniformGrid(self._cell_size())
        self._next = [np.empty_like(pos) for _ in range(3)]
        self._extra = np.zeros_like(pos)
        self._spare: dict = {}

    @property
    def n(self) -> int:
        """Number of boids."""
        return self.position.shape[1]

    def __len__(self) -> int:
        return self.n

    def _cell_size(self) -> float:
        return max(self.separation.radius, self.alignment.radius, self.cohesion.radius)

    def add(self, *behaviors) -> Flock:
        """Add steering behaviours (:mod:`motes.flock.behaviors`); returns self."""
        for b in behaviors:
            if isinstance(b, TARGETS):
                if isinstance(b, Wander) and not any(isinstance(t, Wander) for t in self.targets):
                    self.wander = self.heading.copy()  # kept in step only while wandering
                self.targets.append(b)
            elif isinstance(b, Interaction):
                if b.other is self:
                    raise ValueError("a flock cannot pursue, evade or avoid itself")
                self.interactions.append(b)
            elif isinstance(b, AvoidColliders):
                if self.avoidance is not None:
                    raise ValueError("a flock takes one AvoidColliders; list every collider in it")
                self.avoidance = b
            else:
                raise TypeError(f"not a steering behaviour: {type(b).__name__}")
        return self

    # -- stepping ---------------------------------------------------------------------
    def _sort(self) -> None:
        """Reorder every per-boid array into the grid's order over the positions now."""
        grid = self._grid
        grid.cell_size = self._cell_size()
        grid.build(self.position)
        order = grid.order
        # The grid keeps the pre-sort array as its buffer for the next build: the sorted
        # positions, the step's output and the grid's buffer rotate through three arrays.
        self.position, grid.sorted_positions = grid.sorted_positions, self.position
        rows = ["velocity", "heading"]
        if any(isinstance(b, Wander) for b in self.targets):
            rows.append("wander")
        for name in rows:
            src = getattr(self, name)
            dst = self._spare.get(src.shape)
            if dst is None or dst is src:
                dst = np.empty_like(src)
            permute_rows(src, order, dst)
            setattr(self, name, dst)
            self._spare[src.shape] = src
        self.ids = np.take(self.ids, order)
        packed = np.empty((2, self.n), np.float32)
        permute_rows(np.stack([self.flap, self.bank]), order, packed)
        self.flap, self.bank = packed[0], packed[1]
        for name, f in self.attributes.items():
            self.attributes[name] = Field(np.take(f.data, order, axis=-1), f.unit, f.doc)

    def _params(self, dt: float) -> np.ndarray:
        p = np.zeros(kernels.PARAMS)
        s, a, c, lim = self.separation, self.alignment, self.cohesion, self.limits
        p[kernels.SEP_R2], p[kernels.ALI_R2], p[kernels.COH_R2] = (
            s.radius**2, a.radius**2, c.radius**2,
        )  # fmt: skip
        p[kernels.SEP_COS], p[kernels.ALI_COS], p[kernels.COH_COS] = (
            s.cos_half_fov, a.cos_half_fov, c.cos_half_fov,
        )  # fmt: skip
        p[kernels.SEP_W], p[kernels.ALI_W], p[kernels.COH_W] = s.weight, a.weight, c.weight
        # A rule of weight 0 neither steers nor widens the neighbour search.
        p[kernels.MAX_R2] = max(r.radius**2 if r.weight > 0 else 0.0 for r in (s, a, c))
        p[kernels.MIN_SPEED], p[kernels.MAX_SPEED] = lim.min_speed, lim.max_speed
        p[kernels.MAX_ACCEL] = lim.max_acceleration
        p[kernels.MAX_TURN] = np.radians(lim.max_turn_rate)
        p[kernels.DT], p[kernels.RADIUS] = dt, self.radius
        if self.avoidance is not None:
            p[kernels.AVOID_LOOKAHEAD] = self.avoidance.lookahead
            p[kernels.AVOID_MARGIN] = self.avoidance.margin
            p[kernels.AVOID_W] = self.avoidance.weight
        p[kernels.GRAVITY] = 9.81
        p[kernels.BANK_TIME] = self.bank_time
        p[kernels.FLAP_FREQUENCY] = self.flap_frequency
        p[kernels.SEED] = self.seed % (1 << 52)
        p[kernels.STEP] = self.steps
        return p

    def step(self, dt: float) -> None:
        """Advance every boid by ``dt`` seconds (> 0)."""
        dt = check.positive("dt", dt)
        n = self.n
        if n == 0:
            self.time += dt
            self.steps += 1
            return
        with threads_for(n):
            self._sort()
            extra = self._extra
            if extra.shape != self.position.shape:
                extra = self._extra = np.zeros_like(self.position)
            extra[:] = 0.0
            for b in self.interactions:
                self._interact(b, extra)
            table, path = pack_targets(self.targets)
            avoid = self.avoidance
            if avoid is None:
                colliders = np.zeros((0, ROW), np.float32)
                mesh = (np.zeros((0, 9)), np.zeros(1, np.int64), np.zeros(0, np.int64))
            else:
                colliders, mesh = avoid.table.astype(np.float32), avoid.mesh
            g = self._grid
            pos_out, vel_out, head_out = self._next
            if pos_out.shape != self.position.shape:
                pos_out, vel_out, head_out = self._next = [
                    np.empty_like(self.position) for _ in range(3)
                ]
            kernels.step(
                self.position, self.velocity, self.heading, self.ids, g.cell_start, g.origin,
                1.0 / g.cell, g.dims, self._params(dt), extra, table, path, colliders, *mesh,
                self.wander, self.bank, self.flap, pos_out, vel_out, head_out,
                self.neighbor_count,
            )  # fmt: skip
        self._next = [self.position, self.velocity, self.heading]
        self.position, self.velocity, self.heading = pos_out, vel_out, head_out
        self.time += dt
        self.steps += 1

    def _interact(self, b: Interaction, extra: np.ndarray) -> None:
        other = b.other
        if other.n == 0:
            return
        grid = UniformGrid(b.radius).build(other.position)
        other_vel = np.take(other.velocity, grid.order, axis=1)
        kernels.interact(
            self.position, self.velocity, grid.sorted_positions, other_vel, grid.cell_start,
            grid.origin, 1.0 / grid.cell, grid.dims, int(b.mode), b.radius**2, b.weight,
            b.extra, self.limits.max_speed, extra,
        )  # fmt: skip

    # -- reading ----------------------------------------------------------------------
    def neighbors(self, rule: Rule) -> Neighbors:
        """Each boid's neighbours under ``rule`` (radius and field of view) now, by the
        search the step uses, in CSR form over the current boid order
        (:class:`~motes.spatial.grid.Neighbors`)."""
        grid = UniformGrid(rule.radius).build(self.position)
        pos = grid.sorted_positions
        head = np.take(self.heading, grid.order, axis=1)
        n = self.n
        capacity = 32
        while True:
            out = np.empty((n, capacity + 1), np.int32)
            count = np.empty(n, np.int64)
            kernels.neighbor_lists(
                pos, head, grid.cell_start, grid.origin, 1.0 / grid.cell, grid.dims,
                rule.radius**2, rule.cos_half_fov, out, count,
            )  # fmt: skip
            if n == 0 or count.max() <= capacity:
                break
            capacity = int(count.max())
        # Slots back to boid indices, rows back to boid order.
        row_of = np.empty(n, np.int64)
        row_of[grid.order] = np.arange(n)
        offsets = np.zeros(n + 1, np.int64)
        np.cumsum(count[row_of], out=offsets[1:])
        indices = np.empty(int(offsets[-1]), np.int32)
        compact_rows(out, count, row_of, grid.order.astype(np.int32), offsets, indices)
        return Neighbors(offsets, indices)

    def polarization(self) -> float:
        """Order parameter ``|mean of unit headings|`` in [0, 1]: 1 when all fly alike."""
        return (
            float(np.linalg.norm(self.heading.astype(np.float64).mean(axis=1))) if self.n else 0.0
        )

    def particle_state(self) -> ParticleState:
        """The boids now: views of the flock's arrays (ids stable; the order changes
        every step), with fields ``heading`` (3, n), ``bank`` [rad], ``flap`` [rad],
        ``neighbors`` and the user attributes."""
        n = self.n
        fields = {
            "heading": Field(self.heading, "1", "unit heading"),
            "bank": Field(self.bank, "rad", "bank angle, positive rolls the right wing down"),
            "flap": Field(self.flap, "rad", "wing-beat phase"),
            "neighbors": Field(self.neighbor_count, "", "boids seen in the last step"),
            **self.attributes,
        }
        return ParticleState(
            self.ids, self.position, self.velocity, np.full(n, self.radius, np.float32), fields
        )

    @classmethod
    def in_box(
        cls, count: int, low, high, *, speed: float = 1.0, direction=None, seed: int = 0, **options
    ) -> Flock:
        """``count`` boids uniform in the box ``[low, high]`` [m], flying at ``speed``
        [m/s] in random directions (or along ``direction``), seeded by ``seed``."""
        count = check.integer("count", count, low=0)
        low, high = check.vector("low", low), check.vector("high", high)
        if np.any(high < low):
            raise ValueError(f"high must be >= low on every axis, got {low} and {high}")
        speed = check.non_negative("speed", speed)
        rng = np.random.default_rng(seed)
        pos = rng.uniform(low[:, None], high[:, None], (3, count))
        if direction is None:
            d = rng.normal(size=(3, count))
            d /= np.maximum(np.linalg.norm(d, axis=0), 1e-12)
        else:
            d = np.repeat(check.unit_vector("direction", direction)[:, None], count, axis=1)
        return cls(pos, d * speed, seed=seed, **options)


def _rows(name: str, value) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float32)
    if arr.ndim != 2 or arr.shape[0] != 3:
        raise ValueError(f"{name} must have shape (3, n), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite (no NaN or inf)")
    return np.ascontiguousarray(arr)
