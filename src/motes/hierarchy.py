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

    def _counts(self, k: int) -> np.ndarray:
        if isinstance(self.count, int):
            return np.full(k, self.count, dtype=np.int64)
        rng = self.child.rng
        values = as_distribution("count", self.count).sample(rng, k, 1)[:, 0]
        if np.any(~(values >= 0)):
            raise ValueError(f"count distribution must be >= 0, sampled {values.min()}")
        # Stochastic rounding, vectorised: floor(x) + Bernoulli(frac(x)).
        base = np.floor(values)
        return (base + (rng.random(k) < values - base)).astype(np.int64)

    def _spawn(self, event: ParticleEvent) -> None:
        counts = self._counts(len(event))
        total = int(counts.sum())
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
