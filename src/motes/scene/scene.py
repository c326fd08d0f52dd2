"""Scenes: particle systems, shared colliders, opaque objects, camera and render settings.

A scene is what a scene file describes and what ``motes run`` plays: it steps its systems
with a fixed number of substeps per frame and renders each frame. Load one with
:func:`load_scene` (a built-in name, a ``.toml`` path or TOML text).
"""

from __future__ import annotations

import re
import tomllib
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .. import hierarchy
from ..collide.colliders import Collider
from ..finite import check_finite
from ..integrate.implicit import SolverError
from ..io.entry import Entry
from ..render.bloom import Bloom
from ..render.camera import Camera, Projection
from ..render.occlusion import AmbientOcclusion
from ..render.shading import DirectionalLight, PointLight
from ..state import ParticleState
from ..system import ParticleSystem
from . import parts
from .bodies import Body, BuildContext, build_body
from .camera_path import CameraPath
from .looks import (
    ParticleLook,
    RenderSettings,
    SceneObject,
    SpheresLook,
    SurfaceLook,
    WaterLook,
)
from .overrides import apply_overrides
from .schema import (
    SceneError,
    Table,
    array_of,
    boolean,
    build,
    close_matches,
    color,
    file_name,
    integer,
    key_name,
    number,
    one_of,
    positive,
    scene_file,
    shown,
    string,
    vector,
)

BUILTIN_DIR = Path(__file__).with_name("builtin")


