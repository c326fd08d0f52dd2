"""Hair: strands as particle chains rooted on a moving spherical head.

Each strand is a chain of particles joined by stretch springs. Bending is resisted by a
force proportional to the angle between consecutive segments: the energy
``½ k_b |x_i - 2x_j + x_k|²`` of each joint (``2s sin(θ/2) ≈ sθ`` for segments of
length ``s`` at angle ``θ``), written exactly as three zero-rest-length springs
(:mod:`motes.hair.bending`) so that the implicit integrator assembles it in its compiled
spring path.

The first two particles of each strand are the follicle: they move rigidly with the head
(constraint-filtered, exactly), which fixes the root direction. The rest collide with
the head sphere (push-out with friction) and with any extra colliders. A step is one
implicit Euler solve (Baraff & Witkin 1998) for all strands at once, then a Provot
stretch limit on the stretch springs, then collisions.
"""

from __future__ import annotations

import numpy as np

from .. import _memory
from .. import _validate as check
from .._jit import threads_for
from ..cloth.cloth import BYTES_PER_VERTEX
from ..cloth.drivers import Keyframes
from ..cloth.kernels import collide_kernel
from ..cloth.strain import StrainLimiter
from ..collide.colliders import Collider, Sphere, pack
from ..forces.apply import check_force, force_state, split_implicit
from ..geometry.layout import grown
from ..integrate.implicit import SERIAL_BELOW, ConstraintFilter, ImplicitEuler, SolveReport
from ..state import Field, ParticleState
from .bending import StencilSprings, angle_bending


def euler_matrix(angles_deg) -> np.ndarray:
    """Rotation ``R_y(yaw) R_x(pitch) R_z(roll)`` from (yaw, pitch, roll) [degrees]:
    yaw turns the head about the vertical, pitch nods it."""
    yaw, pitch, roll = np.radians(np.asarray(angles_deg, dtype=np.float64))
    cy, sy, cp, sp, cr, sr = (
        np.cos(yaw),
        np.sin(yaw),
        np.cos(pitch),
        np.sin(pitch),
        np.cos(roll),
        np.sin(roll),
    )
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rx = np.array([[1, 0, 0], [0, cp, -sp], [0, sp, cp]])
    rz = np.array([[cr, -sr, 0], [sr, cr, 0], [0, 0, 1]])
    return ry @ rx @ rz


class Head:
    """A sphere that translates and rotates over time.

    Parameters
    ----------
    center : (3,) array_like
        Centre at rest [m].
    radius : float
        > 0 [m].
    translation : Keyframes, optional
        Offset of the centre [m] over time.
    rotation : Keyframes, optional
        (yaw, pitch, roll) [degrees] over time (see :func:`euler_matrix`).
    friction : float
        Friction of hair on the scalp, in [0, 1] (velocity scaling).
    """

    def __init__(
        self,
        center=(0.0, 0.0, 0.0),
        radius: float = 0.1,
        *,
        translation=None,
        rotation=None,
        friction: float = 0.3,
    ):
        self.center = check.vector("center", center)
        self.radius = check.positive("radius", radius)
        for name, value in (("translation", translation), ("rotation", rotation)):
            if value is not None and not isinstance(value, Keyframes):
                raise TypeError(f"{name} must be Keyframes, got {value!r}")
        self.translation = translation
        self.rotation = rotation
        self.friction = check.unit_interval("friction", friction)

    def pose(self, time: float) -> tuple[np.ndarray, np.ndarray]:
        """Rotation (3, 3) and centre (3,) [m] at ``time`` [s]."""
        r = np.eye(3) if self.rotation is None else euler_matrix(self.rotation(time))
        c = self.center + (0.0 if self.translation is None else self.translation(time))
        return r, c

    def __repr__(self) -> str:
        return f"Head(center={self.center.tolist()}, radius={self.radius})"


