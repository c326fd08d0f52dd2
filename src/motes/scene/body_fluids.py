"""``[[body]] type = "fluid"``: a position-based liquid in a scene (keys in
``docs/scene-format.md``, section "Fluid bodies").

The body owns a :class:`motes.fluids.Fluid`, its nozzles (sources that emit layers of
particles) and shaken tanks, and draws itself as sprites, as one metaball surface per
phase, as clear water in screen space (:class:`motes.render.water.Water`, one per
phase), or a surface and sprites: with ``spray = true`` the particles in thin places
(few neighbours, the density below ``spray_below`` of rest) are drawn as sprites and
left out of the surface. The water look also draws foam: white froth on the particles
where Ihmsen et al.'s potentials say air is mixed in (:mod:`motes.fluids.foam`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .. import fluids
from ..fluids.fluid import check_memory
from ..fluids.foam import foam
from ..io.entry import Entry
from ..render import geometry
from ..render.metaballs import Metaballs
from ..render.shading import Material
from ..render.sprites import SpriteStyle
from ..render.water import Water
from ..spatial.index import STRUCTURES
from ..state import Field
from .bodies import LIVE_KEYS, Body, BuildContext, register
from .parts import body_forces, placed_mesh
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

WATER = (0.25, 0.45, 0.75)

#: Shortest ``max_dt`` [s]: a scene step of up to 1 s (fps >= 1) splits into at most 10⁵.
MIN_DT = 1e-5


class _Nozzle:
    """Emits a disc of particles (a square pattern of ``spacing``) each time the last
    layer has moved one spacing away: the flow rate follows from speed and radius."""

    def __init__(self, position, velocity, radius, spacing, phase, start, stop, *, limit):
        self.position = np.asarray(position, np.float64)
        self.velocity = np.asarray(velocity, np.float64)
        speed = float(np.linalg.norm(self.velocity))
        if speed == 0.0:
            raise ValueError("velocity must be non-zero")
        # About π (r / s)² particles a layer: refused before the pattern is allocated.
        layer = math.pi * (radius / spacing) * (radius / spacing)  # inf, not OverflowError
        if layer > limit:
            raise ValueError(
                f"radius {radius:g} makes layers of about {layer:.3g} particles at spacing "
                f"{spacing:g}, more than max_particles = {limit}"
            )
        axis = self.velocity / speed
        helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        u = np.cross(axis, helper)
        u /= np.linalg.norm(u)
        w = np.cross(axis, u)
        # A square pattern, so that layers one spacing apart are the rest lattice: a
        # denser (hexagonal) one would start compressed and the solver would spring
        # the jet apart.
        k = math.ceil(radius / spacing)
        a, b = np.meshgrid(np.arange(-k, k + 1), np.arange(-k, k + 1), indexing="ij")
        x, y = a * spacing, b * spacing
        inside = x * x + y * y <= radius * radius + 1e-12
        self.layer = (u[:, None] * x[inside] + w[:, None] * y[inside]).astype(np.float64)
        self.interval = spacing / speed
        self.phase, self.start, self.stop = phase, start, stop
        self.clock = 0.0

    def emit(self, fluid: fluids.Fluid, dt: float, limit: int) -> None:
        if not self.start <= fluid.time < self.stop:
            return
        self.clock += dt
        while self.clock >= self.interval:
            self.clock -= self.interval
            k = self.layer.shape[1]
            if len(fluid) + k > limit:
                return
            # A layer emitted `clock` ago has travelled that far already.
            offset = self.velocity * self.clock
            positions = self.position[:, None] + self.layer + offset[:, None]
            velocities = np.repeat(self.velocity[:, None], k, axis=1)
            fluid.add(positions, velocities=velocities, phase=self.phase)


class _Shake:
    """Moves a tank by ``amplitude · sin(2π f t)`` [m]."""

    def __init__(self, tank, amplitude, frequency):
        self.tank, self.amplitude, self.frequency = tank, np.asarray(amplitude), frequency
        self.offset = np.zeros(3)

    def move(self, time: float) -> None:
        target = self.amplitude * math.sin(2 * math.pi * self.frequency * time)
        self.tank.moved(target - self.offset)
        self.offset = target


#: The fluid model's settings a running liquid takes from new values.
_LIVE_SETTINGS = tuple(key for key in LIVE_KEYS["fluid"] if key != "force")


class FluidBody(Body):
    """A liquid in a scene: steps the fluid, its nozzles and shaken tanks; draws it."""

    def __init__(self, fluid, *, colors, nozzles, shakes, walls, look, limit, floating=None):
        self.fluid = fluid
        #: Boxes floating in (or sunk through) the liquid, or None.
        self.floating = floating
        self.colors = np.asarray(colors, np.float32)
        self.nozzles, self.shakes, self.walls = nozzles, shakes, walls
        self.look = look
        self.limit = limit
        self.sprite_style = SpriteStyle(kind="sprite", blend="alpha")
        # Froth: lit by the scene's lights, fading softly into the water it sits on.
        self.foam_style = SpriteStyle(
            kind="sprite", blend="alpha", lit=True, softness=look["foam_radius"]
        )
        # Spray: droplets lit by the lights and streaked over a sixtieth of a second.
        self.spray_style = SpriteStyle(kind="sprite", blend="alpha", lit=True, shutter=1 / 60)
        self.metaballs = None
        # The water look draws in screen space, but exports the same metaball surface.
        if look["mode"] in ("surface", "water"):
            self.metaballs = Metaballs.from_radius(
                look["surface_radius"], sharpness=look["sharpness"], cell_size=look["cell_size"]
            )
        self._shown = None  # a cached frame's particles, drawn instead of the live ones
        self._shown_boxes = None  # and its floating boxes' transforms
        self._surface_memo = None  # (time, shown state, surfaces) of the last surfaces made

    replayable = True

    def show(self, entry: Entry, time: float) -> None:
        if "phase" not in entry.state:
            raise ValueError("holds no phase field: not a liquid")
        phases = entry.state["phase"]
        if phases.size and int(phases.max()) >= len(self.colors):
            raise ValueError(f"has phases past this liquid's {len(self.colors)}")
        if self.floating is not None:
            boxes = len(self.floating.looks)
            given = None if entry.transforms is None else len(entry.transforms[0])
            if given != boxes:
                raise ValueError(f"holds transforms of {given} boxes; the liquid floats {boxes}")
            self._shown_boxes = entry.transforms
        self._shown = entry.state
        for shake in self.shakes:  # the tank where it was at that time
            shake.move(time)

    def take_values(self, fresh: FluidBody) -> None:
        """The solver settings and forces of ``fresh`` (see ``LIVE_KEYS``), over this
        liquid's particles, phases and walls."""
        settings = {key: getattr(fresh.fluid.model, key) for key in _LIVE_SETTINGS}
        self.fluid.model = dataclasses.replace(self.fluid.model, **settings)
        self.fluid.forces = list(fresh.fluid.forces)

    def step(self, dt: float) -> None:
        for shake in self.shakes:
            shake.move(self.fluid.time + dt)
        for nozzle in self.nozzles:
            nozzle.emit(self.fluid, dt, self.limit)
        if self.floating is not None:
            self.floating.step(dt)  # the liquid and its boxes, each pushing the other
        else:
            self.fluid.step(dt)

    def count(self) -> int:
        return len(self.fluid)

    def particle_state(self):
        return self.fluid.particle_state()

    def _drawn(self):
        """The particles drawn: a cached frame's (:meth:`show`) or the live ones."""
        return self.fluid.particle_state() if self._shown is None else self._shown

    def _spray(self) -> np.ndarray:
        """Particles in thin places (see the module docstring)."""
        s = self._drawn()
        if not self.look["spray"]:
            return np.zeros(s.count, bool)
        rest = np.array([p.rest_density for p in self.fluid.model.phases], np.float32)
        return s["density"] < self.look["spray_below"] * rest[s["phase"]]

    def particles(self) -> list:
        if self.look["mode"] == "water":
            return self._froth()
        state = self._drawn()
        # Sprites: every particle, or with a surface only the spray.
        if self.metaballs is not None:
            state = state.take(self._spray())
        if state.count == 0:
            return []
        rgba = np.empty((state.count, 4), np.float32)
        rgba[:, :3] = self.colors[state["phase"]]
        rgba[:, 3] = self.look["alpha"]
        drawn = state.replace(
            radius=np.full(state.count, self.look["radius"], np.float32),
            color=Field(rgba.T, "1", "linear RGBA"),
        )
        return [(drawn, self.sprite_style)]

    def _froth(self) -> list:
        """The water look's sprites: the spray (thin places, left out of the surface) as
        droplets streaked by their motion, and foam on the surface, white by its value."""
        s = self._drawn()
        if s.count == 0:
            return []
        look = self.look
        spray = self._spray()
        out = []
        if spray.any():
            drops = s.take(spray)
            rgba = np.empty((drops.count, 4), np.float32)
            rgba[:, :3] = self.colors[drops["phase"]] * 0.25 + 0.75  # nearly white
            rgba[:, 3] = look["alpha"]
            drops = drops.replace(
                radius=np.full(drops.count, look["radius"], np.float32),
                color=Field(rgba.T, "1", "linear RGBA"),
            )
            out.append((drops, self.spray_style))
        if look["foam"]:
            h = self.fluid.model.derived["h"]
            froth = foam(
                s.positions, s.velocities, h, trapped_air=look["foam_trapped_air"],
                wave_crest=look["foam_wave_crest"], kinetic=look["foam_kinetic"],
            )  # fmt: skip
            chosen = (froth * look["foam_alpha"] > 0.02) & ~spray
            if chosen.any():
                state = s.take(chosen)
                rgba = np.ones((state.count, 4), np.float32)
                rgba[:, 3] = froth[chosen] * look["foam_alpha"]
                state = state.replace(
                    radius=np.full(state.count, look["foam_radius"], np.float32),
                    color=Field(rgba.T, "1", "linear RGBA"),
                )
                out.append((state, self.foam_style))
        return out

    def _surfaces(self) -> list:
        """``(phase, mesh)`` of each phase's metaball surface (spray left out); made once
        per state, as drawing and exporting a frame both ask for it."""
        memo = self._surface_memo
        if memo is not None and memo[0] == self.fluid.time and memo[1] is self._shown:
            return memo[2]
        out = self._make_surfaces()
        self._surface_memo = (self.fluid.time, self._shown, out)
        return out

    def _make_surfaces(self) -> list:
        s = self._drawn()
        if self.metaballs is None or s.count == 0:
            return []
        body = ~self._spray()
        out = []
        for phase in range(len(self.colors)):
            chosen = body & (s["phase"] == phase)
            if chosen.sum() < 2:
                continue
            mesh = self.metaballs.mesh(s.positions[:, chosen].T)
            if len(mesh.faces):
                out.append((phase, mesh))
        return out

    def drawables(self) -> list:
        items = list(self.walls)
        if self.floating is not None:
            items.extend(self.floating.boxes(self._shown_boxes))
        if self.look["mode"] == "water":
            return items + self._waters()
        material = Material(specular=self.look["specular"], shininess=48.0)
        for phase, mesh in self._surfaces():
            items.append(geometry.Mesh(mesh, color=tuple(self.colors[phase]), material=material))
        return items

    def _waters(self) -> list:
        """One :class:`Water` per phase (spray left out)."""
        s = self._drawn()
        if s.count == 0:
            return []
        look, spacing = self.look, self.fluid.model.spacing
        body = ~self._spray()
        out = []
        for phase in range(len(self.colors)):
            chosen = body & (s["phase"] == phase)
            if chosen.any():
                water = Water(
                    s.positions[:, chosen].T, look["water_radius"], volume=spacing**3,
                    color=tuple(self.colors[phase]), clarity=look["clarity"],
                    scatter=look["scatter"], smoothing=look["smoothing"],
                    refraction=look["refraction"], specular=look["specular"],
                )  # fmt: skip
                out.append(water)
        return out

    def entry(self, *, surface: bool = False) -> Entry:
        """The particles and, with ``surface`` and a ``"surface"`` or ``"water"`` look, the
        metaball surface (the one the surface look draws): every phase's mesh in one (the
        spray left out)."""
        state = self.fluid.particle_state()
        # floating boxes go with the liquid as its bodies' transforms
        boxes = None if self.floating is None else self.floating.world.transforms()
        if not surface or self.metaballs is None:
            return Entry(state, transforms=boxes)
        vertices, faces, count = [np.zeros((0, 3), np.float32)], [np.zeros((0, 3), np.int64)], 0
        for _, mesh in self._surfaces():
            vertices.append(mesh.vertices)
            faces.append(mesh.faces.astype(np.int64) + count)
            count += len(mesh.vertices)
        surface = (np.concatenate(vertices), np.concatenate(faces))
        return Entry(state, surface=surface, transforms=boxes)


