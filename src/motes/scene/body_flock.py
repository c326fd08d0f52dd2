"""``[[body]] type = "flock"``: boids in a scene (keys in ``docs/scene-format.md``,
section "Flock bodies").

A flock is built from its table: where the boids start (``center``, ``extent``,
``speed``, ``direction``), Reynolds' three rules (``[body.separation]``,
``[body.alignment]``, ``[body.cohesion]``), the limits, and its steering behaviours as
arrays of tables (``[[body.seek]]``, ``[[body.wander]]``, ``[[body.contain]]``, ...).
Behaviours toward another flock (``[[body.pursue]]``, ``[[body.evade]]``,
``[[body.avoid]]``, ``[[body.follow]]``) name it by its body name; they are linked once
every body is built (:meth:`FlockBody.link`). The scene's colliders are avoided unless
``colliders = false``.

Drawn as birds or fish (a mesh of every boid, :mod:`motes.flock.meshes`), lit flat,
optionally fading with distance into a haze colour, or as round sprites.
"""

from __future__ import annotations

import numpy as np

from .. import flock as fl
from ..flock.meshes import BIRD, FISH, faces, vertices
from ..io.entry import Entry
from ..render import geometry
from ..render.shading import Material
from ..render.sprites import SpriteStyle
from ..state import Field
from .bodies import Body, BuildContext, register
from .schema import (
    SceneError,
    Table,
    array_of,
    boolean,
    build,
    color,
    integer,
    number,
    one_of,
    positive,
    shown,
    vector,
)

#: Most boids in one flock body (about 350 MB of arrays, see ``flock.BYTES_PER_BOID``).
MAX_BOIDS = 2_000_000

#: Most points of a flock body's trails (boids × trail length).
MAX_TRAIL_POINTS = 2_000_000

#: Keys of each interaction table -> its class.
_INTERACTIONS = {
    "pursue": fl.Pursue,
    "evade": fl.Evade,
    "avoid": fl.Avoid,
    "follow": fl.FollowLeader,
}


class FlockBody(Body):
    """A :class:`~motes.flock.Flock` in a scene."""

    def __init__(self, flock: fl.Flock, *, draw, color, size, flap, specular, haze, camera,
                 pending, trail=(0, 1.0, None)):  # fmt: skip
        self.flock = flock
        self.draw = draw
        self.color = np.asarray(color[:3], np.float32)
        self.size = size
        self.flap = flap
        self.haze = haze  # None or (colour (3,), distance [m])
        self.camera = camera
        self.camera_position = np.asarray(camera.position, np.float64)
        self.pending = pending  # [(path, cls, flock name, options)] until link()
        self.material = Material(specular=specular, shininess=24.0)
        self._faces = np.zeros((0, 3), np.int32)
        self.sprite_style = SpriteStyle(blend="alpha", texture=silhouette())
        # Trails: the last ``length`` positions of every boid, by id, in a ring.
        length, self.trail_width, trail_color = trail
        self.trail_color = self.color if trail_color is None else np.asarray(trail_color[:3])
        self._history = np.zeros((length, flock.n, 3))
        self._recorded = 0
        self._shown = None  # a cached frame's boids, drawn instead of the live ones

    @property
    def replayable(self) -> bool:
        # A trail is the boids' path over their last steps, which a cache does not hold.
        return len(self._history) < 2

    def show(self, entry: Entry, time: float) -> None:
        self._shown = entry.state

    def _drawn(self):
        """The boids drawn: a cached frame's (:meth:`show`) or the live ones."""
        return self.flock.particle_state() if self._shown is None else self._shown

    def link(self, bodies: dict) -> None:
        for path, cls, name, options in self.pending:
            other = bodies.get(name)
            if not isinstance(other, FlockBody):
                flocks = sorted(n for n, b in bodies.items() if isinstance(b, FlockBody))
                raise SceneError(
                    f"{path}.flock",
                    f"must name a flock body ({', '.join(map(repr, flocks))}), got {shown(name)}",
                )
            if other is self:
                raise SceneError(f"{path}.flock", "must name another flock, not this one")
            self.flock.add(build(path, cls, other.flock, **options))
        self.pending = []

    def take_values(self, fresh: FlockBody) -> None:
        """The rules, limits, wing beat and banking of ``fresh`` (see ``LIVE_KEYS``),
        over this flock's boids and behaviours."""
        new = fresh.flock
        for name in ("separation", "alignment", "cohesion", "limits", "flap_frequency",
                     "bank_time"):  # fmt: skip
            setattr(self.flock, name, getattr(new, name))

    def step(self, dt: float) -> None:
        self.flock.step(dt)
        if not np.isfinite(self.flock.position).all():
            raise FloatingPointError("boid positions are no longer finite")
        if len(self._history):
            self._history[self._recorded % len(self._history), self.flock.ids] = (
                self.flock.position.T
            )
            self._recorded += 1

    def _trails(self) -> list:
        """Each boid's path over its last steps as a polyline (``geometry.Lines``)."""
        length = min(self._recorded, len(self._history))
        n = self.flock.n
        if length < 2 or n == 0:
            return []
        ring = (self._recorded - length + np.arange(length)) % len(self._history)
        points = self._history[ring].transpose(1, 0, 2).reshape(-1, 3)  # boid-major
        first = (np.arange(n)[:, None] * length + np.arange(length - 1)).ravel()
        segments = np.stack([first, first + 1], axis=1)
        return [geometry.Lines(points, segments, color=self.trail_color, width=self.trail_width)]

    def _colors(self, per: int) -> np.ndarray:
        """(n · per, 3) linear RGB: the flock's colour, hazed with distance."""
        boids = self._drawn()
        n = boids.count
        if self.haze is None:
            return np.broadcast_to(self.color, (n * per, 3))
        haze, distance = self.haze
        d = np.linalg.norm(boids.positions - self.camera_position[:, None], axis=0)
        t = (1.0 - np.exp(-d / distance)).astype(np.float32)[:, None]
        rgb = (1 - t) * self.color + t * haze
        return np.repeat(rgb, per, axis=0)

    def drawables(self) -> list:
        boids = self._drawn()
        if self.draw == "sprites" or boids.count == 0:
            return self._trails()
        from ..geometry.mesh import TriangleMesh

        shape = BIRD if self.draw == "birds" else FISH
        points, normals = vertices(boids.positions, boids["heading"], boids["bank"],
                                   boids["flap"], self.size, self.flap, shape)  # fmt: skip
        if self._faces.shape[0] != boids.count * len(shape.faces):
            self._faces = faces(boids.count, shape)
        mesh = TriangleMesh(points, self._faces, normals)
        colors = self._colors(len(shape.rest))
        mesh = geometry.Mesh(mesh, vertex_colors=colors, smooth=False, material=self.material)
        return [mesh, *self._trails()]

    def particles(self) -> list:
        if self.draw != "sprites":
            return []
        state = self._drawn()
        rgba = np.ones((4, state.count), np.float32)
        rgba[:3] = self._colors(1).T
        # Each sprite turned to its boid's heading as the scene's camera sees it: the
        # screen direction from the boid to a point ahead, counter-clockwise from +x
        # (screen y grows downward).
        tip = state.positions + state["heading"] * np.float32(self.size)
        here, _ = self.camera.project(state.positions.T)
        ahead, _ = self.camera.project(tip.T)
        delta = np.nan_to_num(ahead - here)
        angle = np.arctan2(-delta[:, 1], delta[:, 0]).astype(np.float32)
        fields = {"color": Field(rgba, "1", "linear RGBA"), "rotation": Field(angle, "rad")}
        radius = np.full(state.count, 0.5 * self.size, np.float32)
        return [(state.replace(radius=radius, **fields), self.sprite_style)]

    def particle_state(self):
        return self.flock.particle_state()

    def count(self) -> int:
        return self.flock.n


