"""A Verlet world: particles, constraints, rigid bodies, joints and collisions.

Each substep of ``h`` (Jakobsen 2001, "Advanced Character Physics", §2–4):

1. position Verlet, ``x' = x + e^{-c h}(x - x*) + h² (g + F/m)`` (:func:`.kernels.verlet`,
   then the added forces' ``h² F/m``, :meth:`World.add_force`);
2. swept tests of every path ``x* -> x'`` against a-priori colliders
   (:mod:`motes.collide.swept`);
3. the transforms of the solid bodies (for body contacts);
4. ``iterations`` times: one colour-by-colour sweep of the constraints
   (:mod:`motes.constrain`), the projection out of colliders
   (:mod:`motes.collide.contact`), the projection out of other bodies
   (:mod:`motes.rigid.body_contacts`), and the pins. Constraints and collisions relax
   together, as in Jakobsen's loop, so a body resting on the ground is rigid and
   outside it at once; particles added with :meth:`World.add_sphere_contacts` are
   pushed apart from each other (:mod:`motes.rigid.sphere_contacts`);
5. a velocity pass giving contacts with colliders and between spheres their
   restitution (Müller et al. 2020, §3.5; :mod:`motes.rigid.restitution`).

Every stage is a compiled kernel over float64 arrays. Float64 because position Verlet
stores the velocity as the difference of two positions: in float32, 10 m from the
origin, that difference is quantised to 1e-6 m, i.e. 6e-5 m/s per step at 60 Hz, which
shows up as jitter in resting stacks and as drift in the energy tests.
"""

from __future__ import annotations

import math

import numpy as np

