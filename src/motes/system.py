"""ParticleSystem: one particle store and its ordered pipeline per step.

No physics lives here, only orchestration. One step (Reeves' frame) runs:

1. **emit**: every emitter creates its particles and their initial attributes;
2. **forces**: non-field forces accumulate into the force buffer;
3. **move**: one fused kernel evaluates gravity, drag and wind inline, integrates,
   resolves colliders, ages every particle and flags the ones whose life is over
   (multi-stage integrators advance first, then run the same kernel without moving);
   then contacts with other kinds (a cloth) exchange impulses with them;
4. **extinguish**: other extinction policies flag particles; events (collision, death)
   are delivered; dead particles are removed by one compaction;
5. **over-life**: colour, size and speed curves update the survivors;
6. **children**: child systems (spawned by this system's events) take their step.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from . import _validate as check
from ._jit import threads_for
from ._tracked import fingerprint
from .collide.between import KindContact
from .collide.colliders import Collider
from .collide.contact import pack as pack_colliders
from .emit.emitter import Emitter
from .forces.base import FieldForce, FieldTerms, Force
from .integrate import Integrator
from .integrate.implicit import ImplicitEuler, advance_store
from .integrate.kernels import GAP, Scheme, acceleration_kernel, step_kernel
from .integrate.multistage import rk4, velocity_verlet
from .life.curves import _OverLife
from .life.events import KINDS, gather
from .life.extinction import Extinction
from .particles import ParticleStore
from .state import ParticleState


@dataclass
class _StepSetup:
    """What the fused kernel needs besides particle arrays, valid while ``key`` holds."""

    key: tuple
    kernel: object
    params: np.ndarray
    table: np.ndarray
    #: Triangle meshes' triangles and grid lists (:func:`motes.collide.contact.pack`).
    meshes: tuple[np.ndarray, np.ndarray, np.ndarray]
    quadratic: bool
    track_hits: bool
    #: No field force depends on velocity (no drag): with position-only forces the
    #: leapfrog can carry its end acceleration to the next step.
    velocity_free: bool = False


class ParticleSystem:
    """A particle store, its emitters, forces, colliders and modifiers, stepped in order.

    Parameters
    ----------
    capacity : int
        Maximum live particles (> 0); spawns past it are dropped and counted in
        ``store.dropped``.
    seed : int
        Seed of the system's random generator (all its randomness flows from it).
    integrator : Integrator or str
        Default ``"semi_implicit_euler"``; see :class:`~motes.integrate.Integrator`.
    dtype : numpy.float32 or numpy.float64
        Precision of particle attributes.
    verlet_damping : float
        Fraction of velocity lost per step by the ``verlet`` integrator, in [0, 1).
    attributes : iterable of str or Attribute
        Extra attributes to allocate up front.
    compaction : {"stable", "swap"}
        How dead particles are removed: ``"stable"`` keeps the order of the survivors,
        ``"swap"`` fills holes from the tail (far less data moved; see
        :class:`~motes.ParticleStore`).
    """

    def __init__(
        self,
        capacity: int,
        *,
        seed: int = 0,
        integrator: Integrator | str = Integrator.SEMI_IMPLICIT_EULER,
        dtype=np.float32,
        verlet_damping: float = 0.0,
        attributes=(),
        compaction: str = "stable",
    ):
        self.store = ParticleStore(capacity, attributes, dtype=dtype, compaction=compaction)
        self.seed_sequence = np.random.SeedSequence(check.integer("seed", seed, low=0))
        self.rng = np.random.default_rng(self.seed_sequence)
        try:
            self.integrator = Integrator(integrator)
        except ValueError:
            allowed = ", ".join(repr(i.value) for i in Integrator)
            raise ValueError(f"integrator must be one of {allowed}, got {integrator!r}") from None
        self.verlet_damping = check.real(
            "verlet_damping", verlet_damping, low=0.0, high=1.0, high_open=True
        )
        self.time = 0.0
        self.frame = 0
        #: Step size of the latest step [s] (0 before the first).
        self.last_dt = 0.0
        self.emitters: list[Emitter] = []
        self.field_forces: list[FieldForce] = []
        self.forces: list[Force] = []
        self.colliders: list[Collider] = []
        #: Other kinds the particles collide with (cloths…), after the move; collision
        #: events report them as collider ``len(colliders) + j``.
        self.contacts: list[KindContact] = []
        self.modifiers: list[_OverLife] = []
        self.extinctions: list[Extinction] = []
        self.children: list[ParticleSystem] = []
        self._listeners: dict[str, list[Callable]] = {kind: [] for kind in KINDS}
        self._force_buffer: np.ndarray | None = None
        self._hits: np.ndarray | None = None
        self._no_hits = np.empty(1, dtype=np.int32)
        self._setup_cache: _StepSetup | None = None
        #: The leapfrog's end acceleration and where it was taken (velocity_verlet).
        self._carried = None
        #: Solver of the ``implicit_euler`` integrator (replace it to change tolerances).
        self.implicit_solver = ImplicitEuler()

    # -- building -------------------------------------------------------------------
    def add(self, *items) -> ParticleSystem:
        """Add emitters, forces, colliders, over-life modifiers, extinction policies or
        child links (:class:`~motes.hierarchy.SpawnOnEvent`). Returns ``self``."""
        for item in items:
            if isinstance(item, Emitter):
                self.store.require(*item.writes)
                self.emitters.append(item)
            elif isinstance(item, FieldForce):
                self.store.require(*item.reads)
                self.field_forces.append(item)
            elif isinstance(item, Force):
                item.bind(self.store)
                self.forces.append(item)
            elif isinstance(item, Collider):
                self.colliders.append(item)
            elif isinstance(item, KindContact):
                self.store.require(*item.reads)
                if hasattr(item, "bind"):
                    item.bind(self)
                self.contacts.append(item)
            elif isinstance(item, _OverLife):
                item.bind(self.store)
                self.modifiers.append(item)
            elif isinstance(item, Extinction):
                item.bind(self.store)
                self.extinctions.append(item)
            elif hasattr(item, "attach"):
                item.attach(self)
            else:
                raise TypeError(f"cannot add {item!r} to a ParticleSystem")
        return self

    def remove(self, *items) -> ParticleSystem:
        """Remove previously added emitters, forces, colliders, modifiers or policies."""
        lists = (
            self.emitters,
            self.field_forces,
            self.forces,
            self.colliders,
            self.contacts,
            self.modifiers,
            self.extinctions,
        )
        for item in items:
            owner = next((group for group in lists if any(x is item for x in group)), None)
            if owner is None:
                raise ValueError(f"{item!r} is not part of this system")
            owner[:] = [x for x in owner if x is not item]
        return self

    def on(self, kind: str, callback: Callable) -> None:
        """Call ``callback(event)`` for every ``kind`` event: ``"birth"``, ``"death"``,
        ``"collision"`` or ``"step"`` (every live particle, after each step)."""
        check.choice("kind", kind, KINDS)
        if not callable(callback):
            raise TypeError(f"callback must be callable, got {callback!r}")
        self._listeners[kind].append(callback)

    def child_seed(self) -> int:
        """A seed for a child system, drawn from an independent stream derived from ours."""
        return int(self.seed_sequence.spawn(1)[0].generate_state(1)[0])

    # -- stepping -------------------------------------------------------------------
    def step(self, dt: float) -> None:
        """Advance the system by ``dt`` seconds (one frame)."""
        dt = check.positive("dt", dt)
        with threads_for(self.store.count):
            self._step(dt)
        for child in self.children:
            child.step(dt)

    def _step(self, dt: float) -> None:
        self.last_dt = dt
        store = self.store
        self._emit(dt)
        n = store.count
        scheme = self.integrator.fused_scheme
        setup = self._setup(scheme, dt)
        if scheme == Scheme.NONE and n:
            self._advance_multistage(n, dt, setup)
        elif self.forces and n:
            self._accumulate_forces(
                n, store.raw("position")[:, :n], store.raw("velocity")[:, :n], self.time
            )
        dead = self._move(n, setup)
        dead += self._contact(n, dt, setup.track_hits)
        for policy in self.extinctions:
            policy.mark(store)
        self.time += dt
        self._deliver_collisions(n)
        if dead or self.extinctions:
            self._extinguish(n)
        for modifier in self.modifiers:
            modifier.apply(store)
        if self._listeners["step"] and store.count:
            self._emit_event("step", np.arange(store.count))
        self.frame += 1

    def run(self, steps: int, dt: float) -> None:
        """Take ``steps`` steps of ``dt`` seconds."""
        for _ in range(check.integer("steps", steps, low=0)):
            self.step(dt)

    def _emit(self, dt: float) -> None:
        for emitter in self.emitters:
            new = emitter.emit(self, self.frame, self.time, dt)
            if new.stop > new.start:
                self._born(new, dt)

    def _born(self, new: slice, dt: float) -> None:
        """Bookkeeping for particles just created (by an emitter or a parent's event)."""
        if self._listeners["birth"]:
            self._emit_event("birth", np.arange(new.start, new.stop))

    def _setup(self, scheme: Scheme, dt: float) -> _StepSetup:
        """Kernel, packed parameters and collider table for this step (rebuilt on change)."""
        track_hits = bool(self._listeners["collision"])
        key = (
            scheme,
            dt,
            self.verlet_damping,
            track_hits,
            bool(self.forces),
            self.store.has("inv_mass"),
            fingerprint(self.colliders),
            fingerprint(self.field_forces),
        )
        if self._setup_cache is not None and self._setup_cache.key == key:
            return self._setup_cache
        terms = FieldTerms()
        for force in self.field_forces:
            terms.add(force.terms())
        values = terms.packed()
        values += [dt, self.verlet_damping, 1.0, GAP]
        params = np.array(values, dtype=self.store.dtype)
        table, *meshes = pack_colliders(self.colliders)
        structure = tuple(c.structure for c in self.colliders)
        quadratic = terms.quadratic_drag > 0
        kernel = step_kernel(
            int(scheme),
            structure,
            bool(self.forces) and scheme != Scheme.NONE,
            self.store.has("inv_mass"),
            quadratic,
            track_hits,
        )
        self._setup_cache = _StepSetup(
            key,
            kernel,
            params,
            table.astype(self.store.dtype),
            tuple(meshes),
            quadratic,
            track_hits,
            terms.linear_drag == 0.0 and terms.quadratic_drag == 0.0,
        )
        return self._setup_cache

    def _buffer(self, n: int) -> np.ndarray:
        if self._force_buffer is None:
            self._force_buffer = np.zeros((3, self.store.capacity), dtype=self.store.dtype)
        return self._force_buffer[:, :n]

    def _accumulate_forces(self, n, position, velocity, time) -> np.ndarray:
        out = self._buffer(n)
        out[...] = 0
        for force in self.forces:
            force.accumulate(self.store, position, velocity, time, out)
        return out

    def _inv_mass(self) -> tuple[np.ndarray, bool]:
        if self.store.has("inv_mass"):
            return self.store.raw("inv_mass"), True
        return np.ones(1, dtype=self.store.dtype), False

    def _advance_multistage(self, n, dt, setup: _StepSetup) -> None:
        store = self.store
        inv_mass, has_inv_mass = self._inv_mass()
        params, quadratic = setup.params, setup.quadratic

        def acceleration(x, v, t, out):
            force = self._accumulate_forces(n, x, v, t) if self.forces else out
            acceleration_kernel(
                n, v, inv_mass, has_inv_mass, force, bool(self.forces), params, quadratic, out
            )

        if self.integrator == Integrator.IMPLICIT_EULER:
            advance_store(self.implicit_solver, store, self.forces, params, n, dt, self.time)
            return
        x = store.raw("position")[:, :n]
        v = store.raw("velocity")[:, :n]
        if self.integrator == Integrator.RK4:
            rk4(x, v, self.time, dt, acceleration)
            return
        # The leapfrog's end acceleration a(x') is the next step's a(x) when every force
        # depends on positions alone and nothing moved, was born or died in between.
        carry = setup.velocity_free and all("velocity" not in f.reads for f in self.forces)
        key = (setup, tuple(id(f) for f in self.forces), self.time)
        held = self._carried
        start = None
        if carry and held is not None and held[0] == key and np.array_equal(held[1], x):
            start = held[2]
        end = velocity_verlet(x, v, self.time, dt, acceleration, start=start)
        self._carried = ((setup, key[1], self.time + dt), x.copy(), end) if carry else None

    def _move(self, n: int, setup: _StepSetup) -> int:
        store = self.store
        if n == 0:
            return 0
        if setup.track_hits and self._hits is None:
            self._hits = np.full(store.capacity, -1, dtype=np.int32)
        inv_mass, _ = self._inv_mass()
        position = store.raw("position")
        force = self._force_buffer if self._force_buffer is not None else position
        hits = self._hits if setup.track_hits else self._no_hits
        dead = setup.kernel(
            n,
            position,
            store.raw("velocity"),
            store.raw("age"),
            store.raw("lifetime"),
            inv_mass,
            force,
            setup.params,
            setup.table,
            *setup.meshes,
            store.keep,
            hits,
        )
        return int(dead)

    def _contact(self, n: int, dt: float, track_hits: bool) -> int:
        """Contacts with other kinds, after the move (momentum passes both ways)."""
        killed = 0
        for j, contact in enumerate(self.contacts):
            hits = self._hits if track_hits and n else None
            killed += contact.resolve(self.store, n, dt, hits, len(self.colliders) + j)
        return killed

    def _deliver_collisions(self, n: int) -> None:
        if not self._listeners["collision"] or n == 0:
            return
        hits = self._hits[:n]
        index = np.flatnonzero(hits >= 0)
        if index.size:
            event = gather("collision", self.time, self.store, index, hits[index].copy())
            for callback in self._listeners["collision"]:
                callback(event)

    def _extinguish(self, n: int) -> None:
        store = self.store
        if self._listeners["death"]:
            index = np.flatnonzero(~store.keep[:n])
            if index.size:
                self._emit_event("death", index)
        holders = [f for f in self.forces if type(f).remap is not Force.remap]
        new_index = store.compact(index=bool(holders))
        if new_index is not None:
            for force in holders:
                force.remap(new_index)

    def _emit_event(self, kind: str, index: np.ndarray) -> None:
        event = gather(kind, self.time, self.store, index)
        for callback in self._listeners[kind]:
            callback(event)

    # -- reading ----------------------------------------------------------------------
    def __len__(self) -> int:
        return self.store.count

    def __getitem__(self, name: str) -> np.ndarray:
        """Live view of attribute ``name``: ``(count, c)`` or ``(count,)``."""
        return self.store[name]

    def __setitem__(self, name: str, value) -> None:
        """Set attribute ``name`` of every live particle (broadcasting ``value``)."""
        self.store[name] = value

    def particle_state(self) -> ParticleState:
        """The live particles as views into the store (see
        :meth:`ParticleStore.particle_state`)."""
        return self.store.particle_state()

    @property
    def nbytes(self) -> int:
        """Bytes allocated for this system: the store plus the force and hit buffers."""
        extra = sum(b.nbytes for b in (self._force_buffer, self._hits) if b is not None)
        return self.store.nbytes + extra

    def summary(self) -> dict:
        """Count, bounding box [m] and mean speed [m/s] of the live particles."""
        n = self.store.count
        if n == 0:
            return {"count": 0, "bbox_min": None, "bbox_max": None, "mean_speed": 0.0}
        pos = self.store.raw("position")[:, :n]
        vel = self.store.raw("velocity")[:, :n]
        return {
            "count": n,
            "bbox_min": pos.min(axis=1).astype(float).tolist(),
            "bbox_max": pos.max(axis=1).astype(float).tolist(),
            "mean_speed": float(np.sqrt((vel.astype(np.float64) ** 2).sum(axis=0)).mean()),
        }

    def __repr__(self) -> str:
        return (
            f"ParticleSystem({self.store.count}/{self.store.capacity} particles, "
            f"t={self.time:.4g} s, integrator={self.integrator.value!r})"
        )
