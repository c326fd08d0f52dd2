"""``[[body]] type = "rigid"``: a rigid world composed in the scene file.

The other rigid body types (:mod:`motes.scene.body_rigid`) are ready-made set-ups with a
few knobs; this one lets a scene place its own boxes, tetrahedra, balls, ropes and
ragdolls in one :class:`motes.rigid.World`, each with an initial velocity and a colour.
Every particle collides with the scene's shared ``[[collider]]`` objects (after the
move, or swept with ``detection = "priori"``); solid bodies (boxes, tetrahedra, the
ragdolls' torsos) collide with each other, and balls with each other. Ropes and balls
pass through solid bodies. Named parts can be joined by ``[[body.spring]]`` (XPBD
sticks of compliance 1/stiffness) and ``[[body.joint]]`` (ball joints and hinges: one or
two particles attached to both bodies, Jakobsen 2001, §5). Keys are documented in
``docs/scene-format.md``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .. import rigid
from ..render import geometry
from .bodies import BuildContext, register
from .body_rigid import RigidScene, ragdoll_body, read_world
from .parts import euler_rotation
from .schema import (
    SceneError,
    Table,
    array_of,
    boolean,
    build,
    color,
    integer,
    listed,
    number,
    one_of,
    positive,
    shown,
    string,
    vector,
)

_ZERO = (0.0, 0.0, 0.0)

#: Explicit body groups of jointed parts start here, far above the groups ragdolls take
#: (their first particle index), so the two never meet.
_JOINT_GROUPS = 1 << 30


@dataclass
class _Part:
    """A named part: what springs and joints may refer to."""

    kind: str
    particles: np.ndarray
    joints: dict = field(default_factory=dict)  # ragdoll joint name -> particle
    body: bool = False  # a rigid body (box, tetrahedron) that joints can hold


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


def _compliance(table: Table) -> float:
    return table.get("compliance", number(0.0), 0.0)


def _add_body(table: Table, world, shape, group):
    return build(
        table.path,
        world.add_body,
        shape,
        group=group,
        compliance=_compliance(table),
    )


def _box(table: Table, world, scene: RigidAssembly, k: int, group) -> _Part:
    size = table.get("size", vector(), (0.5, 0.5, 0.5))
    shape = build(
        table.path,
        rigid.BodyShape.box,
        table.get("center", vector()),
        size,
        table.get("mass", positive(), 1.0),
        rotation=_rotation(table),
    )
    body = _add_body(table, world, shape, group)
    _launch(table, world, body.particles)
    palette = ((0.75, 0.45, 0.25), (0.3, 0.5, 0.75), (0.75, 0.7, 0.3), (0.45, 0.65, 0.4))
    scene.boxes.append((body.index, np.asarray(size, dtype=float), _tint(table, palette[k % 4])))
    return _Part("box", body.particles, body=True)


def _tetrahedron(table: Table, world, scene: RigidAssembly, k: int, group) -> _Part:
    shape = build(
        table.path,
        rigid.BodyShape.tetrahedron,
        table.get("center", vector()),
        table.get("edge", positive(), 0.5),
        table.get("mass", positive(), 1.0),
        rotation=_rotation(table),
    )
    body = _add_body(table, world, shape, group)
    _launch(table, world, body.particles)
    pairs = body.particles[shape.sticks]
    scene.line_groups.append((pairs, _tint(table, (0.9, 0.75, 0.3)), 4.0))
    return _Part("tetrahedron", body.particles, body=True)


def _ball(table: Table, world, scene: RigidAssembly, k: int, group) -> _Part:
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
    return _Part("ball", np.array([particle]))


def _rope(table: Table, world, scene: RigidAssembly, k: int, group) -> _Part:
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
    compliance = _compliance(table)
    # Sticks when taut (a chain), ropes when slack: a rope only resists stretching.
    if slack == 1.0:
        world.add_sticks(pairs, np.full(segments, length), compliance=compliance)
    else:
        world.add_ropes(pairs, np.full(segments, length), compliance=compliance)
    ends = {"start": [particles[0]], "end": [particles[-1]], "none": []}
    ends["both"] = ends["start"] + ends["end"]
    if ends[pin]:
        world.pin(ends[pin])
    scene.line_groups.append((pairs, _tint(table, (0.85, 0.8, 0.65)), 3.0))
    return _Part("rope", particles)


def _ragdoll(table: Table, world, scene: RigidAssembly, k: int, group) -> _Part:
    yaw = table.get("yaw", number(), 0.0)
    rotation = euler_rotation([0.0, yaw, 0.0], table.key_path("yaw"))  # turns about y
    height = table.get("height", positive(), 1.8)
    doll = build(
        table.path,
        rigid.add_ragdoll,
        world,
        table.get("position", vector()),
        height=height,
        mass=table.get("mass", positive(), 75.0),
        rotation=rotation,
        compliance=_compliance(table),
        hinge_sides=table.get("hinge_sides", boolean, False),
    )
    _launch(table, world, doll.indices)
    scene.add_capsules(ragdoll_body(doll.particles, height, _tint(table, (0.2, 0.35, 0.75))))
    head = doll.particles["head"]
    scene.spheres.append((head, float(world.radius[head]), (0.85, 0.6, 0.45)))
    return _Part("ragdoll", doll.indices, joints=dict(doll.particles))


_PARTS = {
    "box": _box,
    "tetrahedron": _tetrahedron,
    "ball": _ball,
    "rope": _rope,
    "ragdoll": _ragdoll,
}


@register("rigid")
def rigid_world(table: Table, context: BuildContext) -> RigidAssembly:
    """A rigid world of boxes, tetrahedra, balls, ropes and ragdolls, with springs and
    joints between named parts."""
    world = read_world(table, context)
    scene = RigidAssembly(world)
    joints = table.tables("joint")
    groups = _joint_groups(joints)
    parts: dict[str, _Part] = {}
    for key, add in _PARTS.items():
        for k, item in enumerate(table.tables(key)):
            name = item.get("name", string, None)
            if name is not None and (name in parts or not name or "." in name):
                reason = "is used by another part" if name in parts else "must be non-empty, no '.'"
                raise SceneError(item.key_path("name"), f"{reason}: {shown(name)}")
            part = add(item, world, scene, k, groups.get(name))
            item.finish()
            if name is not None:
                parts[name] = part
    if world.count == 0:
        raise SceneError(table.path, f"a rigid body needs at least one of: {', '.join(_PARTS)}")
    for item in table.tables("spring"):
        _spring(item, world, scene, parts)
        item.finish()
    for item in joints:
        _joint(item, world, scene, parts, groups)
        item.finish()
    return scene


# --- springs and joints -------------------------------------------------------------------


def _joint_groups(joints: list[Table]) -> dict:
    """A body group per set of parts joined (directly or through others), so that
    jointed parts, which overlap at their joints, do not collide with each other."""
    parent: dict[str, str] = {}

    def root(name):
        while parent.setdefault(name, name) != name:
            name = parent[name]
        return name

    for item in joints:
        names = item.data.get("bodies")
        if isinstance(names, list) and len(names) == 2 and all(isinstance(n, str) for n in names):
            parent[root(names[0])] = root(names[1])
        elif isinstance(names, list) and len(names) == 1 and isinstance(names[0], str):
            root(names[0])
    roots = sorted({root(n) for n in parent})
    return {n: _JOINT_GROUPS + roots.index(root(n)) for n in parent}


def _endpoint(value, path, world, parts: dict[str, _Part]):
    """A spring end: a point ``[x, y, z]`` (a new pinned particle there) or a particle of
    a named part: ``"ball"``, ``"crate.3"`` (its particle 3; negative from the end),
    ``"doll.wrist_l"`` (a ragdoll joint)."""
    if isinstance(value, list):
        point = vector()(value, path)
        (anchor,) = world.add_particles([point], 1.0)
        world.pin([anchor])
        return int(anchor)
    text = string(value, path)
    name, _, which = text.partition(".")
    if name not in parts:
        known = listed(parts) or "none (give parts a name)"
        raise SceneError(path, f"no part named {shown(name)}; named parts: {known}")
    part = parts[name]
    if not which:
        if len(part.particles) != 1:
            raise SceneError(
                path,
                f"{shown(name)} is a {part.kind} of {len(part.particles)} particles: name one, "
                f"e.g. {shown(name + '.0')}"
                + (f" or {shown(name + '.head')}" if part.joints else ""),
            )
        return int(part.particles[0])
    if which in part.joints:
        return int(part.joints[which])
    try:
        index = int(which)
    except ValueError:
        allowed = f"an index in [-{len(part.particles)}, {len(part.particles) - 1}]"
        if part.joints:
            allowed += " or one of " + ", ".join(part.joints)
        raise SceneError(path, f"{shown(text)}: {shown(which)} is not {allowed}") from None
    if not -len(part.particles) <= index < len(part.particles):
        raise SceneError(
            path,
            f"{shown(text)}: {shown(name)} has particles 0 to {len(part.particles) - 1} "
            f"(negative from the end), got {index}",
        )
    return int(part.particles[index])


def _spring(table: Table, world, scene: RigidAssembly, parts) -> None:
    """An XPBD stick of compliance 1/stiffness (Macklin et al. 2016): a spring whose
    stiffness does not depend on the iteration count or the step."""
    ends = table.get("between", array_of(lambda v, p: v, min_length=2))
    if len(ends) != 2:
        raise SceneError(table.key_path("between"), f"must be [a, b], got {shown(ends)}")
    a, b = (
        _endpoint(v, f"{table.key_path('between')}[{i}]", world, parts) for i, v in enumerate(ends)
    )
    if a == b:
        raise SceneError(table.key_path("between"), "must join two different particles")
    stiffness = table.get("stiffness", positive())
    rest = table.get("rest_length", number(0.0), None)
    length = None if rest is None else [rest]
    build(table.path, world.add_sticks, [[a, b]], length, compliance=1.0 / stiffness)
    width = table.get("width", positive(), 2.0)
    scene.line_groups.append((np.array([[a, b]]), _tint(table, (0.9, 0.9, 0.9)), width))


def _joint(table: Table, world, scene: RigidAssembly, parts, groups) -> None:
    """A ball joint (one particle) or a hinge (two, along ``axis``) stuck to every
    particle of each joined body: the bodies share it and turn about it (Jakobsen 2001,
    §5, as ``World.add_body(share=...)`` builds joints). With one body, the joint is
    pinned to the world."""
    kind = table.get("type", one_of("ball", "hinge"))
    names = table.get("bodies", array_of(string, min_length=1))
    if len(names) > 2 or len(set(names)) != len(names):
        raise SceneError(
            table.key_path("bodies"), f"must be one or two different part names, got {shown(names)}"
        )
    bodies = []
    for i, name in enumerate(names):
        part = parts.get(name)
        if part is None or not part.body:
            solid = listed(n for n, p in parts.items() if p.body) or "none"
            raise SceneError(
                f"{table.key_path('bodies')}[{i}]",
                f"{shown(name)} is not a named box or tetrahedron; those named: {solid}",
            )
        bodies.append(part.particles)
    at = np.asarray(table.get("at", vector()), dtype=float)
    if kind == "hinge":
        axis = np.asarray(table.get("axis", vector()), dtype=float)
        if np.linalg.norm(axis) == 0:
            raise SceneError(table.key_path("axis"), "must be non-zero")
        half = 0.5 * table.get("width", positive(), 0.25) * axis / np.linalg.norm(axis)
        points = [at - half, at + half]
    else:
        points = [at]
    compliance = _compliance(table)
    mass = 0.02 * sum(float(world.mass[p].sum()) for p in bodies)
    joint = world.add_particles(points, mass / len(points))
    for particles in bodies:
        pairs = [[j, int(p)] for j in joint for p in particles]
        build(table.path, world.add_sticks, pairs, compliance=compliance)
    if len(bodies) == 1:
        world.pin(joint)
    tint = _tint(table, (0.85, 0.85, 0.9))
    if kind == "hinge":
        scene.line_groups.append((np.array([joint]), tint, 4.0))
    else:
        scene.spheres.append((int(joint[0]), 0.03, tint))
