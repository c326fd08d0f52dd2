"""A Verlet world: particles, constraints, rigid bodies, joints and collisions.

:class:`World` is the builder and the façade of three parts, in the spirit of Newton's
Model, State and Control:

- :class:`~motes.rigid.model.WorldModel` (:attr:`World.model`): what stepping reads and
  never changes, packed from the builder's records on first use after a builder call;
- :class:`~motes.rigid.state.WorldState` (:attr:`World.state`): what changes from step
  to step; assigning a saved copy rewinds the world;
- :class:`~motes.rigid.state.WorldControl` (:attr:`World.control`): the velocity
  changes given for the next step (:meth:`World.set_velocity`,
  :meth:`World.add_velocity`, :meth:`World.add_impulse`).

:meth:`World.step` is :func:`motes.rigid.stepping.step` of the three (Jakobsen 2001,
"Advanced Character Physics", §2–4: position Verlet, swept tests, then constraints and
collisions relaxed together, so a body resting on the ground is rigid and outside it at
once, then a velocity pass for restitution).

Every stage is a compiled kernel over float64 arrays. Float64 because position Verlet
stores the velocity as the difference of two positions: in float32, 10 m from the
origin, that difference is quantised to 1e-6 m, i.e. 6e-5 m/s per step at 60 Hz, which
shows up as jitter in resting stacks and as drift in the energy tests.
"""

from __future__ import annotations

import math

import numpy as np

from .. import _validate as check
from ..collide.contact import Detection, check_collider
from ..constrain import ConstraintBuilder
from ..forces.apply import check_force
from ..state import Field, ParticleState
from . import stepping
from .model import BodyRecord, WorldModel, WorldParameters, build_model, merge_pins
from .motion import RigidMotion, impulse_velocities, rigid_motion
from .shapes import BodyShape
from .state import WorldControl, WorldState, WorldWorkspace


class _Parameter:
    """A :class:`World` setting kept in its :class:`~motes.rigid.model.WorldParameters`
    (checked on assignment there; the model shares it, so a change applies from the next
    step on without rebuilding the model)."""

    def __set_name__(self, owner, name: str) -> None:
        self.name = name

    def __get__(self, world, owner=None):
        return self if world is None else getattr(world._parameters, self.name)

    def __set__(self, world, value) -> None:
        setattr(world._parameters, self.name, value)


class Body:
    """Handle of a body in a :class:`World`: its index and particles (global indices)."""

    def __init__(self, index: int, particles: np.ndarray, solid: bool):
        self.index = index
        self.particles = particles
        self.solid = solid

    def __repr__(self) -> str:
        return f"Body({self.index}, {len(self.particles)} particles)"