def silhouette(size: int = 32) -> np.ndarray:
    """A bird seen from above as a sprite texture, (size, size, 4) linear RGBA, facing +x
    (white, so the sprite's colour tints it): a slim body and swept-back pointed wings."""
    t = (np.arange(size) + 0.5) / size * 2 - 1  # texel centres in [-1, 1]
    x, y = np.meshgrid(t, -t)  # y up: row 0 is the top
    body = (x / 0.55) ** 2 + (y / 0.12) ** 2 <= 1
    # A wing: a triangle from the shoulder (x in [-0.15, 0.2] at y = 0) back to the tip
    # (x = -0.35 at |y| = 0.95).
    span = np.abs(y) / 0.95
    front = 0.2 - 0.55 * span
    back = -0.15 - 0.2 * span
    wings = (span <= 1) & (x <= front) & (x >= back)
    tail = (x < -0.4) & (x > -0.8) & (np.abs(y) < 0.08 + 0.25 * (-0.4 - x))
    alpha = (body | wings | tail).astype(np.float32)
    rgba = np.ones((size, size, 4), np.float32)
    rgba[..., 3] = alpha
    return rgba


def _rule(table: Table, key: str, default: fl.Rule) -> fl.Rule:
    t = table.table(key, optional=True)
    if t is None:
        return default
    rule = build(
        t.path,
        fl.Rule,
        radius=t.get("radius", positive(), default.radius),
        weight=t.get("weight", number(0.0), default.weight),
        fov=t.get("fov", number(0.0, 360.0, low_open=True), default.fov),
    )
    t.finish()
    return rule


_REQUIRED = object()

