"""Contacts between kinds: the interface an emitter system calls after it moves.

A :class:`KindContact` is something an emitter system collides with that is itself
simulated by another kind: a cloth, a rigid world. Unlike a :class:`~.colliders.Collider`
it is not folded into the fused step kernel; the system calls :meth:`KindContact.resolve`
right after the move, before extinction and events, and the contact changes the
particles *and* the other kind (momentum passes both ways). Implementations live in
:mod:`motes.couple`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np


class KindContact(ABC):
    """Particles of an emitter system against the current state of another kind."""

    #: Store attributes the contact reads besides position and velocity.
    reads: tuple[str, ...] = ()

    @abstractmethod
    def resolve(self, store, n: int, dt: float, hits: np.ndarray | None, hit_index: int) -> int:
        """Find and answer the contacts of the ``n`` live particles after a step of ``dt``.

        Parameters
        ----------
        store : ParticleStore
            The system's particles, already moved; positions and velocities are updated
            in place, ``store.keep[i] = False`` marks a particle to kill.
        n : int
            Live particles.
        dt : float
            The step [s] (the path of particle ``i`` over it is ``x_i - v_i dt`` to
            ``x_i``).
        hits : (capacity,) int32 or None
            Where to write ``hit_index`` for particles that touched (collision events),
            or None when nobody listens.
        hit_index : int
            The index collision events report for this contact.

        Returns
        -------
        int
            Particles marked to kill.
        """
