"""``[[body]]`` types ``"cloth"`` and ``"hair"`` (keys documented in docs/scene-format.md).

A cloth draws as a shaded mesh (the renderer lights both sides: normals are turned toward
the viewer), hair as lines over a head sphere with a nose and eyes so that turning and
nodding show. A cloth stepped explicitly may blow up: it is always drawn with
each particle clamped to within ``blowup_distance`` of its start (so an explosion stays on
screen as a spiky mess), and once the state is non-finite or 1000 times that far, or
the implicit solve fails (:class:`~motes.integrate.implicit.SolverError`), it stops
stepping and is drawn in ``diverged_color``.
"""

from __future__ import annotations

import numpy as np

from ..cloth import Airflow, Cloth, Keyframes, SpringFamily
from ..collide import TriangleMeshCollider
from ..hair import Hair, Head
from ..integrate.implicit import PRECONDITIONERS, ImplicitEuler, SolverError
from ..io.entry import Entry
from ..render import geometry
from ..render.shading import Material
from .bodies import Body, BuildContext, register
from .parts import MESH_SUFFIXES, body_forces, euler_rotation
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
    scene_file,
    shown,
    vector,
)

#: Most particles along either side of a grid cloth (10⁸ in all, a system's capacity).
GRID_MAX = 10_000


def _pair(reader):
    """An array of two values, each read by ``reader``."""

    def read(value, path):
        if not isinstance(value, list) or len(value) != 2:
            raise SceneError(path, f"must be an array of two values, got {shown(value)}")
        return tuple(reader(v, f"{path}[{i}]") for i, v in enumerate(value))

    return read


def _family(value, path) -> SpringFamily:
    k, kd = vector(2)(value, path)
    return build(path, SpringFamily, k, kd)


def _solver(table: Table, tolerance: float) -> ImplicitEuler:
    return build(
        table.path,
        ImplicitEuler,
        tolerance=table.get("tolerance", number(0.0, 1.0, low_open=True), tolerance),
        max_iterations=table.get("max_iterations", integer(1, 100_000), 500),
        preconditioner=table.get("preconditioner", one_of(*PRECONDITIONERS), "multigrid"),
    )


def _keyframes(table: Table, values: str) -> Keyframes:
    times = table.get("times", array_of(number(), min_length=1))
    rows = table.get(values, array_of(vector(), min_length=1))
    table.finish()
    return build(table.path, Keyframes, times, rows)


def _airflow(table: Table, seed: int) -> Airflow:
    options = {
        "gust": table.get("gust", number(0.0, 1.0), 0.0),
        "gusts": table.get("gusts", integer(0, 64), 3),
        "air_density": table.get("air_density", positive(), 1.2),
        "drag": table.get("drag", number(0.0), 1.0),
        "lift": table.get("lift", number(0.0), 0.6),
    }
    wind = build(table.path, Airflow, table.get("velocity", vector()), seed=seed, **options)
    table.finish()
    return wind


class ClothBody(Body):
    """A :class:`~motes.cloth.Cloth` in a scene."""

    def __init__(
        self, cloth: Cloth, *, color, stripes, diverged_color, blowup: float, specular: float
    ):
        self.cloth = cloth
        self.color = color
        self.stripes = stripes
        self.diverged_color = diverged_color
        self.blowup = blowup
        self.material = Material(specular=specular, shininess=24.0)
        self.diverged_at: float | None = None
        self._start = cloth.position.copy()
        self._last_good = cloth.position.copy()

    def take_values(self, fresh: ClothBody) -> None:
        """Spring families, gravity, air damping and forces of ``fresh`` (see
        ``LIVE_KEYS``), over this cloth's state and pins (:meth:`Cloth.retune`); nothing
        while a change of its mesh waits for the restart."""
        if self.cloth.fits(fresh.cloth.model):
            self.cloth.retune(fresh.cloth.model)

    def step(self, dt: float) -> None:
        if self.diverged_at is not None:
            return
        with np.errstate(all="ignore"):
            try:
                self.cloth.step(dt)
                broke = False
            except SolverError:  # the implicit solve broke down on a diverging state
                broke = True
            offset = self.cloth.position - self._start
            moved = np.abs(offset).max()
        if broke or self.cloth.diverged or not moved < 1e3 * self.blowup:
            self.diverged_at = self.cloth.time
        # Drawn clamped to within ``blowup`` of the start (non-finite values at the
        # start): an exploding cloth shows as a spiky mess that stays on screen.
        offset = np.where(np.isfinite(offset), offset, 0.0)
        self._last_good = self._start + np.clip(offset, -self.blowup, self.blowup)

    def drawables(self) -> list:
        from ..geometry.mesh import TriangleMesh

        mesh = TriangleMesh(self._last_good.T, self.cloth.faces)
        if self.diverged_at is not None:
            return [geometry.Mesh(mesh, color=self.diverged_color, material=self.material)]
        if self.stripes is not None:
            return [geometry.Mesh(mesh, vertex_colors=self.stripes, material=self.material)]
        return [geometry.Mesh(mesh, color=self.color, material=self.material)]

    def count(self) -> int:
        return self.cloth.n

    def contact(self, path: str, name: str, options: dict):
        from ..couple import ClothContact

        return build(path, ClothContact, self.cloth, **options)

    def particle_state(self):
        return self.cloth.particle_state()

    def entry(self, *, surface: bool = False) -> Entry:
        return Entry(self.cloth.particle_state(), faces=self.cloth.faces)

    replayable = True

    def show(self, entry: Entry, time: float) -> None:
        if entry.state.count != self.cloth.n:
            raise ValueError(f"holds {entry.state.count} particles; the cloth has {self.cloth.n}")
        self._last_good = np.array(entry.state.positions, dtype=np.float64)
        self.diverged_at = None