class Scene:
    """A runnable, renderable scene. Build with :func:`load_scene`.

    Attributes
    ----------
    systems : dict[str, ParticleSystem]
        Every system by name, in file order.
    roots : list[ParticleSystem]
        Systems that are nobody's child; stepping them steps their children.
    looks : dict[str, ParticleLook]
    objects : list[SceneObject]
        Opaque geometry, including visible colliders.
    bodies : dict[str, Body]
        Cloths, strands, rigid bodies, liquids (``[[body]]``), stepped after the systems
        in each substep.
    camera_path : CameraPath or None
        Keyframes (``[[camera.key]]``) that move the camera :meth:`render` draws with;
        ``camera`` keeps the ``[camera]`` table's view (screen-scaled emission uses it).
    check_finite : bool
        Whether :meth:`advance` checks every system and body for NaN and infinity after
        each frame (:func:`motes.finite.check_finite`), raising
        :class:`~motes.finite.NonFiniteError`. Off unless asked for.
    overrides : dict[str, object]
        The values :func:`load_scene` set over the file's (dotted key -> value).
    """

    def __init__(
        self,
        *,
        name,
        description,
        duration,
        fps,
        substeps,
        seed,
        camera,
        render,
        systems,
        looks,
        objects,
        bodies=None,
        source=None,
        camera_path=None,
        check_finite=False,
        overrides=None,
        preroll=0.0,
    ):
        self.name = name
        self.description = description
        self.duration = duration
        self.fps = fps
        self.substeps = substeps
        self.seed = seed
        self.camera = camera
        self.render_settings = render
        self.systems = systems
        self.looks = looks
        self.objects = objects
        self.bodies: dict[str, Body] = dict(bodies or {})
        self.source = source
        self.camera_path: CameraPath | None = camera_path
        self.check_finite = bool(check_finite)
        self.overrides: dict[str, object] = dict(overrides or {})
        children = {id(c) for s in systems.values() for c in s.children}
        self.roots = [s for s in systems.values() if id(s) not in children]
        self.frame = 0
        #: Seconds simulated before the first frame (rain already falling), whole frames.
        self.preroll = round(preroll * fps) / fps
        self._prerolled = self.preroll == 0
        self._renderers: dict[tuple[int, int], object] = {}

    @property
    def frame_count(self) -> int:
        """Frames in ``duration`` at ``fps`` (at least 1)."""
        return max(1, round(self.duration * self.fps))

    @property
    def time(self) -> float:
        """Time of the current frame in the shot [s]: 0 at the start of the first frame,
        after the pre-roll (the systems' and bodies' own clocks run ``preroll`` ahead)."""
        return self.frame / self.fps

    def advance(self) -> None:
        """Simulate one frame: ``substeps`` steps of ``1 / (fps · substeps)`` s.

        A system or body whose simulation diverges (positions no longer finite, an
        implicit solve that breaks down) raises :class:`SceneError` naming it: its
        parameters do not suit the step. A cloth does not: it stops and is drawn as
        diverged.
        """
        if not self._prerolled:
            self._prerolled = True
            for _ in range(round(self.preroll * self.fps)):
                self._step(self.frame)
        frame = self.frame + 1
        self._step(frame)
        if self.check_finite:  # every attribute, naming the particle
            self.frame = frame
            self._check_finite()
        for name, system in self.systems.items():
            if not np.isfinite(system["position"]).all():
                raise SceneError(
                    f"system.{key_name(name)}",
                    f"diverged in frame {frame}: particle positions are no longer finite (a "
                    "force too strong, or a step too long, for the integrator)",
                )
        self.frame = frame

    def _step(self, frame: int) -> None:
        """One frame's substeps of every system and body (``frame`` names it in errors:
        0 during the pre-roll)."""
        dt = 1.0 / (self.fps * self.substeps)
        for _ in range(self.substeps):
            for system in self.roots:
                system.step(dt)
            for name, body in self.bodies.items():
                try:
                    body.step(dt)
                except (SolverError, FloatingPointError) as error:
                    raise SceneError(
                        f"body.{key_name(name)}", f"diverged in frame {frame}: {error}"
                    ) from error

    def _check_finite(self) -> None:
        """Raise :class:`~motes.finite.NonFiniteError` at the first NaN or infinity."""
        for kind, items in (("system", self.systems), ("body", self.bodies)):
            for name, item in items.items():
                check_finite(item, owner=f"{kind} {name!r}", frame=self.frame, time=self.time)

    def counts(self) -> dict[str, int]:
        """Live particles per system and body."""
        counts = {name: len(s) for name, s in self.systems.items()}
        counts.update((name, body.count()) for name, body in self.bodies.items())
        return counts

    def states(self) -> dict[str, ParticleState]:
        """The :class:`~motes.state.ParticleState` of every system and body now, by name
        (systems first, each group in file order)."""
        states = {name: s.particle_state() for name, s in self.systems.items()}
        states.update((name, body.particle_state()) for name, body in self.bodies.items())
        return states

    def entries(self, *, surfaces: bool = False) -> dict[str, Entry]:
        """What the cache and the exporters record now, by name (systems first): each
        system's state, each body's :meth:`~motes.scene.bodies.Body.entry` (a cloth's
        faces, hair's strands, a rigid world's transforms; liquid surfaces with
        ``surfaces``)."""
        entries = {name: Entry(s.particle_state()) for name, s in self.systems.items()}
        entries.update((name, body.entry(surface=surfaces)) for name, body in self.bodies.items())
        return entries

    def camera_at(self, time: float | None = None, resolution=None) -> Camera:
        """The camera that draws the scene at ``time`` [s] (default: now): ``camera``
        moved along ``camera_path``, at ``resolution`` (default: the camera's)."""
        resolution = self.camera.resolution if resolution is None else tuple(resolution)
        if self.camera_path is None:
            return self.camera.with_resolution(resolution)
        position, target, fov = self.camera_path.at(self.time if time is None else time)
        c = self.camera
        return Camera(position, target, up=c.up, fov=fov, resolution=resolution, near=c.near,
                      far=c.far, projection=c.projection, height=c.height)  # fmt: skip

    def render(self, resolution=None) -> np.ndarray:
        """The current frame as a (height, width, 3) uint8 sRGB image.

        ``resolution`` is ``(width, height)`` [px]; ``None`` uses the camera's. One
        renderer is kept per resolution (a gallery renders stills and thumbnails). A
        keyframed camera (``camera_path``) is placed at the scene's time.
        """
        return self.renderer(resolution).render_scene(self)

    def renderer(self, resolution=None):
        """The renderer :meth:`render` uses at ``resolution`` (made on first use).

        Making it checks that a frame fits in memory
        (:class:`~motes.InsufficientMemoryError` otherwise): ``motes run`` asks
        for it before simulating.
        """
        from .drawing import SceneRenderer

        wanted = self.camera.resolution if resolution is None else tuple(resolution)
        if wanted not in self._renderers:
            self._renderers[wanted] = SceneRenderer(self, wanted)
        return self._renderers[wanted]

    def __repr__(self) -> str:
        counts = ", ".join(f"{k}={v}" for k, v in self.counts().items())
        return f"Scene({self.name!r}, frame {self.frame}/{self.frame_count}, {counts})"