# --- reading the table -------------------------------------------------------------------


def _phases(table: Table):
    phases, colors = [], []
    for item in table.tables("phase"):
        rest = item.get("rest_density", positive(), 1000.0)
        cohesion = item.get("cohesion", number(0.0), 0.0)
        phases.append(build(item.path, fluids.Phase, rest, cohesion))
        colors.append(item.get("color", color, WATER)[:3])
        item.finish()
    if not phases:
        return (fluids.Phase(),), [WATER]
    return tuple(phases), colors


def _mesh_wall(item: Table, walls_drawn: list, base):
    mesh = placed_mesh(item, base, movable=True)
    wall = build(
        item.path,
        fluids.MeshWall,
        mesh,
        thickness=item.get("thickness", number(0.0), 0.0),
        friction=item.get("friction", number(0.0), 0.0),
        restitution=item.get("restitution", number(0.0, 1.0), 0.0),
    )
    if item.get("visible", boolean, True):
        rgb = item.get("color", color, (0.55, 0.55, 0.58))[:3]
        walls_drawn.append(geometry.Mesh(mesh, color=rgb))
    item.finish()
    return wall


def _wall(item: Table, walls_drawn: list, shakes: list, base):
    kind = item.get("type", one_of("plane", "tank", "box", "sphere", "mesh"))
    if kind == "mesh":
        return _mesh_wall(item, walls_drawn, base)
    options = {
        "adhesion": item.get("adhesion", number(0.0), 0.0),
        "friction": item.get("friction", number(0.0), 0.0),
        "friction_model": item.get(
            "friction_model", one_of(*fluids.boundaries.FRICTION_MODELS), "scale"
        ),
    }  # fmt: skip
    if kind != "plane":  # a plane is not drawn (an [[object]] ground can show it)
        visible = item.get("visible", boolean, True)
        rgb = item.get("color", color, (0.55, 0.55, 0.58))[:3]
    if kind == "plane":
        normal = item.get("normal", vector(), (0.0, 1.0, 0.0))
        point = item.get("point", vector(), (0.0, 0.0, 0.0))
        wall = build(item.path, fluids.Plane, normal, point, **options)
    elif kind == "tank":
        lower = item.get("lower", vector())
        upper = item.get("upper", vector())
        closed = item.get("closed", boolean, False)
        amplitude = item.get("shake_amplitude", vector(), (0.0, 0.0, 0.0))
        frequency = item.get("shake_frequency", number(0.0), 0.0)
        thickness = item.get("wall_thickness", positive(), 0.02)
        wall = build(item.path, fluids.Tank, lower, upper, closed=closed, **options)
        if frequency > 0 and any(amplitude):
            shakes.append(_Shake(wall, amplitude, frequency))
        if visible:
            walls_drawn.append(_TankWalls(wall, thickness, rgb))
    elif kind == "box":
        center = item.get("center", vector())
        size = item.get("size", vector())
        if min(size) <= 0:
            raise SceneError(item.key_path("size"), f"must be > 0 on every axis, got {list(size)}")
        wall = build(item.path, fluids.Box, center, [0.5 * x for x in size], **options)
        if visible:
            walls_drawn.append(geometry.Box(center, size, color=rgb))
    else:
        center = item.get("center", vector())
        radius = item.get("radius", positive())
        inside = item.get("inside", boolean, False)
        wall = build(item.path, fluids.Sphere, center, radius, inside=inside, **options)
        if visible and not inside:
            walls_drawn.append(geometry.Sphere(center, radius, color=rgb))
    item.finish()
    return wall


