"""What the viewer sends of one frame: points, meshes and lines, compact.

Particle positions travel as float16 offsets from the centre of their bounding box
(:func:`quantize`): 6 bytes a particle, with an error of at most ``half_extent · 2⁻¹¹``
per coordinate (half a unit in the last place of float16's 11-bit significand), e.g.
0.5 mm anywhere within 1 m of the centre. Colours travel as 8-bit sRGB. A frame with
more particles than the link carries in time is thinned by a stride (every k-th
particle, the same ones each frame, as particles keep their order in a store).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..color import linear_to_srgb
from ..render import geometry
from ..render.volume import Volume
from ..render.water import Water
from ..state import as_state
from . import packet_kernels as kernels
from .packet_kernels import BLOCK

#: The linear-to-sRGB table of :func:`packet_kernels.pack`.
_SRGB8 = kernels.srgb8_table()

__all__ = [
    "FramePacket",
    "Lines",
    "Mesh",
    "Points",
    "capacity",
    "dequantize",
    "fits",
    "packet_of",
    "padded",
    "quantize",
]

#: Largest offset float16 holds (beyond it a system is sent as float32).
FLOAT16_MAX = 65504.0
#: Relative rounding error of float16 (half its unit in the last place at 1).
FLOAT16_EPS = 2.0**-11
#: Voxels of a volume shown as points, at most (a 128³ smoke has about 10⁵ dense ones).
VOLUME_POINTS = 200_000
#: A moving mesh of more triangles is sent as points at its vertices (a flock of 120,000
#: birds is 1.4 M triangles, 50 MB a frame as a mesh), at most this many.
MESH_FACES_MAX = 200_000
#: Radii a system's point sizes are read from, at most.
SIZE_SAMPLE = 4096
#: Point sizes a system is drawn in, at most: its particles are sorted by radius into
#: classes each spanning at most a factor 2 (when that many do) between the 5th and 95th
#: percentiles of its radii, each class one cloud of its own size.
SIZE_CLASSES = 4
#: Radii spread less than this (95th over 5th percentile) are drawn in one size.
SIZE_SPREAD = 1.5


def quantize(positions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(origin (3,) float64, offsets (n, 3) float16 or float32)`` of ``positions``
    (n, 3) [m]: offsets from the centre of their bounding box, in float16 unless one
    would overflow it (then float32). ``origin + offsets`` is within
    :func:`quantization_error` of ``positions``."""
    positions = np.asarray(positions, dtype=np.float64)
    if len(positions) == 0:
        return np.zeros(3), np.zeros((0, 3), np.float16)
    low, high = positions.min(axis=0), positions.max(axis=0)
    origin = 0.5 * (low + high)
    offsets = positions - origin
    wide = float(np.max(high - low)) / 2.0 >= FLOAT16_MAX
    return origin, offsets.astype(np.float32 if wide else np.float16)


