"""Particle hierarchies (Reeves 1983, section 3): particles that are particle systems.

A :class:`SpawnOnEvent` link makes events of a parent system's particles (death,
collision, every step) create particles in a child system at the parent particles'
positions, with a fraction of their velocity and, optionally, their colour. The child is
stepped by the parent, right after the parent's own step, and draws its randomness from
its own generator, so parent and child streams never interfere.
"""

from __future__ import annotations

import numpy as np

from . import _validate as check
from .emit.distributions import Distribution, as_distribution
from .emit.emitter import Emitter
from .life.events import KINDS, ParticleEvent


class SpawnOnEvent:
    """Spawn child particles for each parent particle that has an event.

    Parameters
    ----------
    child : ParticleSystem
        The system the new particles belong to (give it ``seed=parent.child_seed()``).
    emitter : Emitter
        Template for the children's attributes: its shape is centred on each parent
        particle, its direction and speed add to ``inherit_velocity`` × the parent's
        velocity. Its rate is not used.
    on : str
        ``"death"``, ``"collision"``, ``"birth"`` or ``"step"``.
    count : int or Distribution
        Children per parent event (a distribution is sampled per parent and rounded
        stochastically).
    inherit : tuple of str
        Parent attributes copied to the children (e.g. ``("color",)``).
    """

    def __init__(
        self, child, emitter: Emitter, *, on: str = "death", count=1, inherit: tuple[str, ...] = ()
    ):
        self.child = child
        if not isinstance(emitter, Emitter):
            raise TypeError(f"emitter must be an Emitter, got {emitter!r}")
        self.emitter = emitter
        self.on = check.choice("on", on, KINDS)
        if isinstance(count, Distribution):
            count.check_fits("count", 1)
            if count.lowest is not None and not count.lowest >= 0:
                raise ValueError(
                    f"count must be >= 0, got a law whose least value is {count.lowest}"
                )
            self.count: Distribution | int = count
        else:
            self.count = check.integer("count", count, low=0)
        self.inherit = tuple(inherit)

    def attach(self, parent) -> None:
        """Subscribe to ``parent``'s events and make the child a stepped child of it."""
        if self.child is parent:
            raise ValueError("a system cannot be its own child")
        parent.on(self.on, self._spawn)
        for name in self.inherit:
            parent.store.require(name)
        self.child.store.require(*self.emitter.writes, *self.inherit)
        if self.child not in parent.children:
            parent.children.append(self.child)

    def _counts(self, k: int) -> tuple[np.ndarray, int]:
        """Children of each of ``k`` events, cut to the child's free capacity, and how
        many were asked for in all (exact: the excess is counted as dropped)."""
        free = self.child.store.capacity - self.child.store.count
        if isinstance(self.count, int):
            counts = np.full(k, min(self.count, free), dtype=np.int64)
            wanted = self.count * k
        else:
            rng = self.child.rng
            values = as_distribution("count", self.count).sample(rng, k, 1)[:, 0]
            if np.any(~(values >= 0)):
                raise ValueError(f"count distribution must be >= 0, sampled {values.min()}")
            # Stochastic rounding, vectorised: floor(x) + Bernoulli(frac(x)); at most
            # 2^62 each, so that the integers (and their exact sum) cannot overflow.
            base = np.floor(np.minimum(values, 2.0**62))
            counts = (base + (rng.random(k) < values - base)).astype(np.int64)
            wanted = int(counts.sum(dtype=object))
            counts = np.minimum(counts, free)
        # Children past the capacity would be dropped by the store: never allocate them.
        placed = np.minimum(np.cumsum(counts), free)
        return np.diff(placed, prepend=0), wanted

    def _spawn(self, event: ParticleEvent) -> None:
        counts, wanted = self._counts(len(event))
        total = int(counts.sum())
        self.child.store.dropped += wanted - total
        if total == 0:
            return
        origins = np.repeat(event.position, counts, axis=0)
        base = np.repeat(event.velocity, counts, axis=0) if self.emitter.inherit_velocity else None
        inherited = {
            name: np.repeat(event.attributes[name], counts, axis=0) for name in self.inherit
        }
        new = self.emitter.emit_at(self.child, origins, base, inherited)
        if new.stop > new.start:
            self.child._born(new, self.child.last_dt)