def scalp_directions(count: int, *, seed: int = 0, coverage: float = 0.55) -> np.ndarray:
    """``count`` unit vectors spread over the top, back and sides of a head (y up, face
    +z).

    Uniform on the sphere cap ``y >= 1 - 2·coverage`` inside a hairline: above the
    forehead (``z < 0.55`` where ``y > 0.5``), the temples (``z < 0.15`` where
    ``y > 0.15``) and the back (``z < -0.25``); the face stays bare. Drawn from ``seed``.
    """
    rng = np.random.default_rng(check.integer("seed", seed, low=0))
    out = np.empty((0, 3))
    while len(out) < count:
        y = rng.uniform(1 - 2 * coverage, 1.0, 2 * count)
        phi = rng.uniform(0, 2 * np.pi, 2 * count)
        r = np.sqrt(1 - y * y)
        d = np.stack([r * np.cos(phi), y, r * np.sin(phi)], 1)
        z = d[:, 2]
        scalp = ((y > 0.5) & (z < 0.55)) | ((y > 0.15) & (z < 0.15)) | (z < -0.25)
        out = np.concatenate([out, d[scalp]])
    return out[:count]


def growth_directions(roots: np.ndarray, comb, lift: float) -> np.ndarray:
    """Unit directions in which strands leave the scalp at ``roots`` (k, 3) (unit,
    from the head's centre): ``comb`` projected onto the scalp's tangent plane, tilted
    out of it by ``lift`` (``t + lift·n``, normalised; radial where ``comb`` is normal
    to the scalp)."""
    c = np.asarray(comb, dtype=np.float64)
    tangent = c[None, :] - (roots @ c)[:, None] * roots
    size = np.linalg.norm(tangent, axis=1, keepdims=True)
    along = np.where(size > 1e-6, tangent / np.maximum(size, 1e-300), 0.0)
    g = along + lift * roots
    return g / np.linalg.norm(g, axis=1, keepdims=True)


