"""What a rigid world's step reads and never changes: :class:`WorldModel`.

In the spirit of Newton's ``Model`` (newton-physics): a :class:`~motes.rigid.World` is
the builder; on first use after a builder call it packs its records into one
:class:`WorldModel` — parameters, inverse masses, the built constraints and pins, the
bodies' rest frames, the packed colliders and the sphere contacts — which
:func:`motes.rigid.stepping.step` reads together with a
:class:`~motes.rigid.state.WorldState` (what changes from step to step) and a
:class:`~motes.rigid.state.WorldControl` (the inputs of the next step).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from .. import _validate as check
from ..collide.contact import Detection, pack
from ..constrain import ConstraintBuilder, ConstraintSet, Pins
from ..forces.apply import check_force
from ..geometry.layout import RESTITUTION, SWEPT
from .shapes import BodyShape


def _boolean(name: str, value) -> bool:
    if not isinstance(value, bool):
        raise TypeError(f"{name} must be True or False, got {value!r}")
    return value


# How each parameter is checked, whether given to the constructor or set later.
_CHECKS = {
    "gravity": lambda v: check.vector("gravity", v),
    "damping": lambda v: check.non_negative("damping", v),
    "iterations": lambda v: check.integer("iterations", v, low=1),
    "substeps": lambda v: check.integer("substeps", v, low=1),
    "sqrt_approximation": lambda v: _boolean("sqrt_approximation", v),
    "body_friction": lambda v: check.non_negative("body_friction", v),
    "projection": lambda v: check.choice("projection", v, ("shake", "jakobsen")),
    "forces": lambda v: [check_force(f) for f in v],
}


@dataclass(eq=False)
class WorldParameters:
    """The settings of a world's step (see :class:`~motes.rigid.World` for each).

    Every assignment is checked, so ``world.damping = -1`` fails where it is written.
    A world and its models share one instance: a setting changed between steps applies
    from the next step on, without rebuilding the model.
    """

    gravity: np.ndarray
    """Gravitational acceleration [m/s²], shape (3,)."""
    damping: float
    """Velocity damping rate c [1/s]: each substep keeps ``exp(-c h)`` of the velocity."""
    iterations: int
    """Relaxation iterations per substep, >= 1."""
    substeps: int
    """Substeps per step, >= 1."""
    sqrt_approximation: bool
    """Jakobsen's square-root-free stick projection."""
    body_friction: float
    """Coulomb coefficient between bodies (depth based), >= 0."""
    projection: str
    """Direction sticks push along: ``"shake"`` or ``"jakobsen"``."""
    forces: list
    """Forces besides gravity (``Force`` or ``FieldForce``), evaluated each substep."""

    def __setattr__(self, name: str, value) -> None:
        super().__setattr__(name, _CHECKS[name](value))


@dataclass(frozen=True, eq=False)
class BodyRecord:
    """A body as :meth:`~motes.rigid.World.add_body` recorded it."""

    particles: np.ndarray
    """Its particles (world indices), int64, shape (k,), in the shape's order."""
    shape: BodyShape
    """The shape it was built from (rest positions, masses, faces)."""
    group: int
    """Collision key: bodies with equal keys do not collide (its own index by default,
    ``group + 2**40`` for a given ``group``, so the two never meet)."""


@dataclass(frozen=True, eq=False)
class RestBox:
    """A box body's box in its rest frame (about the rest centre of mass)."""

    centre: np.ndarray
    """Box centre [m], shape (3,)."""
    half_extents: np.ndarray
    """Half edge lengths [m], shape (3,)."""
    axes: np.ndarray
    """Box axes, unit rows, shape (3, 3)."""


@dataclass(frozen=True, eq=False)
class BodyFrame:
    """One body's rest frame, from its particles' masses in the world."""

    particles: np.ndarray
    """Its particles (world indices), int64, shape (k,)."""
    fraction: np.ndarray
    """Each particle's mass over the body's mass, shape (k,)."""
    rest: np.ndarray
    """Rest positions about the rest centre of mass [m], shape (k, 3)."""
    planes: np.ndarray
    """Faces ``(n, d)``: unit outward normal and offset [m] in the rest frame, shape
    (f, 4) (none for a body that is not solid)."""
    edges: np.ndarray
    """Hull edges, particle pairs (world indices) that share two faces, int64,
    shape (e, 2)."""
    group: int
    """Collision key (:attr:`BodyRecord.group`)."""
    inv_mass: float
    """Inverse mass [1/kg]; 0 when a particle is pinned (immovable by contacts)."""
    inertia_inv: np.ndarray
    """Inverse inertia about the centre of mass, rest frame [1/(kg m²)], shape (3, 3);
    0 when immovable."""
    box: RestBox | None
    """Its box when the body is a box (:meth:`BodyShape.box_geometry`)."""


