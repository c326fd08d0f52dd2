"""Emitter shapes: where new particles appear, sampled uniformly.

Every shape draws ``count`` points uniformly in its stated measure (volume, area or
length) in its own local frame; the emitter adds its position. Each point comes with a
unit normal: the surface normal where the shape has one, otherwise the unit direction
from the shape's local origin to the point (a uniformly random direction where that is
zero). Emitters use it as the launch direction.

Sampling is by inverse transform of the measure, vectorised over all samples; all
randomness comes from the ``numpy.random.Generator`` passed in, so the same generator
state gives identical output.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

import numpy as np

from .. import _validate as check

__all__ = ["Box", "Cone", "Disc", "Line", "MeshSurface", "Point", "Shape", "Sphere"]

_TWO_PI = 2.0 * np.pi


def _random_directions(rng: np.random.Generator, count: int) -> np.ndarray:
    """Unit vectors uniform on the sphere, shape (count, 3).

    By Archimedes' theorem ``z`` is uniform on [-1, 1] for a uniform point on the unit
    sphere, so ``z`` and the azimuth are drawn directly (no Gaussian norm that could be 0).
    """
    z = 1.0 - 2.0 * rng.random(count)
    phi = _TWO_PI * rng.random(count)
    rho = np.sqrt(1.0 - z * z)
    return np.column_stack((rho * np.cos(phi), rho * np.sin(phi), z))


def _directions_from_origin(rng: np.random.Generator, pos: np.ndarray) -> np.ndarray:
    """Unit vectors along ``pos`` (count, 3); a random direction where ``pos`` is zero."""
    norm = np.linalg.norm(pos, axis=1)
    zero = norm == 0.0
    out = pos / np.where(zero, 1.0, norm)[:, None]
    if np.any(zero):
        out[zero] = _random_directions(rng, int(np.count_nonzero(zero)))
    return out


def along(*terms: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """``sum(coefficients[:, None] * vector)`` over ``(vector (3,), coefficients (count,))``
    pairs, shape (count, 3).

    Built as three contiguous rows (the result is the transpose of a (3, count) array,
    the store's layout): NumPy's broadcasting over a trailing axis of length 3 runs
    several times slower.
    """
    vector, coefficients = terms[0]
    out = np.outer(vector, coefficients)
    for vector, coefficients in terms[1:]:
        out += np.outer(vector, coefficients)
    return out.T


def repeated(vector: np.ndarray, count: int) -> np.ndarray:
    """``vector`` (3,) repeated ``count`` times, shape (count, 3), laid out as :func:`along`."""
    return np.repeat(np.asarray(vector, dtype=np.float64)[:, None], count, axis=1).T


def _perpendicular_basis(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unit vectors ``(e1, e2)`` with ``e1 x e2 = axis`` for a unit ``axis``."""
    # Start from the coordinate axis least aligned with ``axis`` so the projection is
    # far from zero-length.
    helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = helper - np.dot(helper, axis) * axis
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(axis, e1)


def _empty() -> tuple[np.ndarray, np.ndarray]:
    return np.zeros((0, 3)), np.zeros((0, 3))


class Shape(ABC):
    """An emitter shape: samples positions and normals uniformly in its local frame."""

    def sample(self, rng: np.random.Generator, count: int) -> tuple[np.ndarray, np.ndarray]:
        """Draw ``count`` points uniformly over the shape.

        Parameters
        ----------
        rng : numpy.random.Generator
            The only source of randomness.
        count : int
            Number of samples, >= 0.

        Returns
        -------
        positions : numpy.ndarray
            Sample positions [m] in the shape's local frame, float64, shape (count, 3).
        normals : numpy.ndarray
            Unit normals, float64, shape (count, 3): the surface normal where the shape
            has one, otherwise the unit direction from the local origin to the sample.
        """
        if not isinstance(rng, np.random.Generator):
            raise TypeError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
        count = check.integer("count", count, low=0)
        if count == 0:
            return _empty()
        return self._sample(rng, count)

    @abstractmethod
    def _sample(self, rng: np.random.Generator, count: int) -> tuple[np.ndarray, np.ndarray]:
        """Draw ``count >= 1`` samples; see :meth:`sample`."""

    @property
    @abstractmethod
    def bounding_radius(self) -> float:
        """Radius [m] of a sphere about the local origin that contains the shape."""


class Point(Shape):
    """A single point at the local origin.

    Normals are uniformly random unit directions (an isotropic point source).
    """

    def _sample(self, rng, count):
        return np.zeros((count, 3)), _random_directions(rng, count)

    @property
    def bounding_radius(self) -> float:
        return 0.0

    def __repr__(self) -> str:
        return "Point()"


class Sphere(Shape):
    """A ball (uniform in volume) or a sphere (uniform on its surface), centred at the origin.

    Parameters
    ----------
    radius : float
        Radius [m], > 0.
    surface : bool, optional
        Sample the surface instead of the volume.

    Notes
    -----
    Volume: the radius is ``radius * u**(1/3)`` because the volume inside ``r`` grows as
    ``r**3``. Normals are radial (outward) in both cases.
    """

    def __init__(self, radius: float, *, surface: bool = False) -> None:
        self.radius = check.positive("radius", radius)
        self.surface = bool(surface)

    def _sample(self, rng, count):
        normals = _random_directions(rng, count)
        if self.surface:
            return self.radius * normals, normals
        r = self.radius * np.cbrt(rng.random(count))
        return r[:, None] * normals, normals

    @property
    def bounding_radius(self) -> float:
        return self.radius

    def __repr__(self) -> str:
        return f"Sphere({self.radius!r}, surface={self.surface})"


class Box(Shape):
    """An axis-aligned box centred at the origin, uniform in volume or on its surface.

    Parameters
    ----------
    size : array_like
        Full edge lengths [m] along x, y, z, shape (3,), each > 0.
    surface : bool, optional
        Sample the six faces (each chosen with probability proportional to its area)
        instead of the volume.

    Notes
    -----
    Surface normals are the outward face normals; volume normals are the unit direction
    from the centre to the sample.
    """

    def __init__(self, size, *, surface: bool = False) -> None:
        size = check.vector("size", size)
        if np.any(size <= 0.0):
            raise ValueError(f"size must have every component > 0, got {size.tolist()}")
        self.size = size
        self.surface = bool(surface)
        # Face k lies on axis k // 2, at the + side for even k and the - side for odd k.
        sx, sy, sz = size
        areas = np.array([sy * sz, sy * sz, sx * sz, sx * sz, sx * sy, sx * sy])
        cdf = np.cumsum(areas)
        self._face_cdf = cdf / cdf[-1]

    def _sample(self, rng, count):
        pos = (rng.random((count, 3)) - 0.5) * self.size
        if not self.surface:
            return pos, _directions_from_origin(rng, pos)
        face = np.searchsorted(self._face_cdf, rng.random(count), side="right")
        axis = face // 2
        sign = np.where(face % 2 == 0, 1.0, -1.0)
        rows = np.arange(count)
        pos[rows, axis] = sign * 0.5 * self.size[axis]
        normals = np.zeros((count, 3))
        normals[rows, axis] = sign
        return pos, normals

    @property
    def bounding_radius(self) -> float:
        return 0.5 * float(np.linalg.norm(self.size))

    def __repr__(self) -> str:
        return f"Box({self.size.tolist()!r}, surface={self.surface})"


class Disc(Shape):
    """A flat disc or annulus centred at the origin, uniform over its area.

    Parameters
    ----------
    radius : float
        Outer radius [m], > 0.
    normal : array_like, optional
        Direction perpendicular to the disc, shape (3,), non-zero; normalised.
    inner_radius : float, optional
        Radius [m] of the hole, 0 <= inner_radius < radius.

    Notes
    -----
    The radius is ``sqrt(r_in**2 + u (R**2 - r_in**2))`` because the area inside ``r``
    grows as ``r**2``. Every normal equals ``normal``.
    """

    def __init__(self, radius: float, *, normal=(0.0, 1.0, 0.0), inner_radius: float = 0.0) -> None:
        self.radius = check.positive("radius", radius)
        self.inner_radius = check.real(
            "inner_radius", inner_radius, low=0.0, high=self.radius, high_open=True
        )
        self.normal = check.unit_vector("normal", normal)
        self._e1, self._e2 = _perpendicular_basis(self.normal)

    def _sample(self, rng, count):
        r_in2 = self.inner_radius**2
        r = np.sqrt(r_in2 + rng.random(count) * (self.radius**2 - r_in2))
        theta = _TWO_PI * rng.random(count)
        pos = along((self._e1, r * np.cos(theta)), (self._e2, r * np.sin(theta)))
        return pos, repeated(self.normal, count)

    @property
    def bounding_radius(self) -> float:
        return self.radius

    def __repr__(self) -> str:
        return (
            f"Disc({self.radius!r}, normal={self.normal.tolist()!r}, "
            f"inner_radius={self.inner_radius!r})"
        )


class Cone(Shape):
    """A right circular cone with its apex at the origin, uniform in volume or on its side.

    Parameters
    ----------
    radius : float
        Base radius [m], > 0.
    height : float
        Distance [m] from the apex to the base along ``axis``, > 0.
    axis : array_like, optional
        Direction from the apex to the base centre, shape (3,), non-zero; normalised.
    surface : bool, optional
        Sample the lateral surface (not the base) instead of the solid.

    Notes
    -----
    Volume: the cross-section at height ``h`` has area ∝ ``h**2``, so ``h = H u**(1/3)``,
    and within it the radius is ``(R h / H) sqrt(v)``. Normals are the unit direction from
    the apex (the local origin) to the sample, so volume samples launched along their
    normals spray out within the cone.

    Surface: the lateral circumference at height ``h`` is ∝ ``h``, so ``h = H sqrt(u)``.
    Normals are the outward lateral normals ``(H e_r - R axis) / sqrt(H**2 + R**2)``,
    with ``e_r`` the radial direction.
    """

    def __init__(
        self, radius: float, height: float, *, axis=(0.0, 1.0, 0.0), surface: bool = False
    ) -> None:
        self.radius = check.positive("radius", radius)
        self.height = check.positive("height", height)
        self.axis = check.unit_vector("axis", axis)
        self.surface = bool(surface)
        self._e1, self._e2 = _perpendicular_basis(self.axis)

    def _sample(self, rng, count):
        if self.surface:
            h = self.height * np.sqrt(rng.random(count))
            rho = self.radius / self.height * h
        else:
            h = self.height * np.cbrt(rng.random(count))
            rho = self.radius / self.height * h * np.sqrt(rng.random(count))
        theta = _TWO_PI * rng.random(count)
        radial = along((self._e1, np.cos(theta)), (self._e2, np.sin(theta)))
        pos = along((self.axis, h)) + rho[:, None] * radial
        if not self.surface:
            return pos, _directions_from_origin(rng, pos)
        slant = np.hypot(self.radius, self.height)
        normals = (self.height * radial - self.radius * self.axis) / slant
        return pos, normals

    @property
    def bounding_radius(self) -> float:
        return float(np.hypot(self.radius, self.height))

    def __repr__(self) -> str:
        return (
            f"Cone({self.radius!r}, {self.height!r}, axis={self.axis.tolist()!r}, "
            f"surface={self.surface})"
        )


class Line(Shape):
    """A straight segment, uniform along its length.

    Parameters
    ----------
    start, end : array_like
        End points [m], shape (3,) each; they must differ.

    Notes
    -----
    A segment has no surface normal and the direction from its midpoint is parallel to
    the segment, so each normal is instead a unit vector perpendicular to the segment at
    an azimuth drawn uniformly around it: samples launched along their normals leave the
    line like a cylindrical sheet.
    """

    def __init__(self, start, end) -> None:
        self.start = check.vector("start", start)
        self.end = check.vector("end", end)
        direction = self.end - self.start
        length = float(np.linalg.norm(direction))
        if not length > 0.0:
            raise ValueError(
                f"end must differ from start (a segment of length > 0), got {self.end.tolist()}"
            )
        self._e1, self._e2 = _perpendicular_basis(direction / length)

    def _sample(self, rng, count):
        t = rng.random(count)
        pos = self.start + along((self.end - self.start, t))
        phi = _TWO_PI * rng.random(count)
        normals = along((self._e1, np.cos(phi)), (self._e2, np.sin(phi)))
        return pos, normals

    @property
    def bounding_radius(self) -> float:
        return float(max(np.linalg.norm(self.start), np.linalg.norm(self.end)))

    def __repr__(self) -> str:
        return f"Line({self.start.tolist()!r}, {self.end.tolist()!r})"


class MeshSurface(Shape):
    """The surface of a triangle mesh, uniform over its area.

    Parameters
    ----------
    vertices : array_like
        Vertex positions [m], shape (V, 3), V >= 3.
    faces : array_like of int
        Vertex indices of each triangle, shape (F, 3), F >= 1, each in [0, V).

    Notes
    -----
    A triangle is chosen with probability proportional to its area (inverse transform on
    the cumulative areas), then a point uniform inside it with the square-root barycentric
    map ``p = (1 - s) A + s (1 - v) B + s v C``, ``s = sqrt(u)`` (Osada et al. 2002,
    "Shape distributions", ACM Trans. Graph. 21(4)). Normals are the face normals
    ``(B - A) x (C - A)`` normalised (right-hand rule on the vertex order).

    Degenerate faces (collinear or repeated vertices, detected as
    ``|AB x AC| <= 1e-12 |AB| |AC|``) are never sampled; a mesh whose faces are all
    degenerate is refused.
    """

    def __init__(self, vertices, faces) -> None:
        self.vertices = check.points("vertices", vertices, min_rows=3)
        faces = np.asarray(faces)
        if faces.ndim != 2 or faces.shape[1] != 3 or faces.shape[0] < 1:
            raise ValueError(f"faces must have shape (F, 3) with F >= 1, got shape {faces.shape}")
        if not np.issubdtype(faces.dtype, np.integer):
            raise TypeError(f"faces must be an integer array, got dtype {faces.dtype}")
        n_vertices = self.vertices.shape[0]
        bad = (faces < 0) | (faces >= n_vertices)
        if np.any(bad):
            raise ValueError(
                f"faces must index vertices in [0, {n_vertices - 1}], got {faces[bad].tolist()[:5]}"
            )
        self.faces = faces.astype(np.int64)

        a, b, c = (self.vertices[self.faces[:, k]] for k in range(3))
        cross = np.cross(b - a, c - a)
        twice_area = np.linalg.norm(cross, axis=1)
        # |cross| = |AB| |AC| sin(angle A): relative to the edge lengths, so the test does
        # not depend on the mesh's scale.
        edge_scale = np.linalg.norm(b - a, axis=1) * np.linalg.norm(c - a, axis=1)
        degenerate = twice_area <= 1e-12 * edge_scale
        if np.all(degenerate):
            raise ValueError(
                "faces describe a mesh of zero total area: every triangle is degenerate "
                "(collinear or repeated vertices)"
            )
        twice_area = np.where(degenerate, 0.0, twice_area)
        self._face_normals = cross / np.where(degenerate, 1.0, twice_area)[:, None]
        cdf = np.cumsum(twice_area)
        self.area = 0.5 * float(cdf[-1])
        """Total surface area [m^2]."""
        # Dividing by the last entry makes it exactly 1, so searchsorted never returns F.
        self._face_cdf = cdf / cdf[-1]

    def _sample(self, rng, count):
        face = np.searchsorted(self._face_cdf, rng.random(count), side="right")
        tri = self.faces[face]
        s = np.sqrt(rng.random(count))[:, None]
        v = rng.random(count)[:, None]
        a, b, c = (self.vertices[tri[:, k]] for k in range(3))
        pos = (1.0 - s) * a + s * (1.0 - v) * b + s * v * c
        return pos, self._face_normals[face]

    @property
    def bounding_radius(self) -> float:
        return float(np.max(np.linalg.norm(self.vertices[self.faces.ravel()], axis=1)))

    def __repr__(self) -> str:
        return f"MeshSurface(<{len(self.vertices)} vertices>, <{len(self.faces)} faces>)"
