"""Opaque geometry: ground, spheres, boxes, meshes and lines, drawn with a depth buffer.

Every object becomes triangles (or, for :class:`Lines`, screen-space segments) in world
space; :func:`draw_geometry` draws them all in one pass into a :class:`~motes.render.frame.Frame`:
one combined triangle list, one tile binning, compiled kernels for the rest
(:mod:`motes.render._raster`). Surfaces are lit by :mod:`motes.render.shading`.

>>> import motes as mo
>>> from motes.render.frame import Frame
>>> from motes.render.geometry import Ground, Sphere, draw_geometry
>>> camera = mo.Camera((0, 1.5, 5), (0, 0.5, 0), resolution=(64, 36))
>>> frame = Frame(64, 36)
>>> draw_geometry(frame, camera, [Ground(checker=("#333333", 1.0)), Sphere((0, 0.5, 0), 0.5)])
>>> bool(frame.depth[18, 32] < 5.0)  # the sphere's front, about 4.6 m away
True
"""

from __future__ import annotations

import copy
import functools
from typing import NamedTuple

import numpy as np

from .. import _validate as check
from ..geometry.mesh import TriangleMesh
from ._raster import (
    CORNER,
    LINE_SIZE,
    depth_tiles,
    draw_tiles,
    project_vertices,
    setup_lines,
    setup_triangles,
)
from .camera import Camera
from .frame import Frame
from .shading import (
    LIGHT_OPACITY,
    LIGHT_SHADOW,
    SURFACE_SIZE,
    AmbientLight,
    DirectionalLight,
    Material,
    default_lights,
    rgb,
    surface_row,
)
from .shadows import Shadowing, empty_maps, unshadowed
from .tiles import bin_boxes

__all__ = ["Box", "Capsule", "Ground", "Lines", "Mesh", "Sphere", "draw_geometry"]

DEFAULT_COLOR = (0.7, 0.7, 0.7)


class TriangleSet(NamedTuple):
    """World-space triangles of one object, as :func:`draw_geometry` consumes them."""

    positions: np.ndarray  #: (v, 3) float64 vertex positions [m]
    normals: np.ndarray  #: (v, 3) float32 unit vertex normals (unused when flat)
    colors: np.ndarray  #: (v, 3) float32 linear RGB albedo per vertex
    faces: np.ndarray  #: (f, 3) int32 vertex indices, counter-clockwise seen from outside
    surface: np.ndarray  #: (SURFACE_SIZE,) float64 surface row (material, flat, checker)


def _vertex_colors(name: str, value, count: int) -> np.ndarray:
    """(count, 3) float32 linear RGB: one colour for all, or one per row."""
    if isinstance(value, str) or np.ndim(value) == 1:
        return np.tile(rgb(name, value).astype(np.float32), (count, 1))
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape != (count, 3):
        raise ValueError(f"{name} must be one colour or shape ({count}, 3), got {arr.shape}")
    if not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise ValueError(f"{name} must be finite and non-negative")
    return arr.astype(np.float32)


def _readonly(*arrays):
    for a in arrays:
        a.flags.writeable = False
    return arrays


class Ground:
    """The horizontal plane y = ``height``, as a square.

    Parameters
    ----------
    height : float
        Its y coordinate [m].
    size : float, optional
        Side of the square [m], centred on the world origin. ``None``: centred under the
        camera, reaching the far plane in every direction (a ground to the horizon).
    color : colour
        Linear RGB albedo.
    checker : (colour, float), optional
        ``(second colour, cell size [m])``: a checkerboard on x and z (the second colour
        where ``floor(x / cell) + floor(z / cell)`` is odd), evaluated per pixel from the
        interpolated world position and box-filtered over the pixel's footprint, so
        distant cells fade to the mean instead of shimmering.
    material : Material, optional
    """

    def __init__(
        self,
        height: float = 0.0,
        *,
        size: float | None = None,
        color=DEFAULT_COLOR,
        checker=None,
        material: Material | None = None,
    ):
        self.height = check.real("height", height)
        self.size = None if size is None else check.positive("size", size)
        self.color = rgb("color", color)
        if checker is not None:
            if not isinstance(checker, (tuple, list)) or len(checker) != 2:
                raise ValueError(f"checker must be (second colour, cell size [m]), got {checker!r}")
            checker = (
                rgb("checker colour", checker[0]),
                check.positive("checker cell size", checker[1]),
            )
        self.checker = checker
        self.surface = surface_row(material, flat=True, checker=checker)

    def triangles(self, camera: Camera) -> TriangleSet:
        """Two triangles facing +y (the camera places a ground with no size)."""
        if self.size is None:
            cx, cz, half = camera.position[0], camera.position[2], camera.far
        else:
            cx, cz, half = 0.0, 0.0, 0.5 * self.size
        y = self.height
        positions = np.array(
            [[cx - half, y, cz - half], [cx - half, y, cz + half],
             [cx + half, y, cz + half], [cx + half, y, cz - half]]
        )  # fmt: skip
        faces = np.array([[0, 1, 2], [0, 2, 3]], dtype=np.int32)  # normal +y
        normals = np.tile(np.float32([0, 1, 0]), (4, 1))
        return TriangleSet(
            positions, normals, _vertex_colors("color", self.color, 4), faces, self.surface
        )