def body_frame(record: BodyRecord, mass: np.ndarray, inv_mass: np.ndarray) -> BodyFrame:
    """Rest frame of ``record`` given the particles' masses ``mass`` (n,) [kg] and
    inverse masses ``inv_mass`` (n,) [1/kg] (0 for pinned particles)."""
    index, shape = record.particles, record.shape
    m = mass[index]
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
    return BodyFrame(
        particles=index,
        fraction=m / m.sum(),
        rest=rest,
        planes=planes,
        edges=edges.reshape(-1, 2).astype(np.int64),
        group=record.group,
        inv_mass=1.0 / m.sum() if movable else 0.0,
        inertia_inv=np.linalg.inv(inertia) if movable else np.zeros((3, 3)),
        box=None if box is None else RestBox(box[0] - centre, box[1], box[2]),
    )


@dataclass(frozen=True, eq=False)
class WorldModel:
    """Everything a world's step reads and does not change, packed for the kernels.

    Built by :attr:`motes.rigid.World.model` (:func:`build_model`); entries of bodies
    are body ``i``'s in ``body_start[i]:body_start[i + 1]`` (``e`` entries in all; a
    particle shared by two bodies has an entry in each).
    """

    parameters: WorldParameters
    """The step's settings (shared with the world, see :class:`WorldParameters`)."""
    particle_count: int
    """Number of particles n."""
    particle_mass: np.ndarray
    """Particle masses [kg], shape (n,) (the world's array ``World.mass``)."""
    particle_inv_mass: np.ndarray
    """Inverse masses [1/kg], shape (n,); 0 for pinned particles."""
    particle_radius: np.ndarray
    """Contact radii [m], shape (n,) (the world's array ``World.radius``)."""
    constraints: ConstraintSet
    """Sticks, ropes, limits and hinge sides, coloured for the sweep."""
    pins: Pins | None
    """Pinned particles and their targets (a later pin of a particle wins)."""
    body_start: np.ndarray
    """Start of each body's entries, int64, shape (b + 1,)."""
    body_particles: np.ndarray
    """Particle of each entry, int64, shape (e,)."""
    body_fraction: np.ndarray
    """Mass of the entry's particle over its body's mass, shape (e,)."""
    body_rest: np.ndarray
    """Rest position of each entry about its body's centre of mass [m], shape (e, 3)."""
    body_inv_mass: np.ndarray
    """Inverse mass of each body [1/kg], shape (b,); 0 for immovable bodies."""
    body_inertia_inv: np.ndarray
    """Inverse inertia of each body, rest frame [1/(kg m²)], shape (b, 3, 3)."""
    body_plane_start: np.ndarray
    """Start of each body's faces in :attr:`body_planes`, int64, shape (b + 1,)."""
    body_planes: np.ndarray
    """Faces ``(n, d)`` in their body's rest frame (unit normal, offset [m]),
    shape (f, 4)."""
    body_edge_start: np.ndarray
    """Start of each body's hull edges in :attr:`body_edges`, int64, shape (b + 1,)."""
    body_edges: np.ndarray
    """Hull edges, particle pairs, int64, shape (k, 2)."""
    body_group: np.ndarray
    """Collision key of each body (:attr:`BodyRecord.group`), int64, shape (b,)."""
    body_box: tuple[RestBox | None, ...]
    """Each body's box in its rest frame, None for bodies that are not boxes."""
    collider_table: np.ndarray
    """Packed collider rows (:mod:`motes.geometry.layout`), shape (c, ROW)."""
    mesh_triangles: np.ndarray
    """Triangles of the mesh colliders [m], shape (t, 9)."""
    mesh_cell_start: np.ndarray
    """CSR starts of the mesh colliders' grid cells, int64."""
    mesh_cell_triangles: np.ndarray
    """Triangles listed per grid cell, int64."""
    sphere_particles: np.ndarray
    """Particles that collide as spheres (:meth:`World.add_sphere_contacts`), sorted,
    int64, shape (s,)."""
    sphere_restitution: np.ndarray
    """Restitution of each sphere particle, in [0, 1], shape (s,)."""
    sphere_pairs: np.ndarray
    """Every pair of sphere particles ``(i, j)``, ``i < j``, sorted, int64, shape
    (s (s - 1) / 2, 2): the pairs the sphere contacts test
    (:mod:`motes.collide.sphere_kernels`)."""
    sphere_pair_restitution: np.ndarray
    """Restitution of each pair, the smaller of its two spheres', shape (s (s - 1) / 2,)."""
    solid: bool
    """Body contacts run: some body has faces, and there is more than one body."""
    swept: bool
    """Some collider is detected a priori (swept tests before the relaxation)."""
    bounce: bool
    """Some collider or sphere has restitution (the velocity pass runs)."""

    @property
    def body_count(self) -> int:
        """Number of bodies b."""
        return len(self.body_start) - 1


