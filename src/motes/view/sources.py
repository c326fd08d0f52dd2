"""What the viewer shows: a scene simulated as it is watched, or a cache played back.

Both give :class:`~motes.view.packet.FramePacket` s by frame number (from 1) and the
scene that draws them (its camera starts the browser's view). A live scene keeps what
it simulated in a :class:`~motes.view.timeline.Timeline` to scrub back through.
"""

from __future__ import annotations

from pathlib import Path

from ..scene import SceneError, load_scene
from ..scene.scene import builtin_text
from .packet import FramePacket, packet_of
from .params import parameters, save_scene
from .timeline import Timeline

__all__ = ["CacheSource", "LiveSource", "Source"]

#: The renderer the viewer asks for its parts: tiny, its frame is never drawn.
PARTS_RESOLUTION = (64, 36)


class Source:
    """Frames to show; subclasses say where they come from."""

    scene = None
    #: Frames the source can give now (1 to ``available``; frames before ``first`` let go).
    available = 0
    first = 1
    #: Whether :meth:`advance` can make a new frame (a live scene).
    live = False
    #: Particles sent at most per frame; more are thinned by a stride.
    max_points = 1_000_000

    def packet(self, index: int) -> FramePacket:
        raise NotImplementedError

    def static(self) -> FramePacket:
        """The scene's objects, which do not move: sent once."""
        objects = list(self.scene.renderer(PARTS_RESOLUTION).objects)
        return packet_of([("object", [], objects)], self.scene.camera, index=0, time=0.0)

    def _packet(self, index: int, states=None) -> FramePacket:
        scene = self.scene
        renderer = scene.renderer(PARTS_RESOLUTION)
        parts = [part for part in renderer.parts(scene, states) if part[0] != "object"]
        total = sum(_count(particles) for _, particles, _ in parts)
        stride = max(1, -(-total // self.max_points))
        return packet_of(parts, scene.camera, index=index, time=scene.time, stride=stride)


def _count(particles) -> int:
    from ..state import as_state

    return sum(as_state(item).count for item, _ in particles)


class LiveSource(Source):
    """A scene (built-in name or ``.toml`` file) simulated frame by frame as watched.

    Parameters
    ----------
    source : str or Path
        A built-in scene name or a scene file.
    seed : int, optional
        Overrides the scene's seed.
    overrides : dict, optional
        ``--set`` values (key path -> value).
    history : int
        Bytes of frames kept for the timeline (the oldest are let go past it).
    """

    live = True

    def __init__(self, source, *, seed=None, overrides=None, history: int = 1 << 30):
        self.source = source
        self.seed = seed
        #: Values set over the file: the command line's, then the browser's.
        self.overrides = dict(overrides or {})
        self.timeline = Timeline(history)
        #: The scene, its file's text and its parameters: set by :meth:`restart`.
        self.scene = None
        self.text = ""
        self.parameters: list = []

    def _file_values(self) -> dict:
        values = dict(self.overrides)
        if self.seed is not None:
            values["scene.seed"] = self.seed
        return values

    def _load(self, overrides):
        return load_scene(self.source, seed=self.seed, overrides=overrides, check_finite=True)

    @property
    def available(self) -> int:
        return 0 if self.scene is None else self.scene.frame

    @property
    def first(self) -> int:
        return self.timeline.first or 1

    @property
    def finished(self) -> bool:
        """The scene's duration has been simulated (it can still go on)."""
        return self.scene is not None and self.scene.frame >= self.scene.frame_count

    def advance(self) -> FramePacket:
        """Simulate one frame; its packet (kept in the timeline). Raises SceneError or
        NonFiniteError when the simulation diverges."""
        self.scene.advance()
        packet = self._packet(self.scene.frame)
        self.timeline.add(packet)
        return packet

    def packet(self, index: int) -> FramePacket:
        """Frame ``index``'s packet, from the timeline (KeyError if let go)."""
        return self.timeline.get(index)

    def restart(self) -> None:
        """Load the scene (its file read again) with the current values, at frame 0.
        A SceneError (a file that does not load) leaves the source as it was."""
        text = _scene_text(self.source)
        scene = self._load(self.overrides)
        self.parameters = parameters(text, self._file_values())
        self.text, self.scene = text, scene
        self.timeline.clear()

    def set_values(self, values: dict) -> list[str]:
        """Set ``values`` (key path -> value) over the scene: checked by loading the scene
        with them (a SceneError, naming the key and the allowed range, leaves everything
        as it was); live ones act from the next step. Returns the keys that wait for a
        restart."""
        overrides = {**self.overrides, **values}
        fresh = self._load(overrides)  # raises before anything changes
        self.overrides = overrides
        self.parameters = parameters(self.text, self._file_values())
        live = {p.key for p in self.parameters if p.live}
        _take_parts(self.scene, fresh)
        for name, body in self.scene.bodies.items():
            body.take_values(fresh.bodies[name])
        return [key for key in values if key not in live]

    def save(self, path: Path) -> None:
        """Write the scene file with the current values to ``path``."""
        save_scene(self.text, self._file_values(), path)


def _take_parts(scene, fresh) -> None:
    """Give each system of ``scene`` the emitters, forces, modifiers, colliders and
    extinction policies of its namesake in ``fresh`` (the scene loaded with new values),
    keeping its particles, clock and random generator. Forces that ride a body's flow
    and contacts with bodies are kept: they belong to ``scene``'s bodies."""
    for name, system in scene.systems.items():
        new = fresh.systems[name]
        store = system.store
        for emitter in new.emitters:
            store.require(*emitter.writes)
        for force in new.field_forces:
            store.require(*force.reads)
        forces = [
            old if getattr(old, "rides_body", False) else item
            for old, item in zip(system.forces, new.forces, strict=True)
        ]
        for item in (*forces, *new.modifiers, *new.extinctions):
            if not any(item is old for old in system.forces):
                item.bind(store)
        system.emitters = list(new.emitters)
        system.field_forces = list(new.field_forces)
        system.forces = forces
        system.colliders = list(new.colliders)
        system.modifiers = list(new.modifiers)
        system.extinctions = list(new.extinctions)
        system.integrator = new.integrator
        system.verlet_damping = new.verlet_damping
        # the step's cached set-up and carried acceleration belong to the old parts
        system._setup_cache = None
        system._carried = None


class CacheSource(Source):
    """A particle cache played back with the scene it records (its camera, objects and
    looks); a cache without one shows its particles, meshes and curves as they are."""

    def __init__(self, cache, replay=None):
        self.cache = cache
        self.replay = replay
        self.scene = replay.scene if replay is not None else None

    @property
    def available(self) -> int:
        return self.cache.frame_count

    def packet(self, index: int) -> FramePacket:
        if self.replay is None:
            return _entries_packet(self.cache, index)
        self.replay.place(index - 1)
        return self._packet(index, self.replay.states(index - 1))

    def static(self) -> FramePacket:
        if self.scene is None:
            return FramePacket(0, 0.0)
        return super().static()


def _entries_packet(cache, index: int) -> FramePacket:
    """Frame ``index`` (from 1) of a cache without a scene: each entry's particles as
    points, a cloth's faces and a liquid's surface as meshes, strands as lines."""
    from ..geometry.mesh import TriangleMesh
    from ..render import geometry

    parts = []
    for name in cache.systems:
        entry = cache.entry(index - 1, name)
        state = entry.state
        objects = []
        if entry.faces is not None:
            objects.append(geometry.Mesh(TriangleMesh(state.positions.T, entry.faces)))
        if entry.surface is not None:
            objects.append(geometry.Mesh(TriangleMesh(*entry.surface)))
        if entry.curves is not None and state.count >= 2:
            objects.append(_strands(state.positions.T, entry.curves))
        particles = [] if objects else [(state, None)]
        parts.append((f"entry.{name}", particles, objects))
    time = float(cache.times[index - 1])
    return packet_of(parts, None, index=index, time=time)


def _strands(points, curves):
    import numpy as np

    from ..render import geometry

    starts = np.concatenate([[0], np.cumsum(curves)[:-1]])
    strips = [points[s : s + n] for s, n in zip(starts, curves, strict=True) if n >= 2]
    return geometry.Lines.strips(strips)


def _scene_text(source) -> str:
    """The TOML text of a built-in scene name or a scene file."""
    path = Path(source)
    if path.suffix != ".toml" and "/" not in str(source):
        return builtin_text(str(source))
    try:
        return path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as error:
        raise SceneError("", f"cannot read {source}: {error}") from None