def _pins(table: Table, cloth: Cloth, grid: bool) -> None:
    if grid:
        ny, nx = cloth.grid_shape
        for key, size in (("pin_rows", ny), ("pin_columns", nx)):
            for i in table.get(key, array_of(integer(-size, size - 1)), []):
                rows, cols = (i, slice(None)) if key == "pin_rows" else (slice(None), i)
                cloth.pin(cloth.grid_index(rows, cols))
        for k, (r, c) in enumerate(table.get("pin", array_of(vector(2)), [])):
            if not (-ny <= r < ny and -nx <= c < nx) or r != int(r) or c != int(c):
                raise SceneError(
                    f"{table.key_path('pin')}[{k}]",
                    f"must be a grid cell [row, column] inside {ny} x {nx}, got {[r, c]}",
                )
            cloth.pin(cloth.grid_index(int(r), int(c)))
    vertex = integer(0, cloth.n - 1)
    pinned = table.get("pin_vertices", array_of(vertex), [])
    if pinned:
        cloth.pin(pinned)
    for t in table.tables("handle"):
        if grid:
            ny, nx = cloth.grid_shape
            row = t.get("row", integer(-ny, ny - 1), 0)
            first, last = t.get("columns", _pair(integer(-nx, nx - 1)), (0, nx - 1))
            first, last = first % nx, last % nx  # negative counts from the end
            step = 1 if last >= first else -1
            cols = np.arange(first, last + step, step)
            idx = cloth.grid_index(row, cols)
            taper = t.get("taper", boolean, False)
            weights = np.linspace(0.0, 1.0, len(cols)) if taper else None
        else:
            idx = np.asarray(t.get("vertices", array_of(vertex, min_length=1)))
            weights = None
        path = _keyframes(t, "offsets")
        cloth.move(idx, path, weights=weights)


def _vertex(cloth: Cloth, grid: bool):
    """A reader of one vertex: ``[row, column]`` of a grid cloth (negative from the
    end), a vertex index of a mesh cloth."""
    if not grid:
        return integer(0, cloth.n - 1)
    ny, nx = cloth.grid_shape

    def read(value, path):
        inside = f"a grid vertex [row, column] inside {ny} x {nx} (negative from the end)"
        if not isinstance(value, list) or len(value) != 2:
            raise SceneError(path, f"must be {inside}, got {shown(value)}")
        r, c = vector(2)(value, path)
        if r != int(r) or c != int(c) or not (-ny <= r < ny and -nx <= c < nx):
            raise SceneError(path, f"must be {inside}, got {shown(value)}")
        return int(cloth.grid_index(int(r), int(c))[0])

    return read


def _springs(table: Table, cloth: Cloth, grid: bool) -> None:
    """``[[body.spring]]``: springs between chosen vertices, added in one go."""
    vertex = _vertex(cloth, grid)
    pairs, stiffness, damping, rest = [], [], [], []
    for t in table.tables("spring"):
        a, b = t.get("a", vertex), t.get("b", vertex)
        if a == b:
            raise SceneError(t.key_path("b"), f"must be another vertex than a (both are {a})")
        pairs.append((a, b))
        stiffness.append(t.get("stiffness", number(0.0)))
        damping.append(t.get("damping", number(0.0), 0.0))
        # Default: the distance at rest, as the cloth is built.
        length = float(np.linalg.norm(cloth.position[:, a] - cloth.position[:, b]))
        rest.append(t.get("rest_length", number(0.0), length))
        t.finish()
    if pairs:
        build(table.key_path("spring"), cloth.add_springs, pairs, stiffness, damping, rest)