# --- loading ------------------------------------------------------------------------------


def builtin_scenes() -> dict[str, str]:
    """Built-in scene names and their one-line descriptions, sorted by name."""
    result = {}
    for path in sorted(BUILTIN_DIR.glob("*.toml")):
        data = tomllib.loads(path.read_text())
        result[path.stem] = data.get("scene", {}).get("description", "")
    return result


def load_scene(
    source,
    *,
    seed: int | None = None,
    overrides: Mapping[str, object] | None = None,
    check_finite: bool = False,
) -> Scene:
    """Load a scene from a built-in name, a path to a ``.toml`` file, or TOML text.

    ``seed`` overrides the file's ``scene.seed`` (also over ``overrides``).
    ``overrides`` maps dotted keys to values set over the file's before it is read
    (``{"scene.seed": 7, "system.fire.emitter.0.rate": 500, "camera.fov": 40}``; see
    :mod:`motes.scene.overrides`), so they are checked as the file's values are.
    ``check_finite`` makes :meth:`Scene.advance` stop at the first NaN or infinity.
    Mistakes raise :class:`SceneError` with the key path, the value and what is allowed.
    """
    text, origin, base = _read_source(source)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise SceneError(origin, f"not valid TOML: {error}") from None
    except RecursionError:
        # tomllib parses nested arrays and inline tables recursively.
        raise SceneError(origin, "not valid TOML: arrays or tables nested too deeply") from None
    overrides = dict(overrides or {})
    apply_overrides(data, overrides)
    scene = _build_scene(Table(data, ""), origin, base, seed)
    scene.check_finite = bool(check_finite)
    scene.overrides = overrides
    return scene


def builtin_text(name: str) -> str:
    """The TOML text of built-in scene ``name``; a clear error, with a guess, otherwise."""
    path = BUILTIN_DIR / f"{name}.toml"
    if path.is_file() and name == path.stem:
        return path.read_text()
    names = builtin_scenes()
    guess = close_matches(name, names)
    hint = f"did you mean {guess[0]!r}? " if guess else ""
    raise SceneError(
        "", f"no built-in scene {name!r} and no such file; {hint}built-in: {', '.join(names)}"
    )


def _read_source(source) -> tuple[str, str, Path]:
    if isinstance(source, Path) or (isinstance(source, str) and "\n" not in source):
        path = Path(source)
        if path.suffix != ".toml" and "/" not in str(source):
            return builtin_text(str(source)), str(source), BUILTIN_DIR
        if path.is_dir():
            raise SceneError("", f"{path} is a directory; give a .toml scene file")
        if not path.is_file():
            raise SceneError("", f"scene file not found: {path}")
        try:
            return path.read_bytes().decode("utf-8"), str(path), path.parent
        except UnicodeDecodeError as error:
            raise SceneError(
                "", f"{path} is not a text file (byte {error.start} is not UTF-8)"
            ) from None
    if isinstance(source, str):
        return source, "<text>", Path.cwd()
    raise TypeError(f"source must be a scene name, a path or TOML text, got {source!r}")