def merge_pins(pinned: Sequence[np.ndarray], targets: Sequence[np.ndarray]) -> Pins | None:
    """One :class:`Pins` from the pins in the order given; a later pin of a particle
    wins. None when nothing is pinned."""
    if not pinned:
        return None
    idx = np.concatenate(pinned)
    where = np.concatenate(targets)
    _, last = np.unique(idx[::-1], return_index=True)
    keep = np.sort(len(idx) - 1 - last)
    return Pins(idx[keep], where[keep])


def build_model(
    *,
    parameters: WorldParameters,
    mass: np.ndarray,
    radius: np.ndarray,
    constraints: ConstraintBuilder,
    pins: Pins | None,
    bodies: Sequence[BodyRecord],
    colliders: Sequence,
    detections: Sequence[Detection],
    spheres: Mapping[int, float],
) -> WorldModel:
    """Pack a world's records into a :class:`WorldModel`.

    ``mass`` and ``radius`` (n,) [kg], [m] are kept as given (not copied); ``spheres``
    maps each sphere particle to its restitution.
    """
    n = len(mass)
    inv_mass = 1.0 / mass
    if pins is not None:
        inv_mass[pins.indices] = 0.0
    frames = [body_frame(b, mass, inv_mass) for b in bodies]
    plane_sizes = [len(f.planes) for f in frames]

    def start(sizes):
        return np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)

    def cat(name, empty_shape):
        if not frames:
            return np.zeros(empty_shape)
        return np.concatenate([getattr(f, name) for f in frames])

    table, tri, cell_start, cell_tris = pack(colliders, detections)
    members = np.array(sorted(spheres), dtype=np.int64)
    sphere_e = np.array([spheres[i] for i in members.tolist()], dtype=np.float64)
    first, second = np.triu_indices(len(members), k=1)  # member pairs in member order
    return WorldModel(
        parameters=parameters,
        particle_count=n,
        particle_mass=mass,
        particle_inv_mass=inv_mass,
        particle_radius=radius,
        constraints=constraints.build(n),
        pins=pins,
        body_start=start([len(f.particles) for f in frames]),
        body_particles=cat("particles", (0,)).astype(np.int64),
        body_fraction=cat("fraction", (0,)).astype(np.float64),
        body_rest=cat("rest", (0, 3)).astype(np.float64),
        body_inv_mass=np.array([f.inv_mass for f in frames], dtype=np.float64),
        body_inertia_inv=np.array([f.inertia_inv for f in frames]).reshape(-1, 3, 3),
        body_plane_start=start(plane_sizes),
        body_planes=np.ascontiguousarray(cat("planes", (0, 4)), dtype=np.float64),
        body_edge_start=start([len(f.edges) for f in frames]),
        body_edges=np.ascontiguousarray(cat("edges", (0, 2)), dtype=np.int64),
        body_group=np.array([f.group for f in frames], dtype=np.int64),
        body_box=tuple(f.box for f in frames),
        collider_table=table,
        mesh_triangles=tri,
        mesh_cell_start=cell_start,
        mesh_cell_triangles=cell_tris,
        sphere_particles=members,
        sphere_restitution=sphere_e,
        sphere_pairs=np.stack([members[first], members[second]], axis=1).reshape(-1, 2),
        sphere_pair_restitution=np.minimum(sphere_e[first], sphere_e[second]),
        solid=any(plane_sizes) and len(frames) > 1,
        swept=bool(table[:, SWEPT].any()) if len(table) else False,
        bounce=bool(len(table) and table[:, RESTITUTION].any()) or bool(sphere_e.any()),
    )