def dequantize(origin: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """(n, 3) float64 positions [m] back from :func:`quantize`'s output."""
    return np.asarray(origin, np.float64) + offsets.astype(np.float64)


def quantization_error(offsets: np.ndarray) -> float:
    """Largest error [m] :func:`quantize` can have made in any coordinate of ``offsets``."""
    if offsets.size == 0 or offsets.dtype != np.float16:
        return 0.0 if offsets.size == 0 else float(np.abs(offsets).max()) * 2.0**-23
    # float16's half unit, and float32's where offsets were rounded to it first
    return float(np.abs(offsets.astype(np.float32)).max()) * (FLOAT16_EPS + 2.0**-24) + 2.0**-25


@dataclass(frozen=True)
class Points:
    """Particles drawn as round points of one size."""

    origin: np.ndarray  #: (3,) float64 [m], added to every offset
    offsets: np.ndarray  #: (n, 3) float16 (or float32) [m]
    colors: np.ndarray  #: (n, 3) uint8 sRGB
    size: float  #: point diameter [m]

    @property
    def nbytes(self) -> int:
        return self.offsets.nbytes + self.colors.nbytes


@dataclass(frozen=True)
class Mesh:
    """A triangle mesh of one colour."""

    vertices: np.ndarray  #: (v, 3) float32 [m]
    faces: np.ndarray  #: (f, 3) uint32
    color: tuple[int, int, int]  #: sRGB

    @property
    def nbytes(self) -> int:
        return self.vertices.nbytes + self.faces.nbytes


@dataclass(frozen=True)
class Lines:
    """Line segments (hair strands, trails)."""

    segments: np.ndarray  #: (m, 2, 3) float32 [m]
    colors: np.ndarray  #: (m, 2, 3) uint8 sRGB

    @property
    def nbytes(self) -> int:
        return self.segments.nbytes + self.colors.nbytes


@dataclass
class FramePacket:
    """One frame as the browser draws it: shapes by node name (``system.fire/0``...)."""

    index: int  #: frame number, from 1 (0: before the first step)
    time: float  #: [s]
    points: dict[str, Points] = field(default_factory=dict)
    meshes: dict[str, Mesh] = field(default_factory=dict)
    lines: dict[str, Lines] = field(default_factory=dict)
    #: Live particles by part (before any stride), for the status line.
    counts: dict[str, int] = field(default_factory=dict)

    @property
    def nbytes(self) -> int:
        shapes = (*self.points.values(), *self.meshes.values(), *self.lines.values())
        return sum(shape.nbytes for shape in shapes)

    @property
    def names(self) -> set[str]:
        return set(self.points) | set(self.meshes) | set(self.lines)


def packet_of(parts, camera, *, index: int, time: float, stride: int = 1) -> FramePacket:
    """A :class:`FramePacket` of ``parts`` (:meth:`SceneRenderer.parts` output: ``(path,
    particles, objects)``), every ``stride``-th particle of each system; ``camera``
    places a ground without a size."""
    packet = FramePacket(index, time)
    for path, particles, objects in parts:
        count = 0
        for k, (item, style) in enumerate(particles):
            state = as_state(item)
            count += state.count
            classes = _points_of(state, style, stride) if state.count else []
            for c, points in enumerate(classes):
                if points is not None:  # a size class drawn as its own cloud
                    packet.points[f"{path}/{k}" + (f"s{c}" if c else "")] = points
        for k, obj in enumerate(objects):
            name = f"{path}/shape{k}"
            if isinstance(obj, geometry.Spheres):
                count += len(obj.centers)
                if len(obj.centers):
                    packet.points[name] = _sphere_points(obj, stride)
            elif isinstance(obj, geometry.Lines):
                packet.lines[name] = _lines_of(obj)
            elif isinstance(obj, Volume):
                points = _volume_points(obj)
                if points is not None:
                    packet.points[name] = points
            elif isinstance(obj, Water):
                count += len(obj.positions)
                if len(obj.positions):
                    packet.points[name] = _water_points(obj, stride)
            elif hasattr(obj, "triangles"):
                triangles = obj.triangles(camera)
                if path != "object" and len(triangles.faces) > MESH_FACES_MAX:
                    packet.points[name] = _vertex_points(triangles)
                else:
                    packet.meshes[name] = _mesh_of(triangles)
        if count:
            packet.counts[path] = count
    return packet


def capacity(count: int) -> int:
    """Points a browser's cloud holds for ``count`` particles: ``count`` rounded up to a
    power of 2^(1/4) (at least 64). A cloud whose count changes is rebuilt in the
    browser (a new buffer, a new material), a cloud with room for it is updated in place:
    a system whose count drifts keeps its cloud."""
    return math.ceil(2.0 ** (math.ceil(4.0 * math.log2(max(count, 64))) / 4.0))


def fits(count: int, held: int) -> bool:
    """Whether a cloud of ``held`` points can show ``count`` particles without wasting
    more than about twice the room they need."""
    return count <= held <= 2 * capacity(count)


def padded(offsets: np.ndarray, colors: np.ndarray, held: int):
    """``offsets``, ``colors`` grown to ``held`` rows by repeats of the first particle
    (drawn on top of it: nothing new shows)."""
    extra = held - len(offsets)
    if extra <= 0:
        return offsets, colors
    return (
        np.concatenate([offsets, np.repeat(offsets[:1], extra, axis=0)]),
        np.concatenate([colors, np.repeat(colors[:1], extra, axis=0)]),
    )


def _srgb8(linear: np.ndarray) -> np.ndarray:
    """Linear RGB (…, 3) as 8-bit sRGB, clipped to [0, 1] first."""
    encoded = linear_to_srgb(np.clip(linear, 0.0, 1.0))
    return np.round(encoded * 255.0).astype(np.uint8)


#: Additive particles emitting less than this share of their system's brightest (by the
#: brightest channel of colour × alpha × intensity; of 1 when the brightest gives more)
#: are not sent: an opaque point cannot add faint light, it would hide what lies behind
#: it under a dark disc (a flame's dying particles). Relative, because a flame drawn by
#: thousands of overlapping sprites gives a tenth of its light or less in each.
DIM_LIGHT = 0.1


def _points_of(state, style, stride: int) -> list[Points | None]:
    """A system's particles as points, one :class:`Points` per size class
    (:func:`size_classes`; None for a class none of whose particles is shown). Points
    are opaque:
    alpha-blended particles show their colour; additive ones (light) show their hue at a
    brightness that falls with their light (over the system's brightest, when that is
    below 1) only down to half, and the dimmest are left out (:data:`DIM_LIGHT`). Packed
    by :mod:`.packet_kernels` (offsets rounded to float32, then float16: within
    :func:`quantization_error`; colours within one 8-bit level of :func:`_srgb8`'s)."""
    positions = state.positions
    if "color" in state:
        color = state["color"]
        additive = getattr(style, "blend", None) == "additive"
        mode = kernels.LIGHT if additive else kernels.OPAQUE
    else:
        color, mode = np.zeros((4, 1), np.float32), kernels.WHITE
    intensity = float(getattr(style, "intensity", 1.0))
    taken = -(-positions.shape[1] // stride)
    blocks = -(-taken // BLOCK)
    if mode == kernels.LIGHT and taken:
        peaks = np.zeros(blocks)
        kernels.brightest(color, stride, intensity, peaks)
        if 0.0 < peaks.max() < 1.0:
            intensity /= float(peaks.max())  # the brightest particle gives 1
    radius = np.ascontiguousarray(state.radius, np.float32)
    edges, sizes = size_classes(radius)
    counts = np.zeros((blocks, len(sizes)), np.int64)
    low, high = np.empty((blocks, 3)), np.empty((blocks, 3))
    args = (positions, color, radius, edges, stride, mode, intensity, DIM_LIGHT)
    kernels.count_shown(*args, counts, low, high)
    per_class = counts.sum(axis=0)
    total = int(per_class.sum())
    if total == 0:
        return []
    # Class k's rows start after the classes before it; within it, block by block.
    starts = np.concatenate(([0], np.cumsum(per_class)[:-1]))
    first = starts + np.cumsum(counts, axis=0) - counts
    low, high = low.min(axis=0), high.max(axis=0)
    origin = 0.5 * (low + high)
    offsets = np.empty((total, 3), np.float32)
    colors = np.empty((total, 3), np.uint8)
    kernels.pack(*args, first, origin, _SRGB8, offsets, colors)
    if float(np.max(high - low)) / 2.0 < FLOAT16_MAX:
        offsets = offsets.astype(np.float16)
    return [
        Points(origin, offsets[a : a + n], colors[a : a + n], size) if n else None
        for a, n, size in zip(starts, per_class, sizes, strict=True)
    ]


def _sphere_points(spheres: geometry.Spheres, stride: int) -> Points:
    origin, offsets = quantize(spheres.centers[::stride])
    colors = _srgb8(np.asarray(spheres.colors, np.float32)[::stride])
    return Points(origin, offsets, colors, _diameter(spheres.radii))


def _water_points(water: Water, stride: int) -> Points:
    """A liquid drawn as clear water in the renderer: its particles as points of its tint
    (a preview, not the refracting surface)."""
    origin, offsets = quantize(water.positions[::stride])
    count = len(offsets)
    colors = np.broadcast_to(_srgb8(np.asarray(water.color, np.float32)[None, :]), (count, 3))
    return Points(origin, offsets, np.ascontiguousarray(colors), 1.6 * water.radius)


def _diameter(radius) -> float:
    """One point size for a system: twice its median radius [m] (1 cm if none), the
    median of at most :data:`SIZE_SAMPLE` radii evenly spaced through the system."""
    radius = _size_sample(radius)
    size = 2.0 * float(np.median(radius)) if radius.size else 0.0
    return size if np.isfinite(size) and size > 0 else 0.01


def _size_sample(radius) -> np.ndarray:
    """At most :data:`SIZE_SAMPLE` of ``radius``, evenly spaced through it, finite."""
    radius = np.asarray(radius)
    radius = radius[:: max(1, -(-radius.size // SIZE_SAMPLE))]
    return radius[np.isfinite(radius)]


def size_classes(radius) -> tuple[np.ndarray, list[float]]:
    """``(edges (k - 1,) float32 [m], diameters [m] of the k classes)`` a system's
    particles of ``radius`` (n,) are drawn in: a particle's class is the number of edges
    its radius reaches. Radii spread less than :data:`SIZE_SPREAD` (95th over 5th
    percentile of a sample) make one class of twice the median; wider ones up to
    :data:`SIZE_CLASSES` classes of equal ratio between those percentiles, each drawn at
    its geometric middle (those beyond the percentiles join the end classes)."""
    sample = _size_sample(radius)
    if sample.size:
        lo, hi = (float(x) for x in np.percentile(sample, [5.0, 95.0]))
        if lo > 0.0 and hi >= SIZE_SPREAD * lo:
            k = min(SIZE_CLASSES, max(2, math.ceil(math.log2(hi / lo))))
            ratio = (hi / lo) ** (1.0 / k)
            edges = np.array([lo * ratio**j for j in range(1, k)], np.float32)
            return edges, [2.0 * lo * ratio ** (j + 0.5) for j in range(k)]
    return np.zeros(0, np.float32), [_diameter(radius)]


def _mesh_of(triangles: geometry.TriangleSet) -> Mesh:
    color = _srgb8(triangles.colors.mean(axis=0)) if len(triangles.colors) else (178, 178, 178)
    return Mesh(
        np.ascontiguousarray(triangles.positions, np.float32),
        np.ascontiguousarray(triangles.faces, np.uint32),
        tuple(int(c) for c in color),
    )


def _vertex_points(triangles: geometry.TriangleSet) -> Points:
    """A mesh too big to send each frame as points at (some of) its vertices, each the
    size of its mean edge."""
    faces, positions = triangles.faces, triangles.positions
    step = max(1, -(-len(positions) // VOLUME_POINTS))
    edge = np.linalg.norm(positions[faces[:, 1]] - positions[faces[:, 0]], axis=1).mean()
    origin, offsets = quantize(positions[::step])
    colors = _srgb8(triangles.colors[::step])
    return Points(origin, offsets, colors, float(edge) if edge > 0 else 0.01)


def _lines_of(lines: geometry.Lines) -> Lines:
    return Lines(lines.ends().astype(np.float32), _srgb8(lines.colors))


def _volume_points(volume: Volume) -> Points | None:
    """A volume as points at its denser voxels (above a tenth of its peak), grey by
    density, or glowing by temperature where it emits: a preview, not the lit volume."""
    density = volume.density
    peak = float(density.max()) if density.size else 0.0
    if peak <= 0.0:
        return None
    dense = np.flatnonzero(density.ravel() > 0.1 * peak)
    if dense.size > VOLUME_POINTS:
        dense = dense[:: -(-dense.size // VOLUME_POINTS)]
    ijk = np.stack(np.unravel_index(dense, density.shape), axis=1)
    positions = volume.origin + (ijk + 0.5) * volume.cell_size
    share = (density.ravel()[dense] / peak).astype(np.float32)[:, None]
    rgb = np.asarray(volume.albedo, np.float32) * (0.35 + 0.65 * share)
    if volume.temperature is not None and volume.emission > 0:
        from ..render.volume_blackbody import blackbody_rgb

        glow = blackbody_rgb(volume.temperature.ravel()[dense]).astype(np.float32)
        rgb = np.maximum(rgb * np.ones((1, 3), np.float32), glow)
    origin, offsets = quantize(positions)
    return Points(origin, offsets, _srgb8(rgb), float(volume.cell_size))
