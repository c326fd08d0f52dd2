"""``[[body]] type = "grid_fluid"``: smoke, fire and air on a grid in a scene (keys in
``docs/scene-format.md``, section "Grid fluid bodies").

The body owns a :class:`motes.gridfluid.GridFluid`: its domain (``resolution``,
``cell_size``, ``origin``), walls, buoyancy, dissipation, sources (``[[body.source]]``
balls; ``[[body.particle_source]]``: a system's particles feeding it) and, unless
``colliders = false``, the scene's shared colliders as obstacles. It draws itself as a
ray-marched volume (:class:`motes.render.volume.Volume`) of its density, glowing by its
temperature where ``emission > 0``. Systems ride its flow through a
``[[system.force]] type = "grid_flow"`` naming it.
"""

from __future__ import annotations

import numpy as np

from .. import gridfluid as gf
from ..geometry.layout import KIND, Kind
from ..render.volume import Volume
from .bodies import Body, BuildContext, register
from .schema import (
    SceneError,
    Table,
    array_of,
    boolean,
    build,
    integer,
    number,
    one_of,
    positive,
    shown,
    string,
    vector,
)

_WALLS = ("open", "closed", "no-slip")


class GridFluidBody(Body):
    """A :class:`~motes.gridfluid.GridFluid` in a scene, drawn as a volume."""

    not_replayable = "a grid fluid's density and temperature are not in particle caches"

    def __init__(self, fluid: gf.GridFluid, *, look: dict | None, pending: list, max_dt: float,
                 fade: int = 0):  # fmt: skip
        self.fluid = fluid
        self.look = look  # None: not drawn
        self.fade = edge_fade(fluid, fade)
        self.pending = pending  # [(path, system name, options)] until link()
        self.max_dt = max_dt

    def take_values(self, fresh: GridFluidBody) -> None:
        """Viscosity, vorticity confinement, buoyancy, dissipation and the largest step
        of ``fresh`` (see ``LIVE_KEYS``), over this fluid's velocity, density and
        temperature; its grid, walls and sources are kept."""
        for name in ("viscosity", "vorticity", "buoyancy", "dissipation"):
            setattr(self.fluid, name, getattr(fresh.fluid, name))
        self.max_dt = fresh.max_dt

    def step(self, dt: float) -> None:
        substeps = max(1, -int(-dt // self.max_dt))
        for _ in range(substeps):
            self.fluid.step(dt / substeps)

    def drawables(self) -> list:
        if self.look is None:
            return []
        f = self.fluid
        temperature = f.temperature if self.look.get("emission", 0.0) > 0.0 else None
        density = f.density if self.fade is None else f.density * self.fade
        return [
            Volume.from_zyx(
                density, temperature=temperature, cell_size=f.cell_size, origin=f.origin,
                **self.look,
            )
        ]  # fmt: skip

    def count(self) -> int:
        return int(self.fluid.solid.size)

    def link(self, bodies: dict) -> None:
        del bodies  # sources name systems, resolved by :meth:`link_systems`

    def link_systems(self, systems: dict) -> None:
        """Turn each ``[[body.particle_source]]`` into a source reading its system."""
        for path, name, options in self.pending:
            if name not in systems:
                known = ", ".join(sorted(systems)) or "none"
                raise SceneError(f"{path}.system", f"no system {shown(name)} (systems: {known})")
            self.fluid.add(build(path, gf.ParticleSource, systems[name], **options))
        self.pending = []

    def flow(self, path: str, options: dict):
        """The force a ``[[system.force]] type = "grid_flow"`` naming this body adds."""
        return build(path, gf.GridFlow, self.fluid, **options)


def edge_fade(fluid: gf.GridFluid, cells: int) -> np.ndarray | None:
    """A (nz, ny, nx) factor falling smoothly from 1 to 0 over the last ``cells`` cells
    before each open wall, so smoke leaving the domain thins out instead of ending at a
    flat face of the drawn box; None for ``cells = 0``."""
    if cells <= 0:
        return None
    nz, ny, nx = fluid.solid.shape
    out = np.ones((nz, ny, nx), np.float32)
    for axis, n in enumerate((nx, ny, nz)):
        if n == 1:
            continue
        ramp = np.ones(n, np.float32)
        t = np.clip((np.arange(n) + 0.5) / cells, 0.0, 1.0)
        smooth = (t * t * (3.0 - 2.0 * t)).astype(np.float32)
        if fluid.open_faces[2 * axis]:
            ramp *= smooth
        if fluid.open_faces[2 * axis + 1]:
            ramp *= smooth[::-1]
        shape = [1, 1, 1]
        shape[2 - axis] = n
        out *= ramp.reshape(shape)
    return out


def _walls(table: Table | None) -> dict:
    if table is None:
        return {}
    walls = {}
    for side in gf.model.SIDES:
        value = table.get(side, one_of(*_WALLS), None)
        if value is not None:
            walls[side] = value
    lid = table.get("lid", vector(), None)  # the +y wall moving (a lid-driven cavity)
    if lid is not None:
        walls["+y"] = gf.Wall(slip=False, velocity=lid)
    table.finish()
    return walls


def _obstacles(colliders) -> list:
    """The scene's colliders a grid can rasterise (triangle meshes are left out)."""
    return [c for c in colliders if int(c.packed()[KIND]) != int(Kind.MESH)]


def _look(table: Table | None) -> dict | None:
    table = table or Table({}, "render")
    visible = table.get("visible", boolean, True)
    look = {
        "extinction": table.get("extinction", number(0.0), 10.0),
        "albedo": table.get("albedo", array_of(number(0.0, 1.0), length=3), [0.8, 0.8, 0.8]),
        "anisotropy": table.get("anisotropy", number(-0.99, 0.99), 0.0),
        "emission": table.get("emission", number(0.0), 0.0),
        "step": table.get("step", number(0.05, 8.0), 1.0),
        "shadows": table.get("shadows", boolean, True),
        "light": table.get("light", number(0.0), 0.0),
    }
    table.finish()
    look["albedo"] = tuple(look["albedo"])
    return look if visible else None


@register("grid_fluid")
def build_grid_fluid(table: Table, context: BuildContext) -> GridFluidBody:
    """Read a ``[[body]] type = "grid_fluid"`` table."""
    resolution = table.get("resolution", array_of(integer(2, 4096), min_length=2))
    if len(resolution) > 3:
        raise SceneError(table.key_path("resolution"), "must be [nx, ny] or [nx, ny, nz]")
    buoyancy = table.table("buoyancy", optional=True)
    if buoyancy is not None:
        options = {
            "density_weight": buoyancy.get("density_weight", number(0.0), 0.0),
            "heat_weight": buoyancy.get("heat_weight", number(0.0), 0.0),
            "ambient": buoyancy.get("ambient", positive(), 293.0),
            "up": buoyancy.get("up", vector(), (0.0, 1.0, 0.0)),
        }
        buoyancy.finish()
        buoyancy = build(buoyancy.path, gf.Buoyancy, **options)
    dissipation = table.table("dissipation", optional=True)
    if dissipation is not None:
        options = {
            k: dissipation.get(k, number(0.0), 0.0) for k in ("density", "temperature", "velocity")
        }
        dissipation.finish()
        dissipation = build(dissipation.path, gf.Dissipation, **options)
    solver = table.table("solver", optional=True)
    if solver is not None:
        options = {
            "tolerance": solver.get("tolerance", number(0.0, 1.0), 1e-4),
            "max_iterations": solver.get("max_iterations", integer(1, 10_000), 100),
        }
        solver.finish()
        solver = build(solver.path, gf.Solver, **options)
    obstacles = _obstacles(context.colliders) if table.get("colliders", boolean, True) else []
    fluid = build(
        table.path, gf.GridFluid, resolution,
        table.get("cell_size", positive()),
        origin=table.get("origin", vector(), (0.0, 0.0, 0.0)),
        advection=table.get("advection", one_of(*(a.value for a in gf.Advection)), "maccormack"),
        viscosity=table.get("viscosity", number(0.0), 0.0),
        vorticity=table.get("vorticity", number(0.0), 0.0),
        buoyancy=buoyancy, dissipation=dissipation,
        walls=_walls(table.table("walls", optional=True)),
        obstacles=obstacles, solver=solver,
    )  # fmt: skip
    for index, item in enumerate(table.tables("source")):
        temperature = item.get("temperature", positive(), None)
        source = build(
            item.path, gf.Source, item.get("center", vector()), item.get("radius", positive()),
            density=item.get("density", number(0.0), 1.0), temperature=temperature,
            velocity=item.get("velocity", vector(), (0.0, 0.0, 0.0)),
            pull=item.get("pull", number(0.0), 0.0),
            expansion=item.get("expansion", number(), 0.0),
            start=item.get("start", number(0.0), 0.0),
            stop=item.get("stop", number(0.0), float("inf")),
            noise=item.get("noise", number(0.0, 1.0), 0.0),
            turbulence=item.get("turbulence", number(0.0), 0.0),
            seed=index + context.seed % 1_000_000,
        )  # fmt: skip
        item.finish()
        fluid.add(source)
    pending = []
    for item in table.tables("particle_source"):
        name = item.get("system", string)
        options = {
            "density": item.get("density", number(0.0), 1.0),
            "temperature": item.get("temperature", positive(), None),
            "pull": item.get("pull", number(0.0), 0.0),
        }
        item.finish()
        pending.append((item.path, name, options))
    max_dt = table.get("max_dt", positive(), 1.0 / 30.0)
    render = table.table("render", optional=True)
    fade = render.get("edge_fade", integer(0, 64), 0) if render is not None else 0
    look = _look(render)
    return GridFluidBody(fluid, look=look, pending=pending, max_dt=max_dt, fade=fade)
