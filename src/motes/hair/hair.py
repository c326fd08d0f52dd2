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
stretch limit on the stretch springs, then collisions (:mod:`motes.hair.stepping`).

:class:`Hair` is the façade over a :class:`~motes.hair.model.HairModel` (what stays
fixed), a :class:`~motes.hair.state.HairState` (positions, velocities, time, the
solver's warm start) and a :class:`~motes.hair.state.HairControl` (the follicles).
"""

from __future__ import annotations

import numpy as np

from ..cloth.state import MassSpringFacade
from ..integrate.implicit import ConstraintFilter, ImplicitEuler, SolveReport
from ..state import Field, ParticleState
from . import stepping
from .head import Head, euler_matrix, growth_directions, scalp_directions
from .model import HairModel, build_model
from .state import HairControl, HairState

__all__ = ["Hair", "Head", "euler_matrix", "growth_directions", "scalp_directions"]


class Hair(MassSpringFacade):
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

    The parameters make :attr:`model` (:func:`~motes.hair.model.build_model` checks
    them); the strands start straight, at rest, on the head at time 0 (:attr:`state`).
    """

    _STATE = HairState
    _UNITS = "particles"

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
        self._model = build_model(
            head,
            strands=strands,
            particles=particles,
            length=length,
            length_variation=length_variation,
            directions=directions,
            comb=comb,
            lift=lift,
            mass=mass,
            stretch=stretch,
            bending=bending,
            stretch_limit=stretch_limit,
            air_damping=air_damping,
            gravity=gravity,
            thickness=thickness,
            colliders=colliders,
            solver=solver,
            seed=seed,
            forces=forces,
        )
        self._state = HairState.at_rest(self._model)
        self._control = HairControl.follicles(self._model)
        #: The latest implicit solve's report (None before one).
        self.last_report: SolveReport | None = None

    # -- model, state, control ------------------------------------------------------
    @property
    def model(self) -> HairModel:
        """What stays fixed while stepping (:class:`~motes.hair.model.HairModel`);
        :meth:`add_force` replaces it."""
        return self._model

    @property
    def state(self) -> HairState:
        """The live state (:class:`~motes.hair.state.HairState`): positions,
        velocities, time and the solver's warm start. ``hair.state.copy()`` saves it;
        ``hair.state = saved`` rewinds to a copy of ``saved`` (same particle count), and
        the steps from there repeat bit for bit."""
        return self._state

    @state.setter
    def state(self, value: HairState) -> None:
        self._replace_state(value)

    @property
    def control(self) -> HairControl:
        """The follicles (:class:`~motes.hair.state.HairControl`)."""
        return self._control

    #: Model values :meth:`retune` may replace: none of them changes the strands, the
    #: masses or what the hair collides with.
    RETUNABLE = ("springs", "air_damping", "gravity", "forces")
    SHAPE = ("particle_count", "strand_count", "particle_rest_local")

    def add_force(self, force):
        """Make ``force`` (a :class:`~motes.forces.Force` or ``FieldForce``) act on the
        particles from the next step on; returns it.

        Field forces are explicit except their linear drag (implicit, like
        ``air_damping``); forces with a Jacobian (radial fields, springs) are implicit,
        vortices, curl noise and callbacks explicit
        (:func:`motes.forces.apply.split_implicit`). The follicles are held: forces on
        them go into the constraints' reaction.
        """
        self._model = self._model.with_force(force)
        return force

    def step(self, dt: float) -> None:
        """Advance by ``dt`` seconds."""
        self.last_report = stepping.step(self._model, self._state, self._control, dt)

    def _step(self, h: float) -> None:
        """:meth:`step` on the current thread count (no one-thread rule)."""
        self.last_report = stepping.advance(self._model, self._state, self._control, h)

    # -- the model's parameters -----------------------------------------------------
    @property
    def n(self) -> int:
        """Number of particles."""
        return self._model.particle_count

    @property
    def strand_count(self) -> int:
        """Number of strands."""
        return self._model.strand_count

    @property
    def per_strand(self) -> int:
        """Particles per strand, the two root ones included."""
        return self._model.particles_per_strand

    @property
    def head(self) -> Head:
        """The head the strands grow on."""
        return self._model.head

    @property
    def length(self) -> float:
        """Nominal strand length [m]."""
        return self._model.length

    @property
    def lengths(self) -> np.ndarray:
        """Length of each strand [m], (strands,)."""
        return self._model.strand_length

    @property
    def lift(self) -> float:
        """Tilt of the strands out of the scalp's tangent plane."""
        return self._model.lift

    @property
    def particle_mass(self) -> float:
        """Mass per particle [kg]."""
        return float(self._model.particle_mass[0])

    @property
    def mass(self) -> np.ndarray:
        """Particle masses [kg], (n,). Assigning one replaces the model."""
        return self._model.particle_mass

    @mass.setter
    def mass(self, value) -> None:
        self._model = self._model.with_particle_mass(value)

    @property
    def springs(self):
        """Stretch springs and bending stencils (:class:`~motes.hair.bending.StencilSprings`)."""
        return self._model.springs

    @property
    def stretch_limit(self) -> float | None:
        """Largest relative stretch after each step, or None."""
        return self._model.stretch_limit

    @property
    def air_damping(self) -> float:
        """Drag per unit mass [1/s]."""
        return self._model.air_damping

    @property
    def gravity(self) -> np.ndarray:
        """[m/s²], (3,)."""
        return self._model.gravity

    @property
    def thickness(self) -> float:
        """Distance [m] kept from the scalp and colliders."""
        return self._model.thickness

    @property
    def colliders(self) -> tuple:
        """Obstacles besides the head."""
        return self._model.colliders

    @property
    def solver(self) -> ImplicitEuler:
        """Settings of the implicit solve."""
        return self._model.solver

    @property
    def forces(self) -> tuple:
        """Forces added to the springs and gravity (:meth:`add_force`)."""
        return self._model.forces

    @property
    def constraints(self) -> ConstraintFilter:
        """The follicles' constraint filter (:attr:`control`'s)."""
        return self._control.constraints

    # -- reading --------------------------------------------------------------------
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
