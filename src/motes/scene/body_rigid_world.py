"""``[[body]] type = "rigid"``: a rigid world composed in the scene file.

The other rigid body types (:mod:`motes.scene.body_rigid`) are ready-made set-ups with a
few knobs; this one lets a scene place its own boxes, tetrahedra, balls, ropes and
ragdolls in one :class:`motes.rigid.World`, each with an initial velocity and a colour.
Every particle collides with the scene's shared ``[[collider]]`` objects (after the
move, or swept with ``detection = "priori"``); solid bodies (boxes, tetrahedra, the
ragdolls' torsos) collide with each other, and balls with each other. Ropes and balls
pass through solid bodies. Keys are documented in ``docs/scene-format.md``.
"""

from __future__ import annotations

import numpy as np

from .. import rigid
from ..render import geometry
from .bodies import BuildContext, register
from .body_rigid import RigidScene, read_world
from .parts import euler_rotation
from .schema import SceneError, Table, build, color, integer, number, one_of, positive, vector

_ZERO = (0.0, 0.0, 0.0)


class RigidAssembly(RigidScene):
    """A :class:`RigidScene` whose lines come in groups of their own colour and width."""

    def __init__(self, world):
        super().__init__(world)
        self.line_groups: list[tuple[np.ndarray, tuple, float]] = []

    def drawables(self) -> list:
        out = super().drawables()
        position = self.world.position
        for pairs, tint, width in self.line_groups:
            out.append(geometry.Lines(position, pairs, color=tint, width=width))
        return out


def _rotation(table: Table):
    if not table.has("rotation"):
        return None
    return table.get("rotation", euler_rotation)


def _tint(table: Table, default):
    return table.get("color", color, (*default, 1.0))[:3]


def _launch(table: Table, world, particles) -> None:
    velocity = table.get("velocity", vector(), _ZERO)
    if any(velocity):
        world.set_velocity(particles, velocity)


def _box(table: Table, world, scene: RigidAssembly, k: int) -> None:
    size = table.get("size", vector(), (0.5, 0.5, 0.5))
    shape = build(
        table.path,
        rigid.BodyShape.box,
        table.get("center", vector()),
        size,
        table.get("mass", positive(), 1.0),
        rotation=_rotation(table),
    )
    body = build(table.path, world.add_body, shape)
    _launch(table, world, body.particles)
    palette = ((0.75, 0.45, 0.25), (0.3, 0.5, 0.75), (0.75, 0.7, 0.3), (0.45, 0.65, 0.4))
    scene.boxes.append((body.index, np.asarray(size, dtype=float), _tint(table, palette[k % 4])))


def _tetrahedron(table: Table, world, scene: RigidAssembly, k: int) -> None:
    shape = build(
        table.path,
        rigid.BodyShape.tetrahedron,
        table.get("center", vector()),
        table.get("edge", positive(), 0.5),
        table.get("mass", positive(), 1.0),
        rotation=_rotation(table),
    )
    body = build(table.path, world.add_body, shape)
    _launch(table, world, body.particles)
    pairs = body.particles[shape.sticks]
    scene.line_groups.append((pairs, _tint(table, (0.9, 0.75, 0.3)), 4.0))


def _ball(table: Table, world, scene: RigidAssembly, k: int) -> None:
    radius = table.get("radius", positive(), 0.1)
    (particle,) = build(
        table.path,
        world.add_particles,
        [table.get("center", vector())],
        table.get("mass", positive(), 1.0),
        radius,
    )
    _launch(table, world, [particle])
    world.add_sphere_contacts([particle], table.get("restitution", number(0.0, 1.0), 0.5))
    scene.spheres.append((int(particle), radius, _tint(table, (0.8, 0.2, 0.15))))


def _rope(table: Table, world, scene: RigidAssembly, k: int) -> None:
    start = np.asarray(table.get("start", vector()), dtype=float)
    end = np.asarray(table.get("end", vector()), dtype=float)
    if np.allclose(start, end):
        raise SceneError(table.key_path("end"), "must differ from start")
    segments = table.get("segments", integer(1, 10_000), 20)
    mass = table.get("mass", positive(), 1.0)
    slack = table.get("slack", number(1.0, 10.0), 1.0)
    pin = table.get("pin", one_of("start", "end", "both", "none"), "start")
    t = np.linspace(0.0, 1.0, segments + 1)[:, None]
    particles = world.add_particles(start + t * (end - start), mass / (segments + 1))
    pairs = np.stack([particles[:-1], particles[1:]], axis=1)
    length = slack * np.linalg.norm(end - start) / segments
    # Sticks when taut (a chain), ropes when slack: a rope only resists stretching.
    if slack == 1.0:
        world.add_sticks(pairs, np.full(segments, length))
    else:
        world.add_ropes(pairs, np.full(segments, length))
    ends = {"start": [particles[0]], "end": [particles[-1]], "none": []}
    ends["both"] = ends["start"] + ends["end"]
    if ends[pin]:
        world.pin(ends[pin])
    scene.line_groups.append((pairs, _tint(table, (0.85, 0.8, 0.65)), 3.0))


def _ragdoll(table: Table, world, scene: RigidAssembly, k: int) -> None:
    yaw = table.get("yaw", number(), 0.0)
    rotation = euler_rotation([0.0, yaw, 0.0], table.key_path("yaw"))  # turns about y
    doll = build(
        table.path,
        rigid.add_ragdoll,
        world,
        table.get("position", vector()),
        height=table.get("height", positive(), 1.8),
        mass=table.get("mass", positive(), 75.0),
        rotation=rotation,
    )
    _launch(table, world, doll.indices)
    scene.line_groups.append((doll.segments, _tint(table, (0.2, 0.35, 0.8)), 6.0))
    head = doll.particles["head"]
    scene.spheres.append((head, float(world.radius[head]), (0.85, 0.6, 0.45)))


_PARTS = {
    "box": _box,
    "tetrahedron": _tetrahedron,
    "ball": _ball,
    "rope": _rope,
    "ragdoll": _ragdoll,
}


@register("rigid")
def rigid_world(table: Table, context: BuildContext) -> RigidAssembly:
    """A rigid world of boxes, tetrahedra, balls, ropes and ragdolls."""
    world = read_world(table, context)
    scene = RigidAssembly(world)
    for key, add in _PARTS.items():
        for k, part in enumerate(table.tables(key)):
            add(part, world, scene, k)
            part.finish()
    if world.count == 0:
        raise SceneError(table.path, f"a rigid body needs at least one of: {', '.join(_PARTS)}")
    return scene