@register("cloth")
def build_cloth(table: Table, context: BuildContext) -> ClothBody:
    """A cloth from ``grid`` (+ ``size``, ``origin``, ``rotation``) or a ``mesh`` file."""
    options = {
        "density": table.get("density", positive(), 0.2),
        "structural": table.get("structural", _family, SpringFamily(200.0, 0.2)),
        "shear": table.get("shear", _family, SpringFamily(50.0, 0.05)),
        "bending": table.get("bending", _family, SpringFamily(5.0, 0.01)),
        "gravity": table.get("gravity", vector(), (0.0, -9.81, 0.0)),
        "air_damping": table.get("air_damping", number(0.0), 0.1),
        "thickness": table.get("thickness", number(0.0), 0.005),
        "strain_limit": table.get("strain_limit", number(0.0), 0.1) or None,
        "strain_iterations": table.get("strain_iterations", integer(1, 10_000), 50),
        "scheme": table.get(
            "scheme",
            one_of("implicit_euler", "explicit_euler", "semi_implicit_euler"),
            "implicit_euler",
        ),
        "solver": _solver(table, 1e-2),
        "forces": body_forces(table),
    }
    wind_table = table.table("wind", optional=True)
    if wind_table is not None:
        options["wind"] = _airflow(wind_table, context.seed)
    if table.get("colliders", boolean, True):
        options["colliders"] = list(context.colliders)
    grid = table.has("grid")
    if grid:
        nx, ny = table.get("grid", vector(2))
        if nx != int(nx) or ny != int(ny) or not (2 <= min(nx, ny) <= max(nx, ny) <= GRID_MAX):
            raise SceneError(
                table.key_path("grid"),
                f"must be two integers >= 2, at most {GRID_MAX} each, got {[nx, ny]}",
            )
        cloth = build(
            table.path,
            Cloth.grid,
            int(nx),
            int(ny),
            size=table.get("size", vector(2), (1.0, 1.0)),
            origin=table.get("origin", vector(), (0.0, 0.0, 0.0)),
            rotation=table.get("rotation", euler_rotation, None),
            ripple=table.get("ripple", vector(2), (0.0, 1.0)),
            **options,
        )
    else:
        path = table.get("mesh", scene_file(context.base, suffixes=MESH_SUFFIXES, what="mesh file"))
        try:
            cloth = Cloth.from_mesh(path, **options)
        except OSError as error:
            raise SceneError(table.key_path("mesh"), f"cannot read {path}: {error}") from None
        except ValueError as error:
            raise SceneError(table.key_path("mesh"), str(error)) from None
    _pins(table, cloth, grid)
    _springs(table, cloth, grid)
    tint = table.get("color", color, (0.8, 0.2, 0.15, 1.0))[:3]
    stripes = table.get("stripes", array_of(color, min_length=1), None)
    vertex_colors = None
    if stripes is not None:
        if not grid:
            raise SceneError(table.key_path("stripes"), "needs a grid cloth")
        rows = np.arange(cloth.n) // cloth.grid_shape[1]
        band = rows * len(stripes) // cloth.grid_shape[0]
        vertex_colors = np.array([s[:3] for s in stripes])[band]
    return ClothBody(
        cloth,
        color=tint,
        stripes=vertex_colors,
        diverged_color=table.get("diverged_color", color, (0.9, 0.1, 0.1, 1.0))[:3],
        blowup=table.get("blowup_distance", positive(), 5.0),
        specular=table.get("specular", number(0.0), 0.1),
    )


