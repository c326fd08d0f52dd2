"""Solid boundaries of a fluid, by signed distance: planes, tanks, boxes and spheres;
and triangle meshes, by collision only (:class:`MeshWall`).

Boundaries pack into the collider rows of every solver (:mod:`motes.geometry.layout`)
and are measured by the one signed distance
(:func:`motes.geometry.distance.signed_distance`). Each keeps fluid particles on its
fluid side: the solver pushes a particle closer than its radius back to that distance
(so no particle leaves a closed tank), counts the wall inside a particle's
neighbourhood as fluid at rest density (the rest lattice continued beyond it,
:func:`motes.fluids.sph.wall_share`), and applies the boundary's own adhesion (Akinci,
Akinci & Teschner 2013) and friction.

Friction models against a boundary, for particles in contact with it:

- ``"scale"``: the tangential velocity is multiplied by ``1 - friction`` each step;
- ``"depth"``: Coulomb friction from the penetration depth: the push-out ``δ`` of the
  step is a normal impulse ``δ / Δt``, which removes up to ``friction · δ / Δt`` of
  tangential speed (all of it when that is smaller: static friction).
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

from .. import _validate
from ..geometry.layout import ROW, Kind, pack_row, stack

#: Friction models by their code in a row's ``FRICTION_MODEL`` column.
FRICTION_MODELS = ("scale", "depth")


class Boundary(ABC):
    """Base of the boundaries: adhesion and friction parameters, and packing.

    Parameters
    ----------
    adhesion : float
        Adhesion strength β of Akinci et al. 2013 (eq. 7) toward this boundary [-].
    friction : float
        Friction against this boundary: the tangential scale per step in [0, 1] for
        ``"scale"``, the Coulomb coefficient (>= 0) for ``"depth"``.
    friction_model : str
        ``"scale"`` or ``"depth"`` (see the module docstring).
    """

    def __init__(self, *, adhesion: float = 0.0, friction: float = 0.0, friction_model="scale"):
        self.adhesion = _validate.non_negative("adhesion", adhesion)
        self.friction_model = _validate.choice("friction_model", friction_model, FRICTION_MODELS)
        if friction_model == "scale":
            self.friction = _validate.unit_interval("friction", friction)
        else:
            self.friction = _validate.non_negative("friction", friction)

    def rows(self) -> np.ndarray:
        """Packed rows (one per primitive, :mod:`motes.geometry.layout`), float64, shape
        (k, ROW)."""
        return stack(
            pack_row(
                kind,
                geometry,
                inside=inside,
                friction_model=FRICTION_MODELS.index(self.friction_model),
                friction=self.friction,
                adhesion=self.adhesion,
            )
            for kind, geometry, inside in self._shapes()
        )

    @abstractmethod
    def _shapes(self) -> list:
        """This boundary's primitives as (kind, geometry, inside) triples."""


class Plane(Boundary):
    """A half-space solid: fluid lives where ``normal · x >= offset``.

    Parameters
    ----------
    normal : sequence of 3 floats
        Normal pointing into the fluid (normalised here).
    point : sequence of 3 floats
        A point on the plane [m].
    """

    def __init__(self, normal=(0.0, 1.0, 0.0), point=(0.0, 0.0, 0.0), **options):
        super().__init__(**options)
        self.normal = _validate.unit_vector("normal", normal)
        self.point = _validate.vector("point", point)

    def _shapes(self):
        return [(Kind.PLANE, [*self.normal, float(self.normal @ self.point)], False)]


class Tank(Boundary):
    """An axis-aligned box that holds fluid inside: five walls, or six with ``closed``.

    The walls are half-spaces, so an open tank's side walls extend upward without end:
    a splash over the rim falls back in.

    Parameters
    ----------
    lower, upper : sequence of 3 floats
        Opposite inner corners [m].
    closed : bool
        Whether a lid closes the top (y = upper y).
    """

    def __init__(self, lower, upper, *, closed: bool = False, **options):
        super().__init__(**options)
        self.lower = _validate.vector("lower", lower)
        self.upper = _validate.vector("upper", upper)
        if np.any(self.upper <= self.lower):
            raise ValueError(f"upper must exceed lower on every axis, got {lower}, {upper}")
        self.closed = bool(closed)

    def moved(self, offset) -> None:
        """Translate the tank by ``offset`` [m] (a shaken tank)."""
        offset = _validate.vector("offset", offset)
        self.lower = self.lower + offset
        self.upper = self.upper + offset

    def _shapes(self):
        # Five or six half-spaces rather than one inside box: each wall then takes its
        # own share of a particle's kernel (corners and edges overlap, see
        # ``kernels.walls``) and an open tank's walls rise without end.
        shapes = []
        for axis in range(3):
            for sign, corner in ((1.0, self.lower), (-1.0, self.upper)):
                if axis == 1 and sign < 0 and not self.closed:
                    continue
                normal = np.zeros(3)
                normal[axis] = sign
                shapes += Plane(normal, corner)._shapes()
        return shapes


