"""What hair is while it runs: strands, springs, the head, forces and solver settings.

:class:`HairModel` holds everything that does not change while stepping; positions,
velocities and time are a :class:`~motes.hair.state.HairState`, the follicles held by
the head a :class:`~motes.hair.state.HairControl`. :func:`build_model` validates the
parameters of :class:`~motes.hair.Hair` and assembles the model.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .. import _memory
from .. import _validate as check
from ..cloth.model import BYTES_PER_VERTEX, vertex_masses
from ..cloth.strain import StrainLimiter
from ..collide.colliders import Collider
from ..forces.apply import check_force
from ..integrate.implicit import ImplicitEuler
from .bending import StencilSprings, angle_bending
from .head import Head, growth_directions, scalp_directions


@dataclass(frozen=True, eq=False)
class HairModel:
    """The parts of hair that stay fixed while it steps.

    Frozen: a new force makes a new model (:meth:`with_force`). The ``solver`` and the
    ``strain_limiter`` keep caches as they run that carry nothing from one step to the
    next (the solver's warm start is set from the state before each step).
    """

    particle_count: int
    """Number of particles ``n = strand_count · particles_per_strand``; strand ``j`` is
    particles ``j · particles_per_strand`` to ``(j + 1) · particles_per_strand - 1``,
    root first."""
    strand_count: int
    """Number of strands."""
    particles_per_strand: int
    """Particles per strand, the two root ones included (>= 3)."""
    head: Head
    """The sphere the strands grow on; its keyframes move the follicles."""
    length: float
    """Nominal strand length [m]."""
    strand_length: np.ndarray
    """Length of each strand [m], float64 (strand_count,)."""
    lift: float
    """Tilt of the strands out of the scalp's tangent plane (``t + lift·n``)."""
    particle_mass: np.ndarray
    """Mass of each particle [kg], float64 (n,)."""
    particle_rest_local: np.ndarray
    """Rest positions in the head's frame [m], float64 (n, 3): straight strands."""
    root_indices: np.ndarray
    """The follicle particles (the first two of each strand), int64 (2 · strand_count,)."""
    root_local: np.ndarray
    """Follicle positions in the head's frame [m], float64 (2 · strand_count, 3)."""
    particle_free: np.ndarray
    """Bool (n,): not a follicle (integrated, collides)."""
    springs: StencilSprings
    """Stretch springs, then the bending stencils (zero rest length, signed stiffness
    [N/m], :func:`~motes.hair.bending.angle_bending`)."""
    stretch_limit: float | None
    """Largest relative stretch of a segment after a step, or None."""
    strain_limiter: StrainLimiter | None
    """Provot's correction of the stretch springs, None without a limit."""
    air_damping: float
    """Drag per unit mass [1/s], implicit."""
    gravity: np.ndarray
    """Acceleration of gravity [m/s²], float64 (3,)."""
    thickness: float
    """Distance [m] kept from the scalp and colliders."""
    colliders: tuple[Collider, ...]
    """Obstacles besides the head (planes, spheres, boxes)."""
    solver: ImplicitEuler
    """Settings of the implicit solve."""
    forces: tuple
    """Forces added to the springs and gravity (``Force`` or ``FieldForce``)."""

    def with_force(self, force) -> HairModel:
        """This model with ``force`` (checked) added to :attr:`forces`."""
        return replace(self, forces=(*self.forces, check_force(force)))

    def with_particle_mass(self, mass) -> HairModel:
        """This model with particle masses ``mass`` [kg], (n,), finite and > 0."""
        return replace(self, particle_mass=vertex_masses(mass, self.particle_count))


def build_model(
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
) -> HairModel:
    """The model of hair on ``head``; the parameters are :class:`~motes.hair.Hair`'s
    (each checked, messages name it)."""
    if not isinstance(head, Head):
        raise TypeError(f"head must be a Head, got {head!r}")
    s = check.integer("strands", strands, low=1)
    p = check.integer("particles", particles, low=3)
    # The implicit solve holds per particle about what a cloth's holds per vertex.
    _memory.check(
        f"strands × particles = {s} × {p}",
        s * p * BYTES_PER_VERTEX,
        per=f"about {BYTES_PER_VERTEX} B per particle",
    )
    length = check.positive("length", length)
    if directions is None:
        directions = scalp_directions(s, seed=seed)
    d = check.points("directions", directions)
    if len(d) != s:
        raise ValueError(f"directions must have one row per strand ({s}), got {len(d)}")
    norm = np.linalg.norm(d, axis=1, keepdims=True)
    if np.any(norm == 0):
        raise ValueError("directions must be non-zero")
    d = d / norm
    lift = check.non_negative("lift", lift)
    growth = d if comb is None else growth_directions(d, check.unit_vector("comb", comb), lift)
    n = s * p
    particle_mass = check.positive("mass", mass)
    ks, kd = (check.non_negative(f"stretch[{k}]", v) for k, v in enumerate(stretch))
    kb, kbd = (check.non_negative(f"bending[{k}]", v) for k, v in enumerate(bending))
    if stretch_limit is not None:
        stretch_limit = check.positive("stretch_limit", stretch_limit)
    air_damping = check.non_negative("air_damping", air_damping)
    gravity = check.vector("gravity", gravity)
    thickness = check.non_negative("thickness", thickness)
    colliders = tuple(colliders)
    for c in colliders:
        if not isinstance(c, Collider):
            raise TypeError(f"colliders must hold Collider objects, got {c!r}")
    solver = solver if solver is not None else ImplicitEuler()
    forces = tuple(check_force(f) for f in forces)

    # Rest shape: straight from the root along the growth direction, head's frame.
    variation = check.real("length_variation", length_variation, low=0.0, high=1.0, high_open=True)
    u = np.random.default_rng([check.integer("seed", seed, low=0), 1]).random(s)
    lengths = length * (1.0 - variation * u)
    segment = lengths / (p - 1)  # (s,)
    k = np.arange(p)
    local = head.radius * d[:, None, :] + (segment[:, None] * k)[:, :, None] * growth[:, None, :]
    local = local.reshape(-1, 3)
    index = np.arange(n).reshape(s, p)
    stretch_pairs = np.stack([index[:, :-1].ravel(), index[:, 1:].ravel()], 1)
    triples = np.stack([index[:, :-2].ravel(), index[:, 1:-1].ravel(), index[:, 2:].ravel()], 1)
    b_pairs, b_rest, b_k, b_kd = angle_bending(triples, kb, kbd)
    springs = StencilSprings(
        np.concatenate([stretch_pairs, b_pairs]),
        np.concatenate([np.repeat(segment, p - 1), b_rest]),
        np.concatenate([np.full(len(stretch_pairs), ks), b_k]),
        np.concatenate([np.full(len(stretch_pairs), kd), b_kd]),
    )
    limiter = (
        None
        if stretch_limit is None
        else StrainLimiter(stretch_pairs, np.repeat(segment, p - 1), stretch_limit, 50)
    )
    roots = index[:, :2].ravel()
    free = np.ones(n, dtype=bool)
    free[roots] = False
    return HairModel(
        particle_count=n,
        strand_count=s,
        particles_per_strand=p,
        head=head,
        length=length,
        strand_length=lengths,
        lift=lift,
        particle_mass=np.full(n, particle_mass),
        particle_rest_local=local,
        root_indices=roots,
        root_local=local[roots],
        particle_free=free,
        springs=springs,
        stretch_limit=stretch_limit,
        strain_limiter=limiter,
        air_damping=air_damping,
        gravity=gravity,
        thickness=thickness,
        colliders=colliders,
        solver=solver,
        forces=forces,
    )
