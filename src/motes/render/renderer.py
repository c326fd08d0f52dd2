"""The renderer: background, opaque geometry and particle systems into one image.

Order of drawing: the background; opaque geometry (which fills the depth buffer);
liquids drawn in screen space (:mod:`.water`: they refract what is drawn so far and
write their surface's depth); volumes (:mod:`.volume`: ray-marched up to that depth);
then particle systems, alpha-blended ones first (each sorted back to front; systems
ordered by their mean depth, far first) and additive ones last (order-independent).
Colour is accumulated in linear light and tone-mapped to sRGB at the end.

Particles of any kind are read through their :class:`~motes.state.ParticleState`: a
system, a liquid, a cloth, hair or a rigid world (anything with ``particle_state()``),
or a state itself.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .. import _memory
from .. import _validate as check
from ..color import parse_color
from ..state import ParticleState, as_state
from .background import Background
from .bloom import Bloom
from .camera import Camera
from .emitted_light import emitted_lights
from .frame import Frame
from .geometry import casters, draw_geometry
from .lighting import light_particles
from .occlusion import AmbientOcclusion
from .shading import default_lights
from .shadow_pass import prepare
from .sprites import Blend, SpriteRasterizer, SpriteStyle
from .tonemap import ToneMap, to_srgb8
from .volume import Volume, draw_volumes, volume_shadowing
from .water import Water

_WHITE = np.ones((1, 4), dtype=np.float32)

#: Memory per pixel [bytes] of a frame: linear colour (12) and depth (4) in float32, the
#: 8-bit image (3), rounded up (measured: 19 B per pixel, 21 with a scene's sprites).
BYTES_PER_PIXEL = 24


class Renderer:
    """Render particle systems and opaque objects seen by one camera.

    Parameters
    ----------
    camera : Camera
    background : Background or colour
        A :class:`Background`, or a colour for a solid one.
    lights : sequence of lights, optional
        For opaque geometry (see :mod:`motes.render.shading`); ``None``: a default key
        light and ambient.
    exposure : float
        Multiplier on linear light before tone mapping, > 0.
    tonemap : {"clamp", "reinhard", "aces"}
    supersample : int
        Anti-aliasing samples per pixel side for opaque geometry, 1 to 4.
    ambient_occlusion : AmbientOcclusion, optional
        Soft darkening where opaque surfaces meet
        (:class:`~motes.render.occlusion.AmbientOcclusion`); None: none.
    bloom : Bloom, optional
        Glow around light brighter than white (:class:`~motes.render.bloom.Bloom`),
        added to the frame in linear light; None: none.

    Examples
    --------
    >>> import motes as mo
    >>> fire = mo.ParticleSystem(5_000, seed=1)
    >>> _ = fire.add(mo.Emitter(mo.shapes.Disc(0.3), mo.PerSecond(3000), color="#ff8020",
    ...                         size=0.03), mo.Gravity((0, 2.0, 0)))
    >>> fire.run(30, 1 / 30)
    >>> camera = mo.Camera((0, 1, 4), (0, 1, 0), resolution=(160, 90))
    >>> image = mo.Renderer(camera).render([fire])
    >>> image.shape, image.dtype.name, bool(image.any())
    ((90, 160, 3), 'uint8', True)
    """

    def __init__(
        self,
        camera: Camera,
        *,
        background=None,
        lights=None,
        exposure: float = 1.0,
        tonemap: str = "aces",
        supersample: int = 2,
        bloom: Bloom | None = None,
        ambient_occlusion: AmbientOcclusion | None = None,
    ):
        if not isinstance(camera, Camera):
            raise TypeError(f"camera must be a Camera, got {camera!r}")
        width, height = camera.resolution
        _memory.check(
            f"resolution = {width}x{height}",
            width * height * BYTES_PER_PIXEL,
            per=f"{BYTES_PER_PIXEL} B per pixel",
        )
        self.camera = camera
        if background is None:
            background = Background()
        elif not isinstance(background, Background):
            background = Background(background)
        self.background = background
        self.lights = lights
        self.exposure = check.positive("exposure", exposure)
        self.tonemap = check.choice("tonemap", tonemap, [t.value for t in ToneMap])
        self.supersample = check.integer("supersample", supersample, low=1)
        if bloom is not None and not isinstance(bloom, Bloom):
            raise TypeError(f"bloom must be a Bloom or None, got {bloom!r}")
        self.bloom = bloom
        if ambient_occlusion is not None and not isinstance(ambient_occlusion, AmbientOcclusion):
            raise TypeError(
                f"ambient_occlusion must be an AmbientOcclusion or None, got {ambient_occlusion!r}"
            )
        self.ambient_occlusion = ambient_occlusion
        # One rasteriser per (system, style) keeps its scratch buffers between frames
        # (tens of MB at a million particles); the entries hold no reference to systems.
        self._rasterizers: dict[tuple[int, int], SpriteRasterizer] = {}
        # the white coverage pass of a transparent frame: (style drawn, its rasteriser)
        self._coverage_rasterizers: dict[tuple[int, int], tuple] = {}
        self._frame: Frame | None = None  # render()'s, kept (see _reused_frame)

    @property
    def resolution(self) -> tuple[int, int]:
        return self.camera.resolution

    def render_hdr(self, systems=(), objects=(), *, transparent: bool = False) -> Frame:
        """The frame in linear light (before tone mapping).

        ``transparent`` draws over nothing instead of the background and fills
        ``frame.alpha``: opaque geometry covers its pixels, alpha-blended particles
        ``1 - prod(1 - a)`` of what lies in front of it (a second pass of them in white
        gives it), additive ones nothing (light adds, it does not cover). ``color`` is
        then premultiplied: over a background ``B``, ``color + (1 - alpha) B`` is the
        frame drawn on ``B``.

        ``systems`` holds particles — a :class:`~motes.state.ParticleState` or anything
        with ``particle_state()`` (a :class:`~motes.system.ParticleSystem`, a liquid,
        cloth, hair, a rigid world) — or ``(particles, SpriteStyle)`` pairs; ``objects``
        opaque geometry (:class:`~motes.render.geometry.Ground`, ``Sphere``, ``Box``,
        ``Mesh``, ``Lines``), liquids drawn in screen space
        (:class:`~motes.render.water.Water`) and participating media
        (:class:`~motes.render.volume.Volume`: drawn after the geometry, before the
        particles, whose colours then place them behind, inside or in front of it; see
        :mod:`motes.render.volume`).
        """
        width, height = self.camera.resolution
        frame = Frame(width, height)
        self._draw_frame(frame, systems, objects, transparent)
        return frame

    def _draw_frame(self, frame: Frame, systems, objects, transparent: bool) -> None:
        """Draw everything into ``frame``: a fresh one, or :meth:`render`'s own (every
        pixel of its colour is written, its depth is reset: see :meth:`_reused_frame`)."""
        if not transparent:
            self.background.fill(frame)
        items = self._draw_order(systems)
        objects = list(objects)
        volumes = [o for o in objects if isinstance(o, Volume)]
        waters = [o for o in objects if isinstance(o, Water)]
        if volumes or waters:
            objects = [o for o in objects if not isinstance(o, (Volume, Water))]
        lights = self.lights
        glowing = emitted_lights(items, volumes)
        if glowing:  # this frame's light from glowing particles and volumes
            if lights is None:
                lights = default_lights()
            elif not isinstance(lights, (list, tuple)):
                lights = [lights]
            lights = [*lights, *glowing]
        shadowing = shaded = None
        if objects or volumes or any(style.lit for _, _, style in items):
            casting = [_opacity_of(state) for _, state, style in items if style.shadows]
            casting += [o.opacity_casters() for o in objects if getattr(o, "shadow_radius", 0)]
            shadowing = shaded = prepare(lights, casters(objects), self.camera, casting)
            if volumes:  # geometry and particles in the volumes' shadows too
                shaded = volume_shadowing(shadowing, lights, casting, volumes)
        if objects:
            draw_geometry(
                frame, self.camera, objects, lights=lights, supersample=self.supersample,
                shadowing=shaded,
            )  # fmt: skip
            if self.ambient_occlusion is not None:
                self.ambient_occlusion.apply(frame.color, frame.depth, self.camera)
        for water in waters:
            water.draw(frame, self.camera, lights=lights, background=self.background)
        layer = None
        if volumes:
            layer = draw_volumes(frame, self.camera, volumes, shadowing, froxels=bool(items))
        self._draw_items(frame, items, shaded, layer)
        if transparent:
            frame.alpha = self._coverage(frame, items)
            if layer is not None:
                frame.alpha = layer.cover(frame.alpha)
        if self.bloom is not None:  # light: it covers nothing (the alpha stays)
            self.bloom.apply(frame.color, exposure=self.exposure)

    def draw_particles(self, frame: Frame, systems=()) -> None:
        """Draw ``systems`` (as in :meth:`render_hdr`) into ``frame`` alone: no geometry,
        lights or bloom; lit particles take their own colours. ``motes run`` calls it to
        compile the particle kernels early (:mod:`motes.cli.compile_ahead`)."""
        self._draw_items(frame, self._draw_order(systems), None, None)

    def _draw_items(self, frame: Frame, items, shaded, layer) -> None:
        """Draw ``items`` (:meth:`_draw_order`), lit through ``shaded`` where their style
        asks (and ``shaded`` is given), behind or inside the volume ``layer``."""
        for owner, state, style in items:
            # Keyed by the object passed in (a system lives across frames; a state is
            # taken anew each frame): its rasteriser keeps its scratch buffers.
            key = (id(owner), id(style))
            rasterizer = self._rasterizers.get(key)
            if rasterizer is None or rasterizer.style is not style:  # ids can be reused
                if len(self._rasterizers) > 64:
                    self._rasterizers.clear()
                rasterizer = self._rasterizers[key] = SpriteRasterizer(style)
            colors = _lit_colors(state, shaded) if style.lit and shaded is not None else None
            if layer is not None:
                colors = _colors(state) if colors is None else colors
                colors = layer.through(self.camera, state.positions.T, colors, style)
            draw_system(frame, self.camera, state, rasterizer, colors=colors)

    def _coverage(self, frame: Frame, items) -> np.ndarray:
        """Alpha of a frame drawn over nothing: 1 on opaque geometry, else what the
        alpha-blended particles cover (drawn again in white, at intensity 1, over black,
        with the same depth buffer, so occlusion and soft fading match)."""
        cover = Frame(frame.width, frame.height)
        cover.depth = frame.depth
        for owner, state, style in items:
            if style.blend is not Blend.ALPHA:
                continue
            white = np.array(_colors(state), dtype=np.float32)
            white[:, :3] = 1.0
            key = (id(owner), id(style))
            made_for, rasterizer = self._coverage_rasterizers.get(key, (None, None))
            if made_for is not style:  # none yet, or ids reused
                if len(self._coverage_rasterizers) > 64:
                    self._coverage_rasterizers.clear()
                plain = dataclasses.replace(style, intensity=1.0, lit=False)
                rasterizer = SpriteRasterizer(plain)
                self._coverage_rasterizers[key] = (style, rasterizer)
            draw_system(cover, self.camera, state, rasterizer, colors=white)
        alpha = np.clip(cover.color[..., 0], 0.0, 1.0)
        alpha[np.isfinite(frame.depth)] = 1.0
        return alpha

    def render(self, systems=(), objects=()) -> np.ndarray:
        """The frame as a (height, width, 3) uint8 sRGB image."""
        frame = self._reused_frame()
        self._draw_frame(frame, systems, objects, False)
        return to_srgb8(frame.color, exposure=self.exposure, tonemap=self.tonemap)

    def _reused_frame(self) -> Frame:
        """:meth:`render`'s frame, kept between calls: a fresh 1280 × 720 frame costs
        its 15 MB of zeros and page faults on every call (2.5-3 ms), a kept one a reset
        of its depth. Its colour needs no reset: the background fills every pixel.
        :meth:`render_hdr` returns its frame, so it always makes a new one."""
        width, height = self.camera.resolution
        frame = self._frame
        if frame is None or (frame.width, frame.height) != (width, height):
            frame = self._frame = Frame(width, height)
        else:
            frame.depth.fill(np.inf)
            frame.alpha = None
        return frame

    def _draw_order(self, systems) -> list[tuple[object, ParticleState, SpriteStyle]]:
        """``(owner, state, style)`` of each non-empty item, in drawing order."""
        items = []
        for item in systems:
            owner, style = item if isinstance(item, tuple) else (item, SpriteStyle())
            if not isinstance(style, SpriteStyle):
                raise TypeError(f"style must be a SpriteStyle, got {style!r}")
            state = as_state(owner)
            if state.count:
                items.append((owner, state, style))
        alpha = [p for p in items if p[2].blend is Blend.ALPHA]
        additive = [p for p in items if p[2].blend is not Blend.ALPHA]
        depth = [
            float(self.camera.to_view(state.positions.T.mean(axis=0))[0, 2])
            for _, state, _ in alpha
        ]
        order = sorted(range(len(alpha)), key=lambda k: -depth[k])
        return [alpha[k] for k in order] + additive


def _colors(state: ParticleState) -> np.ndarray:
    """(n, 4) RGBA of a state's particles (white without a ``color`` field)."""
    if "color" in state:
        return state["color"].T
    return np.broadcast_to(_WHITE, (state.count, 4))


