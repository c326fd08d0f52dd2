"""Turning a scene's render settings, objects and looks into renderer calls."""

from __future__ import annotations

from contextlib import contextmanager

import numpy as np

from ..io.frames import read_image
from ..render import geometry
from ..render.frame import Frame
from ..render.metaballs import GridError, Metaballs
from ..render.renderer import Renderer, background_from
from ..render.shading import AmbientLight, DirectionalLight, Material, default_lights
from ..render.sprites import SpriteStyle
from ..render.tonemap import to_srgb8
from ..render.water import Water
from ..state import as_state
from .looks import ParticleLook, SceneObject, SpheresLook, SurfaceLook, WaterLook
from .schema import SceneError, key_name


class SceneRenderer:
    """Renders a scene's current state; built once per scene and resolution."""

    def __init__(self, scene, resolution=None):
        settings = scene.render_settings
        camera = scene.camera if resolution is None else scene.camera.with_resolution(resolution)
        self.renderer = Renderer(
            camera,
            background=background_from(settings.background),
            lights=_lights(settings.lights, settings.ambient),
            exposure=settings.exposure,
            tonemap=settings.tonemap,
            supersample=settings.supersample,
            bloom=settings.bloom,
            ambient_occlusion=settings.ambient_occlusion,
        )
        self.objects = [_drawable(o) for o in scene.objects]
        shown = {name: look for name, look in scene.looks.items() if look.visible}
        self.styles = {
            name: _style(look, f"system.{name}.render")
            for name, look in shown.items()
            if look.surface is None and look.spheres is None and look.water is None
        }
        self.surfaces = {
            name: _Surface(look.surface) for name, look in shown.items() if look.surface
        }
        self.surfaces.update(
            {name: _Spheres(look.spheres) for name, look in shown.items() if look.spheres}
        )
        self.surfaces.update(
            {name: _Water(look.water) for name, look in shown.items() if look.water}
        )

    @property
    def resolution(self) -> tuple[int, int]:
        return self.renderer.resolution

    def render_scene(self, scene, states=None) -> np.ndarray:
        """The scene's frame now, as a (height, width, 3) uint8 sRGB image; ``states``
        (system name -> ParticleState) draws those particles in place of the live
        systems' (a cached frame: ``motes render``)."""
        return self.renderer.render(*self._contents(scene, states))

    def render_scene_hdr(self, scene, states=None, *, transparent: bool = False):
        """The scene's frame now in linear light, before exposure and tone mapping: a
        :class:`~motes.render.frame.Frame` (``color``, ``depth``; with ``transparent``,
        premultiplied over nothing, and ``alpha``)."""
        return self.renderer.render_hdr(*self._contents(scene, states), transparent=transparent)

    @property
    def exposure(self) -> float:
        """The scene's exposure (a factor on linear radiance)."""
        return self.renderer.exposure

    @property
    def tonemap(self) -> str:
        """The scene's tone curve (:class:`~motes.render.tonemap.ToneMap` name)."""
        return self.renderer.tonemap

    def draw_particles(self, scene) -> None:
        """Draw the scene's particles now into a scratch frame, alone
        (:meth:`~motes.render.renderer.Renderer.draw_particles`), the scene's bloom over
        them and its tone curve: on a first run their kernels then compile early, while
        the helper of :mod:`motes.cli.compile_ahead` compiles the rest. The scratch
        frame's corner pixel is set above the bloom's threshold, so that every bloom
        pass runs (the helper's frame 0, and particles on black, may have no light that
        bright)."""
        systems = [(scene.systems[name], style) for name, style in self.styles.items()]
        for body in scene.bodies.values():
            systems.extend(body.particles())
        frame = Frame(*self.resolution)
        renderer = self.renderer
        renderer.draw_particles(frame, systems)
        if renderer.bloom is not None:
            frame.color[0, 0] = 2.0 * renderer.bloom.threshold / renderer.exposure
            renderer.bloom.apply(frame.color, exposure=renderer.exposure)
        to_srgb8(frame.color, exposure=renderer.exposure, tonemap=renderer.tonemap)

    def _contents(self, scene, states) -> tuple[list, list]:
        """The particle systems and the objects the renderer draws for the scene now."""
        if scene.camera_path is not None:
            self.renderer.camera = scene.camera_at(scene.time, self.resolution)
        systems, objects = [], []
        for _, particles, shapes in self.parts(scene, states):
            systems.extend(particles)
            objects.extend(shapes)
        return systems, objects

    def parts(self, scene, states=None) -> list[tuple[str, list, list]]:
        """What each part of the scene draws now: ``(path, particles, objects)`` with
        ``particles`` a list of ``(particles, SpriteStyle)`` and ``objects`` of
        ``render.geometry`` objects (and volumes). The scene's own objects come first
        (path ``"object"``), then each system (``"system.NAME"``), then each body
        (``"body.NAME"``); ``states`` as in :meth:`render_scene`."""
        particles = scene.systems if states is None else states
        parts = [("object", [], list(self.objects))]
        for name, style in self.styles.items():
            parts.append((f"system.{key_name(name)}", [(particles[name], style)], []))
        for name, surface in self.surfaces.items():
            path = f"system.{key_name(name)}"
            with _surface_of(f"{path}.render", scene):
                parts.append((path, [], surface.drawables(particles[name])))
        for name, body in scene.bodies.items():
            path = f"body.{key_name(name)}"
            with _surface_of(path, scene):
                parts.append((path, list(body.particles()), list(body.drawables())))
        return parts