def _camera(table: Table | None) -> tuple[Camera, CameraPath | None]:
    """The ``[camera]`` table: the camera, and its keyframed path if it has keys."""
    if table is None:
        return Camera(), None
    kwargs = {
        "position": table.get("position", vector(), (0.0, 1.0, 5.0)),
        "target": table.get("target", vector(), (0.0, 1.0, 0.0)),
        "up": table.get("up", vector(), (0.0, 1.0, 0.0)),
        "fov": table.get("fov", number(0.0, 180.0, low_open=True, high_open=True), 45.0),
        "resolution": table.get("resolution", array_of(integer(1, 16384)), [640, 360]),
        "near": table.get("near", positive(), 0.05),
        "far": table.get("far", positive(), 1000.0),
        "projection": table.get(
            "projection", one_of(*(p.value for p in Projection)), "perspective"
        ),
        "height": table.get("height", positive(), 2.0),
    }
    keys = table.tables("key")
    table.finish()
    camera = build(table.path, Camera, **kwargs)
    return camera, _camera_path(keys, camera, table.key_path("key"))


def _camera_path(keys: list[Table], camera: Camera, path: str) -> CameraPath | None:
    """``[[camera.key]]`` tables; a key without ``position``, ``target`` or ``fov``
    keeps the previous key's (the first key: the ``[camera]`` table's)."""
    if not keys:
        return None
    times, positions, targets, fovs = [], [], [], []
    position, target, fov = tuple(camera.position), tuple(camera.target), camera.fov
    fov_reader = number(0.0, 180.0, low_open=True, high_open=True)
    for key in keys:
        time = key.get("time", number(0.0))
        if times and time <= times[-1]:
            raise SceneError(
                key.key_path("time"), f"must be later than the key before ({times[-1]}), got {time}"
            )
        position = key.get("position", vector(), position)
        target = key.get("target", vector(), target)
        fov = key.get("fov", fov_reader, fov)
        key.finish()
        # Each key must be a valid view on its own (target away from the eye, up not
        # along the view): the constructor's checks, reported at the key.
        build(key.path, Camera, position, target, up=camera.up, fov=fov)
        times.append(time)
        positions.append(position)
        targets.append(target)
        fovs.append(fov)
    return build(path, CameraPath, times, positions, targets, fovs)


def _background(value, path):
    """A colour, or ``[top, bottom]`` for a vertical gradient."""
    if (
        isinstance(value, list)
        and len(value) == 2
        and all(isinstance(v, (str, list)) for v in value)
    ):
        return color(value[0], f"{path}[0]"), color(value[1], f"{path}[1]")
    return color(value, path), None


def _render_settings(table: Table | None) -> RenderSettings:
    settings = RenderSettings()
    if table is None:
        return settings
    settings.background = table.get("background", _background, settings.background)
    settings.exposure = table.get("exposure", positive(), 1.0)
    settings.tonemap = table.get("tonemap", one_of("clamp", "reinhard", "aces"), "aces")
    settings.supersample = table.get("supersample", integer(1, 4), 2)
    settings.bloom = table.get("bloom", _bloom, None)
    settings.ambient_occlusion = table.get("ambient_occlusion", _occlusion, None)
    for light in table.tables("light"):
        settings.lights.append(_light(light))
    ambient = table.get("ambient", _ambient, None)
    if ambient is not None:
        settings.ambient = ambient
    table.finish()
    return settings


def _effect(factory, readers: dict):
    """Reader of a render effect (bloom, ambient occlusion): ``true`` (its defaults),
    ``false`` (none) or a table of the keys in ``readers`` (key -> reader)."""

    def read(value, path):
        if isinstance(value, bool):
            return factory() if value else None
        if not isinstance(value, dict):
            raise SceneError(path, f"must be true, false or a table ({', '.join(readers)}), "
                                   f"got {shown(value)}")  # fmt: skip
        table, default = Table(value, path), factory()
        made = factory(**{k: table.get(k, r, getattr(default, k)) for k, r in readers.items()})
        table.finish()
        return made

    return read


_bloom = _effect(
    Bloom, {"strength": number(0.0, 1.0), "radius": number(0.001, 0.5), "threshold": number(0.0)}
)
_occlusion = _effect(AmbientOcclusion, {"radius": positive(), "strength": number(0.0, 1.0)})


def _ambient(value, path):
    """``ambient``: one colour (light from every direction) or [sky, ground]."""
    if (
        isinstance(value, list)
        and len(value) == 2
        and all(isinstance(v, (str, list)) for v in value)
    ):
        return tuple(color(v, f"{path}[{k}]")[:3] for k, v in enumerate(value))
    one = color(value, path)[:3]
    return one, one