class _TankWalls:
    """Draws a tank's floor, side walls and back wall (the side facing -z) as slabs,
    following the tank when it moves; the front (+z) stays open to the camera."""

    def __init__(self, tank, thickness, rgb):
        self.tank, self.thickness, self.rgb = tank, thickness, rgb
        # The extents at rest: a tank shaken far out would lose them to round-off.
        self.size = np.asarray(tank.upper - tank.lower, dtype=np.float64)

    def boxes(self):
        lo, hi, t = self.tank.lower, self.tank.upper, self.thickness
        c = 0.5 * (lo + hi)
        size = self.size
        slabs = [
            ((c[0], lo[1] - t / 2, c[2]), (size[0] + 2 * t, t, size[2] + 2 * t)),
            ((lo[0] - t / 2, c[1], c[2]), (t, size[1], size[2] + 2 * t)),
            ((hi[0] + t / 2, c[1], c[2]), (t, size[1], size[2] + 2 * t)),
            ((c[0], c[1], lo[2] - t / 2), (size[0], size[1], t)),
        ]
        return [geometry.Box(center, dims, color=self.rgb) for center, dims in slabs]


@register("fluid")
def build_fluid(table: Table, context: BuildContext) -> FluidBody:
    """Read a ``[[body]] type = "fluid"`` table."""
    spacing = table.get("spacing", positive())
    phases, colors = _phases(table)
    drawn, shakes = [], []
    walls = [_wall(item, drawn, shakes, context.base) for item in table.tables("wall")]
    settings = {
        "kernel_ratio": table.get("kernel_ratio", number(), 2.0),
        "iterations": table.get("iterations", integer(1, 1000), 4),
        "xsph": table.get("xsph", number(), 0.01),
        "viscosity": table.get("viscosity", number(), 0.0),
        "viscosity_width": table.get("viscosity_width", positive(), None),
        "repulsion": table.get("repulsion", number(), 0.0),
        "tensile": table.get("tensile", number(), 0.0),
        "vorticity": table.get("vorticity", number(), 0.0),
        "relaxation": table.get("relaxation", number(), 0.01),
        "max_dt": table.get("max_dt", number(MIN_DT), 1.0 / 240.0),
        "gravity": table.get("gravity", vector(), (0.0, -9.81, 0.0)),
        "structure": table.get("structure", one_of(*STRUCTURES), "grid"),
    }
    model = build(table.path, fluids.FluidModel, spacing=spacing, phases=phases,
                  boundaries=tuple(walls), **settings)  # fmt: skip
    limit = table.get("max_particles", integer(1, 100_000_000), 20_000)
    positions, velocities, phase = [], [], []
    placed = 0
    for item in table.tables("block"):
        lower = item.get("lower", vector())
        upper = item.get("upper", vector())
        index = item.get("phase", integer(0, len(phases) - 1), 0)
        speed = item.get("velocity", vector(), (0.0, 0.0, 0.0))
        # The blocks together hold at most max_particles: counted before allocating.
        with np.errstate(over="ignore"):
            count = float(np.prod(build(item.path, fluids.lattice_cells, lower, upper, spacing)))
        if placed + count > limit:
            before = f" with the {placed} of the blocks before" if placed else ""
            raise SceneError(
                item.path,
                f"holds {count:.3g} particles at spacing {spacing:g}{before}, more than "
                f"max_particles = {limit}",
            )
        block = build(item.path, fluids.lattice, lower, upper, spacing)
        placed += block.shape[1]
        positions.append(block)
        velocities.append(np.repeat(np.asarray(speed)[:, None], block.shape[1], axis=1))
        phase.append(np.full(block.shape[1], index, np.int32))
        item.finish()
    nozzles = []
    for item in table.tables("source"):
        nozzles.append(
            build(
                item.path, _Nozzle,
                item.get("position", vector()), item.get("velocity", vector()),
                item.get("radius", positive()), spacing,
                item.get("phase", integer(0, len(phases) - 1), 0),
                item.get("start", number(0.0), 0.0), item.get("stop", number(0.0), math.inf),
                limit=limit,
            )
        )  # fmt: skip
        item.finish()
    if nozzles:  # sources fill the liquid up to the limit: it must fit
        build(table.key_path("max_particles"), check_memory, f"max_particles = {limit}", limit)
    forces = body_forces(table)
    if positions:
        pos = np.concatenate(positions, axis=1)
        fluid = fluids.Fluid(model, pos, velocities=np.concatenate(velocities, axis=1),
                             phase=np.concatenate(phase), forces=forces)  # fmt: skip
    else:
        fluid = fluids.Fluid(model, np.zeros((3, 0)), forces=forces)
    look = _look(table.table("render", optional=True), spacing)
    if look["mode"] == "water":  # a tint: light through the liquid keeps some of each
        for k, rgb in enumerate(colors):
            if min(rgb) <= 0.0 or max(rgb) > 1.0:
                raise SceneError(
                    f"{table.key_path('phase')}[{k}].color",
                    f'must have each channel in (0, 1] with mode = "water" (what white '
                    f"light becomes after `clarity` metres), got {shown(list(rgb))}",
                )
    floats = table.tables("float")
    floating = _Floating(fluid, walls, floats, table.key_path("float")) if floats else None
    return FluidBody(fluid, colors=colors, nozzles=nozzles, shakes=shakes,
                     walls=_WallList(drawn), look=look, limit=limit,
                     floating=floating)  # fmt: skip