#: Target behaviours: table key -> (class, [(key, reader, default), ...] in argument order).
_TARGETS = {
    "seek": (fl.Seek, [("target", vector(), _REQUIRED), ("weight", number(0.0), 1.0)]),
    "flee": (fl.Flee, [("target", vector(), _REQUIRED), ("radius", positive(), 5.0),
                       ("weight", number(0.0), 1.0)]),
    "arrive": (fl.Arrive, [("target", vector(), _REQUIRED), ("slowing_radius", positive(), 5.0),
                           ("weight", number(0.0), 1.0)]),
    "wander": (fl.Wander, [("radius", positive(), 1.0), ("distance", number(0.0), 2.0),
                           ("jitter", number(0.0), 2.0), ("weight", number(0.0), 1.0)]),
    "contain": (fl.Contain, [("low", vector(), _REQUIRED), ("high", vector(), _REQUIRED),
                             ("margin", positive(), 2.0), ("weight", number(0.0), 2.0)]),
    "path": (fl.FollowPath, [("points", array_of(vector(), min_length=2), _REQUIRED),
                             ("radius", positive(), 1.0), ("lookahead", number(0.0), 0.5),
                             ("lead", number(0.0), 2.0), ("weight", number(0.0), 1.0)]),
}  # fmt: skip


def _targets(table: Table) -> list:
    out = []
    for key, (cls, fields) in _TARGETS.items():
        for t in table.tables(key):
            values = {
                name: t.get(name, reader) if default is _REQUIRED else t.get(name, reader, default)
                for name, reader, default in fields
            }
            t.finish()
            out.append(build(t.path, cls, **values))
    return out


def _pending(table: Table) -> list:
    pending = []
    for key, cls in _INTERACTIONS.items():
        for t in table.tables(key):
            name = t.get("flock", _name)
            options = {
                "radius": t.get("radius", positive(), 5.0),
                "weight": t.get("weight", number(0.0), 2.0),
            }
            if key == "follow":
                options["behind"] = t.get("behind", number(0.0), 2.0)
            t.finish()
            pending.append((t.path, cls, name, options))
    return pending


def _name(value, path):
    if not isinstance(value, str) or not value:
        raise SceneError(path, f"must be the name of a flock body, got {shown(value)}")
    return value


@register("flock")
def build_flock(table: Table, context: BuildContext) -> FlockBody:
    """Boids uniform in a box, with their rules, limits and behaviours."""
    count = table.get("count", integer(0, MAX_BOIDS))
    center = np.asarray(table.get("center", vector(), (0.0, 0.0, 0.0)))
    extent = np.asarray(table.get("extent", vector(), (10.0, 10.0, 10.0)))
    if np.any(extent < 0):
        raise SceneError(
            table.key_path("extent"), f"must be >= 0 on every axis, got {extent.tolist()}"
        )
    limits = build(
        table.path,
        fl.Limits,
        min_speed=table.get("min_speed", number(0.0), 0.0),
        max_speed=table.get("max_speed", positive(), 10.0),
        max_acceleration=table.get("max_acceleration", positive(), 20.0),
        max_turn_rate=table.get("max_turn_rate", positive(), 360.0),
    )
    direction = table.get("direction", vector(), None)
    flock = build(
        table.path,
        fl.Flock.in_box,
        count,
        center - extent / 2,
        center + extent / 2,
        speed=table.get("speed", number(0.0), 1.0),
        direction=direction,
        seed=context.seed,
        separation=_rule(table, "separation", fl.flock.SEPARATION),
        alignment=_rule(table, "alignment", fl.flock.ALIGNMENT),
        cohesion=_rule(table, "cohesion", fl.flock.COHESION),
        limits=limits,
        radius=table.get("radius", positive(), 0.1),
        flap_frequency=table.get("flap_frequency", number(0.0), 6.0),
        bank_time=table.get("bank_time", positive(), 0.2),
    )
    flock.add(*_targets(table))
    if table.get("colliders", boolean, True) and context.colliders:
        flock.add(
            build(
                table.path,
                fl.AvoidColliders,
                list(context.colliders),
                lookahead=table.get("avoid_lookahead", number(0.0), 1.0),
                margin=table.get("avoid_margin", positive(), 2.0),
                weight=table.get("avoid_weight", number(0.0), 4.0),
            )
        )
    haze_color = table.get("haze_color", color, None)
    haze_distance = table.get("haze_distance", positive(), 100.0)
    haze = None
    if haze_color is not None:
        haze = (np.asarray(haze_color[:3], np.float32), haze_distance)
    return FlockBody(
        flock,
        draw=table.get("draw", one_of("birds", "fish", "sprites"), "birds"),
        color=table.get("color", color, (0.02, 0.02, 0.025, 1.0)),
        size=table.get("size", positive(), 4 * flock.radius),
        flap=table.get("flap", number(0.0, 2.0), 1.0),
        specular=table.get("specular", number(0.0), 0.0),
        haze=haze,
        camera=context.camera,
        pending=_pending(table),
        trail=_trail(table, count),
    )


def _trail(table: Table, count: int) -> tuple:
    length = table.get("trail", integer(0, 10_000), 0)
    width = table.get("trail_width", positive(), 1.0)
    trail_color = table.get("trail_color", color, None)
    if length * count > MAX_TRAIL_POINTS:
        raise SceneError(
            table.key_path("trail"),
            f"trail × count must be at most {MAX_TRAIL_POINTS:,} points, got {length} × {count:,}",
        )
    return length, width, trail_color