class HairBody(Body):
    """:class:`~motes.hair.Hair` on its head in a scene."""

    def __init__(self, hair: Hair, *, color, tip_color, width: float, head_color,
                 shadow_radius: float = 0.0, shadow_opacity: float = 0.2):  # fmt: skip
        self.hair = hair
        self.shadow_radius, self.shadow_opacity = shadow_radius, shadow_opacity
        self.width = width
        self.head_color = head_color
        p = hair.per_strand
        t = np.linspace(0.0, 1.0, p)[:, None]
        ramp = (1 - t) * np.asarray(color) + t * np.asarray(tip_color)
        self.point_colors = np.tile(ramp, (hair.strand_count, 1))
        index = np.arange(hair.n).reshape(hair.strand_count, p)
        self.segments = np.stack([index[:, :-1].ravel(), index[:, 1:].ravel()], 1)
        # strands taper from the root to 40 % of the width at the tip
        along = np.tile(np.arange(p - 1) / max(p - 2, 1), hair.strand_count)
        self.widths = width * (1.0 - 0.6 * along)

    def take_values(self, fresh: HairBody) -> None:
        """Stretch and bending springs, gravity, air damping and forces of ``fresh`` (see
        ``LIVE_KEYS``), over this hair's state (:meth:`Hair.retune`); nothing while new
        strands wait for the restart."""
        if self.hair.fits(fresh.hair.model):
            self.hair.retune(fresh.hair.model)

    def step(self, dt: float) -> None:
        self.hair.step(dt)

    def drawables(self) -> list:
        head = self.hair.head
        r, c = head.pose(self.hair.time)
        radius = head.radius
        features = [
            geometry.Sphere(c, radius, color=self.head_color),
            geometry.Sphere(
                c + r @ (0.0, -0.1 * radius, 0.98 * radius), 0.18 * radius, color=self.head_color
            ),
        ]
        for side in (-1.0, 1.0):
            eye = c + r @ (0.35 * side * radius, 0.2 * radius, 0.88 * radius)
            features.append(geometry.Sphere(eye, 0.1 * radius, color=(0.02, 0.02, 0.03)))
        lines = geometry.Lines(
            self.hair.position.T, self.segments, point_colors=self.point_colors,
            width=self.widths, shading="hair", shadow_radius=self.shadow_radius,
            shadow_opacity=self.shadow_opacity,
        )  # fmt: skip
        return [*features, lines]

    def count(self) -> int:
        return self.hair.n

    def particle_state(self):
        return self.hair.particle_state()

    def entry(self, *, surface: bool = False) -> Entry:
        curves = np.full(self.hair.strand_count, self.hair.per_strand, dtype=np.int64)
        return Entry(self.hair.particle_state(), curves=curves)

    replayable = True

    def show(self, entry: Entry, time: float) -> None:
        self.hair.position = entry.state.positions
        self.hair.time = time  # the head's pose


def _hair_colliders(table: Table, context: BuildContext) -> list:
    if not table.get("colliders", boolean, True):
        return []
    for collider in context.colliders:
        if isinstance(collider, TriangleMeshCollider):
            raise SceneError(
                table.key_path("colliders"),
                "hair collides with planes, spheres and boxes, not with the scene's "
                "triangle-mesh collider; set colliders = false",
            )
    return list(context.colliders)


@register("hair")
def build_hair(table: Table, context: BuildContext) -> HairBody:
    """Strands on a head that may move (``translation``, ``rotation`` keyframes)."""
    head_table = table.table("head", optional=True)
    head_options = {}
    center, radius, friction = (0.0, 1.6, 0.0), 0.1, 0.3
    if head_table is not None:
        center = head_table.get("center", vector(), center)
        radius = head_table.get("radius", positive(), radius)
        friction = head_table.get("friction", number(0.0, 1.0), friction)
        move = head_table.table("translation", optional=True)
        if move is not None:
            head_options["translation"] = _keyframes(move, "offsets")
        turn = head_table.table("rotation", optional=True)
        if turn is not None:
            head_options["rotation"] = _keyframes(turn, "angles")
        head_color = head_table.get("color", color, (0.85, 0.62, 0.5, 1.0))[:3]
        head_table.finish()
    else:
        head_color = (0.85, 0.62, 0.5)
    head = build(table.key_path("head"), Head, center, radius, friction=friction, **head_options)
    hair = build(
        table.path,
        Hair,
        head,
        strands=table.get("strands", integer(1, 100_000), 500),
        particles=table.get("particles", integer(3, 1000), 10),
        length=table.get("length", positive(), 0.25),
        length_variation=table.get("length_variation", number(0.0, 1.0, high_open=True), 0.0),
        comb=table.get("comb", vector(), (0.0, -1.0, -1.0)),
        lift=table.get("lift", number(0.0), 0.3),
        mass=table.get("mass", positive(), 1e-4),
        stretch=table.get("stretch", vector(2), (500.0, 0.02)),
        bending=table.get("bending", vector(2), (2.0, 0.001)),
        stretch_limit=table.get("stretch_limit", number(0.0), 0.02) or None,
        air_damping=table.get("air_damping", number(0.0), 1.0),
        gravity=table.get("gravity", vector(), (0.0, -9.81, 0.0)),
        thickness=table.get("thickness", number(0.0), 0.004),
        colliders=_hair_colliders(table, context),
        solver=_solver(table, 1e-2),
        seed=context.seed % (2**32),
        forces=body_forces(table),
    )
    return HairBody(
        hair,
        color=table.get("color", color, (0.25, 0.14, 0.07, 1.0))[:3],
        tip_color=table.get("tip_color", color, (0.55, 0.38, 0.2, 1.0))[:3],
        width=table.get("width", positive(), 1.5),
        head_color=head_color,
        shadow_radius=table.get("shadow_radius", number(0.0), 0.0),
        shadow_opacity=table.get("shadow_opacity", number(0.0, 1.0), 0.2),
    )
