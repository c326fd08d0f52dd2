"""``[[body]]`` types built on a rigid world (:mod:`motes.rigid`).

Each type builds a :class:`motes.rigid.World` from a few keys (documented in
``docs/scene-format.md``, section "Rigid bodies") and draws it: boxes as shaded boxes
placed by their body transforms, sticks and ropes as lines, heads, bobs and projectiles
as spheres. The scene's shared ``[[collider]]`` objects (a ground plane) collide with
every particle of the world.

Keys every type reads: ``iterations`` (relaxation iterations, default 10), ``substeps``
(world substeps per scene step, default 1), ``projection`` (``"shake"`` or
``"jakobsen"``), ``damping`` [1/s], ``gravity``, ``detection`` (``"posteriori"`` or
``"priori"``: how the shared colliders are found, by default each collider's own) and
``[[body.force]]`` tables.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from .. import rigid
from ..collide import Box as BoxCollider
from ..io.entry import Entry
from ..render import geometry
from .bodies import Body, BuildContext, register
from .parts import body_forces
from .schema import (
    SceneError,
    Table,
    boolean,
    build,
    color,
    integer,
    number,
    one_of,
    positive,
    vector,
)

#: World settings a rigid body's scene keys set, which act from the next step.
WORLD_SETTINGS = ("gravity", "damping", "iterations", "substeps", "projection", "forces")

_BOX_COLORS = ((0.75, 0.45, 0.25), (0.3, 0.5, 0.75), (0.75, 0.7, 0.3), (0.45, 0.65, 0.4))


class RigidScene(Body):
    """A rigid world and what to draw of it.

    Attributes
    ----------
    world : motes.rigid.World
    boxes : list of (body index, size (3,), colour)
        Solid boxes drawn at their body transforms.
    lines : (m, 2) int array
        Particle pairs drawn as lines (sticks, ropes, bones).
    spheres : list of (particle, radius [m], colour)
    capsules : list of (end, end, radius [m], colour)
        Capsules between two ends, each a particle or a tuple of particles (their mean):
        bodies with volume (a ragdoll's limbs and torso).
    static : list
        Fixed drawables (stairs, walls, anchors).
    """

    def __init__(
        self,
        world,
        *,
        boxes=(),
        lines=None,
        spheres=(),
        capsules=(),
        static=(),
        line_color=(0.9, 0.9, 0.85),
        line_width=3.0,
    ):
        self.world = world
        self.boxes = list(boxes)
        self.lines = np.zeros((0, 2), dtype=np.int64) if lines is None else np.asarray(lines)
        self.spheres = list(spheres)
        self.capsules = []
        self.add_capsules(capsules)
        self.static = list(static)
        self.line_color = line_color
        self.line_width = line_width
        self.hooks = []  # callables (body, time) run before each step
        self.trails: list[int] = []  # particles whose recent path is drawn
        self.history: list[np.ndarray] = []

    def add_capsules(self, capsules) -> None:
        """Draw capsules ``(end, end, radius [m], colour)``, each end a particle or a
        tuple of particles (their mean)."""
        for a, b, radius, tint in capsules:
            self.capsules.append((np.atleast_1d(a), np.atleast_1d(b), radius, tint))

    def take_values(self, fresh: RigidScene) -> None:
        """The world settings of ``fresh`` (see ``LIVE_KEYS``: gravity, damping,
        iterations, substeps, projection, forces), over this world's bodies and state;
        they act from the next step (the world's model shares its settings)."""
        for name in WORLD_SETTINGS:
            value = getattr(fresh.world, name)
            setattr(self.world, name, list(value) if name == "forces" else value)

    def step(self, dt: float) -> None:
        for hook in self.hooks:
            hook(self, self.world.time)
        if self.trails and not self.history:
            self.history.append(self.world.position[self.trails].copy())
        self.world.step(dt)
        if self.trails:
            self.history = [*self.history[-12:], self.world.position[self.trails].copy()]

    def count(self) -> int:
        return self.world.count

    def particle_state(self):
        return self.world.particle_state()

    def entry(self, *, surface: bool = False) -> Entry:
        transforms = self.world.transforms()
        # A world of particles, sticks and ropes only has no body to place.
        return Entry(
            self.world.particle_state(), transforms=transforms if len(transforms[0]) else None
        )

    @property
    def replayable(self) -> bool:
        # A trail is a path over the last steps, which a cache does not hold.
        return not self.trails

    def show(self, entry: Entry, time: float) -> None:
        state = entry.state
        if state.count != self.world.count:
            raise ValueError(
                f"holds {state.count} particles; the rigid world has {self.world.count}"
            )
        # The bodies' transforms and every drawable follow from the particles.
        self.world.position[:] = state.positions.T
        if "previous" in state:
            self.world.previous[:] = state["previous"].T

    def contact(self, path: str, name: str, options: dict):
        from ..couple import RigidContact

        if len(self.world.boxes()[0]) == 0 and len(self.world.spheres) == 0:
            raise SceneError(
                path,
                f"emitter particles cannot collide with body {name!r}: its rigid world "
                "has no boxes or balls (particles hit box bodies and balls)",
            )
        return build(path, RigidContact, self.world, **options)

    def drawables(self) -> list:
        out = list(self.static)
        position = self.world.position
        if self.boxes:
            centre, rotation = self.world.transforms()
            for index, size, tint in self.boxes:
                out.append(geometry.Box(centre[index], size, rotation=rotation[index], color=tint))
        if len(self.lines):
            out.append(
                geometry.Lines(position, self.lines, color=self.line_color, width=self.line_width)
            )
        if len(self.history) >= 2:
            paths = np.stack(self.history, axis=1)  # (particles, samples, 3)
            out.append(geometry.Lines.strips(list(paths), color=(1.0, 0.85, 0.4), width=2.0))
        for particle, radius, tint in self.spheres:
            out.append(geometry.Sphere(position[particle], radius, color=tint, subdivisions=2))
        for a, b, radius, tint in self.capsules:
            ends = position[a].mean(axis=0), position[b].mean(axis=0)
            out.append(geometry.Capsule(*ends, radius, color=tint, subdivisions=2))
        return out


def read_world(table: Table, context: BuildContext) -> rigid.World:
    """The world every rigid type reads (keys listed in the module docstring), with the
    scene's shared colliders added (found after the move, or swept: ``detection``)."""
    world = build(
        table.path,
        rigid.World,
        gravity=table.get("gravity", vector(), (0.0, -9.81, 0.0)),
        damping=table.get("damping", number(0.0), 0.0),
        iterations=table.get("iterations", integer(1, 200), 10),
        substeps=table.get("substeps", integer(1, 1000), 1),
        projection=table.get("projection", one_of("shake", "jakobsen"), "shake"),
        forces=body_forces(table),
    )
    # Unset: each collider's own (its table's ``detection``; posteriori but for meshes).
    detection = table.get("detection", one_of("posteriori", "priori"), None)
    for collider in context.colliders:
        build(table.path, world.add_collider, collider, detection)  # errors name the body
    return world


def _box(table: Table, center, size, mass: float) -> rigid.BodyShape:
    """A box body of a set-up; sizes that vanish beside large coordinates (no volume left
    in floating point) are refused at the body."""
    return build(table.path, rigid.BodyShape.box, center, size, mass)


def _step_box(center, size, tint):
    collider = BoxCollider(center, size, friction=0.6)
    return collider, geometry.Box(center, size, color=tint)


@register("ragdoll_stairs")
def ragdoll_stairs(table: Table, context: BuildContext) -> RigidScene:
    """A ragdoll thrown down a staircase."""
    world = read_world(table, context)
    steps = table.get("steps", integer(1, 40), 6)
    rise = table.get("step_height", positive(), 0.2)
    run = table.get("step_depth", positive(), 0.3)
    width = table.get("width", positive(), 2.0)
    tint = table.get("color", color, (0.55, 0.55, 0.6, 1.0))[:3]
    static = []
    for k in range(steps):
        h = rise * (steps - k)
        collider, drawable = _step_box((0.0, h / 2, run * k + run / 2), (width, h, run), tint)
        world.add_collider(collider)
        static.append(drawable)
    doll = build(
        table.path,
        rigid.add_ragdoll,
        world,
        (0.0, rise * steps, run / 2),
        height=table.get("height", positive(), 1.75),
        mass=table.get("mass", positive(), 70.0),
        compliance=table.get("compliance", number(0.0), 0.0),
        hinge_sides=table.get("hinge_sides", boolean, False),
    )
    world.set_velocity(doll.indices, table.get("throw", vector(), (0.0, 1.0, 2.5)))
    head = doll.particles["head"]
    return RigidScene(
        world,
        static=static,
        spheres=[(head, float(world.radius[head]), _SKIN)],
        capsules=ragdoll_body(doll.particles, table.get("height", positive(), 1.75)),
    )


_SKIN, _SHIRT, _TROUSERS = (0.85, 0.6, 0.45), (0.2, 0.35, 0.75), (0.18, 0.18, 0.22)

#: A ragdoll's body: (end, end, radius as a share of its height, colour); an end is a
#: joint or joints whose mean it is. The radii stay near the particles' contact radius
#: (0.025 of the height), so that the drawn body does not sink into what it lands on.
_RAGDOLL_BODY = (
    ("neck", "head", 0.022, _SKIN),
    (("shoulder_l", "shoulder_r"), "chest", 0.06, _SHIRT),  # chest
    ("shoulder_l", "shoulder_r", 0.035, _SHIRT),
    ("chest", ("hip_l", "hip_r"), 0.05, _SHIRT),  # belly
    ("hip_l", "hip_r", 0.045, _TROUSERS),
    ("shoulder_l", "elbow_l", 0.026, _SHIRT),
    ("shoulder_r", "elbow_r", 0.026, _SHIRT),
    ("elbow_l", "wrist_l", 0.022, _SKIN),
    ("elbow_r", "wrist_r", 0.022, _SKIN),
    ("hip_l", "knee_l", 0.034, _TROUSERS),
    ("hip_r", "knee_r", 0.034, _TROUSERS),
    ("knee_l", "ankle_l", 0.028, _TROUSERS),
    ("knee_r", "ankle_r", 0.028, _TROUSERS),
)


def ragdoll_body(particles: dict, height: float, shirt=_SHIRT) -> list:
    """Capsules for a ragdoll's limbs and trunk (joint particles by name), sized by its
    height [m], the shirt in ``shirt`` (linear RGB)."""

    def joints(end):
        names = (end,) if isinstance(end, str) else end
        return tuple(particles[n] for n in names)

    return [
        (joints(a), joints(b), share * height, shirt if tint is _SHIRT else tint)
        for a, b, share, tint in _RAGDOLL_BODY
    ]


@register("rope_bridge")
def rope_bridge(table: Table, context: BuildContext) -> RigidScene:
    """Planks hung between two anchors by ropes, with boxes falling on them."""
    world = read_world(table, context)
    planks = table.get("planks", integer(2, 60), 12)
    span = table.get("span", positive(), 4.0)
    height = table.get("height", positive(), 1.5)
    width = table.get("width", positive(), 1.0)
    box_count = table.get("boxes", integer(0, 20), 3)
    box_size = table.get("box_size", positive(), 0.22)
    drop = table.get("drop_height", positive(), 1.0)
    thickness = table.get("plank_thickness", positive(), 0.08)
    pitch = span / planks
    size = np.array([0.8 * pitch, thickness, width])
    scene = RigidScene(world, line_color=(0.6, 0.5, 0.35), line_width=2.0)
    corners = []
    for k in range(planks):
        x = -span / 2 + pitch * (k + 0.5)
        body = world.add_body(_box(table, (x, height, 0.0), size, 5.0), group=0)
        scene.boxes.append((body.index, size, (0.55, 0.38, 0.22)))
        corners.append(body.particles)
    # Ropes along both edges: each plank's +x corners to the next plank's -x corners,
    # top and bottom, slack 2 % (two levels keep a plank from flipping over its rope).
    ropes = []
    for a, b in itertools.pairwise(corners):
        ropes += [[a[3], b[2]], [a[7], b[6]], [a[1], b[0]], [a[5], b[4]]]
    ends = world.add_particles(
        [
            [-span / 2, height + 0.02, -width / 2],
            [-span / 2, height + 0.02, width / 2],
            [span / 2, height + 0.02, -width / 2],
            [span / 2, height + 0.02, width / 2],
        ],
        1.0,
    )
    world.pin(ends)
    ropes += [
        [ends[0], corners[0][2]],
        [ends[1], corners[0][6]],
        [ends[2], corners[-1][3]],
        [ends[3], corners[-1][7]],
    ]
    ropes = np.array(ropes)
    length = np.linalg.norm(world.position[ropes[:, 1]] - world.position[ropes[:, 0]], axis=1)
    world.add_ropes(ropes, 1.02 * length)
    scene.lines = ropes
    posts = [
        geometry.Box(
            (sx * (span / 2 + 0.05), height / 2, sz * width / 2),
            (0.1, height + 0.1, 0.1),
            color=(0.4, 0.3, 0.2),
        )
        for sx in (-1, 1)
        for sz in (-1, 1)
    ]
    scene.static += posts
    for k in range(box_count):
        x = -span / 2 + pitch * (round((k + 1) * planks / (box_count + 1)) + 0.5)
        c = (x, height + drop + 0.6 * k, 0.05 * (k % 2))
        body = world.add_body(_box(table, c, (box_size,) * 3, 4.0))
        scene.boxes.append((body.index, np.full(3, box_size), _BOX_COLORS[k % 4]))
    return scene


@register("pendulums")
def pendulums(table: Table, context: BuildContext) -> RigidScene:
    """A Newton's cradle: a row of sphere bobs on V-shaped strings, the first pulled
    back. The bobs collide as spheres with restitution (a velocity pass after the
    relaxation), hung a little apart so that they meet pair by pair and the blow passes
    down the row to the last bob (see :mod:`motes.collide.sphere_kernels`)."""
    world = read_world(table, context)
    count = table.get("count", integer(1, 20), 5)
    length = table.get("length", positive(), 1.0)
    bob = table.get("bob_size", positive(), 0.2)
    release = math.radians(table.get("release_angle", number(0.0, 170.0), 50.0))
    top = table.get("height", positive(), 2.0)
    gap = table.get("gap", number(0.0), 0.003)
    restitution = table.get("restitution", number(0.0, 1.0), 1.0)
    scene = RigidScene(world, line_color=(0.85, 0.85, 0.8), line_width=2.0)
    strings, bobs = [], []
    for k in range(count):
        x = (k - (count - 1) / 2) * (bob + gap)
        angle = -release if k == 0 else 0.0
        pivot = np.array([x, top, 0.0])
        centre = pivot + length * np.array([math.sin(angle), -math.cos(angle), 0.0])
        particle = int(world.add_particles([centre], mass=1.0, radius=bob / 2)[0])
        tint = (0.8, 0.15, 0.1) if k == 0 else (0.8, 0.8, 0.85)
        scene.spheres.append((particle, bob / 2, tint))
        anchors = world.add_particles(
            pivot + np.array([[0, 0, -0.5 * length], [0, 0, 0.5 * length]])
        )
        world.pin(anchors)
        pairs = [[anchors[0], particle], [anchors[1], particle]]
        world.add_sticks(pairs)  # the V keeps each bob swinging in the x-y plane
        strings += pairs
        bobs.append(particle)
    world.add_sphere_contacts(bobs, restitution=restitution)
    scene.lines = np.array(strings)
    scene.static.append(
        geometry.Box(
            (0, top + 0.03, 0), (count * bob + 0.4, 0.06, length + 0.1), color=(0.3, 0.3, 0.32)
        )
    )
    return scene


@register("box_tower")
def box_tower(table: Table, context: BuildContext) -> RigidScene:
    """A tower of boxes knocked over by a heavy box thrown at it."""
    world = read_world(table, context)
    levels = table.get("levels", integer(1, 30), 6)
    size = table.get("box_size", positive(), 0.5)
    speed = table.get("projectile_speed", positive(), 12.0)
    delay = table.get("delay", number(0.0), 1.0)
    scene = RigidScene(world)
    gap = 0.02 * size  # the corner particles' contact radius is 1 % of the size
    for k in range(levels):
        for j, dx in enumerate((-0.5 * size - gap, 0.5 * size + gap) if k % 2 == 0 else (0.0,)):
            c = (dx, (k + 0.5) * (size + gap), 0.0)
            body = world.add_body(_box(table, c, (size,) * 3, 1.0))
            scene.boxes.append((body.index, np.full(3, size), _BOX_COLORS[(k + j) % 4]))
    ball = world.add_body(rigid.BodyShape.box((-6.0, 1.0, 0.0), (0.4,) * 3, 20.0))
    scene.boxes.append((ball.index, np.full(3, 0.4), (0.25, 0.25, 0.28)))
    world.pin(ball.particles)  # held until thrown
    aim = np.array([0.0, 0.55 * levels * size, 0.0]) - (-6.0, 1.0, 0.0)
    flight = np.linalg.norm(aim) / speed
    velocity = aim / flight + (0.0, 0.5 * 9.81 * flight, 0.0)  # lob to hit mid-height
    thrown = []

    def throw(body, time):
        if not thrown and time >= delay:
            body.world.unpin(ball.particles)
            body.world.set_velocity(ball.particles, velocity)
            thrown.append(True)

    scene.hooks.append(throw)
    return scene


@register("swept_vs_posteriori")
def swept_vs_posteriori(table: Table, context: BuildContext) -> RigidScene:
    """Two fast projectiles at two thin walls: the left wall detects a priori (swept),
    the right a posteriori; relaunched every ``period`` seconds."""
    world = read_world(table, context)
    speed = table.get("speed", positive(), 100.0)
    thickness = table.get("wall_thickness", positive(), 0.01)
    period = table.get("period", positive(), 0.25)
    radius = table.get("radius", positive(), 0.08)
    restitution = table.get("restitution", number(0.0, 1.0), 0.3)
    show_paths = table.get("trails", boolean, True)
    scene = RigidScene(world, line_color=(1.0, 0.8, 0.3), line_width=2.0)
    start = np.array([[-3.0, 1.0, -0.8], [-3.0, 1.0, 0.8]])
    tints = ((0.3, 0.8, 0.4), (0.9, 0.3, 0.25))
    for lane, (detection, tint) in enumerate(zip(("priori", "posteriori"), tints, strict=True)):
        z = start[lane, 2]
        wall = BoxCollider((0.0, 1.0, z), (thickness, 2.0, 1.2), restitution=restitution)
        world.add_collider(wall, detection=detection)
        scene.static.append(geometry.Box(wall.center, (thickness, 2.0, 1.2), color=tint))
    shots = world.add_particles(start, 1.0, radius)
    scene.spheres = [(int(p), radius, (0.95, 0.95, 0.9)) for p in shots]
    if show_paths:
        scene.trails = [int(p) for p in shots]
    launched = []

    def launch(body, time):
        cycle = math.floor(time / period + 1e-9)
        if cycle >= len(launched):
            body.world.position[shots] = start
            body.world.previous[shots] = start
            body.world.set_velocity(shots, (speed, 0.0, 0.0))
            body.history.clear()
            launched.append(cycle)

    scene.hooks.append(launch)
    return scene
