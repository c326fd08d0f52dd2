"""Colliders: planes, spheres and boxes that particles bounce off, stick to or die in.

Detection is a posteriori: after the move, a particle found inside a collider's solid
region is pushed out along the collider's normal, then its velocity responds (see
:mod:`motes.collide.response`). Every collider can hold particles *outside* its solid
(a ball on the ground) or, with ``inside=True``, *inside* it (particles in a tank).
"""

from __future__ import annotations

from enum import IntEnum, StrEnum

import numpy as np

from .. import _validate as check
from .._tracked import Tracked
from ..geometry.layout import Kind, pack_row, stack

__all__ = [
    "Box",
    "Collider",
    "Detection",
    "Friction",
    "Kind",
    "Plane",
    "Response",
    "Sphere",
    "pack",
]


class Response(IntEnum):
    """What a particle does on contact."""

    BOUNCE = 0  #: pushed out; restitution on the normal, friction on the tangent
    STICK = 1  #: pushed out and stopped (velocity zero)
    KILL = 2  #: dies at the end of the step
    EVENT = 3  #: passes through untouched; only a collision event is raised (a trigger)


class Friction(IntEnum):
    """How friction reduces tangential velocity ``v_t`` on contact."""

    #: ``v_t <- (1 - mu) v_t``: simple velocity scaling (mu in [0, 1]).
    SCALE = 0
    #: Coulomb bound with the normal impulse estimated from the penetration depth ``p``:
    #: ``|v_t| <- max(0, |v_t| - mu p / dt)`` (Jakobsen 2001: tangential velocity reduced
    #: in proportion to the penetration depth).
    DEPTH = 1


class Detection(StrEnum):
    """When collisions with a collider are found."""

    #: After the move: penetrating particles are pushed out (a fast particle may pass
    #: through a thin shape between two steps).
    POSTERIORI = "posteriori"
    #: Before the move as well: each particle's path over the step is swept against the
    #: shape (:mod:`motes.geometry.sweep`), so a fast particle cannot pass through a thin
    #: wall and a bounce happens at the time of impact within the step.
    PRIORI = "priori"


class Collider(Tracked):
    """Common response parameters.

    Parameters
    ----------
    restitution : float
        Fraction of the normal speed kept on bounce, in [0, 1].
    friction : float
        mu >= 0 (in [0, 1] for ``Friction.SCALE``).
    friction_model : Friction or str
        ``"scale"`` or ``"depth"``.
    response : Response or str
        ``"bounce"``, ``"stick"``, ``"kill"`` or ``"event"``.
    inside : bool
        Keep particles inside the shape instead of outside it.
    detection : Detection or str
        ``"posteriori"`` (found after the move) or ``"priori"`` (the path over each
        step is swept against the shape as well).
    """

    kind: Kind
    #: Detection when none is given (triangle meshes: swept, as a thin shell cannot be
    #: found after the move).
    default_detection = Detection.POSTERIORI

    def __init__(
        self,
        *,
        restitution: float = 0.5,
        friction: float = 0.0,
        friction_model: Friction | str = Friction.SCALE,
        response: Response | str = Response.BOUNCE,
        inside: bool = False,
        detection: Detection | str | None = None,
    ):
        self.restitution = check.unit_interval("restitution", restitution)
        self.friction_model = _enum("friction_model", friction_model, Friction)
        if self.friction_model == Friction.SCALE:
            self.friction = check.unit_interval("friction", friction)
        else:
            self.friction = check.non_negative("friction", friction)
        self.response = _enum("response", response, Response)
        if not isinstance(inside, bool):
            raise TypeError(f"inside must be True or False, got {inside!r}")
        self.inside = inside
        self.detection = (
            self.default_detection
            if detection is None
            else _enum("detection", detection, Detection)
        )

    @property
    def swept(self) -> bool:
        """Whether paths are swept against this collider (a-priori detection)."""
        return self.detection == Detection.PRIORI

    @property
    def structure(self) -> tuple[int, int, int, int, int]:
        """(kind, inside, response, friction_model, swept): what the compiled kernel
        specialises on."""
        return (
            int(self.kind),
            int(self.inside),
            int(self.response),
            int(self.friction_model),
            int(self.swept),
        )

    def _geometry(self) -> list[float]:
        raise TypeError(f"{type(self).__name__} is abstract")

    def packed(self) -> np.ndarray:
        """This collider as one row of the collider layout (:mod:`motes.geometry.layout`):
        float64, shape (ROW,)."""
        return pack_row(
            self.kind,
            self._geometry(),
            inside=self.inside,
            response=int(self.response),
            friction_model=int(self.friction_model),
            restitution=self.restitution,
            friction=self.friction,
            swept=self.swept,
        )