@functools.lru_cache(maxsize=8)
def icosphere(subdivisions: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit icosphere: (v, 3) float64 vertices on the unit sphere, (f, 3) int32 faces.

    Each subdivision splits every triangle into four at its edge midpoints (pushed out to
    the sphere): ``20 · 4^subdivisions`` faces, counter-clockwise seen from outside.
    """
    phi = (1 + 5**0.5) / 2
    v = np.array(
        [[-1, phi, 0], [1, phi, 0], [-1, -phi, 0], [1, -phi, 0],
         [0, -1, phi], [0, 1, phi], [0, -1, -phi], [0, 1, -phi],
         [phi, 0, -1], [phi, 0, 1], [-phi, 0, -1], [-phi, 0, 1]], dtype=np.float64
    )  # fmt: skip
    f = np.array(
        [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11],
         [1, 5, 9], [5, 11, 4], [11, 10, 2], [10, 7, 6], [7, 1, 8],
         [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8], [3, 8, 9],
         [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]]
    )  # fmt: skip
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    for _ in range(subdivisions):
        edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
        unique, inverse = np.unique(edges, axis=0, return_inverse=True)
        mid = v[unique[:, 0]] + v[unique[:, 1]]
        mid /= np.linalg.norm(mid, axis=1, keepdims=True)
        m = len(v) + inverse.reshape(3, -1)  # midpoints of edges 01, 12, 20 of each face
        a, b, c = f.T
        f = np.concatenate(
            [np.stack(t, axis=1) for t in
             ((a, m[0], m[2]), (b, m[1], m[0]), (c, m[2], m[1]), (m[0], m[1], m[2]))]
        )  # fmt: skip
        v = np.concatenate([v, mid])
    return _readonly(v, f.astype(np.int32))


class Sphere:
    """A sphere, tessellated as an icosphere (vertices on the sphere: it is inscribed).

    Parameters
    ----------
    center : (3,) array_like
        Centre [m].
    radius : float
        Radius [m], > 0.
    color : colour
        Linear RGB albedo.
    smooth : bool
        Interpolate the exact sphere normals (True) or shade each facet flat.
    subdivisions : int
        Icosphere level in [0, 6]: ``20 · 4^subdivisions`` triangles (3: 1,280). The
        surface lies between the sphere and the sphere touching its nearest face plane
        (radius × 0.9955 at level 3, 0.9989 at level 4).
    material : Material, optional
    """

    def __init__(
        self,
        center=(0.0, 0.0, 0.0),
        radius: float = 0.5,
        *,
        color=DEFAULT_COLOR,
        smooth: bool = True,
        subdivisions: int = 3,
        material: Material | None = None,
    ):
        self.center = check.vector("center", center)
        self.radius = check.positive("radius", radius)
        self.color = rgb("color", color)
        self.smooth = bool(smooth)
        self.subdivisions = check.integer("subdivisions", subdivisions, low=0)
        if self.subdivisions > 6:
            raise ValueError(f"subdivisions must be <= 6, got {subdivisions}")
        self.surface = surface_row(material, flat=not self.smooth)

    def triangles(self, camera: Camera) -> TriangleSet:
        """The icosphere scaled and moved into place, with exact sphere normals."""
        unit, faces = icosphere(self.subdivisions)
        positions = self.center + self.radius * unit
        colors = _vertex_colors("color", self.color, len(unit))
        return TriangleSet(positions, unit.astype(np.float32), colors, faces, self.surface)


class Spheres:
    """Many spheres at once (grains, marbles, debris): one icosphere per centre, drawn as
    one mesh with exact sphere normals.

    Parameters
    ----------
    centers : (n, 3) array_like
        Centres [m].
    radii : (n,) array_like or float
        Radii [m], >= 0.
    colors : (n, 3) array_like or colour
        Linear RGB albedo per sphere, or one colour.
    subdivisions : int
        Icosphere level in [0, 3] per sphere (1: 80 triangles).
    material : Material, optional
    """

    def __init__(self, centers, radii, *, colors=DEFAULT_COLOR, subdivisions: int = 1,
                 material: Material | None = None):  # fmt: skip
        self.centers = check.points("centers", centers, min_rows=0)
        n = len(self.centers)
        radii = np.broadcast_to(np.asarray(radii, dtype=np.float64), (n,))
        if not np.all(np.isfinite(radii)) or np.any(radii < 0):
            raise ValueError("radii must be finite and >= 0")
        self.radii = radii
        self.subdivisions = check.integer("subdivisions", subdivisions, low=0)
        if self.subdivisions > 3:
            raise ValueError(f"subdivisions must be <= 3, got {subdivisions}")
        if isinstance(colors, str) or np.ndim(colors) == 1:
            self.colors = np.broadcast_to(rgb("colors", colors), (n, 3))
        else:
            self.colors = _vertex_colors("colors", colors, n)
        self.surface = surface_row(material, flat=False)

    def triangles(self, camera: Camera) -> TriangleSet:
        unit, faces = icosphere(self.subdivisions)
        n, v = len(self.centers), len(unit)
        positions = (self.centers[:, None, :] + self.radii[:, None, None] * unit).reshape(-1, 3)
        normals = np.broadcast_to(unit.astype(np.float32), (n, v, 3)).reshape(-1, 3)
        colors = np.repeat(np.asarray(self.colors, np.float32), v, axis=0)
        all_faces = faces[None, :, :] + (v * np.arange(n, dtype=np.int32))[:, None, None]
        return TriangleSet(positions, normals, colors, all_faces.reshape(-1, 3), self.surface)


class Capsule:
    """A capsule: every point within ``radius`` of the segment from ``a`` to ``b``.

    Drawn as an icosphere whose two halves are moved to the ends: the triangles that
    cross the equator stretch into the cylinder, and every vertex keeps its exact normal
    (a capsule's normal is the sphere's on the caps and radial on the cylinder).

    Parameters
    ----------
    a, b : (3,) array_like
        Ends of the axis [m] (may coincide: a sphere).
    radius : float
        Radius [m], > 0.
    color : colour
        Linear RGB albedo.
    subdivisions : int
        Icosphere level in [0, 6] (3: 1,280 triangles).
    material : Material, optional
    """

    def __init__(
        self,
        a=(0.0, 0.0, 0.0),
        b=(0.0, 1.0, 0.0),
        radius: float = 0.1,
        *,
        color=DEFAULT_COLOR,
        subdivisions: int = 3,
        material: Material | None = None,
    ):
        self.a = check.vector("a", a)
        self.b = check.vector("b", b)
        self.radius = check.positive("radius", radius)
        self.color = rgb("color", color)
        self.subdivisions = check.integer("subdivisions", subdivisions, low=0)
        if self.subdivisions > 6:
            raise ValueError(f"subdivisions must be <= 6, got {subdivisions}")
        self.surface = surface_row(material, flat=False)

    def triangles(self, camera: Camera) -> TriangleSet:
        """The icosphere split at its equator across the axis, halves at ``a`` and ``b``."""
        unit, faces = icosphere(self.subdivisions)
        axis = self.b - self.a
        toward_b = unit @ axis >= 0.0  # a vertex on the equator is the cylinder's b end
        ends = np.where(toward_b[:, None], self.b, self.a)
        positions = ends + self.radius * unit
        colors = _vertex_colors("color", self.color, len(unit))
        return TriangleSet(positions, unit.astype(np.float32), colors, faces, self.surface)


def _rotation(value) -> np.ndarray:
    r = np.asarray(value, dtype=np.float64)
    if r.shape != (3, 3) or not np.all(np.isfinite(r)):
        raise ValueError(f"rotation must be a finite (3, 3) matrix, got shape {r.shape}")
    if not np.allclose(r @ r.T, np.eye(3), atol=1e-6) or np.linalg.det(r) < 0:
        raise ValueError("rotation must be a proper rotation matrix (orthonormal, det +1)")
    return r


class Box:
    """An oriented box, flat shaded: 8 vertices, 12 triangles.

    Parameters
    ----------
    center : (3,) array_like
        Centre [m].
    size : float or (3,) array_like
        Edge lengths along its local x, y, z [m], each > 0.
    rotation : (3, 3) array_like, optional
        Rotation matrix whose columns are the box's local axes in world space.
    color : colour
        Linear RGB albedo.
    material : Material, optional
    """

    # Corner i has local coordinates (i & 1, i >> 1 & 1, i >> 2 & 1) - 1/2; two triangles
    # per face, counter-clockwise seen from outside.
    _FACES = np.array(
        [[0, 4, 6], [0, 6, 2], [1, 3, 7], [1, 7, 5],  # -x, +x
         [0, 1, 5], [0, 5, 4], [2, 6, 7], [2, 7, 3],  # -y, +y
         [0, 2, 3], [0, 3, 1], [4, 5, 7], [4, 7, 6]],  # -z, +z
        dtype=np.int32,
    )  # fmt: skip
    _CORNERS = np.array([[i & 1, i >> 1 & 1, i >> 2 & 1] for i in range(8)], dtype=np.float64) - 0.5

    def __init__(
        self,
        center=(0.0, 0.0, 0.0),
        size=1.0,
        *,
        rotation=None,
        color=DEFAULT_COLOR,
        material: Material | None = None,
    ):
        self.center = check.vector("center", center)
        if np.ndim(size) == 0:
            size = (size, size, size)
        self.size = check.vector("size", size)
        if np.any(self.size <= 0):
            raise ValueError(f"size must be > 0 along every axis, got {self.size.tolist()}")
        self.rotation = np.eye(3) if rotation is None else _rotation(rotation)
        self.color = rgb("color", color)
        self.surface = surface_row(material, flat=True)

    def triangles(self, camera: Camera) -> TriangleSet:
        """The 12 triangles in world space (flat shaded: vertex normals unused)."""
        positions = self.center + (self._CORNERS * self.size) @ self.rotation.T
        normals = np.zeros((8, 3), dtype=np.float32)  # flat: face normals are used
        colors = _vertex_colors("color", self.color, 8)
        return TriangleSet(positions, normals, colors, self._FACES, self.surface)


class Mesh:
    """A triangle mesh (a cloth, a metaball surface, a model).

    Parameters
    ----------
    mesh : TriangleMesh
        Vertices [m], counter-clockwise faces and unit vertex normals.
    color : colour
        Linear RGB albedo of the whole mesh (ignored when ``vertex_colors`` is given).
    vertex_colors : (v, 3) array_like, optional
        Linear RGB albedo per vertex, interpolated across faces.
    smooth : bool
        Interpolate the mesh's vertex normals (True) or shade each face flat.
    material : Material, optional
    """

    def __init__(
        self,
        mesh: TriangleMesh,
        *,
        color=DEFAULT_COLOR,
        vertex_colors=None,
        smooth: bool = True,
        material: Material | None = None,
    ):
        if not isinstance(mesh, TriangleMesh):
            raise TypeError(f"mesh must be a TriangleMesh, got {type(mesh).__name__}")
        self.mesh = mesh
        count = len(mesh.vertices)
        self.colors = _vertex_colors(
            "color" if vertex_colors is None else "vertex_colors",
            color if vertex_colors is None else vertex_colors,
            count,
        )
        self.smooth = bool(smooth)
        self.surface = surface_row(material, flat=not self.smooth)

    def triangles(self, camera: Camera) -> TriangleSet:
        """The mesh as it is (positions converted to float64)."""
        m = self.mesh
        return TriangleSet(
            m.vertices.astype(np.float64), m.normals, self.colors, m.faces, self.surface
        )


class Lines:
    """Anti-aliased line segments of a given pixel width, depth-tested, unlit.

    Each segment is drawn as a capsule in the image (round ends, so polylines join
    without gaps) whose coverage falls from 1 to 0 over one sample at its edge; the
    coverage blends its colour over what is drawn, and depth is written where it is at
    least 1/2. Lines are drawn after every triangle of the same call.

    Parameters
    ----------
    points : (n, 3) array_like
        Vertex positions [m].
    segments : (m, 2) array_like of int, optional
        Indices of each segment's ends; ``None`` joins the points in order (a polyline).
    color : colour or (m, 3) array_like
        Linear RGB radiance, one for all or one per segment.
    point_colors : (n, 3) array_like, optional
        Linear RGB per point, interpolated along segments (replaces ``color``).
    width : float or (m,) array_like
        Width [px of the frame], > 0. Lines thinner than a sample are drawn a sample wide
        with proportionally less coverage.
    shading : {"flat", "hair"}
        ``"flat"``: the colours as given (unlit). ``"hair"``: lit as fibres by
        Kajiya & Kay's (1989) model from the scene's lights, each segment's tangent
        ``t`` standing for the fibre: diffuse ``colour * sin(t, l)`` and a highlight
        ``specular * (sin(t, l) sin(t, e) - cos(t, l) cos(t, e))^shininess`` in the
        light's colour (``l`` toward the light, ``e`` toward the eye), plus the ambient
        light times the colour. Shadowed, at each segment end, by the frame's shadow and
        opacity maps (geometry, shadow-casting particles, and strands that cast): each
        end's colour scaled by the share of the light that reaches it.
    specular, shininess : float
        The highlight's strength (>= 0) and exponent (> 0), for ``"hair"``.
    shadow_radius : float
        The strands cast soft shadows (on geometry, lit particles and themselves) through
        the opacity maps, as blobs of this radius [m] at the segments' midpoints, >= 0;
        0: they cast none. About half a segment's length makes a strand a continuous
        occluder.
    shadow_opacity : float
        Opacity of each blob, in [0, 1] (hair is dense: a little each).
    """

    def __init__(
        self,
        points,
        segments=None,
        *,
        color=(1, 1, 1),
        point_colors=None,
        width=1.0,
        shading: str = "flat",
        specular: float = 0.25,
        shininess: float = 60.0,
        shadow_radius: float = 0.0,
        shadow_opacity: float = 0.2,
    ):
        pts = check.points("points", points, min_rows=1)
        if segments is None:
            if len(pts) < 2:
                raise ValueError("points needs at least 2 rows for a polyline")
            segments = np.stack([np.arange(len(pts) - 1), np.arange(1, len(pts))], axis=1)
        seg = np.asarray(segments)
        if seg.size == 0:
            seg = seg.reshape(0, 2)
        if seg.ndim != 2 or seg.shape[1] != 2 or not np.issubdtype(seg.dtype, np.integer):
            raise ValueError(
                f"segments must be an (m, 2) integer array, got {seg.dtype} {seg.shape}"
            )
        if seg.size and (seg.min() < 0 or seg.max() >= len(pts)):
            raise ValueError(f"segments must index points in [0, {len(pts) - 1}]")
        self.points = pts
        self.segments = seg.astype(np.int64)
        m = len(seg)
        if point_colors is not None:
            pc = _vertex_colors("point_colors", point_colors, len(pts))
            self.colors = pc[self.segments]
        else:
            per_segment = _vertex_colors("color", color, m)
            self.colors = np.repeat(per_segment[:, None, :], 2, axis=1)
        w = np.asarray(width, dtype=np.float64)
        if w.ndim == 0:
            w = np.full(m, float(w))
        if w.shape != (m,):
            raise ValueError(f"width must be a number or shape ({m},), got {w.shape}")
        if not np.all(np.isfinite(w)) or np.any(w <= 0):
            raise ValueError("width must be finite and > 0 [px]")
        self.width = w
        self.shading = check.choice("shading", shading, ("flat", "hair"))
        self.specular = check.non_negative("specular", specular)
        self.shininess = check.positive("shininess", shininess)
        self.shadow_radius = check.non_negative("shadow_radius", shadow_radius)
        self.shadow_opacity = check.real("shadow_opacity", shadow_opacity, low=0.0, high=1.0)

    def opacity_casters(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """What the opacity maps take of strands that cast shadows: blob centres (m, 3)
        at the segments' midpoints, radii (m,) and opacities (m,)."""
        m = len(self.segments)
        centres = self.ends().mean(axis=1)
        return centres, np.full(m, self.shadow_radius), np.full(m, self.shadow_opacity)

    def lit(self, camera: Camera, lights) -> Lines:
        """These lines with each segment end's colour lit as a fibre (``shading =
        "hair"``: see the class notes); ``self`` for flat lines."""
        if self.shading == "flat" or not len(self.segments):
            return self
        ends = self.ends()  # (m, 2, 3)
        tangent = ends[:, 1] - ends[:, 0]
        length = np.linalg.norm(tangent, axis=1, keepdims=True)
        tangent = np.where(length > 0, tangent / np.maximum(length, 1e-30), (1.0, 0.0, 0.0))
        tangent = tangent[:, None, :]  # the segment's, at both ends
        eye = camera.position - ends
        eye /= np.maximum(np.linalg.norm(eye, axis=2, keepdims=True), 1e-30)
        base = self.colors.astype(np.float64)
        out = np.zeros_like(base)
        cos_e = np.sum(tangent * eye, axis=2)
        sin_e = np.sqrt(np.maximum(1.0 - cos_e**2, 0.0))
        for light in default_lights() if lights is None else lights:
            radiance = light.color * light.intensity
            if isinstance(light, AmbientLight):
                out += base * 0.5 * (light.color + light.ground) * light.intensity
                continue
            if isinstance(light, DirectionalLight):
                toward = np.broadcast_to(-light.direction, ends.shape)
                scale = 1.0
            else:  # a point light
                toward = light.position - ends
                distance = np.linalg.norm(toward, axis=2, keepdims=True)
                toward = toward / np.maximum(distance, 1e-30)
                scale = 1.0 / np.maximum(distance, 1e-30) ** 2 if light.falloff else 1.0
            cos_l = np.sum(tangent * toward, axis=2)
            sin_l = np.sqrt(np.maximum(1.0 - cos_l**2, 0.0))
            highlight = np.maximum(sin_l * sin_e - cos_l * cos_e, 0.0) ** self.shininess
            # the highlight half white, half the fibre's colour (light that entered it)
            tint = 0.5 + 0.5 * base
            lit = base * sin_l[..., None] + self.specular * highlight[..., None] * tint
            out += radiance * scale * lit
        shaded = copy.copy(self)
        shaded.colors = out.astype(np.float32)
        shaded.shading = "flat"
        return shaded

    @classmethod
    def strips(cls, strips, *, color=(1, 1, 1), width=1.0) -> Lines:
        """Polylines (hair strands, ropes) from a sequence of (k_i, 3) arrays, k_i >= 2.

        ``color`` is one colour, or one per strip ((s, 3)).
        """
        strips = [check.points(f"strips[{i}]", s, min_rows=2) for i, s in enumerate(strips)]
        if not strips:
            raise ValueError("strips must hold at least one polyline")
        lengths = np.array([len(s) for s in strips])
        starts = np.concatenate([[0], np.cumsum(lengths)[:-1]])
        first = np.concatenate(
            [st + np.arange(n - 1) for st, n in zip(starts, lengths, strict=True)]
        )
        segments = np.stack([first, first + 1], axis=1)
        if not isinstance(color, str) and np.ndim(color) == 2:
            color = np.repeat(_vertex_colors("color", color, len(strips)), lengths - 1, axis=0)
        return cls(np.concatenate(strips), segments, color=color, width=width)

    def ends(self) -> np.ndarray:
        """(m, 2, 3) float64 world positions of both ends of each segment [m]."""
        return self.points[self.segments]


def draw_geometry(
    frame: Frame,
    camera: Camera,
    objects,
    *,
    lights=None,
    supersample: int = 2,
    shadowing: Shadowing | None = None,
) -> None:
    """Draw opaque objects into ``frame``, depth-tested against and writing ``frame.depth``.

    Parameters
    ----------
    frame : Frame
        Read and written: ``color`` (h, w, 3) float32 linear RGB, ``depth`` (h, w)
        float32 linear view depth [m] (``inf``: nothing). Its size must match the camera.
    camera : Camera
    objects : sequence of Ground, Sphere, Box, Mesh, Lines
        Drawn in one pass; order matters only among lines blending over each other.
    lights : sequence of DirectionalLight, PointLight and at most one AmbientLight, optional
        ``None``: :func:`motes.render.shading.default_lights`.
    supersample : int
        Samples per pixel along each axis, 1 to 4. Each 32×32-pixel tile is drawn into
        a buffer ``supersample`` times larger, initialised by replicating the frame's
        colour and depth, then resolved: a pixel gets the mean of its samples' colours
        and the *minimum* of their depths, so a particle near a silhouette is compared
        with (and soft-faded against) the nearest surface in its pixel. Pixels no sample
        of which was drawn are left exactly as they were.
    shadowing : Shadowing, optional
        The lights with their shadow and opacity maps for this frame
        (:func:`motes.render.shadow_pass.prepare`, which the renderer calls); by default
        ``lights`` without shadows.

    Notes
    -----
    Triangles are two-sided (cloth is seen from both sides): the side facing the
    camera is lit as the front. Triangles crossing the near plane are clipped, those
    wholly beyond the far plane culled, and samples beyond it discarded. Ties in depth
    go to the object drawn first.
    """
    if not isinstance(frame, Frame):
        raise TypeError(f"frame must be a Frame, got {type(frame).__name__}")
    if not isinstance(camera, Camera):
        raise TypeError(f"camera must be a Camera, got {type(camera).__name__}")
    if (frame.width, frame.height) != camera.resolution:
        raise ValueError(
            f"frame size {frame.width}x{frame.height} must match the camera resolution "
            f"{camera.resolution[0]}x{camera.resolution[1]}"
        )
    ss = check.integer("supersample", supersample, low=1)
    if ss > 4:
        raise ValueError(f"supersample must be <= 4, got {supersample}")
    if shadowing is None:
        shadowing = unshadowed(lights)
    sets, line_sets = [], []
    for i, obj in enumerate(objects):
        if isinstance(obj, Lines):
            lit = obj.lit(camera, lights)
            if obj.shading == "hair":  # a lit copy: its colours are its own
                lit.colors = lit.colors * _light_share(shadowing, lit.ends())
            line_sets.append(lit)
        elif isinstance(obj, (Ground, Sphere, Spheres, Capsule, Box, Mesh)):
            sets.append(obj.triangles(camera))
        else:
            raise TypeError(
                f"objects[{i}] must be a Ground, Sphere, Capsule, Box, Mesh or Lines, "
                f"got {type(obj).__name__}"
            )
    positions, normals, colors, faces, face_surface, surfaces = _combine(sets)
    ends, seg_colors, widths = _combine_lines(line_sets)

    cam = camera.packed()
    view = np.empty_like(positions)
    project_vertices(cam, positions, view)
    slots = 2 * len(faces)
    tri = np.empty((slots, 3, CORNER))
    tri_face = np.empty(slots, dtype=np.int32)
    tri_facing = np.zeros(slots)
    face_normal = np.empty((len(faces), 3))
    tri_box = np.empty((4, slots), dtype=np.int32)
    setup_triangles(
        cam, ss, positions, view, faces, tri, tri_face, tri_facing, face_normal, tri_box
    )
    lines = np.empty((len(ends), LINE_SIZE))
    line_box = np.empty((4, len(ends)), dtype=np.int32)
    if len(ends):  # no call without lines: a scene without any compiles no line set-up
        setup_lines(cam, ss, ends, widths, lines, line_box)
    # Triangles first, then lines: the tile kernel relies on that order.
    box = np.concatenate([tri_box, line_box], axis=1)
    bins = bin_boxes(box[0], box[1], box[2], box[3], frame.width, frame.height)
    draw_tiles(
        cam, ss, bins.order, bins.starts, bins.items, bins.tiles_x, slots, tri, tri_face,
        tri_facing, positions, normals, colors, faces, face_surface, face_normal, surfaces,
        shadowing.lights, shadowing.ambient, shadowing.arrays, lines, seg_colors, frame.color,
        frame.depth,
    )  # fmt: skip


def draw_depth(camera: Camera, objects) -> np.ndarray:
    """(h, w) float32 view depth [m] of the nearest of ``objects`` (grounds, spheres,
    capsules, boxes, meshes) in each pixel of ``camera``, ``inf`` where there is none:
    what :func:`draw_geometry` writes into ``frame.depth`` at one sample per pixel,
    without shading anything (a shadow map's pass)."""
    width, height = camera.resolution
    depth = np.full((height, width), np.inf, dtype=np.float32)
    positions, _, _, faces, _, _ = _combine([obj.triangles(camera) for obj in objects])
    cam = camera.packed()
    view = np.empty_like(positions)
    project_vertices(cam, positions, view)
    slots = 2 * len(faces)
    tri = np.empty((slots, 3, CORNER))
    tri_box = np.empty((4, slots), dtype=np.int32)
    setup_triangles(
        cam, 1, positions, view, faces, tri, np.empty(slots, dtype=np.int32), np.zeros(slots),
        np.empty((len(faces), 3)), tri_box,
    )  # fmt: skip
    bins = bin_boxes(*tri_box, width, height)
    depth_tiles(cam, bins.order, bins.starts, bins.items, bins.tiles_x, tri, depth)
    return depth


def _light_share(shadowing: Shadowing, ends: np.ndarray) -> np.ndarray:
    """(m, 2, 3) share of the light reaching each segment end through ``shadowing``'s
    maps: the light a white point there receives over what it would unshadowed (ambient
    included in both, so a point in full shadow keeps its ambient share)."""
    from .lighting import light_particles

    points = np.ascontiguousarray(ends.reshape(-1, 3), dtype=np.float64)
    if len(points) == 0 or (len(shadowing.arrays[0]) == 0 and len(shadowing.arrays[3]) == 0):
        return np.ones((len(ends), 2, 1))
    x, y, z = (np.ascontiguousarray(points[:, k]) for k in range(3))
    white = np.ones((len(points), 3), np.float32)
    reached, free = np.empty_like(white), np.empty_like(white)
    light_particles(shadowing.lights, shadowing.ambient, shadowing.arrays, x, y, z, white, reached)
    plain = shadowing.lights.copy()
    plain[:, LIGHT_SHADOW] = plain[:, LIGHT_OPACITY] = -1.0  # no map
    light_particles(plain, shadowing.ambient, empty_maps(), x, y, z, white, free)
    share = np.clip(reached / np.maximum(free, 1e-12), 0.0, 1.0)
    return share.reshape(len(ends), 2, 3)


def casters(objects) -> list:
    """The objects that cast shadows: everything opaque but grounds and lines."""
    return [o for o in objects if isinstance(o, (Sphere, Spheres, Capsule, Box, Mesh))]


def _combine(sets: list[TriangleSet]):
    """Concatenate triangle sets, offsetting face indices; face -> surface row index."""
    if not sets:
        return (
            np.zeros((0, 3)), np.zeros((0, 3), np.float32), np.zeros((0, 3), np.float32),
            np.zeros((0, 3), np.int32), np.zeros(0, np.int32), np.zeros((1, SURFACE_SIZE)),
        )  # fmt: skip
    counts = np.array([len(s.positions) for s in sets])
    offsets = np.concatenate([[0], np.cumsum(counts)[:-1]])
    positions = np.concatenate([s.positions for s in sets]).astype(np.float64, copy=False)
    normals = np.concatenate([s.normals for s in sets]).astype(np.float32, copy=False)
    colors = np.concatenate([s.colors for s in sets]).astype(np.float32, copy=False)
    faces = np.concatenate([s.faces + o for s, o in zip(sets, offsets, strict=True)]).astype(
        np.int32
    )
    face_surface = np.repeat(np.arange(len(sets), dtype=np.int32), [len(s.faces) for s in sets])
    surfaces = np.stack([s.surface for s in sets])
    return positions, normals, colors, faces, face_surface, surfaces


def _combine_lines(line_sets: list[Lines]):
    if not line_sets:
        return np.zeros((0, 2, 3)), np.zeros((0, 2, 3), np.float32), np.zeros(0)
    ends = np.concatenate([ls.ends() for ls in line_sets])
    colors = np.concatenate([ls.colors for ls in line_sets]).astype(np.float32, copy=False)
    widths = np.concatenate([ls.width for ls in line_sets])
    return ends, colors, widths
