"""Particles of one emitter system colliding with each other: grains, marbles, debris.

:class:`ParticleCollisions` is added to a system like a collider. After the system moves
its particles (forces, integration, colliders), it finds the pairs closer than their two
radii (``size``) through a spatial structure (:mod:`motes.spatial`) and relaxes them
together with the system's bouncing colliders, now taken as spheres too (the fused step
treats particles as points: right for sparks and smoke, wrong for a grain resting on
the ground, whose centre must stay one radius above it). Each of ``iterations`` passes
pushes overlapping pairs apart with Coulomb friction
(:mod:`motes.collide.sphere_kernels`) and projects particles out of the colliders with
depth friction (:func:`motes.collide.contact.project_contacts`); then the pairs get their
restitution. Momentum is conserved pair by pair.
"""

from __future__ import annotations

import numpy as np

from .. import _validate as check
from ..forces.fields import Gravity
from ..spatial.index import STRUCTURES, spatial_index
from .between import KindContact
from .colliders import Response
from .contact import pack, project_contacts
from .sphere_kernels import project_pairs, restitute_pairs


class ParticleCollisions(KindContact):
    """Particles of a system as spheres of their radius (``size``) that collide.

    Parameters
    ----------
    restitution : float
        Coefficient of restitution in [0, 1] of every particle pair: 0 inelastic, 1
        elastic (contacts approaching slower than ``2 g h`` stay inelastic).
    friction : float
        Coulomb coefficient >= 0 between particles (by penetration depth): about 0.5
        for sand, what lets a heap keep its slope.
    iterations : int
        Gauss–Seidel passes over the contacts per step (>= 1): a deep heap needs more
        to carry its weight down to the ground without sinking.
    structure : {"grid", "octree", "kdtree"}
        Where the pairs are found (:func:`motes.spatial.spatial_index`).
    gravity : (3,) array_like or None
        Gravity [m/s²]: its magnitude sets the inelastic threshold ``2 g h``, its
        direction what is "down" for ``stacking``. None (default): the sum of the
        system's :class:`~motes.Gravity` forces, read every step.
    stacking : float
        Mass scaling for piles (>= 0; Macklin et al. 2014, §5.2): within the position pass
        a particle one diameter below another counts ``exp(stacking)`` times heavier, so
        a heap carries its weight to the ground instead of sinking into itself. Velocities
        and restitution use the true masses. 0 (or no gravity) keeps true masses
        throughout, which conserves momentum exactly; with gravity the ground takes
        momentum anyway.

    Examples
    --------
    >>> import numpy as np
    >>> import motes
    >>> from motes.emit.nbody import add_particles
    >>> system = motes.ParticleSystem(2, dtype=np.float64)
    >>> _ = system.add(motes.ParticleCollisions(restitution=1.0, friction=0.0))
    >>> x = np.array([[0.0, 0.15], [0.0, 0.0], [0.0, 0.0]])
    >>> v = np.array([[1.0, -1.0], [0.0, 0.0], [0.0, 0.0]])
    >>> _ = add_particles(system, x, v, size=[0.05, 0.05], lifetime=[10.0, 10.0])
    >>> system.step(0.05)
    >>> system["velocity"][:, 0].round(6).tolist()  # an elastic head-on swap
    [-1.0, 1.0]
    """

    reads = ("size",)

    def __init__(
        self,
        *,
        restitution: float = 0.3,
        friction: float = 0.5,
        iterations: int = 4,
        structure: str = "grid",
        gravity=None,
        stacking: float = 3.0,
    ):
        self.restitution = check.unit_interval("restitution", restitution)
        self.friction = check.non_negative("friction", friction)
        self.iterations = check.integer("iterations", iterations, low=1)
        if self.iterations > 1000:
            raise ValueError(f"iterations must be in [1, 1000], got {iterations}")
        self.structure = check.choice("structure", structure, STRUCTURES)
        self.gravity = None if gravity is None else check.vector("gravity", gravity)
        self.stacking = check.real("stacking", stacking, low=0.0, high=20.0)
        #: Contacts (overlapping pairs, counted once per pass) of the latest step.
        self.last_contacts = 0
        self._system = None
        self._packed = None

    def bind(self, system) -> None:
        """Called by :meth:`ParticleSystem.add`: the system whose colliders join the
        relaxation."""
        self._system = system

    def _gravity(self) -> np.ndarray:
        if self.gravity is not None:
            return self.gravity
        fields = [] if self._system is None else self._system.field_forces
        return sum((f.acceleration for f in fields if isinstance(f, Gravity)), np.zeros(3))

    def _colliders(self):
        """The system's bouncing colliders, packed (re-packed when the list changes)."""
        chosen = [] if self._system is None else self._system.colliders
        chosen = [c for c in chosen if c.response == Response.BOUNCE]
        key = tuple(id(c) for c in chosen)
        if self._packed is None or self._packed[0] != key:
            self._packed = (key, pack(chosen))
        return self._packed[1]

    def __repr__(self) -> str:
        return (
            f"ParticleCollisions(restitution={self.restitution}, friction={self.friction}, "
            f"iterations={self.iterations}, structure={self.structure!r})"
        )

    def candidate_pairs(self, position: np.ndarray, reach: float) -> np.ndarray:
        """Sorted pairs (p, 2) of particles closer than ``reach`` [m] (a margin added)."""
        reach = reach * (1.0 + 1e-5)  # the grid compares float32 coordinates
        if self.structure == "grid":
            index = spatial_index("grid", cell_size=reach)
        else:
            index = spatial_index(self.structure)
        return index.build(position).pairs(reach)

    def resolve(self, store, n: int, dt: float, hits, hit_index: int) -> int:
        self.last_contacts = 0
        if n == 0:
            return 0
        position = store.raw("position")[:, :n]
        velocity = store.raw("velocity")[:, :n]
        radius = np.ascontiguousarray(store.raw("size")[:n], dtype=np.float64)
        if not radius.max() > 0.0:
            return 0
        pairs = self.candidate_pairs(position, 2.0 * float(radius.max()))
        # In float64 and position-based form: q is where each particle started the step.
        x = position.astype(np.float64)
        q = x - dt * velocity.astype(np.float64)
        start, before = q.copy(), x.copy()
        if store.has("inv_mass"):
            inv_mass = store.raw("inv_mass")[:n].astype(np.float64)
        else:
            inv_mass = np.ones(n)
        touched = np.zeros(n, np.int64)
        gravity = self._gravity()
        g = float(np.linalg.norm(gravity))
        up = -gravity / g if g > 0.0 else np.zeros(3)
        stacking = self.stacking if g > 0.0 else 0.0
        table, tri, cell_start, cell_tris = self._colliders()
        grounded = np.zeros(n, np.int64)
        for _ in range(self.iterations):
            project_pairs(*x, *q, inv_mass, radius, pairs, self.friction, up, stacking, touched)
            if len(table):
                project_contacts(
                    *x, *q, radius, inv_mass, table, tri, cell_start, cell_tris, grounded
                )
        self.last_contacts = int(touched.sum()) // 2
        touched += grounded
        rest = 2.0 * g * dt * dt
        restitution = np.full(len(pairs), self.restitution)
        restitute_pairs(*x, *q, *before, inv_mass, radius, pairs, restitution, rest)
        changed = (touched > 0) | np.any(q != start, axis=0)
        if changed.any():
            index = np.flatnonzero(changed)
            position[:, index] = x[:, index]
            velocity[:, index] = (x[:, index] - q[:, index]) / dt
            if hits is not None:
                hits[index] = hit_index
        return 0
