"""Particles drawn as points, round or textured sprites, and motion-blur streaks.

Reeves (1983) rendered each particle as a small light source: a point that adds its
colour to the pixels it covers (additive, so no sorting), or, when moving, a streak
along its path during the frame's exposure ("motion-blurred particles"). This module
draws those and the sprites of later practice:

- **points**: the colour lands on the four pixels around the particle's sub-pixel
  position with bilinear (tent) weights that sum to 1 (anti-aliased, energy-conserving);
- **sprites**: a screen-space disc of radius ``radius × pixels-per-metre`` at the
  particle's depth, with a smooth falloff ``(1 - r²/R²)²`` or a flat disc with an
  anti-aliased edge, or a bilinear RGBA texture on the square ``[-R, R]²`` rotated by the
  particle's ``rotation``;
- **streaks** (``shutter > 0``): the footprint swept from ``p - v · shutter`` to ``p``;
  points become anti-aliased lines, round sprites capsules;
- **blending**: additive (order-independent) or alpha-over, back to front by view depth;
- **depth test and soft particles** against :attr:`Frame.depth`.

Energy convention (unit peak)
-----------------------------
Profiles have a peak weight of 1, so a sprite looks equally bright at any distance (its
image shrinks), as an emissive surface does. Its *energy*, the sum of its weights over the
pixels, is therefore the profile's area at its true pixel radius ``R``
(:meth:`SpriteStyle.footprint_area`): πR²/3 for the smooth profile, π(R² + 1/12) for the
flat disc (its 1 px linear edge adds π/12), ``4R² · mean texel alpha`` for a texture and 1
px² for a point. Every particle deposits exactly that (to float rounding) whatever its
sub-pixel position: its sampled weights are scaled by ``energy / sum of sampled
weights``. Hence:

- additive blending adds ``rgb · alpha · intensity · energy`` to the frame in total;
- a sprite smaller than the minimum footprint (1 px radius, 0.5 px for the flat disc,
  1.5 px for textures) is spread over that footprint with its true energy, so far-away
  particles dim smoothly as 1/depth² instead of vanishing or flickering between pixels;
- a streak deposits the same energy as the still particle (a moving particle does not get
  brighter), and in alpha-over its opacity is scaled by the same factor (the still area
  over the streak area).

Footprints whose pixel box exceeds ``EXACT_AREA`` (1024 px²) are normalised by the
profile's analytic integral instead of the sampled sum (sampling error below 3e-4).

Details
-------
- Alpha-over: a fragment of weight ``w`` (profile × energy scale × depth factor) has
  opacity ``clamp(alpha · w, 0, 1)`` and colour ``rgb · intensity`` (times the texel's
  RGB); particles are composited back to front by the view depth of their position,
  ties in input order.
- Streaks: both ends are projected (the tail clipped to ``[near, far]`` along the
  segment); the width is the head's pixel radius; a fragment's depth is interpolated
  along the streak at its nearest point. A point's streak weighs each pixel by the
  bilinear tent of its offset from the nearest point of the segment (so a zero-length
  streak is the still point). Textured sprites have no streaks.
- Culling: particles whose view depth is outside ``[near, far]`` are not drawn.

How it is drawn
---------------
All passes are compiled, parallel and free of write races, and the image does not
depend on the number of threads. :func:`.sprite_kernels.project_kernel` projects and
measures the particles in fixed chunks. Additive footprints that reach at most half a
tile beyond the 32 px tile holding their centre (nearly all particles of a fire or a
spray) take a fast path (:mod:`.splat_kernels`): a counting sort by tile, then the tiles
are drawn in four phases by the parity of their column and row, tiles of one phase in
parallel, each particle whole by one thread. The others, and all alpha-over particles
(sorted far to near), are listed in every tile their pixel box overlaps
(:func:`motes.render.tiles.bin_boxes`) and each tile blends its list in order.

References
----------
Reeves, W. T. (1983). Particle systems—a technique for modeling a class of fuzzy
objects. ACM Transactions on Graphics 2(2), 91-108.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

import numpy as np

from .. import _validate as check
from .._jit import threads_for
from . import _footprint as fp
from . import splat_kernels as splat
from . import sprite_kernels as k
from .camera import Camera
from .frame import Frame
from .tiles import CHUNK, TILE, bin_boxes, interleaved, scan_counts

__all__ = ["Blend", "Falloff", "SpriteKind", "SpriteRasterizer", "SpriteStyle", "draw_particles"]


class SpriteKind(StrEnum):
    """What a particle is drawn as."""

    POINT = "point"  # a light source at a sub-pixel position (size ignored)
    SPRITE = "sprite"  # a disc (or textured square) of the particle's radius


class Falloff(StrEnum):
    """Radial profile of round sprites."""

    SMOOTH = "smooth"  # (1 - r²/R²)²: soft, like a glowing blob
    DISC = "disc"  # flat to R, then a 1 px anti-aliased edge


class Blend(StrEnum):
    """How fragments combine with the frame."""

    ADDITIVE = "additive"  # color += rgb · a · weight: light, order-independent
    ALPHA = "alpha"  # color = rgb · a + color · (1 - a), back to front


#: Smallest footprint radius [px] per footprint kind (see the module docstring).
MIN_RADIUS_PX = {fp.SMOOTH: 1.0, fp.DISC: 0.5, fp.TEXTURE: 1.5, fp.POINT: 1.0}


@dataclass(frozen=True, eq=False)
class SpriteStyle:
    """How a set of particles is drawn: validated, immutable options.

    Parameters
    ----------
    kind : {"sprite", "point"}
        Sprites use each particle's radius; points ignore it.
    falloff : {"smooth", "disc"}
        Profile of untextured sprites.
    blend : {"additive", "alpha"}
        Additive light or alpha-over compositing (depth-sorted, far first).
    softness : float
        Soft-particle distance [m], >= 0. A fragment at view depth ``d`` over opaque
        geometry at depth ``D`` is weighted by ``clamp((D - d) / softness, 0, 1)``, so it
        fades as it nears a surface and vanishes behind it; 0 is a hard depth test
        (drawn only where ``d < D``).
    shutter : float
        Exposure time [s], >= 0. When > 0, particles are drawn as streaks from
        ``position - velocity · shutter`` to ``position`` (velocities are then required).
    texture : (th, tw, 4) array_like, optional
        Linear RGBA sprite image (row 0 at the top), sampled bilinearly over the square
        ``[-R, R]²`` turned by each particle's ``rotation`` and multiplied by its colour.
        Values must be finite and >= 0. Replaces the falloff; sprites only, no streaks.
    intensity : float
        Factor on every particle's colour, >= 0.
    lit : bool
        Shade the particles by the lights: each colour times the ambient light plus every
        light reaching the particle through shadows (smoke, dust, snow). False: the
        colour is the light the particle gives (fire, sparks).
    shadows : bool
        The particles shadow opaque geometry and lit particles through an opacity shadow
        map (their colour's alpha is their opacity; :mod:`motes.render.opacity`).
    light : float
        The particles light the scene, >= 0: one point light at the centre of their
        light, ``light`` times what they give off (:mod:`motes.render.emitted_light`);
        0: they light nothing.
    """

    kind: SpriteKind | str = SpriteKind.SPRITE
    falloff: Falloff | str = Falloff.SMOOTH
    blend: Blend | str = Blend.ADDITIVE
    softness: float = 0.0
    shutter: float = 0.0
    texture: np.ndarray | None = None
    intensity: float = 1.0
    lit: bool = False
    shadows: bool = False
    light: float = 0.0

    def __post_init__(self):
        def set_(name, value):
            object.__setattr__(self, name, value)

        set_("kind", SpriteKind(check.choice("kind", self.kind, [v.value for v in SpriteKind])))
        set_("falloff", Falloff(check.choice("falloff", self.falloff, [v.value for v in Falloff])))
        set_("blend", Blend(check.choice("blend", self.blend, [v.value for v in Blend])))
        set_("softness", check.non_negative("softness", self.softness))
        set_("shutter", check.non_negative("shutter", self.shutter))
        set_("intensity", check.non_negative("intensity", self.intensity))
        set_("light", check.non_negative("light", self.light))
        for flag in ("lit", "shadows"):
            if not isinstance(getattr(self, flag), bool):
                raise TypeError(f"{flag} must be True or False, got {getattr(self, flag)!r}")
        if self.texture is not None:
            if self.kind is SpriteKind.POINT:
                raise ValueError("texture needs kind='sprite' (points have no image)")
            if self.shutter > 0:
                raise ValueError(
                    "texture cannot be combined with shutter > 0 (no textured streaks)"
                )
            texture = np.array(self.texture, dtype=np.float32, order="C")
            if texture.ndim != 3 or texture.shape[2] != 4 or 0 in texture.shape:
                raise ValueError(f"texture must have shape (th, tw, 4), got {texture.shape}")
            if not np.isfinite(texture).all() or (texture < 0).any():
                raise ValueError("texture values must be finite and >= 0")
            texture.flags.writeable = False
            set_("texture", texture)

    @property
    def footprint(self) -> int:
        """The kernels' footprint kind (``sprite_kernels.POINT`` ...)."""
        if self.kind is SpriteKind.POINT:
            return fp.POINT
        if self.texture is not None:
            return fp.TEXTURE
        return fp.SMOOTH if self.falloff is Falloff.SMOOTH else fp.DISC

    @property
    def min_radius_px(self) -> float:
        """Smallest footprint radius [px]; smaller particles keep their energy over it."""
        return MIN_RADIUS_PX[self.footprint]

    def footprint_area(self, radius_px) -> np.ndarray:
        """Energy [px²] of a particle of pixel radius ``radius_px``: its total weight.

        The area of the unit-peak profile at the true radius (``radius_px`` is ignored for
        points, whose energy is 1). A still particle inside the frame and unoccluded adds
        ``rgb · alpha · intensity ·`` this to the frame under additive blending; so does
        its streak.
        """
        r = np.minimum(np.asarray(radius_px, dtype=np.float64), fp.MAX_RADIUS_PX)
        kind = self.footprint
        if kind == fp.POINT:
            return np.ones_like(r)
        if kind == fp.SMOOTH:
            return np.pi * r * r / 3.0
        if kind == fp.DISC:
            return np.pi * (r * r + 1.0 / 12.0)
        return 4.0 * r * r * float(self.texture[..., 3].mean())


_CHECKS = (
    (fp.BAD_POSITION, "positions must be finite (no NaN or inf)"),
    (fp.BAD_COLOR, "colors must be finite (no NaN or inf)"),
    (fp.BAD_RADIUS, "radii must be finite (no NaN or inf)"),
    (fp.NEGATIVE_RADIUS, "radii must be >= 0"),
    (fp.BAD_ROTATION, "rotation must be finite (no NaN or inf)"),
    (fp.BAD_VELOCITY, "velocities must be finite (no NaN or inf)"),
)


class SpriteRasterizer:
    """Draws particles with one :class:`SpriteStyle`.

    It keeps its scratch buffers (particle records, tile lists) between calls: draw every
    frame of an animation with one rasteriser. One rasteriser is not for concurrent use.

    Parameters
    ----------
    style : SpriteStyle, optional
        Defaults to additive smooth sprites.
    """

    def __init__(self, style: SpriteStyle | None = None):
        if style is None:
            style = SpriteStyle()
        if not isinstance(style, SpriteStyle):
            raise TypeError(f"style must be a SpriteStyle, got {style!r}")
        self.style = style
        self._scratch: dict[str, np.ndarray] = {}

    def _buffer(self, name: str, shape: tuple[int, ...], dtype=np.float32) -> np.ndarray:
        """A scratch array of ``shape``, reused between calls (grown when too small).

        Fresh arrays of a million particles' records cost their page faults on every
        frame (tens of MB zeroed by the kernel); reused ones do not.
        """
        size = int(np.prod(shape))
        buffer = self._scratch.get(name)
        if buffer is None or buffer.size < size or buffer.dtype != dtype:
            buffer = np.empty(max(size, 1), dtype)
            self._scratch[name] = buffer
        return buffer[:size].reshape(shape)

    def draw(
        self,
        frame: Frame,
        camera: Camera,
        positions,
        colors,
        radii=None,
        *,
        rotation=None,
        velocities=None,
    ) -> int:
        """Draw particles into ``frame`` (its colour, tested against its depth).

        Parameters
        ----------
        frame : Frame
            Target; ``frame.color`` is blended in place, ``frame.depth`` read.
        camera : Camera
            Its resolution must be the frame's size.
        positions : (n, 3) array_like
            World positions [m].
        colors : (n, 4) array_like
            Linear RGBA; alpha scales additive light and is the alpha-over opacity (the
            fragment opacity is clamped to [0, 1]).
        radii : (n,) array_like, optional
            Radius [m] of each sprite (>= 0); required for sprites, ignored for points.
        rotation : (n,) array_like, optional
            Angle [rad] of each textured sprite, counter-clockwise on screen; 0 when
            omitted. Ignored without a texture.
        velocities : (n, 3) array_like, optional
            Velocity [m/s]; required when ``style.shutter > 0``, ignored otherwise.

        Returns
        -------
        int
            Particles drawn: those inside the depth range ``[near, far]`` whose footprint
            overlaps the image (occlusion is per pixel and not counted).

        Arrays are converted to float32 (views are kept when they already are); values
        are checked to be finite in the projection pass, before anything is drawn.
        """
        style = self.style
        kind = style.footprint
        if not isinstance(frame, Frame):
            raise TypeError(f"frame must be a Frame, got {frame!r}")
        if not isinstance(camera, Camera):
            raise TypeError(f"camera must be a Camera, got {camera!r}")
        if camera.resolution != (frame.width, frame.height):
            raise ValueError(
                f"camera resolution {camera.resolution} must match the frame's "
                f"{(frame.width, frame.height)}"
            )
        positions = _particle_array("positions", positions, None, 3)
        n = positions.shape[0]
        colors = _particle_array("colors", colors, n, 4)
        if kind == fp.POINT:
            radii = _DUMMY_1D
        elif radii is None:
            raise ValueError("radii are required for sprites (kind='sprite')")
        else:
            radii = _particle_array("radii", radii, n, None)
        if kind == fp.TEXTURE:
            rotation = np.zeros(n, np.float32) if rotation is None else rotation
            rotation = _particle_array("rotation", rotation, n, None)
        else:
            rotation = _DUMMY_1D
        streak = style.shutter > 0
        if streak:
            if velocities is None:
                raise ValueError("velocities are required when style.shutter > 0")
            velocities = _particle_array("velocities", velocities, n, 3)
        else:
            velocities = _DUMMY_2D
        if n == 0:
            return 0

        for name, array in (("frame.color", frame.color), ("frame.depth", frame.depth)):
            if array.dtype != np.float32 or not array.flags.c_contiguous:
                raise ValueError(f"{name} must be a C-contiguous float32 array")
        texture = _DUMMY_TEXTURE if style.texture is None else style.texture
        arrays = (positions, colors, radii, rotation, velocities)
        with threads_for(n):
            drawn, general, fragments = self._project(frame, camera, arrays, texture)
            if drawn > general:
                fast = self._sort_fast(frame, drawn - general)
            if general:
                binned, bins = self._bin_general(frame)
        # Below a few particles' worth of pixels, waking the thread pool (a dozen parallel
        # launches) costs more than the work.
        with threads_for(fragments // FRAGMENTS_PER_PARTICLE):
            if drawn > general:
                self._draw_fast(frame, texture, *fast)
            if general:
                k.draw_kernel(kind, streak)(
                    binned, bins.starts, bins.order,
                    bins.tiles_x, style.blend is Blend.ADDITIVE,
                    fp.inverse_softness(style.softness), texture, frame.depth, frame.color,
                )  # fmt: skip
        return drawn

    def _project(self, frame, camera, arrays, texture) -> tuple[int, int, int]:
        """Project and classify; returns particles drawn, general-path ones, fragments."""
        style = self.style
        kind, streak = style.footprint, style.shutter > 0
        n = arrays[0].shape[0]
        tiles = -(-frame.width // TILE) * -(-frame.height // TILE)
        chunks = -(-n // CHUNK)
        wide = streak or kind == fp.TEXTURE
        self._record = self._buffer("record", (n, fp.RECORD_WIDE if wide else fp.RECORD_BASE))
        self._boxes = self._buffer("boxes", (4, n), np.int32)
        self._tile_of = self._buffer("tile_of", (n,), np.int32)
        self._counts = self._buffer("counts", (chunks, splat.LISTS * tiles), np.int64)
        self._counts[:] = 0
        status = np.zeros((chunks, 4), np.int64)
        alpha_mean = float(texture[..., 3].mean()) if kind == fp.TEXTURE else 0.0
        additive = style.blend is Blend.ADDITIVE
        checks = _bit_columns(arrays)
        # Still additive footprints: those that fit the fast path's windows first, in
        # vectorised passes; the projection kernel then visits the others.
        listed = additive and not streak and kind != fp.TEXTURE
        deferred = self._buffer("deferred", (n if listed else 0,), np.int64)
        deferred_count = np.zeros(chunks, np.int64)
        if listed:
            k.windows_kernel(kind)(
                camera.packed(), arrays[0], arrays[1], arrays[2], checks, style.min_radius_px,
                style.intensity, self._record, self._boxes, self._tile_of, deferred,
                deferred_count, status,
            )  # fmt: skip
        k.project_kernel(kind, streak)(
            camera.packed(), *arrays, checks, style.min_radius_px, style.shutter,
            style.intensity, additive, additive, texture, alpha_mean, self._record,
            self._boxes, self._tile_of, self._counts, status, listed, deferred,
            deferred_count,
        )  # fmt: skip
        problems = int(np.bitwise_or.reduce(status[:, k.PROBLEMS]))
        for bit, message in _CHECKS:
            if problems & bit:
                raise ValueError(message)
        totals = status.sum(axis=0)
        return int(totals[k.DRAWN]), int(totals[k.GENERAL]), int(totals[k.FRAGMENTS])

    def _sort_fast(self, frame, count: int):
        """The fast path's records in list order, and the lists' starts."""
        starts = np.empty(self._counts.shape[1] + 1, np.int64)
        scan_counts(self._counts, starts)
        records = self._buffer("sorted", (count, self._record.shape[1]))
        splat.scatter_records(
            self._record.view(np.int64), self._tile_of, self._counts, records.view(np.int64)
        )
        return records, starts

    def _draw_fast(self, frame, texture, records, starts) -> None:
        """Draw the fast path's lists: four parity phases, one kernel per list kind."""
        style = self.style
        tiles_x, tiles_y = -(-frame.width // TILE), -(-frame.height // TILE)
        sizes = np.diff(starts).reshape(-1, splat.LISTS)  # (tiles, lists)
        nearest = self._buffer("nearest", (tiles_y, tiles_x))
        splat.tile_nearest(frame.depth, nearest)
        for tiles in _parity_phases(tiles_x, tiles_y):
            for which, window in enumerate(splat.WINDOWS):
                if sizes[tiles, which].any():
                    splat.splat_kernel(style.footprint, style.shutter > 0, window)(
                        records, starts, tiles, fp.inverse_softness(style.softness), texture,
                        frame.depth, frame.color, nearest.reshape(-1),
                    )  # fmt: skip

    def _bin_general(self, frame):
        """The general path's records in tile-list order, and the tile lists."""
        boxes, record = self._boxes, self._record
        if self.style.blend is Blend.ADDITIVE:
            bins = bin_boxes(*boxes, frame.width, frame.height)
            index = bins.items
        else:
            visible = np.flatnonzero(boxes[2] >= boxes[0])
            # Back to front; the stable sort keeps equal depths in input order.
            order = visible[np.argsort(-record[visible, fp.DEPTH], kind="stable")]
            bins = bin_boxes(*boxes[:, order], frame.width, frame.height)
            index = order[bins.items]
        binned = self._buffer("binned", (index.shape[0], record.shape[1]))
        k.gather_rows(record, index, binned)
        return binned, bins


def draw_particles(
    frame: Frame,
    camera: Camera,
    positions,
    colors,
    radii=None,
    *,
    style: SpriteStyle | None = None,
    rotation=None,
    velocities=None,
) -> int:
    """Draw particles into ``frame`` with ``style``; see :meth:`SpriteRasterizer.draw`.

    Examples
    --------
    >>> import numpy as np
    >>> from motes.render.camera import Camera
    >>> from motes.render.frame import Frame
    >>> frame = Frame(64, 48)
    >>> camera = Camera((0, 0, 5), (0, 0, 0), resolution=(64, 48))
    >>> draw_particles(frame, camera, [[0, 0, 0]], [[1, 0.5, 0.2, 1]], [0.1])
    1
    >>> style = SpriteStyle("point", intensity=2.0)
    >>> frame = Frame(64, 48)
    >>> draw_particles(frame, camera, [[0, 0, 0]], [[1, 0.5, 0.2, 1]], style=style)
    1
    >>> [round(float(c), 5) for c in frame.color.sum(axis=(0, 1))]  # a point's energy is 1
    [2.0, 1.0, 0.4]
    """
    return SpriteRasterizer(style).draw(
        frame, camera, positions, colors, radii, rotation=rotation, velocities=velocities
    )


_DUMMY_1D = np.zeros(1, np.float32)
_DUMMY_2D = np.zeros((1, 3), np.float32)
_DUMMY_TEXTURE = np.zeros((1, 1, 4), np.float32)
_NO_BITS = np.zeros(0, np.int32)
for _dummy in (_DUMMY_1D, _DUMMY_2D, _DUMMY_TEXTURE):
    _dummy.flags.writeable = False


def _particle_array(name: str, value, n: int | None, columns: int | None) -> np.ndarray:
    """``value`` as float32 (a view when it already is), shape (n, columns) or (n,)."""
    try:
        array = np.asarray(value, dtype=np.float32)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be an array of numbers, got {type(value).__name__}") from None
    rows = "n" if n is None else str(n)
    expected = f"({rows}, {columns})" if columns else f"({rows},)"
    ok = array.ndim == (2 if columns else 1) and (columns is None or array.shape[1] == columns)
    if not ok or (n is not None and array.shape[0] != n):
        hint = "" if n is None else " (n = len(positions))"
        raise ValueError(f"{name} must have shape {expected}{hint}, got shape {array.shape}")
    return array


def _bit_columns(arrays) -> tuple[np.ndarray, ...]:
    """The int32 bits of the projection's float32 inputs (positions, colors, radii,
    rotation, velocities) as contiguous 1-D arrays, for its finiteness test: each
    column of an array whose columns are contiguous (a particle state's rows, passed
    transposed), else the whole array in one (copied where it is not contiguous); last,
    the values each entry holds per particle (0 for the unused ones). The entries of
    array ``a`` are ``k.CHECK_START[a]:k.CHECK_START[a + 1]``."""
    entries, widths = [], []
    for array, columns in zip(arrays, np.diff(k.CHECK_START), strict=True):
        bits = array.view(np.int32).reshape(array.shape[0], -1)
        if bits.shape[1] == columns and bits.strides[0] == bits.itemsize:
            entries += [bits[:, c] for c in range(columns)]
            widths += [1] * columns
        else:
            entries += [np.ascontiguousarray(bits).reshape(-1)] + [_NO_BITS] * (columns - 1)
            widths += [bits.shape[1]] + [0] * (columns - 1)
    # All read-only views, so that the tuple has one type (a caller's array may be
    # read-only) and the kernel one signature.
    views = []
    for entry in [*entries, np.array(widths, dtype=np.int32)]:
        view = entry.view()
        view.flags.writeable = False
        views.append(view)
    return tuple(views)


#: Pixels of drawing work counted as one particle's by the one-thread rule (a sprite of
#: about 3 px covers 9).
FRAGMENTS_PER_PARTICLE = 8


def _parity_phases(tiles_x: int, tiles_y: int) -> list[np.ndarray]:
    """The fast path's four tile phases, by the parity of tile column and row.

    Tiles of one phase are two tiles apart, so footprints reaching half a tile beyond
    their owners never meet (see :mod:`.splat_kernels`). Each phase is interleaved like
    :func:`motes.render.tiles.interleaved`.
    """
    tx, ty = np.meshgrid(np.arange(tiles_x), np.arange(tiles_y))
    tile = (ty * tiles_x + tx).ravel()
    phase = ((tx % 2) + 2 * (ty % 2)).ravel()
    return [tile[phase == p][interleaved(int(np.sum(phase == p)))] for p in range(4)]
