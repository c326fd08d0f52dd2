"""What a cloth is while it runs: topology, masses, springs, forces and solver settings.

:class:`ClothModel` holds everything that does not change while stepping; the
positions, velocities and time are a :class:`~motes.cloth.state.ClothState`, pins and
handles a :class:`~motes.cloth.state.ClothControl` (the split of Newton's ``Model``,
``State`` and ``Control``). :func:`build_model` validates a cloth's parameters and
assembles its model; adding a force or springs gives a new model
(:meth:`ClothModel.with_force`, :meth:`ClothModel.with_springs`), never one changed in
place.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from enum import StrEnum

import numpy as np

from .. import _memory
from .. import _validate as check
from ..collide.colliders import Collider
from ..collide.mesh import TriangleMeshCollider
from ..forces.apply import check_force
from ..forces.springs import Springs
from ..integrate.implicit import ImplicitEuler
from . import topology
from .drivers import Airflow
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


#: Default stiffness [N/m] and damping [N s/m] of each family.
STRUCTURAL = SpringFamily(200.0, 0.2)
SHEAR = SpringFamily(50.0, 0.05)
BENDING = SpringFamily(5.0, 0.01)


def _family(name: str, value) -> SpringFamily:
    if isinstance(value, SpringFamily):
        return value
    try:
        k, kd = (value, 0.0) if np.ndim(value) == 0 else value
        return SpringFamily(float(k), float(kd))
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name} must be a stiffness or (stiffness, damping): {error}") from None


@dataclass(frozen=True, eq=False)
class ClothModel:
    """The parts of a cloth that stay fixed while it steps.

    Frozen: a new force or new springs make a new model (:meth:`with_force`,
    :meth:`with_springs`). Two objects in it keep caches as they run, neither of which
    carries anything from one step to the next: the ``solver`` (its sparsity pattern; its
    warm start is set from the state before each step) and the ``strain_limiter`` (its
    spring order, a function of the pins).
    """

    vertex_count: int
    """Number of vertices ``n`` (the cloth's particles)."""
    faces: np.ndarray
    """Triangles, int64 (f, 3): vertex indices, counter-clockwise."""
    topology: topology.Topology
    """The spring families' pairs, and the vertices [m] (n, 3) they were built on."""
    density: float
    """Areal density [kg/m²]."""
    vertex_mass: np.ndarray
    """Lumped vertex masses [kg], float64 (n,): a third of each triangle's mass per
    corner, all > 0."""
    structural: SpringFamily
    """Stiffness [N/m] and damping [N s/m] of the structural springs."""
    shear: SpringFamily
    """Stiffness [N/m] and damping [N s/m] of the shear springs."""
    bending: SpringFamily
    """Stiffness [N/m] and damping [N s/m] of the bending springs."""
    springs: Springs
    """Every spring, one :class:`~motes.forces.springs.Springs` (implicit, compiled): the
    families with a non-zero stiffness or damping, then springs added between chosen
    vertices in the order they were added; rest lengths [m]."""
    structural_pairs: np.ndarray
    """Vertex pairs of the structural springs, int64 (s, 2): the ones strain limiting
    and :meth:`~motes.cloth.Cloth.stretch` measure."""
    structural_rest_length: np.ndarray
    """Rest length of each structural spring [m], float64 (s,)."""
    vertex_triangle_start: np.ndarray
    """Vertex -> triangle incidence, CSR pointers, int64 (n + 1,): vertex ``i``'s
    triangles are ``vertex_triangles[start[i]:start[i + 1]]`` (the wind's gather)."""
    vertex_triangles: np.ndarray
    """Triangle of each incidence, int64 (3 f,)."""
    gravity: np.ndarray
    """Acceleration of gravity [m/s²], float64 (3,)."""
    air_damping: float
    """Drag per unit mass [1/s] on absolute velocity (``f = -c m v``), implicit."""
    wind: Airflow | None
    """Aerodynamic drag and lift per triangle, or None."""
    colliders: tuple[Collider, ...]
    """Every collider, in the order given."""
    collider_shapes: tuple[Collider, ...]
    """The planes, spheres and boxes of ``colliders`` (the particle kernel's geometry)."""
    collider_meshes: tuple[TriangleMeshCollider, ...]
    """The triangle meshes of ``colliders`` (swept, then projected out)."""
    thickness: float
    """Distance [m] kept between vertices and collider surfaces."""
    strain_limit: float | None
    """Largest relative stretch of a structural spring after a step, or None."""
    strain_iterations: int
    """Most strain-limiting passes per step (>= 1)."""
    strain_limiter: StrainLimiter | None
    """Provot's correction of the structural springs, None without a limit."""
    scheme: Scheme
    """Time integration."""
    solver: ImplicitEuler
    """Settings of the implicit solve (tolerance, iterations, warm start)."""
    forces: tuple
    """Forces added to springs, gravity and wind (``Force`` or ``FieldForce``)."""

    def with_force(self, force) -> ClothModel:
        """This model with ``force`` (checked) added to :attr:`forces`."""
        return replace(self, forces=(*self.forces, check_force(force)))

    def with_vertex_mass(self, mass) -> ClothModel:
        """This model with vertex masses ``mass`` [kg], (n,), finite and > 0."""
        m = vertex_masses(mass, self.vertex_count)
        return replace(self, vertex_mass=m)

    def with_springs(self, pairs, stiffness, damping, rest_length) -> ClothModel:
        """This model with springs between chosen vertices added to :attr:`springs`.

        Parameters
        ----------
        pairs : (k, 2) array_like of int
            Vertex indices in [0, n - 1], two different ones per spring.
        stiffness, damping : float or (k,) array_like
            ``k_s`` >= 0 [N/m] and ``k_d`` >= 0 [N s/m].
        rest_length : float or (k,) array_like
            Finite, >= 0 [m] (0: a stitch that pulls the two vertices together).
        """
        pairs = spring_pairs(pairs, self.vertex_count)
        k = len(pairs)
        ks = _per_spring("stiffness", stiffness, k, "[N/m]")
        kd = _per_spring("damping", damping, k, "[N s/m]")
        rest = _per_spring("rest_length", rest_length, k, "[m]")
        s = self.springs
        springs = Springs(
            np.concatenate([s.pairs, pairs]),
            np.concatenate([s.rest_length, rest]),
            np.concatenate([s.stiffness, ks]),
            np.concatenate([s.damping, kd]),
        )
        return replace(self, springs=springs)


def vertex_masses(mass, n: int) -> np.ndarray:
    """``mass`` as float64 (n,) [kg], checked finite and > 0 (no copy when it is one)."""
    m = np.asarray(mass, dtype=np.float64)
    if m.shape != (n,) or not np.all(np.isfinite(m)) or np.any(m <= 0):
        raise ValueError(f"mass must be finite and > 0 with shape ({n},) [kg], got {m.shape}")
    return m


def spring_pairs(pairs, n: int) -> np.ndarray:
    """``pairs`` as int64 (k, 2) vertex indices, checked: each in [0, n - 1], no vertex
    joined to itself, at least one pair."""
    p = np.asarray(pairs)
    if p.ndim == 1 and p.shape == (2,):
        p = p[None, :]
    if p.ndim != 2 or p.shape[1] != 2 or p.shape[0] == 0:
        raise ValueError(f"pairs must be a (k, 2) array of vertex indices, k >= 1, got {p.shape}")
    if p.dtype.kind not in "iu":
        raise ValueError(f"pairs must be integer vertex indices, got dtype {p.dtype}")
    bad = (p < 0) | (p >= n)
    if bad.any():
        row = int(np.flatnonzero(bad.any(axis=1))[0])
        raise ValueError(
            f"pairs must index vertices in [0, {n - 1}], pair {row} is {p[row].tolist()}"
        )
    same = p[:, 0] == p[:, 1]
    if same.any():
        row = int(np.flatnonzero(same)[0])
        raise ValueError(
            f"pairs must join two different vertices, pair {row} joins vertex {p[row, 0]} to itself"
        )
    return p.astype(np.int64)


def _per_spring(name: str, value, k: int, unit: str) -> np.ndarray:
    """A float or (k,) values, finite and >= 0, as float64 (k,)."""
    try:
        a = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number or {k} numbers {unit}, got {value!r}") from None
    if a.ndim > 1 or (a.ndim == 1 and a.shape != (k,)):
        raise ValueError(f"{name} must be a number or ({k},) numbers {unit}, got shape {a.shape}")
    if not np.all(np.isfinite(a)) or np.any(a < 0):
        raise ValueError(f"{name} must be finite and >= 0 {unit}, got {value!r}")
    return np.broadcast_to(a, (k,)).copy()


def build_model(
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
) -> ClothModel:
    """The model of a cloth with rest positions ``vertices`` (n, 3) [m]; the parameters
    are :class:`~motes.cloth.Cloth`'s (each checked, messages name it)."""
    vertices = check.points("vertices", vertices)
    n = len(vertices)
    _memory.check(
        f"vertices ({n})", n * BYTES_PER_VERTEX, per=f"about {BYTES_PER_VERTEX} B per vertex"
    )
    faces = np.asarray(faces)
    if faces.ndim != 2 or faces.shape[1] != 3 or faces.dtype.kind not in "iu":
        raise ValueError(f"faces must be an (f, 3) integer array, got {faces.shape}")
    if faces.size == 0 or faces.min() < 0 or faces.max() >= n:
        raise ValueError(f"faces must be non-empty and index vertices in [0, {n - 1}]")
    faces = faces.astype(np.int64)
    top = springs if springs is not None else topology.from_triangles(vertices, faces)
    density = check.positive("density", density)
    mass = topology.vertex_masses(vertices, faces, density)
    if np.any(mass <= 0):
        raise ValueError("every vertex must belong to a triangle of non-zero area")
    families = (
        ("structural", _family("structural", structural)),
        ("shear", _family("shear", shear)),
        ("bending", _family("bending", bending)),
    )
    pairs, rest, ks, kd = [], [], [], []
    for name, family in families:
        p = getattr(top, name)
        if len(p) == 0 or (family.stiffness == 0 and family.damping == 0):
            continue
        pairs.append(p)
        rest.append(np.linalg.norm(vertices[p[:, 0]] - vertices[p[:, 1]], axis=1))
        ks.append(np.full(len(p), family.stiffness))
        kd.append(np.full(len(p), family.damping))
    all_springs = Springs(
        np.concatenate(pairs), np.concatenate(rest), np.concatenate(ks), np.concatenate(kd)
    )
    structural_pairs = np.ascontiguousarray(top.structural, dtype=np.int64)
    structural_rest = np.linalg.norm(
        vertices[structural_pairs[:, 0]] - vertices[structural_pairs[:, 1]], axis=1
    )
    tri_start, tris = topology.vertex_triangles(faces, n)

    gravity = check.vector("gravity", gravity)
    air_damping = check.non_negative("air_damping", air_damping)
    if wind is not None and not isinstance(wind, Airflow):
        raise TypeError(f"wind must be a Airflow, got {wind!r}")
    colliders = tuple(colliders)
    for c in colliders:
        if not isinstance(c, Collider):
            raise TypeError(f"colliders must hold Collider objects, got {c!r}")
    thickness = check.non_negative("thickness", thickness)
    if strain_limit is not None:
        strain_limit = check.positive("strain_limit", strain_limit)
    strain_iterations = check.integer("strain_iterations", strain_iterations, low=1)
    try:
        scheme = Scheme(scheme)
    except ValueError:
        allowed = ", ".join(repr(s.value) for s in Scheme)
        raise ValueError(f"scheme must be one of {allowed}, got {scheme!r}") from None
    return ClothModel(
        vertex_count=n,
        faces=faces,
        topology=top,
        density=density,
        vertex_mass=mass,
        structural=families[0][1],
        shear=families[1][1],
        bending=families[2][1],
        springs=all_springs,
        structural_pairs=structural_pairs,
        structural_rest_length=structural_rest,
        vertex_triangle_start=tri_start,
        vertex_triangles=tris,
        gravity=gravity,
        air_damping=air_damping,
        wind=wind,
        colliders=colliders,
        # Planes, spheres and boxes go through the particle kernel's geometry; triangle
        # meshes through the rigid world's gridded closest-point projection.
        collider_shapes=tuple(c for c in colliders if not isinstance(c, TriangleMeshCollider)),
        collider_meshes=tuple(c for c in colliders if isinstance(c, TriangleMeshCollider)),
        thickness=thickness,
        strain_limit=strain_limit,
        strain_iterations=strain_iterations,
        strain_limiter=None
        if strain_limit is None
        else StrainLimiter(structural_pairs, structural_rest, strain_limit, strain_iterations),
        scheme=scheme,
        solver=solver if solver is not None else ImplicitEuler(tolerance=1e-2),
        forces=tuple(check_force(f) for f in forces),
    )