def _light(table: Table):
    """A ``[[render.light]]``: directional (the default) or a point light."""
    kind = table.get("type", one_of("directional", "point"), "directional")
    options = {
        "color": table.get("color", color, (1.0, 1.0, 1.0, 1.0))[:3],
        "intensity": table.get("intensity", number(0.0), 1.0),
    }
    if kind == "point":
        light = build(
            table.path, PointLight, table.get("position", vector()),
            falloff=table.get("falloff", boolean, True), **options,
        )  # fmt: skip
    else:
        light = build(
            table.path, DirectionalLight, table.get("direction", vector()),
            shadows=table.get("shadows", boolean, True), **options,
        )  # fmt: skip
    table.finish()
    return light


def _tint(value, path):
    """A water colour: every channel in (0, 1] (what white light becomes)."""
    rgba = color(value, path)
    if not all(0.0 < c <= 1.0 for c in rgba[:3]):
        raise SceneError(path, f"must have each channel in (0, 1], got {shown(value)}")
    return rgba[:3]


def _look(table: Table | None, base: Path) -> ParticleLook:
    look = ParticleLook()
    if table is None:
        return look
    look.kind = table.get(
        "kind", one_of("sprite", "point", "surface", "spheres", "water"), "sprite"
    )
    if look.kind == "water":
        look.water = WaterLook(
            radius=table.get("radius", positive(), 0.05),
            clarity=table.get("clarity", positive(), 1.0),
            scatter=table.get("scatter", number(0.0, 1.0), 0.1),
            smoothing=table.get("smoothing", number(0.0), 3.0),
            refraction=table.get("refraction", number(0.0), 0.25),
            specular=table.get("specular", number(0.0), 1.0),
            color=table.get("color", _tint, None),
        )
        look.visible = table.get("visible", boolean, True)
        table.finish()
        return look
    if look.kind == "spheres":
        look.spheres = SpheresLook(
            subdivisions=table.get("subdivisions", integer(0, 3), 1),
            specular=table.get("specular", number(0.0), 0.4),
            color=table.get("color", color, None),
        )
        look.visible = table.get("visible", boolean, True)
        table.finish()
        return look
    if look.kind == "surface":
        radius = table.get("radius", positive(), 0.1)
        look.surface = SurfaceLook(
            radius=radius,
            sharpness=table.get("sharpness", positive(), 1.5),
            threshold=table.get("threshold", positive(), 1.0),
            cell_size=table.get("cell_size", positive(), 0.5 * radius),
            specular=table.get("specular", number(0.0), 0.6),
            color=table.get("color", color, None),
        )
        look.visible = table.get("visible", boolean, True)
        table.finish()
        return look
    look.blend = table.get("blend", one_of("additive", "alpha"), "additive")
    look.softness = table.get("softness", number(0.0), 0.0)
    look.shutter = table.get("shutter", number(0.0, 1.0), 0.0)
    look.intensity = table.get("intensity", number(0.0), 1.0)
    look.lit = table.get("lit", boolean, False)
    look.shadows = table.get("shadows", boolean, False)
    look.light = table.get("light", number(0.0), 0.0)
    look.texture = table.get("texture", scene_file(base, what="image file"), None)
    look.visible = table.get("visible", boolean, True)
    table.finish()
    return look


#: An opaque box's full extents [m], each > 0.
_sizes = array_of(positive(), length=3)

_OBJECT_KEYS = {
    "ground": {
        "height": number(),
        "size": positive(),
        "checker": color,
        "checker_size": positive(),
    },
    "sphere": {"center": vector(), "radius": positive(), "subdivisions": integer(0, 6)},
    "capsule": {"a": vector(), "b": vector(), "radius": positive()},
    "box": {"center": vector(), "size": lambda v, p: tuple(_sizes(v, p)), "rotation": vector()},
}


def _object(table: Table) -> SceneObject:
    kind = table.get("type", one_of(*_OBJECT_KEYS))
    params = {}
    for key, reader in _OBJECT_KEYS[kind].items():
        if table.has(key):
            params[key] = table.get(key, reader)
    tint = table.get("color", color, (0.6, 0.6, 0.6, 1.0))
    table.finish()
    return SceneObject(kind, params, tint)