def _opacity_of(state: ParticleState) -> tuple:
    """What an opacity map needs of shadow-casting particles: positions (n, 3), radius
    (n,), alpha (n,)."""
    return state.positions.T, np.asarray(state.radius), _colors(state)[:, 3]


def _lit_colors(state: ParticleState, shadowing) -> np.ndarray:
    """The particles' colours lit by the frame's lights (:func:`light_particles`)."""
    rgba = np.array(_colors(state), dtype=np.float32)
    rgb = np.ascontiguousarray(rgba[:, :3])
    out = np.empty_like(rgb)
    x, y, z = (np.ascontiguousarray(r, dtype=np.float64) for r in state.positions)
    light_particles(shadowing.lights, shadowing.ambient, shadowing.arrays, x, y, z, rgb, out)
    rgba[:, :3] = out
    return rgba


def draw_system(
    frame: Frame, camera: Camera, particles, rasterizer: SpriteRasterizer, *, colors=None
) -> int:
    """Draw particles (a :class:`~motes.state.ParticleState` or anything with
    ``particle_state()``); returns the number drawn.

    Colour comes from ``colors`` (n, 4) when given, else the state's ``color`` field
    (white without one), the sprite
    radius from ``radius``, the texture angle from ``rotation`` when the style has a
    texture, the streak from ``velocities`` when it has a shutter. The rasteriser takes
    ``(n, c)`` arrays: the state's ``(c, n)`` rows are passed transposed, without a copy.
    """
    state = as_state(particles)
    style = rasterizer.style
    n = state.count
    if n == 0:
        return 0
    colors = _colors(state) if colors is None else colors
    rotation = state["rotation"] if "rotation" in state and style.texture is not None else None
    velocities = state.velocities.T if style.shutter > 0 else None
    return rasterizer.draw(
        frame, camera, state.positions.T, colors, state.radius,
        rotation=rotation, velocities=velocities,
    )  # fmt: skip


def background_from(settings) -> Background:
    """A Background from a scene's ``(top, bottom)`` colours."""
    top, bottom = settings
    return Background(parse_color(top), None if bottom is None else parse_color(bottom))
