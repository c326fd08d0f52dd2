"""Cloth: a mass-spring triangle mesh stepped by the implicit integrator.

:class:`Cloth` is the façade: it builds a :class:`~motes.cloth.model.ClothModel` (what
stays fixed), holds a :class:`~motes.cloth.state.ClothState` (positions, velocities,
time, the solver's warm start) and a :class:`~motes.cloth.state.ClothControl` (pins and
handles), and steps them with :func:`motes.cloth.stepping.step`:

1. explicit forces: gravity, the wind's per-triangle drag and lift, and added forces
   (:meth:`Cloth.add_force`; those with a Jacobian go to the implicit solve);
2. the integrator: implicit Euler (Baraff & Witkin 1998) with the springs (the families
   and those of :meth:`Cloth.add_springs`) and the air damping implicit, pins and moving
   handles as constraint filters, or an explicit scheme for comparison;
3. strain limiting (Provot 1995): over-stretched structural springs are shortened;
4. collisions with planes, spheres, boxes (push-out, restitution, friction) and
   triangle meshes.

Not handled: self-collision (the cloth passes through itself).
"""

from __future__ import annotations

import numpy as np

from .. import _memory
from .. import _validate as check
from ..integrate.implicit import ConstraintFilter, ImplicitEuler, SolveReport
from ..state import Field, ParticleState
from . import stepping, topology
from .drivers import Airflow, Keyframes
from .model import (
    BENDING,
    BYTES_PER_VERTEX,
    SHEAR,
    STRUCTURAL,
    ClothModel,
    Scheme,
    SpringFamily,
    build_model,
    spring_pairs,
)
from .state import ClothControl, ClothState, Handle, MassSpringFacade

__all__ = ["BYTES_PER_VERTEX", "Cloth", "Scheme", "SpringFamily"]