class _Floating:
    """``[[body.float]]`` boxes: a rigid world of their own, coupled with the liquid both
    ways (:class:`~motes.couple.fluid_rigid.FloatingBodies`); the liquid's tanks and
    planes are its colliders."""

    def __init__(self, fluid, walls, tables, path: str):
        from ..collide.colliders import Plane
        from ..couple.fluid_rigid import FloatingBodies
        from ..rigid import World
        from ..rigid.shapes import BodyShape

        self.world = World(gravity=fluid.model.gravity, substeps=4, iterations=4, damping=0.5)
        for wall in walls:
            for normal, point in _wall_planes(wall):
                self.world.add_collider(Plane(normal, point=point, friction=0.3))
        bodies, self.looks = [], []
        for item in tables:
            size = item.get("size", vector(), (0.2, 0.2, 0.2))
            density = item.get("density", positive())
            center = item.get("center", vector())
            shape = build(item.path, BodyShape.box, center, size,
                          density * float(np.prod(size)))  # fmt: skip
            bodies.append((self.world.add_body(shape), size))
            self.looks.append((np.asarray(size), item.get("color", color, (0.6, 0.45, 0.3))))
            item.finish()
        self.pair = build(path, FloatingBodies, fluid, self.world, bodies)

    def step(self, dt: float) -> None:
        self.pair.step(dt)

    def boxes(self, transforms=None) -> list:
        """The boxes to draw: where the world holds them, or at ``transforms`` (centres,
        rotations: a cached frame's)."""
        centers, rotations = self.world.transforms() if transforms is None else transforms
        return [
            geometry.Box(centers[b.index], size, rotation=rotations[b.index], color=tint[:3])
            for b, (size, tint) in zip(self.pair.bodies, self.looks, strict=True)
        ]