def _enum(name, value, enum):
    if isinstance(value, enum):
        return value
    if isinstance(value, str) and value.upper() in enum.__members__:
        return enum[value.upper()]
    allowed = ", ".join(repr(m.lower()) for m in enum.__members__)
    raise ValueError(f"{name} must be one of {allowed}, got {value!r}")


class Plane(Collider):
    """Infinite plane ``n · x = offset``; the solid side is where ``n · x < offset``.

    Parameters
    ----------
    normal : (3,) array_like
        Normal pointing to the free side (normalised here).
    offset : float
        Signed distance of the plane from the origin along ``normal`` [m]. Equivalently
        give ``point`` on the plane.
    """

    kind = Kind.PLANE

    def __init__(self, normal=(0.0, 1.0, 0.0), offset: float = 0.0, *, point=None, **response):
        super().__init__(**response)
        if self.inside:
            raise ValueError("inside=True has no meaning for a Plane: flip its normal instead")
        self.normal = check.unit_vector("normal", normal)
        if point is not None:
            self.offset = float(self.normal @ check.vector("point", point))
        else:
            self.offset = check.real("offset", offset)

    def _geometry(self):
        return [*self.normal, self.offset]


class Sphere(Collider):
    """Solid ball (or, with ``inside=True``, a spherical container).

    Parameters
    ----------
    center : (3,) array_like
        [m]
    radius : float
        > 0 [m]
    """

    kind = Kind.SPHERE

    def __init__(self, center=(0.0, 0.0, 0.0), radius: float = 1.0, **response):
        super().__init__(**response)
        self.center = check.vector("center", center)
        self.radius = check.positive("radius", radius)

    def _geometry(self):
        return [*self.center, self.radius]


class Box(Collider):
    """Oriented box (or, with ``inside=True``, a box-shaped tank).

    Parameters
    ----------
    center : (3,) array_like
        [m]
    size : (3,) array_like
        Full edge lengths along the box's own axes, each > 0 [m].
    rotation : (3, 3) array_like, optional
        Columns are the box's axes in world coordinates (orthonormal, right-handed).
        Identity (the default) gives an axis-aligned box.
    """

    kind = Kind.BOX

    def __init__(self, center=(0.0, 0.0, 0.0), size=(1.0, 1.0, 1.0), *, rotation=None, **response):
        super().__init__(**response)
        self.center = check.vector("center", center)
        size = check.vector("size", size)
        if np.any(size <= 0):
            raise ValueError(f"size must be > 0 along every axis, got {size.tolist()}")
        self.half_extent = size / 2
        rot = np.eye(3) if rotation is None else np.asarray(rotation, dtype=np.float64)
        if rot.shape != (3, 3) or not np.all(np.isfinite(rot)):
            raise ValueError(f"rotation must be a finite (3, 3) matrix, got shape {rot.shape}")
        if not np.allclose(rot.T @ rot, np.eye(3), atol=1e-6) or np.linalg.det(rot) < 0:
            raise ValueError("rotation must be orthonormal and right-handed (det = +1)")
        self.rotation = rot

    def _geometry(self):
        return [*self.center, *self.half_extent, *self.rotation.T.ravel()]


def pack(colliders) -> tuple[np.ndarray, tuple]:
    """Table of rows ``(k, ROW)`` and the structure tuple the kernel compiles for."""
    colliders = list(colliders)
    table = stack(c.packed() for c in colliders)
    return table, tuple(c.structure for c in colliders)