def _collider_object(collider, tint) -> SceneObject:
    """The drawable twin of a visible collider (a mesh collider passes its mesh)."""
    if not isinstance(collider, Collider):
        return SceneObject("mesh", {"mesh": collider}, tint)
    kind = type(collider).__name__.lower()
    if kind == "plane":
        normal = np.asarray(collider.normal, dtype=float)
        if not np.allclose(normal / np.linalg.norm(normal), (0, 1, 0)):
            raise SceneError("collider", "only horizontal planes (normal [0, 1, 0]) can be visible")
        return SceneObject("ground", {"height": float(collider.offset)}, tint)
    if kind == "sphere":
        return SceneObject(
            "sphere", {"center": tuple(collider.center), "radius": float(collider.radius)}, tint
        )
    if kind == "capsule":
        return SceneObject(
            "capsule",
            {"a": tuple(collider.a), "b": tuple(collider.b), "radius": float(collider.radius)},
            tint,
        )
    return SceneObject(
        "box",
        {
            "center": tuple(collider.center),
            "size": tuple(2.0 * np.asarray(collider.half_extent)),
            "matrix": np.asarray(collider.rotation),
        },
        tint,
    )


def _build_scene(root: Table, origin: str, base: Path, seed_override) -> Scene:
    head = root.table("scene", optional=True) or Table({}, "scene")
    name = head.get("name", file_name, _default_name(origin))
    description = head.get("description", string, "")
    duration = head.get("duration", positive(), 4.0)
    fps = head.get("fps", number(1.0, 1000.0), 30.0)
    substeps = head.get("substeps", integer(1, 1000), 1)
    preroll = head.get("preroll", number(0.0, 3600.0), 0.0)
    seed = head.get("seed", integer(0), 0)
    if seed_override is not None:
        seed = integer(0)(seed_override, "seed")
    head.finish()
    camera, camera_path = _camera(root.table("camera", optional=True))
    render = _render_settings(root.table("render", optional=True))

    objects = [_object(t) for t in root.tables("object")]
    shared, shared_paths = [], []
    for t in root.tables("collider"):
        c, drawn, tint = parts.collider(t, base)
        shared.append(c)
        shared_paths.append(t.path)
        if drawn is not None:
            objects.append(_collider_object(drawn, tint))

    system_tables = root.tables("system")
    body_tables = root.tables("body")
    root.finish()
    if not system_tables and not body_tables:
        raise SceneError("system", "a scene needs at least one [[system]] or [[body]]")
    # Bodies take the seeds after the systems', so adding a body keeps the systems' streams.
    seeds = np.random.SeedSequence(seed).spawn(len(system_tables) + len(body_tables))
    body_seeds = seeds[len(system_tables) :]
    systems: dict[str, ParticleSystem] = {}
    looks: dict[str, ParticleLook] = {}
    pending_children = []
    pending_contacts = []
    pending_flows = []
    for t, seq in zip(system_tables, seeds[: len(system_tables)], strict=True):
        system_name = t.get("name", string)
        if system_name in systems:
            raise SceneError(t.key_path("name"), f"duplicate system name {shown(system_name)}")
        system = build(
            t.path,
            ParticleSystem,
            capacity=t.get("capacity", integer(1, 100_000_000), 100_000),
            seed=int(seq.generate_state(1)[0]),
            integrator=t.get("integrator", one_of(*parts.INTEGRATORS), "semi_implicit_euler"),
            verlet_damping=t.get("verlet_damping", number(0.0, 1.0), 0.0),
            compaction=t.get("compaction", one_of("stable", "swap"), "stable"),
        )
        for e in t.tables("emitter"):
            system.add(parts.emitter(e, camera, base))
        for f in t.tables("force"):
            if f.data.get("type") == "grid_flow":  # rides a body's flow: after the bodies
                pending_flows.append((system, f))
            else:
                system.add(parts.force(f))
        for p in t.tables("particles"):
            parts.place_particles(p, system)
        for m in t.tables("modifier"):
            system.add(parts.modifier(m))
        for c in t.tables("collider"):
            collider, drawn, tint = parts.collider(c, base)
            build(c.path, system.add, collider)
            if drawn is not None:
                objects.append(_collider_object(drawn, tint))
        if t.get("shared_colliders", boolean, True):
            for c, path in zip(shared, shared_paths, strict=True):
                build(path, system.add, c)
        collisions = t.table("collisions", optional=True)
        if collisions is not None:
            system.add(parts.particle_collisions(collisions))
        pending_children.extend((system, c) for c in t.tables("child"))
        pending_contacts.extend((system_name, system, c) for c in t.tables("contact"))
        looks[system_name] = _look(t.table("render", optional=True), base)
        t.finish()
        systems[system_name] = system

    for parent, c in pending_children:
        child_name = c.get("system", one_of(*systems))
        child = systems[child_name]
        template = c.table("emitter", optional=True) or Table({}, c.key_path("emitter"))
        link = build(
            c.path,
            hierarchy.SpawnOnEvent,
            child,
            parts.emitter(template, camera, base, template=True),
            on=c.get("on", one_of(*parts.EVENT_KINDS), "death"),
            count=c.get("count", _count, 1),
            inherit=tuple(c.get("inherit", array_of(string), [])),
        )
        c.finish()
        parent.add(link)

    bodies: dict[str, Body] = {}
    for t, seq in zip(body_tables, body_seeds, strict=True):
        context = BuildContext(camera, base, int(seq.generate_state(1)[0]), list(shared))
        body_name, body = build_body(t, context)
        if body_name in systems or body_name in bodies:
            raise SceneError(t.key_path("name"), f"duplicate name {shown(body_name)}")
        bodies[body_name] = body
    for body in bodies.values():
        body.link(bodies)
        body.link_systems(systems)
    for system, f in pending_flows:
        system.add(_flow(f, bodies))

    for system_name, system, c in pending_contacts:
        system.add(_contact(c, bodies, system_name))

    return Scene(
        name=name,
        description=description,
        duration=duration,
        fps=fps,
        substeps=substeps,
        seed=seed,
        camera=camera,
        render=render,
        systems=systems,
        looks=looks,
        objects=objects,
        bodies=bodies,
        source=origin,
        camera_path=camera_path,
        preroll=preroll,
    )