def _wall_planes(wall):
    """The (normal, point) planes of a tank or plane wall, for a rigid world's colliders."""
    if isinstance(wall, fluids.Tank):
        planes = []
        for axis in range(3):
            for sign, corner in ((1.0, wall.lower), (-1.0, wall.upper)):
                if axis == 1 and sign < 0 and not wall.closed:
                    continue
                normal = np.zeros(3)
                normal[axis] = sign
                planes.append((normal, corner))
        return planes
    if isinstance(wall, fluids.Plane):
        return [(wall.normal, wall.point)]
    return []


class _WallList:
    """Iterates the wall geometry of the current state (tanks move when shaken)."""

    def __init__(self, items):
        self.items = items

    def __iter__(self):
        for item in self.items:
            if isinstance(item, _TankWalls):
                yield from item.boxes()
            else:
                yield item


def _thresholds(value, path):
    """A ``[low, high]`` pair of foam thresholds, 0 <= low < high."""
    pair = array_of(number(0.0), length=2)(value, path)
    if not pair[0] < pair[1]:
        raise SceneError(path, f"must be [low, high] with low < high, got {shown(value)}")
    return tuple(pair)


def _look(table: Table | None, spacing: float) -> dict:
    empty = Table({}, "render") if table is None else table
    look = {
        "mode": empty.get("mode", one_of("particles", "surface", "water"), "surface"),
        "radius": empty.get("radius", positive(), 0.6 * spacing),
        "alpha": empty.get("alpha", number(0.0, 1.0), 0.8),
        "surface_radius": empty.get("surface_radius", positive(), 1.2 * spacing),
        "sharpness": empty.get("sharpness", positive(), 1.5),
        "cell_size": empty.get("cell_size", positive(), 0.6 * spacing),
        "spray": empty.get("spray", boolean, False),
        "spray_below": empty.get("spray_below", number(0.0, 1.0), 0.55),
        "specular": empty.get("specular", number(0.0), 0.6),
        "water_radius": empty.get("water_radius", positive(), 1.0 * spacing),
        "clarity": empty.get("clarity", positive(), 1.0),
        "scatter": empty.get("scatter", number(0.0, 1.0), 0.1),
        "smoothing": empty.get("smoothing", number(0.0), 3.0),
        "refraction": empty.get("refraction", number(0.0), 0.25),
        "foam": empty.get("foam", boolean, True),
        "foam_alpha": empty.get("foam_alpha", number(0.0, 1.0), 0.5),
        "foam_radius": empty.get("foam_radius", positive(), 0.7 * spacing),
        "foam_trapped_air": empty.get("foam_trapped_air", _thresholds, (2.0, 8.0)),
        "foam_wave_crest": empty.get("foam_wave_crest", _thresholds, (0.5, 2.0)),
        "foam_kinetic": empty.get("foam_kinetic", _thresholds, (0.5, 4.0)),
    }
    empty.finish()
    return look
