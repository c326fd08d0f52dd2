"""Cloth: a mass-spring triangle mesh stepped by the implicit integrator.

One step (``Cloth.step``):

1. explicit forces: gravity, the wind's per-triangle drag and lift, and added forces
   (:meth:`Cloth.add_force`; those with a Jacobian go to the implicit solve);
2. the integrator: implicit Euler (Baraff & Witkin 1998) with the springs and the air
   damping implicit, pins and moving handles as constraint filters, or an explicit
   scheme for comparison;
3. strain limiting (Provot 1995): over-stretched structural springs are shortened;
4. collisions with planes, spheres and boxes (push-out, restitution, friction).

Not handled: self-collision (the cloth passes through itself) and triangle-mesh
colliders.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

import numpy as np

from .. import _memory
from .. import _validate as check
from .._jit import threads_for
from ..collide import contact
from ..collide.colliders import Collider, pack
from ..collide.contact import project_contacts
from ..collide.mesh import TriangleMeshCollider
from ..collide.swept import sweep_contacts
from ..forces.apply import add_forces, check_force, force_state, split_implicit
from ..forces.springs import Springs
from ..geometry.layout import grown
from ..integrate.implicit import SERIAL_BELOW, ConstraintFilter, ImplicitEuler, SolveReport
from ..state import Field, ParticleState
from . import topology
from .drivers import Airflow, Keyframes
from .kernels import (
    aero_triangle_kernel,
    collide_kernel,
    gather_triangles_kernel,
)
from .strain import StrainLimiter

#: Memory per vertex [bytes] of a cloth that steps (measured peak at 90,000 and
#: 202,500 vertices of a grid: about 2,000 B): positions, springs three ways (topology,
#: forces, per-spring blocks of the implicit solve), triangles and the solver's vectors.
BYTES_PER_VERTEX = 2048


class Scheme(StrEnum):
    """How a cloth advances in time."""

    IMPLICIT_EULER = "implicit_euler"  #: Baraff & Witkin 1998
    EXPLICIT_EULER = "explicit_euler"  #: x += h v0, v += h a (for comparison)
    SEMI_IMPLICIT_EULER = "semi_implicit_euler"  #: v += h a, x += h v1 (symplectic)


@dataclass(frozen=True)
class SpringFamily:
    """Stiffness ``k_s`` [N/m] and damping ``k_d`` [N s/m] of one family of springs."""

    stiffness: float
    damping: float = 0.0

    def __post_init__(self):
        check.non_negative("stiffness", self.stiffness)
        check.non_negative("damping", self.damping)


def _family(name: str, value) -> SpringFamily:
    if isinstance(value, SpringFamily):
        return value
    try:
        k, kd = (value, 0.0) if np.ndim(value) == 0 else value
        return SpringFamily(float(k), float(kd))
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name} must be a stiffness or (stiffness, damping): {error}") from None


class Cloth:
    """A cloth: particles at the vertices of a triangle mesh joined by springs.

    Parameters
    ----------
    vertices : (n, 3) array_like
        Rest positions [m] (spring rest lengths are measured here).
    faces : (f, 3) array_like of int
        Triangles, counter-clockwise.
    springs : Topology, optional
        Spring families; default :func:`topology.from_triangles`.
    density : float
        Areal density > 0 [kg/m²]; each vertex gets a third of its triangles' mass.
    structural, shear, bending : SpringFamily or float or (float, float)
        Stiffness [N/m] and damping [N s/m] of each family.
    gravity : (3,) array_like
        [m/s²].
    air_damping : float
        Drag per unit mass >= 0 [1/s] on absolute velocity (``f = -c m v``), implicit.
    wind : Airflow, optional
        Aerodynamic drag and lift per triangle.
    colliders : sequence of Collider
        Planes, spheres, boxes (their friction and restitution apply) and
        :class:`~motes.collide.TriangleMeshCollider` meshes (projected out with depth
        friction, as in a rigid world; the mesh's own ``thickness`` adds to the cloth's).
    thickness : float
        Distance >= 0 [m] kept between particles and collider surfaces.
    strain_limit : float or None
        Largest stretch of structural springs, e.g. 0.1 for 10 % (Provot 1995), or
        None for none.
    strain_iterations : int
        Most Gauss-Seidel passes of the strain correction per step (>= 1); passes stop
        once no structural spring exceeds the limit by more than 0.1 % strain
        (:mod:`motes.cloth.strain`).
    scheme : Scheme or str
        ``"implicit_euler"`` (default), ``"explicit_euler"`` or ``"semi_implicit_euler"``.
    solver : ImplicitEuler, optional
        Solver settings for the implicit scheme; default tolerance 1e-2 (a 1 m, 64×64
        cloth then ends a 1 s fall within 1.2 mm of a 1e-6 solve, with 54 iterations per
        step against 80 at 1e-3 and 194 at 1e-6).
    forces : sequence of Force or FieldForce
        More forces on the vertices (radial fields, vortices, curl noise, callbacks,
        drag...), evaluated at the cloth's state every step; see :meth:`add_force`.
    """

    def __init__(
        self,
        vertices,
        faces,
        *,
        springs: topology.Topology | None = None,
        density: float = 0.2,
        structural=SpringFamily(200.0, 0.2),
        shear=SpringFamily(50.0, 0.05),
        bending=SpringFamily(5.0, 0.01),
        gravity=(0.0, -9.81, 0.0),
        air_damping: float = 0.1,
        wind: Airflow | None = None,
        colliders=(),
        thickness: float = 0.005,
        strain_limit: float | None = 0.1,
        strain_iterations: int = 50,
        scheme: Scheme | str = Scheme.IMPLICIT_EULER,
        solver: ImplicitEuler | None = None,
        forces=(),
    ):
        vertices = check.points("vertices", vertices)
        _memory.check(
            f"vertices ({len(vertices)})",
            len(vertices) * BYTES_PER_VERTEX,
            per=f"about {BYTES_PER_VERTEX} B per vertex",
        )
        faces = np.asarray(faces)
        if faces.ndim != 2 or faces.shape[1] != 3 or faces.dtype.kind not in "iu":
            raise ValueError(f"faces must be an (f, 3) integer array, got {faces.shape}")
        if faces.size == 0 or faces.min() < 0 or faces.max() >= len(vertices):
            raise ValueError(
                f"faces must be non-empty and index vertices in [0, {len(vertices) - 1}]"
            )
        faces = faces.astype(np.int64)
        self.topology = springs if springs is not None else topology.from_triangles(vertices, faces)
        self.faces = faces
        self.n = len(vertices)
        self.density = check.positive("density", density)
        self.mass = topology.vertex_masses(vertices, faces, self.density)
        if np.any(self.mass <= 0):
            raise ValueError("every vertex must belong to a triangle of non-zero area")
        families = {
            "structural": _family("structural", structural),
            "shear": _family("shear", shear),
            "bending": _family("bending", bending),
        }
        self.families = families
        pairs, rest, ks, kd = [], [], [], []
        for name, family in families.items():
            p = getattr(self.topology, name)
            if len(p) == 0 or (family.stiffness == 0 and family.damping == 0):
                continue
            pairs.append(p)
            rest.append(np.linalg.norm(vertices[p[:, 0]] - vertices[p[:, 1]], axis=1))
            ks.append(np.full(len(p), family.stiffness))
            kd.append(np.full(len(p), family.damping))
        self.springs = Springs(
            np.concatenate(pairs), np.concatenate(rest), np.concatenate(ks), np.concatenate(kd)
        )
        self._structural = np.ascontiguousarray(self.topology.structural, dtype=np.int64)
        self._structural_rest = np.linalg.norm(
            vertices[self._structural[:, 0]] - vertices[self._structural[:, 1]], axis=1
        )
        self._tri_first, self._tris = topology.vertex_triangles(faces, self.n)

        self.gravity = check.vector("gravity", gravity)
        self.air_damping = check.non_negative("air_damping", air_damping)
        if wind is not None and not isinstance(wind, Airflow):
            raise TypeError(f"wind must be a Airflow, got {wind!r}")
        self.wind = wind
        self.colliders = list(colliders)
        for c in self.colliders:
            if not isinstance(c, Collider):
                raise TypeError(f"colliders must hold Collider objects, got {c!r}")
        # Planes, spheres and boxes go through the particle kernel's geometry; triangle
        # meshes through the rigid world's gridded closest-point projection.
        self._shapes = [c for c in self.colliders if not isinstance(c, TriangleMeshCollider)]
        self._meshes = [c for c in self.colliders if isinstance(c, TriangleMeshCollider)]
        self.thickness = check.non_negative("thickness", thickness)
        self.strain_limit = (
            None if strain_limit is None else check.positive("strain_limit", strain_limit)
        )
        self.strain_iterations = check.integer("strain_iterations", strain_iterations, low=1)
        self._limiter = (
            None
            if strain_limit is None
            else StrainLimiter(
                self._structural, self._structural_rest, strain_limit, strain_iterations
            )
        )
        try:
            self.scheme = Scheme(scheme)
        except ValueError:
            allowed = ", ".join(repr(s.value) for s in Scheme)
            raise ValueError(f"scheme must be one of {allowed}, got {scheme!r}") from None
        self.solver = solver if solver is not None else ImplicitEuler(tolerance=1e-2)
        #: Forces added to springs, gravity and wind (:meth:`add_force`).
        self.forces = [check_force(f) for f in forces]

        #: Positions [m] and velocities [m/s], float64 (3, n): the implicit solve's precision.
        self.position = np.ascontiguousarray(vertices.T)
        self.velocity = np.zeros((3, self.n))
        self.time = 0.0
        self.constraints = ConstraintFilter(self.n)
        self._handles: list[tuple] = []
        self._tri_force = np.empty((3, len(faces)))
        self.last_report: SolveReport | None = None

    # -- construction helpers -------------------------------------------------------
    @classmethod
    def grid(
        cls,
        nx: int,
        ny: int,
        *,
        size=(1.0, 1.0),
        origin=(0.0, 0.0, 0.0),
        rotation=None,
        ripple=(0.0, 1.0),
        **options,
    ) -> Cloth:
        """A rectangular ``nx`` × ``ny`` cloth with structural, shear and bending springs.

        In its own frame the cloth lies in the x-y plane with its top-left corner at the
        origin, columns along +x and rows along -y (row 0 on top: a curtain or flag
        hanging from its top edge). ``rotation`` (3, 3) (columns: the frame's axes in
        world coordinates) and ``origin`` [m] place it. ``ripple = (amplitude, wavelength)``
        [m] pleats the rest shape along its normal, ``z = a sin(2π x / λ)`` (a curtain's
        folds; also what lets a compressed cloth buckle instead of shrinking in its plane).
        ``options`` go to :class:`Cloth`.
        """
        nx = check.integer("nx", nx, low=2)
        ny = check.integer("ny", ny, low=2)
        _memory.check(
            f"nx × ny = {nx} × {ny} vertices",
            nx * ny * BYTES_PER_VERTEX,
            per=f"about {BYTES_PER_VERTEX} B per vertex",
        )
        width, height = (check.positive(f"size[{k}]", v) for k, v in enumerate(size))
        rot = np.eye(3) if rotation is None else np.asarray(rotation, dtype=np.float64)
        if rot.shape != (3, 3) or not np.allclose(rot.T @ rot, np.eye(3), atol=1e-6):
            raise ValueError("rotation must be an orthonormal (3, 3) matrix")
        amplitude = check.non_negative("ripple[0]", ripple[0])
        wavelength = check.positive("ripple[1]", ripple[1])
        top = topology.grid(nx, ny, width, height)
        local = top.vertices.copy()
        local[:, 2] = amplitude * np.sin(2 * np.pi * local[:, 0] / wavelength)
        world = local @ rot.T + check.vector("origin", origin)
        top = topology.Topology(world, top.faces, top.structural, top.shear, top.bending)
        cloth = cls(world, top.faces, springs=top, **options)
        cloth.grid_shape = (ny, nx)
        return cloth

    @classmethod
    def from_mesh(cls, mesh, **options) -> Cloth:
        """A cloth from a :class:`~motes.geometry.TriangleMesh`, or an OBJ / PLY path."""
        if not hasattr(mesh, "faces"):
            from ..io.meshes import read_mesh

            mesh = read_mesh(mesh)
        return cls(np.asarray(mesh.vertices, dtype=np.float64), mesh.faces, **options)

    def grid_index(self, rows, cols) -> np.ndarray:
        """Particle indices of grid ``rows`` × ``cols`` (ints, slices or arrays)."""
        shape = getattr(self, "grid_shape", None)
        if shape is None:
            raise TypeError("grid_index needs a cloth made by Cloth.grid")
        return np.arange(self.n).reshape(shape)[rows, cols].ravel()

    # -- pins and handles -----------------------------------------------------------
    def pin(self, indices) -> None:
        """Hold ``indices`` where they are."""
        self.constraints.pin(indices)

    def move(self, indices, path: Keyframes, *, weights=None) -> None:
        """Make ``indices`` a handle: from now on particle ``i`` follows its current
        position translated by ``w_i (path(t) - path(now))``.

        ``weights`` (k,) default to 1; a taper (0 at one end of a curtain rail, 1 at the
        other) gathers the cloth as it is pulled.
        """
        if not isinstance(path, Keyframes):
            raise TypeError(f"path must be Keyframes, got {path!r}")
        idx = np.atleast_1d(np.asarray(indices, dtype=np.int64))
        w = np.ones(idx.size) if weights is None else np.asarray(weights, dtype=np.float64)
        if w.shape != idx.shape or not np.all(np.isfinite(w)):
            raise ValueError(f"weights must be finite with shape {idx.shape}, got {w.shape}")
        self.constraints.pin(idx)
        anchor = self.position[:, idx] - w * path(self.time)[:, None]
        self._handles.append((idx, anchor, path, w))

    def release(self, indices) -> None:
        """Free pinned or handled particles."""
        idx = np.atleast_1d(np.asarray(indices, dtype=np.int64))
        self.constraints.release(idx)
        self._handles = [
            (i[keep], a[:, keep], p, w[keep])
            for i, a, p, w in self._handles
            if (keep := ~np.isin(i, idx)).any()
        ]

    @property
    def pinned(self) -> np.ndarray:
        """Bool (n,): particles held by a pin or a handle."""
        return self.constraints.constrained

    # -- forces ---------------------------------------------------------------------
    def external_force(self) -> np.ndarray:
        """Gravity and wind on each particle [N], (3, n), at the current state."""
        f = self.mass[None, :] * self.gravity[:, None]
        if self.wind is not None:
            w = self.wind
            aero_triangle_kernel(
                *self.position,
                *self.velocity,
                self.faces,
                w.velocity,
                w.packed(),
                self.time,
                w.frequencies,
                w.phases,
                self._tri_force,
            )
            gather_triangles_kernel(self._tri_force, self._tri_first, self._tris, *f)
        return f

    def add_force(self, force):
        """Make ``force`` (a :class:`~motes.forces.Force` or ``FieldForce``) act on the
        vertices from the next step on; returns it.

        With the implicit scheme, field forces are explicit except their linear drag
        (implicit, like ``air_damping``), and forces with a Jacobian (radial fields,
        springs) are implicit; vortices, curl noise and callbacks are explicit
        (:func:`motes.forces.apply.split_implicit`).
        """
        self.forces.append(check_force(force))
        return force

    def force(self) -> np.ndarray:
        """Total force on each particle [N], (3, n): springs, gravity, wind, air damping
        and :attr:`forces`.

        Pins and handles excluded (their reaction is whatever balances this).
        """
        f = self.external_force() - self.air_damping * self.mass * self.velocity
        self.springs.accumulate(None, self.position, self.velocity, self.time, f)
        return add_forces(self.forces, self.position, self.velocity, self.mass, self.time, f)

    def energy(self) -> float:
        """Kinetic + spring + gravitational potential energy [J]."""
        kinetic = 0.5 * float(np.sum(self.mass * self.velocity**2))
        gravity = -float(np.sum(self.mass * (self.gravity @ self.position)))
        return kinetic + self.springs.energy(self.position) + gravity

    # -- stepping -------------------------------------------------------------------
    def step(self, dt: float) -> None:
        """Advance by ``dt`` seconds."""
        h = check.positive("dt", dt)
        with threads_for(self.n, SERIAL_BELOW):
            self._step(h)

    def _step(self, h: float) -> None:
        for idx, anchor, path, w in self._handles:
            target = anchor + w * path(self.time + h)[:, None]
            self.constraints.velocity[:, idx] = (target - self.position[:, idx]) / h
        external = self.external_force()
        start = self.position.copy() if self._meshes else None
        if self.scheme == Scheme.IMPLICIT_EULER:
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
        else:
            add_forces(self.forces, self.position, self.velocity, self.mass, self.time, external)
            self._explicit(h, external)
        free = ~self.pinned
        if self.strain_limit is not None:
            self._limit_strain(h, free)
        if self._shapes:
            self._collide(h, free)
        if self._meshes:
            self._collide_meshes(h, free, start)
        self.time += h

    def _explicit(self, h: float, external: np.ndarray) -> None:
        f = external - self.air_damping * self.mass * self.velocity
        self.springs.accumulate(None, self.position, self.velocity, self.time, f)
        a = f / self.mass
        held = self.pinned
        target = self.constraints.velocity
        if self.scheme == Scheme.EXPLICIT_EULER:
            v_move = np.where(held, target, self.velocity)
            self.velocity = np.where(held, target, self.velocity + h * a)
        else:
            self.velocity = np.where(held, target, self.velocity + h * a)
            v_move = self.velocity
        self.position += h * v_move

    def _limit_strain(self, h: float, free: np.ndarray) -> None:
        """Provot 1995: shorten structural springs stretched past the limit, ordered from
        the pins out, and give the velocities the same change / h
        (:class:`~motes.cloth.strain.StrainLimiter`)."""
        self._limiter.apply(self.position, self.velocity, self.mass, ~free, h)

    @property
    def strain_passes(self) -> int:
        """Strain-limiting passes the latest step took (0 without a limit)."""
        return 0 if self._limiter is None else self._limiter.passes

    def _collide_meshes(self, h: float, free: np.ndarray, start: np.ndarray) -> None:
        """Triangle meshes are thin shells, which a particle can cross within one step:
        each path ``start -> position`` is swept against them first (stopping at the first
        hit and reflecting with the mesh's restitution,
        :func:`motes.collide.swept.sweep_contacts`), then what still lies within
        ``thickness`` is projected out with depth friction
        (:func:`motes.collide.contact.project_contacts`). A particle that touched takes
        the velocity of its corrected travel."""
        table, tri, cell_start, cell_tris = contact.pack(
            self._meshes, [contact.Detection.PRIORI] * len(self._meshes)
        )
        previous = start.copy()  # rewritten by the sweep for particles that hit
        hits = np.zeros(self.n, dtype=np.int64)
        radius = np.full(self.n, self.thickness)
        movable = free.astype(np.float64)
        mesh_data = (table, tri, cell_start, cell_tris, hits)
        sweep_contacts(*self.position, *previous, radius, movable, *mesh_data)
        project_contacts(*self.position, *previous, radius, movable, *mesh_data)
        touched = hits > 0
        self.velocity[:, touched] = (self.position[:, touched] - previous[:, touched]) / h

    def _collide(self, h: float, free: np.ndarray) -> None:
        table, _ = pack(self._shapes)
        collide_kernel(*self.position, *self.velocity, free, grown(table, self.thickness), h)

    # -- reading --------------------------------------------------------------------
    @property
    def diverged(self) -> bool:
        """True once the state is not finite (an explicit step too large blows up)."""
        return not (np.isfinite(self.position).all() and np.isfinite(self.velocity).all())

    def particle_state(self) -> ParticleState:
        """The vertices as a :class:`~motes.state.ParticleState`.

        ``positions`` and ``velocities`` are the cloth's float64 rows (the explicit
        schemes replace ``velocity`` each step: take a new state after one); ``ids`` are
        the vertex indices; ``radius`` is :attr:`thickness` [m], the distance kept from
        colliders. Fields: ``mass`` [kg] (the cloth's array) and ``pinned`` (bool, held
        by a pin or a handle; computed).
        """
        fields = {
            "mass": Field(self.mass, "kg", "vertex mass"),
            "pinned": Field(self.pinned.copy(), "", "held by a pin or a handle"),
        }
        radius = np.full(self.n, self.thickness)
        return ParticleState(np.arange(self.n), self.position, self.velocity, radius, fields)

    def vertices(self) -> np.ndarray:
        """Positions as (n, 3) [m]."""
        return self.position.T.copy()

    def mesh(self):
        """The current shape as a :class:`~motes.geometry.TriangleMesh`."""
        from ..geometry.mesh import TriangleMesh

        return TriangleMesh(self.position.T, self.faces)

    def stretch(self) -> np.ndarray:
        """Relative stretch ``|d|/s - 1`` of each structural spring."""
        s = self._structural
        d = self.position[:, s[:, 0]] - self.position[:, s[:, 1]]
        return np.linalg.norm(d, axis=0) / self._structural_rest - 1.0

    def __repr__(self) -> str:
        return (
            f"Cloth({self.n} particles, {self.springs.spring_count} springs, "
            f"scheme={self.scheme.value!r})"
        )