def _contact(table: Table, bodies: dict[str, Body], system_name: str):
    """A ``[[system.contact]]``: the system's particles against a body, both ways."""
    name = table.get("body", one_of(*bodies) if bodies else _no_bodies)
    options = {
        "restitution": table.get("restitution", number(0.0, 1.0), 0.0),
        "friction": table.get("friction", number(0.0), 0.0),
        "thickness": table.get("thickness", positive(), 0.01),
        "response": table.get("response", one_of("bounce", "kill"), "bounce"),
        "particle_mass": table.get("particle_mass", positive(), None),
    }
    table.finish()
    try:
        return bodies[name].contact(table.path, name, options)
    except SceneError as error:
        if error.path != table.path:
            raise
        raise SceneError(error.path, f"system {system_name!r}: {error.message}") from None


def _flow(table: Table, bodies: dict[str, Body]):
    """A ``[[system.force]] type = "grid_flow"``: drag toward a grid fluid's velocity."""
    table.get("type", string)
    name = table.get("body", one_of(*bodies) if bodies else _no_bodies)
    options = {"response_time": table.get("response_time", positive(), 0.1)}
    table.finish()
    return bodies[name].flow(table.path, options)


def _no_bodies(value, path):
    raise SceneError(path, f"names body {shown(value)}, but the scene has no [[body]]")


def _default_name(origin: str) -> str:
    """The file's stem, made a safe output name (scene files may be named anything)."""
    if origin == "<text>":
        return "scene"
    stem = re.sub(r"[^A-Za-z0-9_.-]", "_", Path(origin).stem).lstrip("._-")
    return stem[:100] or "scene"


def _count(value, path):
    if isinstance(value, int) and not isinstance(value, bool):
        return integer(0)(value, path)
    return parts.distribution(value, path)