class Box(Boundary):
    """A solid box that fluid flows around, oriented by a rotation.

    Parameters
    ----------
    center : sequence of 3 floats
        Centre [m].
    half_extents : sequence of 3 floats
        Half sizes along the box's own axes [m], each > 0.
    rotation : (3, 3) array_like, optional
        Rotation whose columns are the box's axes in world coordinates (the identity,
        an axis-aligned box, by default). A wall that moves with a body takes the body's
        rotation every step (:class:`motes.couple.FloatingBodies`).
    """

    def __init__(self, center, half_extents, *, rotation=None, **options):
        super().__init__(**options)
        self.center = _validate.vector("center", center)
        self.half_extents = _validate.vector("half_extents", half_extents)
        if np.any(self.half_extents <= 0):
            raise ValueError(f"half_extents must be > 0, got {self.half_extents.tolist()}")
        self.rotation = np.eye(3) if rotation is None else rotation

    @property
    def rotation(self) -> np.ndarray:
        """(3, 3) rotation; its columns are the box's axes."""
        return self._rotation

    @rotation.setter
    def rotation(self, value) -> None:
        r = np.asarray(value, dtype=np.float64)
        if r.shape != (3, 3) or not np.allclose(r @ r.T, np.eye(3), atol=1e-6):
            raise ValueError("rotation must be a (3, 3) rotation matrix")
        self._rotation = r

    def _shapes(self):
        # The row holds the axes as unit rows: the rotation's columns.
        return [(Kind.BOX, [*self.center, *self.half_extents, *self._rotation.T.ravel()], False)]


class Sphere(Boundary):
    """A solid ball (fluid outside) or, with ``inside``, a spherical bowl holding fluid.

    Parameters
    ----------
    center : sequence of 3 floats
        Centre [m].
    radius : float
        Radius [m], > 0.
    inside : bool
        Fluid inside the sphere instead of outside.
    """

    def __init__(self, center, radius: float, *, inside: bool = False, **options):
        super().__init__(**options)
        self.center = _validate.vector("center", center)
        self.radius = _validate.positive("radius", radius)
        self.inside = bool(inside)

    def _shapes(self):
        return [(Kind.SPHERE, [*self.center, self.radius], self.inside)]


class MeshWall(Boundary):
    """A triangle mesh the fluid cannot cross: collision only.

    Unlike the signed-distance walls, a mesh does not count toward the density of the
    particles beside it and has no adhesion: after the constraint solve, each particle's
    path over the step is swept against the mesh (stopped at the first hit, bounced with
    ``restitution``), then what lies within half a spacing (plus ``thickness``) is
    projected out with depth friction: the rigid world's kernels
    (:mod:`motes.collide.swept`, :mod:`motes.collide.contact`). Particles beside a
    mesh therefore see a density deficit and settle slightly closer to it than to a
    signed-distance wall.

    Parameters
    ----------
    mesh : TriangleMesh or (vertices (v, 3), faces (f, 3))
        Triangles [m], thin shells seen from both sides.
    thickness : float
        Half-thickness of the shell >= 0 [m].
    friction : float
        Coulomb coefficient >= 0 of the depth friction.
    restitution : float
        Kept fraction of the normal speed at a swept hit, in [0, 1].
    """

    def __init__(self, mesh, *, thickness: float = 0.0, friction: float = 0.0, restitution=0.0):
        from ..collide.mesh import TriangleMeshCollider

        super().__init__(friction=friction, friction_model="depth")
        self.collider = TriangleMeshCollider(
            mesh, thickness=thickness, friction=friction, restitution=restitution
        )

    def _shapes(self):
        # Swept and projected by the rigid world's kernels instead (see above).
        return []


def pack(boundaries) -> np.ndarray:
    """All boundaries as packed rows, float64, shape (k, ROW)."""
    rows = [b.rows() for b in boundaries]
    return np.concatenate(rows) if rows else np.zeros((0, ROW))