@contextmanager
def _surface_of(path: str, scene):
    """A metaball surface whose particles spread too far for its grid: a SceneError at
    ``path`` (which cell size, or which escaped particles, is the scene's to change)."""
    try:
        yield
    except GridError as error:
        raise SceneError(path, f"cannot draw its surface in frame {scene.frame}: {error}") from None


class _Surface:
    """A system's particles as one shaded metaball surface (Blinn's field, polygonised by
    marching cubes: :class:`~motes.render.metaballs.Metaballs`), as liquids draw."""

    def __init__(self, look: SurfaceLook):
        self.look = look
        self.metaballs = Metaballs.from_radius(
            look.radius,
            sharpness=look.sharpness,
            threshold=look.threshold,
            cell_size=look.cell_size,
        )
        self.material = Material(specular=look.specular, shininess=48.0)

    def drawables(self, particles) -> list:
        """The surface over ``particles`` (a system or a ParticleState)."""
        state = as_state(particles)
        if state.count < 2:
            return []
        mesh = self.metaballs.mesh(state.positions.T)
        if len(mesh.faces) == 0:
            return []
        rgb = self.look.color
        if rgb is None:
            rgb = state["color"].T[:, :3].mean(axis=0) if "color" in state else _GREY
        return [geometry.Mesh(mesh, color=tuple(float(c) for c in rgb[:3]), material=self.material)]


_GREY = (0.7, 0.7, 0.7)


class _Spheres:
    """A system's particles as shaded spheres of their radius (``size``): grains,
    marbles, debris."""

    def __init__(self, look: SpheresLook):
        self.look = look
        self.material = Material(specular=look.specular, shininess=64.0)

    def drawables(self, particles) -> list:
        """A sphere per particle of ``particles`` (a system or a ParticleState)."""
        state = as_state(particles)
        if state.count == 0:
            return []
        colors = self.look.color
        if colors is None:
            colors = state["color"].T[:, :3] if "color" in state else _GREY
        return [
            geometry.Spheres(
                state.positions.T, state.radius, colors=colors,
                subdivisions=self.look.subdivisions, material=self.material,
            )
        ]  # fmt: skip


class _Water:
    """A system's particles as clear water in screen space (a waterfall's sheet)."""

    def __init__(self, look: WaterLook):
        self.look = look

    def drawables(self, particles) -> list:
        """The :class:`~motes.render.water.Water` over ``particles``."""
        state = as_state(particles)
        if state.count == 0:
            return []
        look = self.look
        rgb = look.color
        if rgb is None:
            rgb = state["color"].T[:, :3].mean(axis=0) if "color" in state else _WATER
        rgb = np.clip(np.asarray(rgb, np.float64), 1e-3, 1.0)
        return [
            Water(
                state.positions.T, look.radius, color=tuple(rgb), clarity=look.clarity,
                scatter=look.scatter, smoothing=look.smoothing, refraction=look.refraction,
                specular=look.specular,
            )
        ]  # fmt: skip


_WATER = (0.3, 0.62, 0.8)


def _lights(lights, ambient=None):
    """A scene's lights: its own, or the default key light (casting shadows), with its
    ambient or the default one."""
    if not lights:
        key = next(x for x in default_lights() if isinstance(x, DirectionalLight))
        lights = [DirectionalLight(key.direction, color=key.color, intensity=key.intensity,
                                   shadows=True)]  # fmt: skip
    if ambient is None:
        return [*lights, *(x for x in default_lights() if isinstance(x, AmbientLight))]
    sky, ground = ambient
    return [*lights, AmbientLight(sky, ground=ground)]


def _style(look: ParticleLook, path: str) -> SpriteStyle:
    texture = None
    if look.texture is not None:
        try:
            from ..color import srgb_to_linear

            image = read_image(look.texture).astype(np.float64) / 255.0
        except OSError as error:
            raise SceneError(f"{path}.texture", f"cannot read image: {error}") from None
        # A texture's RGB is sRGB-encoded like any image; its brightness drives alpha.
        rgb = srgb_to_linear(image)
        alpha = rgb.mean(axis=2, keepdims=True)
        texture = np.concatenate([np.ones_like(rgb), alpha], axis=2).astype(np.float32)
    return SpriteStyle(
        kind=look.kind,
        blend=look.blend,
        softness=look.softness,
        shutter=look.shutter,
        intensity=look.intensity,
        texture=texture,
        lit=look.lit,
        shadows=look.shadows,
        light=look.light,
    )


def _drawable(obj: SceneObject):
    color = obj.color[:3]
    p = obj.params
    if obj.kind == "ground":
        checker = (p["checker"][:3], p.get("checker_size", 1.0)) if "checker" in p else None
        return geometry.Ground(
            height=p.get("height", 0.0), size=p.get("size"), color=color, checker=checker
        )
    if obj.kind == "mesh":
        return geometry.Mesh(p["mesh"], color=color)
    if obj.kind == "sphere":
        return geometry.Sphere(
            p.get("center", (0.0, 0.0, 0.0)),
            p.get("radius", 1.0),
            color=color,
            subdivisions=p.get("subdivisions", 3),
        )
    if obj.kind == "capsule":
        return geometry.Capsule(
            p.get("a", (0.0, 0.0, 0.0)),
            p.get("b", (0.0, 1.0, 0.0)),
            p.get("radius", 0.1),
            color=color,
        )
    rotation = p.get("matrix")
    if rotation is None and "rotation" in p:
        from .parts import euler_rotation

        rotation = euler_rotation(list(p["rotation"]), "object.rotation")
    return geometry.Box(
        p.get("center", (0.0, 0.0, 0.0)),
        p.get("size", (1.0, 1.0, 1.0)),
        rotation=rotation,
        color=color,
    )