class World:
    """Particles, constraints, rigid bodies and colliders stepped by position Verlet.

    Parameters
    ----------
    gravity : (3,) array_like
        [m/s²]
    damping : float
        Velocity damping rate c >= 0 [1/s]: each substep keeps ``exp(-c h)`` of it.
    iterations : int
        Relaxation iterations per substep, >= 1.
    substeps : int
        Substeps per :meth:`step`, >= 1.
    sqrt_approximation : bool
        Jakobsen's square-root-free stick projection (see :mod:`motes.constrain.kernels`).
    body_friction : float
        Coulomb coefficient mu >= 0 between bodies (depth based).
    projection : {"shake", "jakobsen"}
        Direction sticks push along: the pair's direction at the start of the substep
        (SHAKE: no energy drift; a 60° pendulum keeps its period within 0.05 % at 60 Hz)
        or the current one (Jakobsen 2001, PBD: dissipative, the same pendulum runs 6 %
        fast as its swing decays). See :mod:`motes.constrain.kernels`.
    forces : sequence of Force or FieldForce
        Forces besides gravity (:meth:`add_force`).

    Each parameter is also an attribute, checked when assigned and read at each step.
    The world builds a :attr:`model` from what is added, steps its :attr:`state` and
    applies its :attr:`control` (see :mod:`motes.rigid.world`).
    """

    def __init__(
        self,
        *,
        gravity=(0.0, -9.81, 0.0),
        damping: float = 0.0,
        iterations: int = 10,
        substeps: int = 1,
        sqrt_approximation: bool = False,
        body_friction: float = 0.5,
        projection: str = "shake",
        forces=(),
    ):
        self._parameters = WorldParameters(
            gravity=gravity,
            damping=damping,
            iterations=iterations,
            substeps=substeps,
            sqrt_approximation=sqrt_approximation,
            body_friction=body_friction,
            projection=projection,
            forces=forces,
        )
        self.mass = np.zeros(0)
        self.radius = np.zeros(0)
        self._constraints = ConstraintBuilder()
        self._pinned: list[np.ndarray] = []
        self._pin_targets: list[np.ndarray] = []
        self._colliders: list = []
        self._detections: list[Detection] = []
        self._bodies: list[BodyRecord] = []
        self._spheres: dict[int, float] = {}  # sphere particle -> restitution
        self._state = WorldState(np.zeros((3, 0)), np.zeros((3, 0)))
        self._control = WorldControl()
        self._model: WorldModel | None = None
        self._workspace = WorldWorkspace.zeros(0)

    gravity = _Parameter()
    damping = _Parameter()
    iterations = _Parameter()
    substeps = _Parameter()
    sqrt_approximation = _Parameter()
    body_friction = _Parameter()
    projection = _Parameter()
    #: Forces besides gravity (:meth:`add_force`).
    forces = _Parameter()

    # --- building --------------------------------------------------------------------

    @property
    def count(self) -> int:
        """Number of particles."""
        return self._state.particle_count

    def add_particles(self, positions, mass=1.0, radius=0.0) -> np.ndarray:
        """Add particles at rest; returns their indices.

        ``positions`` (k, 3) [m]; ``mass`` [kg] > 0 and ``radius`` [m] >= 0 (its contact
        radius against colliders and bodies), each one number or one per particle.
        """
        pts = check.points("positions", positions, min_rows=1)
        k = len(pts)
        m = np.broadcast_to(np.asarray(mass, dtype=np.float64), (k,))
        r = np.broadcast_to(np.asarray(radius, dtype=np.float64), (k,))
        if not np.all(np.isfinite(m)) or np.any(m <= 0):
            raise ValueError("mass must be finite and > 0 [kg]")
        if not np.all(np.isfinite(r)) or np.any(r < 0):
            raise ValueError("radius must be finite and >= 0 [m]")
        first = self.count
        state = self._state
        state.particle_position = np.ascontiguousarray(
            np.concatenate([state.particle_position, pts.T], axis=1)
        )
        state.particle_previous = np.ascontiguousarray(
            np.concatenate([state.particle_previous, pts.T], axis=1)
        )
        self.mass = np.concatenate([self.mass, m])
        self.radius = np.concatenate([self.radius, r])
        self._model = None
        return np.arange(first, first + k)

    def add_body(
        self,
        shape: BodyShape,
        *,
        share=None,
        group: int | None = None,
        radius: float | None = None,
        stiffness: float = 1.0,
        compliance: float = 0.0,
    ) -> Body:
        """Add a rigid body: its particles, its sticks and (if solid) its faces.

        ``share`` maps local particle indices of ``shape`` to existing particles, which
        the body uses instead of new ones (adding the shape's mass to them): sharing one
        particle makes a ball joint, sharing two a hinge (Jakobsen 2001, §5). Bodies of
        one ``group`` (default: a group of its own) do not collide with each other.
        ``radius`` [m] is the contact radius of its particles: by default 1 % of the
        shape's smallest extent, so bodies resting face to face still touch (see
        :mod:`motes.rigid.body_contacts`).
        """
        if not isinstance(shape, BodyShape):
            raise TypeError(f"shape must be a BodyShape, got {type(shape).__name__}")
        share = dict(share or {})
        k = len(shape.positions)
        for local, particle in share.items():
            if not 0 <= local < k or not 0 <= particle < self.count:
                raise ValueError(
                    f"share: {local} -> {particle} is not a local -> existing "
                    f"particle pair (local < {k}, existing < {self.count})"
                )
        if radius is None:
            extent = np.ptp(shape.positions, axis=0)
            radius = 0.01 * float(extent[extent > 0].min()) if np.any(extent > 0) else 0.0
        fresh = [i for i in range(k) if i not in share]
        index = np.empty(k, dtype=np.int64)
        if fresh:
            index[fresh] = self.add_particles(shape.positions[fresh], shape.masses[fresh], radius)
        for local, particle in share.items():
            index[local] = particle
            self.mass[particle] += shape.masses[local]
        pairs = index[shape.sticks]
        lengths = np.linalg.norm(
            shape.positions[shape.sticks[:, 1]] - shape.positions[shape.sticks[:, 0]], axis=1
        )
        self._constraints.add_sticks(pairs, lengths, stiffness=stiffness, compliance=compliance)
        solid = len(shape.planes) > 0
        key = len(self._bodies) if group is None else int(group) + (1 << 40)
        self._bodies.append(BodyRecord(index, shape, key))
        self._model = None
        return Body(len(self._bodies) - 1, index, solid)

    def _current_lengths(self, pairs):
        x = self._state.particle_position
        p = x[:, pairs[:, 1]] - x[:, pairs[:, 0]]
        return np.sqrt((p * p).sum(axis=0))

    def _pairs(self, pairs, width):
        arr = np.asarray(pairs)
        if arr.ndim != 2 or arr.shape[1] != width or not np.issubdtype(arr.dtype, np.integer):
            raise ValueError(f"pairs must be an (m, {width}) integer array")
        if arr.size and (arr.min() < 0 or arr.max() >= self.count):
            raise ValueError(f"particle indices must be in [0, {self.count - 1}]")
        return arr.astype(np.int64)

    def add_sticks(self, pairs, rest_length=None, *, stiffness=1.0, compliance=0.0):
        """Sticks between particle pairs; rest lengths default to the current distances."""
        pairs = self._pairs(pairs, 2)
        if rest_length is None:
            rest_length = self._current_lengths(pairs)
        self._model = None
        return self._constraints.add_sticks(
            pairs, rest_length, stiffness=stiffness, compliance=compliance
        )

    def add_ropes(self, pairs, length=None, *, stiffness=1.0, compliance=0.0):
        """Ropes (max distance) between pairs; lengths default to the current distances."""
        pairs = self._pairs(pairs, 2)
        if length is None:
            length = self._current_lengths(pairs)
        self._model = None
        return self._constraints.add_ropes(
            pairs, length, stiffness=stiffness, compliance=compliance
        )

    def add_distance_limits(self, pairs, min_length, max_length, *, stiffness=1.0, compliance=0.0):
        """Keep each pair's distance in ``[min_length, max_length]`` [m]."""
        self._model = None
        return self._constraints.add_distance(
            self._pairs(pairs, 2),
            min_length,
            max_length,
            stiffness=stiffness,
            compliance=compliance,
        )

    def add_angle_limits(
        self, triples, min_angle, max_angle=math.pi, *, stiffness=1.0, compliance=0.0
    ):
        """Joint limits: the angle at ``pivot`` of each ``(pivot, i, j)`` in range [rad]."""
        self._model = None
        return self._constraints.add_angle_limits(
            self._pairs(triples, 3),
            min_angle,
            max_angle,
            stiffness=stiffness,
            compliance=compliance,
        )

    def add_hinge_sides(self, rows, offset=0.0, *, stiffness=1.0, recovery=3.0):
        """Keep hinge joints bending one way only; rows ``(i, k, l, r, j)`` (see
        :meth:`motes.constrain.ConstraintBuilder.add_hinge_sides`). The side ``j`` is
        on now is the allowed one: build the body slightly bent the right way."""
        rows = self._pairs(rows, 5)
        x = self.position
        i, k, left, right, j = (rows[:, c] for c in range(5))
        n = np.cross(x[k] - x[i], x[right] - x[left])
        side = np.einsum("ij,ij->i", x[j] - x[k], n)
        orientation = np.where(side > 0, -1.0, 1.0)
        self._model = None
        return self._constraints.add_hinge_sides(
            rows, orientation, offset, stiffness=stiffness, recovery=recovery
        )

    def pin(self, indices, targets=None) -> None:
        """Hold particles at ``targets`` ((k, 3) [m]; default: where they are)."""
        idx = np.atleast_1d(np.asarray(indices))
        if not np.issubdtype(idx.dtype, np.integer) or idx.size == 0:
            raise ValueError("indices must be particle indices")
        if idx.min() < 0 or idx.max() >= self.count:
            raise ValueError(f"indices must be in [0, {self.count - 1}]")
        if targets is None:
            targets = self._state.particle_position[:, idx].T
        targets = check.points("targets", targets, min_rows=len(idx))
        self._pinned.append(idx.astype(np.int64))
        self._pin_targets.append(targets[: len(idx)])
        self._state.particle_position[:, idx] = targets[: len(idx)].T
        self._state.particle_previous[:, idx] = targets[: len(idx)].T
        self._model = None

    def unpin(self, indices) -> None:
        """Release pinned particles (they keep their position and start at rest)."""
        drop = set(np.atleast_1d(np.asarray(indices)).tolist())
        kept = [(i, t) for idx, tg in zip(self._pinned, self._pin_targets, strict=True)
                for i, t in zip(idx.tolist(), tg, strict=True) if i not in drop]  # fmt: skip
        self._pinned = [np.array([i for i, _ in kept], dtype=np.int64)] if kept else []
        self._pin_targets = [np.array([t for _, t in kept])] if kept else []
        self._model = None

    def add_collider(self, collider, detection: Detection | str | None = None) -> None:
        """A plane, sphere, box, capsule or triangle mesh; ``detection`` is
        ``"posteriori"`` (after the move) or ``"priori"`` (swept), by default the
        collider's own (:attr:`motes.collide.Collider.detection`).
        The collider's ``friction`` is the Coulomb mu of the depth-based friction; its
        ``restitution`` is kept of the normal speed of a hit, found before the move
        (swept) or after it (a velocity pass after the relaxation, see
        :mod:`motes.rigid.restitution`)."""
        self._detections.append(check_collider(collider, detection))
        self._colliders.append(collider)
        self._model = None

    def add_force(self, force):
        """Make ``force`` (a :class:`~motes.forces.Force` or ``FieldForce``) act on every
        particle from the next substep on; returns it.

        Each substep evaluates the forces at its start (velocity ``(x - x*)/h``) and adds
        ``h² F / m`` to the Verlet move, with gravity: an acceleration in
        ``x' = x + e^{-c h}(x - x*) + h² (g + F/m)``. Pinned and static particles do not
        move.
        """
        self._parameters.forces.append(check_force(force))
        return force

    def add_sphere_contacts(self, indices, restitution: float = 0.0) -> None:
        """Let particles collide with each other as spheres of their radius.

        Every pair among all particles added this way is tested (``O(k²)``: for tens to
        hundreds of balls or bobs; see :mod:`motes.collide.sphere_kernels`). ``restitution`` in
        [0, 1] is kept for the normal velocity of a pair (the smaller of the two).
        """
        idx = np.atleast_1d(np.asarray(indices))
        if idx.size == 0 or not np.issubdtype(idx.dtype, np.integer):
            raise ValueError("indices must be particle indices")
        if idx.min() < 0 or idx.max() >= self.count:
            raise ValueError(f"indices must be in [0, {self.count - 1}]")
        e = check.unit_interval("restitution", restitution)
        for i in idx.tolist():
            self._spheres[int(i)] = e
        self._model = None

    def set_velocity(self, indices, velocity) -> None:
        """Give particles a velocity [m/s] ((3,) or (k, 3)), applied at the next step."""
        idx = np.atleast_1d(np.asarray(indices, dtype=np.int64))
        if idx.size and (idx.min() < 0 or idx.max() >= self.count):
            raise ValueError(f"indices must be in [0, {self.count - 1}]")
        v = np.broadcast_to(np.asarray(velocity, dtype=np.float64), (len(idx), 3))
        if not np.all(np.isfinite(v)):
            raise ValueError("velocity must be finite")
        self._control.particle_velocity_sets.append((idx, v.copy()))

    def add_velocity(self, indices, change) -> None:
        """Add ``change`` [m/s] ((k, 3)) to the velocities of particles ``indices`` at
        the next step: an impulse from another kind (a liquid) divided by the mass."""
        idx = np.atleast_1d(np.asarray(indices, dtype=np.int64))
        if idx.size and (idx.min() < 0 or idx.max() >= self.count):
            raise ValueError(f"indices must be in [0, {self.count - 1}]")
        dv = np.broadcast_to(np.asarray(change, dtype=np.float64), (len(idx), 3))
        if not np.all(np.isfinite(dv)):
            raise ValueError("change must be finite")
        self._control.particle_velocity_changes.append((idx, dv.copy()))

    def add_impulse(self, groups, impulse, angular_impulse=None) -> None:
        """Give particle sets, each as a rigid body, an impulse at the next step.

        Each set of ``groups`` (index arrays: a body's ``particles``, one ball) receives
        the impulse ``impulse[k]`` (3,) [N s] through its centre of mass and the angular
        impulse ``angular_impulse[k]`` [N m s] about it (none by default): its particles'
        velocities change by ``J/M + (I⁻¹ A) × (x - c)``, which changes the set's momentum
        by exactly ``J`` and its angular momentum about its centre by exactly ``A``
        (:mod:`motes.rigid.motion`), taken at the positions now. An impulse ``J`` at a
        point ``p`` is ``J`` with ``A = (p - c) × J``. Sets holding a pinned particle do
        not move: the pins take the impulse.
        """
        groups = [np.atleast_1d(np.asarray(g, dtype=np.int64)) for g in groups]
        for g in groups:
            if g.size == 0 or g.min() < 0 or g.max() >= self.count:
                raise ValueError(f"groups must hold particle indices in [0, {self.count - 1}]")
        impulse = np.asarray(impulse, dtype=np.float64).reshape(len(groups), 3)
        if angular_impulse is not None:
            angular_impulse = np.asarray(angular_impulse, dtype=np.float64)
            angular_impulse = angular_impulse.reshape(len(groups), 3)
        for value, name in ((impulse, "impulse"), (angular_impulse, "angular_impulse")):
            if value is not None and not np.all(np.isfinite(value)):
                raise ValueError(f"{name} must be finite")
        movable = self.model.particle_inv_mass > 0
        free = [k for k, g in enumerate(groups) if movable[g].all()]
        if not free:
            return
        members, change = impulse_velocities(
            self._state.particle_position,
            self.mass,
            [groups[k] for k in free],
            impulse[free],
            None if angular_impulse is None else angular_impulse[free],
        )
        self._control.particle_velocity_changes.append((members, change))

    def motion(self, groups) -> RigidMotion:
        """Particle sets (index arrays: a body's ``particles``, one ball) as rigid bodies
        now: centres of mass, velocities, angular velocities, inverse masses and inverse
        inertias about the centres (world axes), read from the particles
        (:mod:`motes.rigid.motion`). The velocities are those the next step starts from:
        the last substep's ``(x - x*)/h`` with the changes given since
        (:meth:`set_velocity`, :meth:`add_velocity`, :meth:`add_impulse`). A set holding
        a pinned particle has zero inverse mass and inertia."""
        groups = [np.atleast_1d(np.asarray(g, dtype=np.int64)) for g in groups]
        movable = self.model.particle_inv_mass > 0
        velocity = stepping.next_velocity(self._state, self._control)
        return rigid_motion(self._state.particle_position, velocity, self.mass, groups, movable)

    def boxes(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The bodies that are boxes (:meth:`BodyShape.box_geometry`) as they are now.

        Returns
        -------
        index : (k,) int64
            Their body indices.
        centre : (k, 3)
            Box centres [m] (the centre of mass moved by the body's transform).
        half_extents : (k, 3)
            Half edge lengths [m].
        axes : (k, 3, 3)
            The box axes, unit rows, in world coordinates.
        """
        boxes = self.model.body_box
        index = np.array([b for b, box in enumerate(boxes) if box is not None], np.int64)
        if len(index) == 0:
            return index, np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3, 3))
        centre, rotation = self.transforms()
        offset = np.array([boxes[b].centre for b in index])
        half = np.array([boxes[b].half_extents for b in index])
        axes = np.array([boxes[b].axes for b in index])
        rotation = rotation[index]
        # A rest axis a turns to R a: as rows, axes @ R^T.
        return (
            index,
            centre[index] + np.einsum("kij,kj->ki", rotation, offset),
            half,
            np.einsum("kaj,kij->kai", axes, rotation),
        )

    @property
    def spheres(self) -> np.ndarray:
        """Particles that collide as spheres of their radius (:meth:`add_sphere_contacts`),
        sorted."""
        return np.array(sorted(self._spheres), dtype=np.int64)

    # --- state -----------------------------------------------------------------------

    @property
    def state(self) -> WorldState:
        """The world's :class:`~motes.rigid.state.WorldState`, live (stepping changes it
        in place; :meth:`WorldState.copy` saves one).

        Assigning a state rewinds the world to it: its values are copied into the
        world's arrays (views taken before stay live, and the saved state can be
        assigned again). Pending velocity changes (:attr:`control`) are kept. A state
        with another particle count is refused.
        """
        return self._state

    @state.setter
    def state(self, state: WorldState) -> None:
        if not isinstance(state, WorldState):
            raise TypeError(f"state must be a WorldState, got {type(state).__name__}")
        n = self.count
        if state.particle_count != n:
            raise ValueError(f"state holds {state.particle_count} particles, the world has {n}")
        if state.particle_previous.shape != (3, n):
            raise ValueError(
                f"state.particle_previous must have shape (3, {n}), "
                f"got {state.particle_previous.shape}"
            )
        own = self._state
        np.copyto(own.particle_position, state.particle_position)
        np.copyto(own.particle_previous, state.particle_previous)
        own.time = float(state.time)
        own.last_substep = state.last_substep
        rotation = state.body_rotation
        own.body_rotation = None if rotation is None else np.array(rotation, np.float64, order="C")

    @property
    def control(self) -> WorldControl:
        """The velocity changes waiting for the next step
        (:class:`~motes.rigid.state.WorldControl`)."""
        return self._control

    @property
    def time(self) -> float:
        """Simulated time [s] (:attr:`WorldState.time`)."""
        return self._state.time

    @time.setter
    def time(self, value: float) -> None:
        self._state.time = float(value)

    @property
    def position(self) -> np.ndarray:
        """(n, 3) view of the positions [m] (writable: moves particles, keeping velocity
        only if ``previous`` is moved too)."""
        return self._state.particle_position.T

    @property
    def previous(self) -> np.ndarray:
        """(n, 3) view of the positions one substep ago [m]."""
        return self._state.particle_previous.T

    @property
    def velocity(self) -> np.ndarray:
        """(n, 3) velocities ``(x - x*)/h`` [m/s] of the last substep (zero before one)."""
        state = self._state
        if state.last_substep is None:
            return np.zeros((self.count, 3))
        return (state.particle_position - state.particle_previous).T / state.last_substep

    def particle_state(self) -> ParticleState:
        """The particles as a :class:`~motes.state.ParticleState`.

        ``positions`` are the world's float64 rows (a view; :meth:`add_particles`
        reallocates them); ``velocities`` are computed as :attr:`velocity` (zero before
        the first step); ``ids`` are the particle indices; ``radius`` is each particle's
        contact radius [m] (a view: a ball's radius, 1 % of a body's smallest extent by
        default, 0 for a point particle). Fields: ``mass`` [kg] (a view) and
        ``previous`` (3, n) [m], the positions one substep ago (a view; with
        ``positions``, the whole Verlet state).
        """
        state = self._state
        x, q = state.particle_position, state.particle_previous
        if state.last_substep is None:
            velocities = np.zeros((3, self.count))
        else:
            velocities = (x - q) / state.last_substep
        fields = {
            "mass": Field(self.mass, "kg", "particle mass"),
            "previous": Field(q, "m", "positions one substep ago"),
        }
        ids = np.arange(self.count)
        return ParticleState(ids, x, velocities, self.radius, fields)

    @property
    def colliders(self) -> tuple:
        """The colliders, in the order added."""
        return tuple(self._colliders)

    @property
    def bodies(self) -> list[Body]:
        return [Body(i, b.particles, len(b.shape.planes) > 0) for i, b in enumerate(self._bodies)]

    @property
    def constraints(self):
        """The built :class:`~motes.constrain.ConstraintSet` (built on first use)."""
        return self.model.constraints

    def transforms(self) -> tuple[np.ndarray, np.ndarray]:
        """Centres of mass ``(b, 3)`` [m] and rotations ``(b, 3, 3)`` of every body."""
        return stepping.transforms(self.model, self._state)

    def energy(self) -> tuple[float, float]:
        """Kinetic and gravitational potential energy [J] of the movable particles.

        Both at the middle of the last substep: the velocity ``(x - x*)/h`` belongs to
        that instant, so the potential is taken at ``(x + x*)/2``. (Pairing it with the
        potential at ``x`` instead makes a falling body seem to lose ``m g Δv h / 2``.)
        """
        moving = self.model.particle_inv_mass > 0
        v = self.velocity[moving]
        m = self.mass[moving]
        kinetic = 0.5 * float(m @ (v * v).sum(axis=1))
        middle = 0.5 * (self.position[moving] + self.previous[moving])
        potential = -float(m @ (middle @ self.gravity))
        return kinetic, potential

    def contacts(self) -> np.ndarray:
        """Contacts found per particle during the last step (colliders and bodies)."""
        if self._model is None:  # a builder call since: none found with these particles
            return np.zeros(self.count, dtype=np.int64)
        return self._workspace.particle_hits.copy()

    # --- stepping --------------------------------------------------------------------

    @property
    def model(self) -> WorldModel:
        """The :class:`~motes.rigid.model.WorldModel` the step reads.

        Built on first use after a builder call (``add_*``, :meth:`pin`,
        :meth:`unpin`), never by stepping: the same object from step to step. Building
        it restarts the bodies' rotation warm start (:attr:`WorldState.body_rotation`)
        from their exact rotations.
        """
        if self._model is None:
            self._model = build_model(
                parameters=self._parameters,
                mass=self.mass,
                radius=self.radius,
                constraints=self._constraints,
                pins=merge_pins(self._pinned, self._pin_targets),
                bodies=self._bodies,
                colliders=self._colliders,
                detections=self._detections,
                spheres=self._spheres,
            )
            self._workspace = WorldWorkspace.zeros(self.count)
            self._state.body_rotation = stepping.exact_rotations(self._model, self._state)
        return self._model

    def step(self, dt: float) -> None:
        """Advance by ``dt`` [s] in :attr:`substeps` substeps."""
        dt = check.positive("dt", dt)
        model, state, control = self.model, self._state, self._control
        self._workspace = stepping.step(model, state, control, dt, workspace=self._workspace)