from .. import _validate as check
from .._jit import threads_for
from ..collide.contact import Detection, check_collider, pack, project_contacts
from ..collide.swept import sweep_contacts
from ..constrain import ConstraintBuilder, Pins
from ..forces.apply import add_forces, check_force
from ..geometry.layout import RESTITUTION, SWEPT
from ..state import Field, ParticleState
from .body_contacts import body_contacts
from .kernels import verlet
from .motion import RigidMotion, impulse_velocities, rigid_motion
from .restitution import restitute_contacts
from .shapes import BodyShape
from .sphere_contacts import project_spheres, restitute_spheres
from .transform import body_transforms


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
        self.gravity = check.vector("gravity", gravity)
        self.damping = check.non_negative("damping", damping)
        self.iterations = check.integer("iterations", iterations, low=1)
        self.substeps = check.integer("substeps", substeps, low=1)
        if not isinstance(sqrt_approximation, bool):
            raise TypeError(f"sqrt_approximation must be True or False, got {sqrt_approximation!r}")
        self.sqrt_approximation = sqrt_approximation
        self.body_friction = check.non_negative("body_friction", body_friction)
        self.projection = check.choice("projection", projection, ("shake", "jakobsen"))
        self._position = np.zeros((3, 0))
        self._previous = np.zeros((3, 0))
        self.mass = np.zeros(0)
        self.radius = np.zeros(0)
        self._constraints = ConstraintBuilder()
        self._pinned: list[np.ndarray] = []
        self._pin_targets: list[np.ndarray] = []
        self._colliders: list = []
        self._detections: list[Detection] = []
        self._bodies: list[dict] = []
        self._velocity_pending: list[tuple[np.ndarray, np.ndarray]] = []
        self._velocity_added: list[tuple[np.ndarray, np.ndarray]] = []
        self._spheres: dict[int, float] = {}  # sphere particle -> restitution
        self._built = None
        self.time = 0.0
        self._h = None
        #: Forces besides gravity (:meth:`add_force`).
        self.forces = [check_force(f) for f in forces]

    # --- building --------------------------------------------------------------------

    @property
    def count(self) -> int:
        """Number of particles."""
        return self._position.shape[1]

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
        self._position = np.ascontiguousarray(np.concatenate([self._position, pts.T], axis=1))
        self._previous = np.ascontiguousarray(np.concatenate([self._previous, pts.T], axis=1))
        self.mass = np.concatenate([self.mass, m])
        self.radius = np.concatenate([self.radius, r])
        self._built = None
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
        body = {
            "particles": index,
            "shape": shape,
            "group": len(self._bodies) if group is None else int(group) + (1 << 40),
        }
        self._bodies.append(body)
        self._built = None
        return Body(len(self._bodies) - 1, index, solid)

    def _current_lengths(self, pairs):
        p = self._position[:, pairs[:, 1]] - self._position[:, pairs[:, 0]]
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
        self._built = None
        return self._constraints.add_sticks(
            pairs, rest_length, stiffness=stiffness, compliance=compliance
        )

    def add_ropes(self, pairs, length=None, *, stiffness=1.0, compliance=0.0):
        """Ropes (max distance) between pairs; lengths default to the current distances."""
        pairs = self._pairs(pairs, 2)
        if length is None:
            length = self._current_lengths(pairs)
        self._built = None
        return self._constraints.add_ropes(
            pairs, length, stiffness=stiffness, compliance=compliance
        )

    def add_distance_limits(self, pairs, min_length, max_length, *, stiffness=1.0, compliance=0.0):
        """Keep each pair's distance in ``[min_length, max_length]`` [m]."""
        self._built = None
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
        self._built = None
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
        self._built = None
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
            targets = self._position[:, idx].T
        targets = check.points("targets", targets, min_rows=len(idx))
        self._pinned.append(idx.astype(np.int64))
        self._pin_targets.append(targets[: len(idx)])
        self._position[:, idx] = targets[: len(idx)].T
        self._previous[:, idx] = targets[: len(idx)].T
        self._built = None

    def unpin(self, indices) -> None:
        """Release pinned particles (they keep their position and start at rest)."""
        drop = set(np.atleast_1d(np.asarray(indices)).tolist())
        kept = [(i, t) for idx, tg in zip(self._pinned, self._pin_targets, strict=True)
                for i, t in zip(idx.tolist(), tg, strict=True) if i not in drop]  # fmt: skip
        self._pinned = [np.array([i for i, _ in kept], dtype=np.int64)] if kept else []
        self._pin_targets = [np.array([t for _, t in kept])] if kept else []
        self._built = None

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
        self._built = None

    def add_force(self, force):
        """Make ``force`` (a :class:`~motes.forces.Force` or ``FieldForce``) act on every
        particle from the next substep on; returns it.

        Each substep evaluates the forces at its start (velocity ``(x - x*)/h``) and adds
        ``h² F / m`` to the Verlet move, with gravity: an acceleration in
        ``x' = x + e^{-c h}(x - x*) + h² (g + F/m)``. Pinned and static particles do not
        move.
        """
        self.forces.append(check_force(force))
        return force

    def add_sphere_contacts(self, indices, restitution: float = 0.0) -> None:
        """Let particles collide with each other as spheres of their radius.

        Every pair among all particles added this way is tested (``O(k²)``: for tens to
        hundreds of balls or bobs; see :mod:`motes.rigid.sphere_contacts`). ``restitution`` in
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
        self._built = None

    def set_velocity(self, indices, velocity) -> None:
        """Give particles a velocity [m/s] ((3,) or (k, 3)), applied at the next step."""
        idx = np.atleast_1d(np.asarray(indices, dtype=np.int64))
        if idx.size and (idx.min() < 0 or idx.max() >= self.count):
            raise ValueError(f"indices must be in [0, {self.count - 1}]")
        v = np.broadcast_to(np.asarray(velocity, dtype=np.float64), (len(idx), 3))
        if not np.all(np.isfinite(v)):
            raise ValueError("velocity must be finite")
        self._velocity_pending.append((idx, v.copy()))

    def add_velocity(self, indices, change) -> None:
        """Add ``change`` [m/s] ((k, 3)) to the velocities of particles ``indices`` at
        the next step: an impulse from another kind (a liquid) divided by the mass."""
        idx = np.atleast_1d(np.asarray(indices, dtype=np.int64))
        if idx.size and (idx.min() < 0 or idx.max() >= self.count):
            raise ValueError(f"indices must be in [0, {self.count - 1}]")
        dv = np.broadcast_to(np.asarray(change, dtype=np.float64), (len(idx), 3))
        if not np.all(np.isfinite(dv)):
            raise ValueError("change must be finite")
        self._velocity_added.append((idx, dv.copy()))

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
        movable = self._build()["inv_mass"] > 0
        free = [k for k, g in enumerate(groups) if movable[g].all()]
        if not free:
            return
        members, change = impulse_velocities(
            self._position,
            self.mass,
            [groups[k] for k in free],
            impulse[free],
            None if angular_impulse is None else angular_impulse[free],
        )
        self._velocity_added.append((members, change))

    def motion(self, groups) -> RigidMotion:
        """Particle sets (index arrays: a body's ``particles``, one ball) as rigid bodies
        now: centres of mass, velocities, angular velocities, inverse masses and inverse
        inertias about the centres (world axes), read from the particles
        (:mod:`motes.rigid.motion`). The velocities are those the next step starts from:
        the last substep's ``(x - x*)/h`` with the changes given since
        (:meth:`set_velocity`, :meth:`add_velocity`, :meth:`add_impulse`). A set holding
        a pinned particle has zero inverse mass and inertia."""
        groups = [np.atleast_1d(np.asarray(g, dtype=np.int64)) for g in groups]
        movable = self._build()["inv_mass"] > 0
        return rigid_motion(self._position, self._next_velocity(), self.mass, groups, movable)

    def _next_velocity(self) -> np.ndarray:
        """(3, n) velocities [m/s] the next substep starts from (the pending changes
        applied in the order :meth:`_substep` applies them)."""
        v = np.zeros((3, self.count))
        if self._h is not None:
            v = (self._position - self._previous) / self._h
        for idx, value in self._velocity_pending:
            v[:, idx] = value.T
        for idx, change in self._velocity_added:
            np.add.at(v, (slice(None), idx), change.T)
        return v

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
        s = self._build()
        index = np.array([b for b, box in enumerate(s["boxes"]) if box is not None], np.int64)
        if len(index) == 0:
            return index, np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3, 3))
        centre, rotation = self.transforms()
        offset = np.array([s["boxes"][b][0] for b in index])
        half = np.array([s["boxes"][b][1] for b in index])
        axes = np.array([s["boxes"][b][2] for b in index])
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
    def position(self) -> np.ndarray:
        """(n, 3) view of the positions [m] (writable: moves particles, keeping velocity
        only if ``previous`` is moved too)."""
        return self._position.T

    @property
    def previous(self) -> np.ndarray:
        """(n, 3) view of the positions one substep ago [m]."""
        return self._previous.T

    @property
    def velocity(self) -> np.ndarray:
        """(n, 3) velocities ``(x - x*)/h`` [m/s] of the last substep (zero before one)."""
        if self._h is None:
            return np.zeros((self.count, 3))
        return (self._position - self._previous).T / self._h

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
        if self._h is None:
            velocities = np.zeros((3, self.count))
        else:
            velocities = (self._position - self._previous) / self._h
        fields = {
            "mass": Field(self.mass, "kg", "particle mass"),
            "previous": Field(self._previous, "m", "positions one substep ago"),
        }
        ids = np.arange(self.count)
        return ParticleState(ids, self._position, velocities, self.radius, fields)

    @property
    def colliders(self) -> tuple:
        """The colliders, in the order added."""
        return tuple(self._colliders)

    @property
    def bodies(self) -> list[Body]:
        return [
            Body(i, b["particles"], len(b["shape"].planes) > 0) for i, b in enumerate(self._bodies)
        ]

    @property
    def constraints(self):
        """The built :class:`~motes.constrain.ConstraintSet` (built on first use)."""
        return self._build()["constraints"]

    def transforms(self) -> tuple[np.ndarray, np.ndarray]:
        """Centres of mass ``(b, 3)`` [m] and rotations ``(b, 3, 3)`` of every body."""
        s = self._build()
        return body_transforms(
            self._position, s["body_start"], s["body_particles"], s["fraction"], s["rest"]
        )

    def energy(self) -> tuple[float, float]:
        """Kinetic and gravitational potential energy [J] of the movable particles.

        Both at the middle of the last substep: the velocity ``(x - x*)/h`` belongs to
        that instant, so the potential is taken at ``(x + x*)/2``. (Pairing it with the
        potential at ``x`` instead makes a falling body seem to lose ``m g Δv h / 2``.)
        """
        s = self._build()
        moving = s["inv_mass"] > 0
        v = self.velocity[moving]
        m = self.mass[moving]
        kinetic = 0.5 * float(m @ (v * v).sum(axis=1))
        middle = 0.5 * (self.position[moving] + self.previous[moving])
        potential = -float(m @ (middle @ self.gravity))
        return kinetic, potential

    def contacts(self) -> np.ndarray:
        """Contacts found per particle during the last step (colliders and bodies)."""
        return self._build()["hits"].copy()

    # --- stepping --------------------------------------------------------------------

    def _build(self) -> dict:
        if self._built is not None:
            return self._built
        n = self.count
        inv_mass = 1.0 / self.mass
        pins = None
        if self._pinned:
            idx = np.concatenate(self._pinned)
            targets = np.concatenate(self._pin_targets)
            _, last = np.unique(idx[::-1], return_index=True)  # a later pin wins
            keep = np.sort(len(idx) - 1 - last)
            pins = Pins(idx[keep], targets[keep])
            inv_mass[pins.indices] = 0.0
        bodies = [self._body_frame(b, inv_mass) for b in self._bodies]
        sizes = [len(b["particles"]) for b in bodies]
        plane_sizes = [len(b["planes"]) for b in bodies]

        def cat(key, shape):
            return np.concatenate([b[key] for b in bodies]) if bodies else np.zeros(shape)

        table, tri, cell_start, cell_tris = pack(self._colliders, self._detections)
        members = np.array(sorted(self._spheres), dtype=np.int64)
        sphere_e = np.array([self._spheres[i] for i in members.tolist()], dtype=np.float64)
        self._built = {
            "constraints": self._constraints.build(n),
            "inv_mass": inv_mass,
            "pins": pins,
            "body_start": np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64),
            "body_particles": cat("particles", (0,)).astype(np.int64),
            "fraction": cat("fraction", (0,)).astype(np.float64),
            "rest": cat("rest", (0, 3)).astype(np.float64),
            "body_inv_mass": np.array([b["inv_mass"] for b in bodies], dtype=np.float64),
            "inertia_inv": np.array([b["inertia_inv"] for b in bodies]).reshape(-1, 3, 3),
            "plane_start": np.concatenate([[0], np.cumsum(plane_sizes)]).astype(np.int64),
            "edge_start": np.concatenate(
                [[0], np.cumsum([len(b["edges"]) for b in bodies])]
            ).astype(np.int64),
            "edges": np.ascontiguousarray(cat("edges", (0, 2)), dtype=np.int64),
            "planes": np.ascontiguousarray(cat("planes", (0, 4)), dtype=np.float64),
            "group": np.array([b["group"] for b in bodies], dtype=np.int64),
            "boxes": [b["box"] for b in bodies],
            "rotation": None,
            "solid": any(plane_sizes) and len(bodies) > 1,
            "table": table,
            "swept": bool(table[:, SWEPT].any()) if len(table) else False,
            "mesh": (tri, cell_start, cell_tris),
            "hits": np.zeros(n, dtype=np.int64),
            "spheres": members,
            "sphere_restitution": sphere_e,
            "bounce": bool(len(table) and table[:, RESTITUTION].any()) or bool(sphere_e.any()),
            "before": np.zeros((3, n)),
        }
        # Body rotations warm-start the compiled refinement (see rigid.body_contacts).
        self._built["rotation"] = np.ascontiguousarray(self.transforms()[1])
        return self._built

    def _body_frame(self, body, inv_mass) -> dict:
        """Rest frame of a body from the particles' masses in the world.

        The mass fractions, the rest positions about the centre of mass, the faces in
        that frame, the inverse mass and rest inverse inertia (0 when a particle is
        pinned: the body is then immovable by contacts).
        """
        index, shape = body["particles"], body["shape"]
        m = self.mass[index]
        centre = m @ shape.positions / m.sum()
        rest = shape.positions - centre
        planes = shape.planes.copy()
        planes[:, 3] -= planes[:, :3] @ centre
        inertia = np.einsum(
            "k,kij->ij",
            m,
            (rest**2).sum(1)[:, None, None] * np.eye(3) - rest[:, :, None] * rest[:, None, :],
        )
        # Flat or thin bodies (a pelvis triangle) have a near-singular inertia: a floor of
        # 1e-6 of its trace keeps the inverse finite.
        inertia += 1e-6 * max(np.trace(inertia), 1e-12) * np.eye(3)
        # Hull edges: particle pairs that share two faces (for edge-across-face contacts).
        pairs = shape.sticks
        if len(shape.planes) and len(pairs):
            scale = max(float(np.ptp(shape.positions, axis=0).max()), 1e-12)
            on = np.abs(shape.positions @ shape.planes[:, :3].T - shape.planes[:, 3]) < 1e-6 * scale
            shared = (on[pairs[:, 0]] & on[pairs[:, 1]]).sum(axis=1)
            edges = index[pairs[shared >= 2]]
        else:
            edges = np.zeros((0, 2), dtype=np.int64)
        movable = bool(np.all(inv_mass[index] > 0))
        box = shape.box_geometry()
        if box is not None:  # its centre and axes in the rest frame
            box = (box[0] - centre, box[1], box[2])
        return {
            "box": box,
            "particles": index,
            "fraction": m / m.sum(),
            "rest": rest,
            "planes": planes,
            "group": body["group"],
            "inv_mass": 1.0 / m.sum() if movable else 0.0,
            "inertia_inv": np.linalg.inv(inertia) if movable else np.zeros((3, 3)),
            "edges": edges.reshape(-1, 2).astype(np.int64),
        }

    def step(self, dt: float) -> None:
        """Advance by ``dt`` [s] in :attr:`substeps` substeps."""
        dt = check.positive("dt", dt)
        s = self._build()
        h = dt / self.substeps
        with threads_for(self.count):
            s["hits"][:] = 0
            for _ in range(self.substeps):
                self._substep(s, h)

    def _restitute(self, s, h) -> None:
        """Velocity pass (Müller et al. 2020, §3.5): restitution of the contacts."""
        x, q, before = self._position, self._previous, s["before"]
        rest = 2.0 * float(np.linalg.norm(self.gravity)) * h * h  # 2 |g| h, times h
        if len(s["table"]):
            tri, cell_start, cell_tris = s["mesh"]
            restitute_contacts(
                *x, *q, *before, self.radius, s["inv_mass"], s["table"],
                tri, cell_start, cell_tris, rest,
            )  # fmt: skip
        if len(s["spheres"]) > 1:
            restitute_spheres(
                *x, *q, *before, s["inv_mass"], self.radius, s["spheres"],
                s["sphere_restitution"], rest,
            )  # fmt: skip

    def _force_move(self, h: float, inv_mass: np.ndarray) -> np.ndarray:
        """``h² F / m`` [m], (3, n), of :attr:`forces` at the start of the substep (taken
        before the Verlet kernel overwrites the previous positions)."""
        x = self._position
        velocity = (x - self._previous) / h
        force = add_forces(self.forces, x, velocity, self.mass, self.time)
        return (h * h) * inv_mass * force

    def _substep(self, s, h) -> None:
        x, q = self._position, self._previous
        for idx, v in self._velocity_pending:
            q[:, idx] = x[:, idx] - v.T * h
        self._velocity_pending.clear()
        # Position Verlet carries velocity as x - x*: a change dv moves x* by -dv h.
        for idx, dv in self._velocity_added:
            np.subtract.at(q, (slice(None), idx), dv.T * h)
        self._velocity_added.clear()
        inv_mass, table, hits = s["inv_mass"], s["table"], s["hits"]
        tri, cell_start, cell_tris = s["mesh"]
        g = self.gravity
        push = self._force_move(h, inv_mass) if self.forces else None
        verlet(*x, *q, inv_mass, g[0], g[1], g[2], math.exp(-self.damping * h), h * h)
        if push is not None:
            x += push
        if s["swept"]:
            sweep_contacts(*x, *q, self.radius, inv_mass, table, tri, cell_start, cell_tris, hits)
        if s["bounce"]:
            s["before"][:] = x  # for the velocity pass (restitution)
        constraints = s["constraints"]
        constraints.reset_multipliers()
        for _ in range(self.iterations):
            if len(constraints):
                constraints.sweep(
                    x,
                    inv_mass,
                    h,
                    sqrt_approximation=self.sqrt_approximation,
                    previous=q,
                    shake=self.projection == "shake",
                )
            if len(table):
                project_contacts(
                    *x, *q, self.radius, inv_mass, table, tri, cell_start, cell_tris, hits
                )
            if len(s["spheres"]) > 1:
                project_spheres(*x, inv_mass, self.radius, s["spheres"], hits)
            if s["solid"]:
                body_contacts(
                    *x,
                    *q,
                    inv_mass,
                    self.radius,
                    s["body_start"],
                    s["body_particles"],
                    s["fraction"],
                    s["rest"],
                    s["body_inv_mass"],
                    s["inertia_inv"],
                    s["plane_start"],
                    s["planes"],
                    s["group"],
                    s["rotation"],
                    s["edge_start"],
                    s["edges"],
                    self.body_friction,
                    hits,
                )
            if s["pins"] is not None:
                s["pins"].apply(x)
        if s["bounce"]:
            self._restitute(s, h)
        self._h = h
        self.time += h