class Hair:
    """Strands of hair on a :class:`Head`.

    Parameters
    ----------
    head : Head
    strands : int
        Number of strands (>= 1).
    particles : int
        Particles per strand including the two root particles (>= 3).
    length : float
        Strand length [m] (> 0).
    length_variation : float
        In [0, 1): strand ``j`` is ``length · (1 - length_variation · u_j)`` long, ``u_j``
        uniform in [0, 1) drawn from ``seed`` (uneven ends read as hair, not a wig).
    directions : (strands, 3) array_like, optional
        Root directions from the head's centre; default :func:`scalp_directions`.
    comb : (3,) array_like or None
        Direction in the head's frame the hair is combed toward (default down and back);
        strands leave the scalp along it (see :func:`growth_directions`), which is also
        their straight rest shape. None: straight out from the scalp.
    lift : float
        How steeply strands leave the scalp (>= 0): the tilt ``t + lift·n`` of the
        combed tangent ``t`` toward the normal ``n``.
    mass : float
        Mass per particle > 0 [kg].
    stretch : (float, float)
        Stiffness [N/m] and damping [N s/m] of the stretch springs.
    bending : (float, float)
        Bending stiffness ``k_b`` [N/m] of ``½ k_b |x_i - 2x_j + x_k|²`` per joint, and a
        damping [N s/m] along ``(i, k)``.
    stretch_limit : float or None
        Largest relative stretch after each step (Provot 1995), or None.
    air_damping : float
        Drag per unit mass >= 0 [1/s], implicit.
    gravity : (3,) array_like
        [m/s²].
    thickness : float
        Distance >= 0 [m] kept from the scalp and colliders.
    colliders : sequence of Collider
        Extra obstacles (shoulders, a floor).
    solver : ImplicitEuler, optional
    seed : int
        For the default root directions.
    forces : sequence of Force or FieldForce
        More forces on the particles, evaluated every step; see :meth:`add_force`.
    """

    def __init__(
        self,
        head: Head,
        *,
        strands: int = 500,
        particles: int = 10,
        length: float = 0.25,
        length_variation: float = 0.0,
        directions=None,
        comb=(0.0, -1.0, -1.0),
        lift: float = 0.3,
        mass: float = 1e-4,
        stretch=(500.0, 0.02),
        bending=(2.0, 0.001),
        stretch_limit: float | None = 0.02,
        air_damping: float = 1.0,
        gravity=(0.0, -9.81, 0.0),
        thickness: float = 0.004,
        colliders=(),
        solver: ImplicitEuler | None = None,
        seed: int = 0,
        forces=(),
    ):
        if not isinstance(head, Head):
            raise TypeError(f"head must be a Head, got {head!r}")
        self.head = head
        s = check.integer("strands", strands, low=1)
        p = check.integer("particles", particles, low=3)
        # The implicit solve holds per particle about what a cloth's holds per vertex.
        _memory.check(
            f"strands × particles = {s} × {p}",
            s * p * BYTES_PER_VERTEX,
            per=f"about {BYTES_PER_VERTEX} B per particle",
        )
        self.length = check.positive("length", length)
        if directions is None:
            directions = scalp_directions(s, seed=seed)
        d = check.points("directions", directions)
        if len(d) != s:
            raise ValueError(f"directions must have one row per strand ({s}), got {len(d)}")
        norm = np.linalg.norm(d, axis=1, keepdims=True)
        if np.any(norm == 0):
            raise ValueError("directions must be non-zero")
        d = d / norm
        self.lift = check.non_negative("lift", lift)
        if comb is None:
            growth = d
        else:
            growth = growth_directions(d, check.unit_vector("comb", comb), self.lift)
        self.strand_count, self.per_strand = s, p
        self.n = s * p
        self.particle_mass = check.positive("mass", mass)
        self.mass = np.full(self.n, self.particle_mass)
        ks, kd = (check.non_negative(f"stretch[{k}]", v) for k, v in enumerate(stretch))
        kb, kbd = (check.non_negative(f"bending[{k}]", v) for k, v in enumerate(bending))
        self.stretch_limit = (
            None if stretch_limit is None else check.positive("stretch_limit", stretch_limit)
        )
        self.air_damping = check.non_negative("air_damping", air_damping)
        self.gravity = check.vector("gravity", gravity)
        self.thickness = check.non_negative("thickness", thickness)
        self.colliders = list(colliders)
        for c in self.colliders:
            if not isinstance(c, Collider):
                raise TypeError(f"colliders must hold Collider objects, got {c!r}")
        self.solver = solver if solver is not None else ImplicitEuler()
        #: Forces added to the springs and gravity (:meth:`add_force`).
        self.forces = [check_force(f) for f in forces]

        # Rest shape: straight from the root along the growth direction, head's frame.
        variation = check.real(
            "length_variation", length_variation, low=0.0, high=1.0, high_open=True
        )
        u = np.random.default_rng([check.integer("seed", seed, low=0), 1]).random(s)
        self.lengths = self.length * (1.0 - variation * u)  #: per strand [m], (strands,)
        segment = self.lengths / (p - 1)  # (s,)
        k = np.arange(p)
        local = (
            head.radius * d[:, None, :] + (segment[:, None] * k)[:, :, None] * growth[:, None, :]
        )
        self._local = local.reshape(-1, 3)
        index = np.arange(self.n).reshape(s, p)
        stretch_pairs = np.stack([index[:, :-1].ravel(), index[:, 1:].ravel()], 1)
        triples = np.stack([index[:, :-2].ravel(), index[:, 1:-1].ravel(), index[:, 2:].ravel()], 1)
        b_pairs, b_rest, b_k, b_kd = angle_bending(triples, kb, kbd)
        self.springs = StencilSprings(
            np.concatenate([stretch_pairs, b_pairs]),
            np.concatenate([np.repeat(segment, p - 1), b_rest]),
            np.concatenate([np.full(len(stretch_pairs), ks), b_k]),
            np.concatenate([np.full(len(stretch_pairs), kd), b_kd]),
        )
        self._limiter = (
            None
            if self.stretch_limit is None
            else StrainLimiter(stretch_pairs, np.repeat(segment, p - 1), self.stretch_limit, 50)
        )

        self._roots = index[:, :2].ravel()
        self._root_local = self._local[self._roots]
        self.constraints = ConstraintFilter(self.n)
        self.constraints.pin(self._roots)
        self._free = np.ones(self.n, dtype=bool)
        self._free[self._roots] = False
        self.time = 0.0
        r, c = head.pose(0.0)
        #: Positions [m] and velocities [m/s], float64 (3, n); strand ``j`` is particles
        #: ``j * per_strand`` to ``(j + 1) * per_strand - 1``, root first.
        self.position = np.ascontiguousarray((self._local @ r.T + c).T)
        self.velocity = np.zeros((3, self.n))
        self.last_report: SolveReport | None = None

    def add_force(self, force):
        """Make ``force`` (a :class:`~motes.forces.Force` or ``FieldForce``) act on the
        particles from the next step on; returns it.

        Field forces are explicit except their linear drag (implicit, like
        ``air_damping``); forces with a Jacobian (radial fields, springs) are implicit,
        vortices, curl noise and callbacks explicit
        (:func:`motes.forces.apply.split_implicit`). The follicles are held: forces on
        them go into the constraints' reaction.
        """
        self.forces.append(check_force(force))
        return force

    def step(self, dt: float) -> None:
        """Advance by ``dt`` seconds."""
        h = check.positive("dt", dt)
        with threads_for(self.n, SERIAL_BELOW):
            self._step(h)

    def _step(self, h: float) -> None:
        r, c = self.head.pose(self.time + h)
        target = (self._root_local @ r.T + c).T
        self.constraints.velocity[:, self._roots] = (target - self.position[:, self._roots]) / h
        external = self.mass[None, :] * self.gravity[:, None]
        others, drag = split_implicit(self.forces, self.velocity, self.mass, external)
        self.last_report = self.solver.step(
            self.position,
            self.velocity,
            self.mass,
            h,
            forces=[self.springs, *others],
            external=external,
            damping=self.air_damping * self.mass + drag,
            constraints=self.constraints,
            store=force_state(self.position, self.velocity, self.mass),
            time=self.time,
        )
        if self._limiter is not None:
            self._limiter.apply(self.position, self.velocity, self.mass, ~self._free, h)
        scalp = Sphere(
            c, self.head.radius + self.thickness, restitution=0.0, friction=self.head.friction
        )
        # The scalp sphere already includes the thickness; the other colliders grow by it.
        table, _ = pack([scalp, *self.colliders])
        table[1:] = grown(table[1:], self.thickness)
        collide_kernel(*self.position, *self.velocity, self._free, table, h)
        self.time += h

    def particle_state(self) -> ParticleState:
        """The particles as a :class:`~motes.state.ParticleState`.

        ``positions`` and ``velocities`` are the hair's float64 rows; ``ids`` are the
        particle indices (strand ``j`` holds ``j * per_strand`` to
        ``(j + 1) * per_strand - 1``, root first); ``radius`` is :attr:`thickness` [m],
        the distance kept from the scalp and colliders. Fields: ``mass`` [kg] (the hair's
        array) and ``strand`` (int64, the strand of each particle; computed).
        """
        ids = np.arange(self.n)
        fields = {
            "mass": Field(self.mass, "kg", "particle mass"),
            "strand": Field(ids // self.per_strand, "", "strand index, root first"),
        }
        radius = np.full(self.n, self.thickness)
        return ParticleState(ids, self.position, self.velocity, radius, fields)

    def strands(self) -> np.ndarray:
        """Positions as (strands, particles, 3) [m]."""
        return self.position.T.reshape(self.strand_count, self.per_strand, 3).copy()

    def segment_lengths(self) -> np.ndarray:
        """(strands, particles - 1) current segment lengths [m]."""
        s = self.strands()
        return np.linalg.norm(np.diff(s, axis=1), axis=2)

    def __repr__(self) -> str:
        return f"Hair({self.strand_count} strands × {self.per_strand} particles)"