class Cloth(MassSpringFacade):
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

    The parameters make :attr:`model` (:func:`~motes.cloth.model.build_model` checks
    them); the positions start at ``vertices`` at rest, time 0 (:attr:`state`).
    """

    _STATE = ClothState
    _UNITS = "vertices"

    def __init__(
        self,
        vertices,
        faces,
        *,
        springs: topology.Topology | None = None,
        density: float = 0.2,
        structural=STRUCTURAL,
        shear=SHEAR,
        bending=BENDING,
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
        self._model = build_model(
            vertices,
            faces,
            springs=springs,
            density=density,
            structural=structural,
            shear=shear,
            bending=bending,
            gravity=gravity,
            air_damping=air_damping,
            wind=wind,
            colliders=colliders,
            thickness=thickness,
            strain_limit=strain_limit,
            strain_iterations=strain_iterations,
            scheme=scheme,
            solver=solver,
            forces=forces,
        )
        n = self._model.vertex_count
        rest = check.points("vertices", vertices)
        self._state = ClothState(np.ascontiguousarray(rest.T), np.zeros((3, n)))
        self._control = ClothControl.free(n)
        #: The latest implicit solve's report (None before one).
        self.last_report: SolveReport | None = None

    # -- model, state, control ------------------------------------------------------
    @property
    def model(self) -> ClothModel:
        """What stays fixed while stepping (:class:`~motes.cloth.model.ClothModel`);
        :meth:`add_force` and :meth:`add_springs` replace it."""
        return self._model

    @property
    def state(self) -> ClothState:
        """The live state (:class:`~motes.cloth.state.ClothState`): positions,
        velocities, time and the solver's warm start. ``cloth.state.copy()`` saves it;
        ``cloth.state = saved`` rewinds to a copy of ``saved`` (same vertex count), and
        the steps from there repeat bit for bit (pins and handles are not part of it)."""
        return self._state

    @state.setter
    def state(self, value: ClothState) -> None:
        self._replace_state(value)

    @property
    def control(self) -> ClothControl:
        """Pins and handles (:class:`~motes.cloth.state.ClothControl`)."""
        return self._control

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
        self._control.constraints.pin(indices)

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
        self._control.constraints.pin(idx)
        anchor = self.position[:, idx] - w * path(self.time)[:, None]
        self._control.handles.append(Handle(idx, anchor, path, w))

    def release(self, indices) -> None:
        """Free pinned or handled particles."""
        idx = np.atleast_1d(np.asarray(indices, dtype=np.int64))
        control = self._control
        control.constraints.release(idx)
        control.handles[:] = [
            Handle(h.indices[keep], h.anchor[:, keep], h.path, h.weights[keep])
            for h in control.handles
            if (keep := ~np.isin(h.indices, idx)).any()
        ]

    @property
    def pinned(self) -> np.ndarray:
        """Bool (n,): particles held by a pin or a handle."""
        return self._control.constraints.constrained

    @property
    def constraints(self) -> ConstraintFilter:
        """The pins' and handles' constraint filter (:attr:`control`'s)."""
        return self._control.constraints

    # -- forces and springs ---------------------------------------------------------
    def external_force(self) -> np.ndarray:
        """Gravity and wind on each particle [N], (3, n), at the current state."""
        return stepping.external_force(self._model, self._state)

    def add_force(self, force):
        """Make ``force`` (a :class:`~motes.forces.Force` or ``FieldForce``) act on the
        vertices from the next step on; returns it.

        With the implicit scheme, field forces are explicit except their linear drag
        (implicit, like ``air_damping``), and forces with a Jacobian (radial fields,
        springs) are implicit; vortices, curl noise and callbacks are explicit
        (:func:`motes.forces.apply.split_implicit`).
        """
        self._model = self._model.with_force(force)
        return force

    #: Model values :meth:`retune` may replace: none of them changes the vertices, the
    #: faces, the masses or what the cloth collides with.
    RETUNABLE = ("structural", "shear", "bending", "springs", "gravity", "air_damping", "forces")
    SHAPE = ("vertex_count", "faces")

    def add_springs(self, pairs, stiffness, damping=0.0, rest_length=None) -> None:
        """Join chosen vertices by springs, from the next step on: a seam stitched shut,
        a tether, a drawstring.

        They join :attr:`springs`, so the implicit solve treats them implicitly with
        their Jacobian, like the cloth's own springs (strain limiting does not touch
        them).

        Parameters
        ----------
        pairs : (k, 2) array_like of int
            Vertex indices ``(a, b)`` in [0, n - 1], ``a != b``.
        stiffness : float or (k,) array_like
            ``k_s`` >= 0 [N/m].
        damping : float or (k,) array_like
            ``k_d`` >= 0 [N s/m], along the spring.
        rest_length : float or (k,) array_like, optional
            Finite, >= 0 [m]; 0 makes a stitch that pulls the two vertices together.
            Default: their distance now.
        """
        pairs = spring_pairs(pairs, self.n)
        if rest_length is None:
            x = self.position
            rest_length = np.linalg.norm(x[:, pairs[:, 0]] - x[:, pairs[:, 1]], axis=0)
        self._model = self._model.with_springs(pairs, stiffness, damping, rest_length)

    def force(self) -> np.ndarray:
        """Total force on each particle [N], (3, n): springs, gravity, wind, air damping
        and :attr:`forces`.

        Pins and handles excluded (their reaction is whatever balances this).
        """
        return stepping.total_force(self._model, self._state)

    def energy(self) -> float:
        """Kinetic + spring + gravitational potential energy [J]."""
        return stepping.energy(self._model, self._state)

    # -- stepping -------------------------------------------------------------------
    def step(self, dt: float) -> None:
        """Advance by ``dt`` seconds."""
        report = stepping.step(self._model, self._state, self._control, dt)
        if report is not None:
            self.last_report = report

    def _step(self, h: float) -> None:
        """:meth:`step` on the current thread count (no one-thread rule)."""
        report = stepping.advance(self._model, self._state, self._control, h)
        if report is not None:
            self.last_report = report

    @property
    def strain_passes(self) -> int:
        """Strain-limiting passes the latest step took (0 without a limit)."""
        limiter = self._model.strain_limiter
        return 0 if limiter is None else limiter.passes

    # -- the model's parameters -----------------------------------------------------
    @property
    def n(self) -> int:
        """Number of vertices."""
        return self._model.vertex_count

    @property
    def faces(self) -> np.ndarray:
        """Triangles, int64 (f, 3)."""
        return self._model.faces

    @property
    def mass(self) -> np.ndarray:
        """Vertex masses [kg], (n,). Assigning one replaces the model."""
        return self._model.vertex_mass

    @mass.setter
    def mass(self, value) -> None:
        self._model = self._model.with_vertex_mass(value)

    @property
    def springs(self):
        """Every spring (:class:`~motes.forces.springs.Springs`): the families', then
        those of :meth:`add_springs`."""
        return self._model.springs

    @property
    def topology(self) -> topology.Topology:
        """The spring families' pairs."""
        return self._model.topology

    @property
    def families(self) -> dict[str, SpringFamily]:
        """Structural, shear and bending :class:`SpringFamily` by name (a new dict)."""
        m = self._model
        return {"structural": m.structural, "shear": m.shear, "bending": m.bending}

    @property
    def density(self) -> float:
        """Areal density [kg/m²]."""
        return self._model.density

    @property
    def gravity(self) -> np.ndarray:
        """[m/s²], (3,)."""
        return self._model.gravity

    @property
    def air_damping(self) -> float:
        """Drag per unit mass [1/s]."""
        return self._model.air_damping

    @property
    def wind(self) -> Airflow | None:
        """Aerodynamic drag and lift, or None."""
        return self._model.wind

    @property
    def colliders(self) -> tuple:
        """Planes, spheres, boxes and triangle meshes."""
        return self._model.colliders

    @property
    def thickness(self) -> float:
        """Distance [m] kept from collider surfaces."""
        return self._model.thickness

    @property
    def strain_limit(self) -> float | None:
        """Largest stretch of structural springs, or None."""
        return self._model.strain_limit

    @property
    def strain_iterations(self) -> int:
        """Most strain-limiting passes per step."""
        return self._model.strain_iterations

    @property
    def scheme(self) -> Scheme:
        """Time integration."""
        return self._model.scheme

    @property
    def solver(self) -> ImplicitEuler:
        """Settings of the implicit solve."""
        return self._model.solver

    @property
    def forces(self) -> tuple:
        """Forces added to springs, gravity and wind (:meth:`add_force`)."""
        return self._model.forces

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
            "pinned": Field(self.pinned, "", "held by a pin or a handle"),
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
        m = self._model
        s = m.structural_pairs
        d = self.position[:, s[:, 0]] - self.position[:, s[:, 1]]
        return np.linalg.norm(d, axis=0) / m.structural_rest_length - 1.0

    def __repr__(self) -> str:
        return (
            f"Cloth({self.n} particles, {self.springs.spring_count} springs, "
            f"scheme={self.scheme.value!r})"
        )
