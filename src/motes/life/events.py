"""Particle events: birth, death, collision and step, delivered as arrays."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

KINDS = ("birth", "death", "collision", "step")


@dataclass
class ParticleEvent:
    """A batch of particles that had the same kind of event in one step.

    Attributes
    ----------
    kind : str
        ``"birth"``, ``"death"``, ``"collision"`` or ``"step"``.
    time : float
        Simulation time at the end of the step [s].
    ids : int64 (k,)
        Particle ids.
    position, velocity : (k, 3)
        State at the event [m], [m/s] (copies, safe to keep).
    attributes : dict of name -> (k, ...) arrays
        Other attributes of those particles (colour, size, ...), copied.
    collider : int (k,) or None
        For collisions: index of the collider hit (in the system's collider list).
    """

    kind: str
    time: float
    ids: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    attributes: dict = field(default_factory=dict)
    collider: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.ids)


def gather(kind: str, time: float, store, index: np.ndarray, collider=None) -> ParticleEvent:
    """Copy the state of the particles at ``index`` into an event."""
    extra = {
        name: np.array(store[name][index])
        for name in store.names
        if name not in ("position", "velocity", "id")
    }
    return ParticleEvent(
        kind,
        time,
        np.array(store["id"][index]),
        np.array(store["position"][index]),
        np.array(store["velocity"][index]),
        extra,
        collider,
    )
