"""Scene-file tables to library objects: shapes, rates, distributions, forces, colliders...

Every table with variants names its variant with ``type`` (``{ type = "disc",
radius = 0.3 }``); each reader checks its keys and hands values to the library
constructor, whose own range checks are reported with the key path (see ``schema.build``).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .. import colliders, emit, forces, life
from ..emit import shapes
from ..integrate import Integrator
from ..life.events import KINDS
from ..spatial.index import STRUCTURES
from .schema import (
    SceneError,
    Table,
    array_of,
    boolean,
    build,
    color,
    integer,
    keyed,
    number,
    one_of,
    positive,
    scene_file,
    shown,
    vector,
)

#: Mesh files the scene reads (``motes.io.meshes``).
MESH_SUFFIXES = (".obj", ".ply")

# --- distributions ------------------------------------------------------------------------


def _plain_value(value, path):
    """A number, an array of 1 to 4 numbers (a vector, RGB or RGBA), or a colour string."""
    if isinstance(value, str):
        return color(value, path)
    if isinstance(value, list):
        if not 1 <= len(value) <= 4:
            raise SceneError(path, f"must be a number or 1 to 4 numbers, got {shown(value)}")
        return tuple(number()(v, f"{path}[{i}]") for i, v in enumerate(value))
    return number()(value, path)


def distribution(value, path):
    """A per-particle initial value.

    ``1.5``, ``[0, 1, 0]`` or ``"#ff8800"`` (constant), ``{ uniform = [low, high] }``,
    ``{ normal = [mean, std], low = ..., high = ... }`` or
    ``{ gradient = [[0, "#ffffff"], [1, "#ff0000"]] }`` (chosen uniformly along the stops).
    """
    if not isinstance(value, dict):
        return emit.Constant(_plain_value(value, path))
    table = Table(value, path)
    forms = [k for k in ("constant", "uniform", "normal", "gradient") if k in value]
    if len(forms) != 1:
        raise SceneError(
            path, "must have exactly one of the keys constant, uniform, normal, gradient"
        )
    form = forms[0]
    if form == "constant":
        result = emit.Constant(table.get("constant", _plain_value))
    elif form == "uniform":
        low, high = table.get("uniform", array_of(_plain_value, min_length=2))[:2]
        _pair_only(table, "uniform")
        result = build(path, emit.Uniform, low, high)
    elif form == "normal":
        mean, std = table.get("normal", array_of(number(), min_length=2))[:2]
        _pair_only(table, "normal")
        low = table.get("low", number(), None)
        high = table.get("high", number(), None)
        result = build(path, emit.Normal, mean, std, low=low, high=high)
    else:
        stops = table.get("gradient", keyed(_plain_value))
        result = build(path, emit.Gradient, stops)
    table.finish()
    return result


def _pair_only(table: Table, key: str) -> None:
    if len(table.data[key]) != 2:
        raise SceneError(table.key_path(key), f"must be [a, b], got {shown(table.data[key])}")


# --- emission -----------------------------------------------------------------------------

_SHAPES = {
    "point": lambda t: shapes.Point(),
    "sphere": lambda t: build(
        t.path,
        shapes.Sphere,
        t.get("radius", positive()),
        surface=t.get("surface", boolean, False),
    ),
    "box": lambda t: build(
        t.path, shapes.Box, t.get("size", vector()), surface=t.get("surface", boolean, False)
    ),
    "disc": lambda t: build(
        t.path,
        shapes.Disc,
        t.get("radius", positive()),
        normal=t.get("normal", vector(), (0.0, 1.0, 0.0)),
        inner_radius=t.get("inner_radius", number(0.0), 0.0),
    ),
    "cone": lambda t: build(
        t.path,
        shapes.Cone,
        t.get("radius", positive()),
        t.get("height", positive()),
        axis=t.get("axis", vector(), (0.0, 1.0, 0.0)),
        surface=t.get("surface", boolean, False),
    ),
    "line": lambda t: build(t.path, shapes.Line, t.get("start", vector()), t.get("end", vector())),
}

_DIRECTIONS = {
    "cone": lambda t: build(
        t.path,
        emit.Cone,
        axis=t.get("axis", vector(), (0.0, 1.0, 0.0)),
        angle=t.get("angle", number(0.0, 180.0), 30.0),
    ),
    "isotropic": lambda t: emit.Isotropic(),
    "shape_normal": lambda t: build(
        t.path, emit.ShapeNormal, spread=t.get("spread", number(0.0, 180.0), 0.0)
    ),
    "radial": lambda t: emit.Radial(),
}


def _variant(table: Table, variants: dict, what: str):
    kind = table.get("type", one_of(*variants))
    result = variants[kind](table)
    table.finish()
    return result


def shape(value, path, base: Path):
    """An emitter shape; ``base`` is the folder a mesh file is read from."""
    variants = {**_SHAPES, "mesh": lambda t: _mesh_surface(t, base)}
    return _variant(Table(value, path), variants, "shape")


def _mesh_surface(table: Table, base: Path):
    mesh = placed_mesh(table, base)
    return build(table.key_path("path"), shapes.MeshSurface, mesh.vertices, mesh.faces)


def placed_mesh(table: Table, base: Path, *, movable: bool = False):
    """A triangle mesh read from the file ``path`` (relative to ``base``, see
    ``schema.scene_file``), scaled by ``scale``, turned by ``rotation`` (angles [deg]) and,
    when ``movable``, moved by ``position`` [m], in that order."""
    from ..io.meshes import read_mesh

    file = table.get("path", scene_file(base, suffixes=MESH_SUFFIXES, what="mesh file"))
    scale = table.get("scale", positive(), 1.0)
    rotation = table.get("rotation", euler_rotation, None)
    offset = table.get("position", vector(), (0.0, 0.0, 0.0)) if movable else (0.0, 0.0, 0.0)
    try:
        mesh = read_mesh(file)
    except OSError as error:
        raise SceneError(table.key_path("path"), f"cannot read {file}: {error}") from None
    except ValueError as error:  # MeshFormatError names the file and line
        raise SceneError(table.key_path("path"), str(error)) from None
    if len(mesh.faces) == 0:
        raise SceneError(table.key_path("path"), f"{file} holds no triangles")
    vertices = scale * mesh.vertices.astype(np.float64)
    if rotation is not None:
        vertices = vertices @ rotation.T
    vertices = vertices + np.asarray(offset)
    return type(mesh)(vertices, mesh.faces)


def direction(value, path):
    return _variant(Table(value, path), _DIRECTIONS, "direction")


def rate(value, path, camera):
    """``{ type = "per_second" | "per_frame" | "burst", ..., screen_scaled = false }``."""
    t = Table(value, path)
    kind = t.get("type", one_of("per_second", "per_frame", "burst"))
    if kind == "per_second":
        result = build(
            path, emit.PerSecond, t.get("rate", number(0.0)), stop=t.get("stop", number(0.0), None)
        )
    elif kind == "per_frame":
        result = build(
            path,
            emit.PerFrame,
            t.get("mean", number(0.0)),
            variance=t.get("variance", number(0.0), 0.0),
            delta_mean=t.get("delta_mean", number(), 0.0),
            delta_variance=t.get("delta_variance", number(), 0.0),
            start_frame=t.get("start_frame", integer(0), 0),
        )
    else:
        result = build(
            path,
            emit.Burst,
            t.get("count", integer(0)),
            at=t.get("at", number(0.0), 0.0),
            every=t.get("every", positive(), None),
            repeat=t.get("repeat", integer(1), None),
        )
    if t.get("screen_scaled", boolean, False):
        result = build(
            path, emit.ScreenScaled, result, camera, margin=t.get("margin", number(0.0), 0.0)
        )
    t.finish()
    return result


def _position(value, path):
    """``[x, y, z]`` or a path ``{ times = [...], points = [[x, y, z], ...] }``."""
    if isinstance(value, dict):
        t = Table(value, path)
        times = t.get("times", array_of(number(), min_length=1))
        points = t.get("points", array_of(vector(), min_length=1))
        t.finish()
        return build(path, emit.Path, times, points)
    return vector()(value, path)


def emitter(table: Table, camera, base: Path, *, template: bool = False) -> emit.Emitter:
    """An emitter; a ``template`` (for child systems) has no rate and an optional shape.
    ``base`` is the folder files it names (mesh shapes) are read from."""
    kwargs = {
        "position": table.get("position", _position, (0.0, 0.0, 0.0)),
        "lifetime": table.get("lifetime", distribution, 1.0),
        "speed": table.get("speed", distribution, 1.0),
        "direction": table.get("direction", direction, None),
        "inherit_velocity": table.get("inherit_velocity", number(), 0.0),
    }
    for key in ("color", "size", "mass", "rotation"):
        kwargs[key] = table.get(key, distribution, None)
    charge = table.get("charge", distribution, None)
    if charge is not None:
        kwargs["attributes"] = {"charge": charge}
    the_shape = table.get("shape", lambda v, p: shape(v, p, base), None)
    the_rate = None if template else table.get("rate", lambda v, p: rate(v, p, camera))
    table.finish()
    return build(table.path, emit.Emitter, the_shape, the_rate, **kwargs)


# --- forces -------------------------------------------------------------------------------

_FORCES = {
    "gravity": lambda t: build(
        t.path, forces.Gravity, t.get("acceleration", vector(), (0.0, -9.81, 0.0))
    ),
    "drag": lambda t: build(
        t.path,
        forces.Drag,
        t.get("coefficient", number(0.0)),
        wind=t.get("wind", vector(), (0.0, 0.0, 0.0)),
    ),
    "quadratic_drag": lambda t: build(
        t.path,
        forces.QuadraticDrag,
        t.get("coefficient", number(0.0)),
        wind=t.get("wind", vector(), (0.0, 0.0, 0.0)),
    ),
    "wind": lambda t: build(
        t.path,
        forces.Wind,
        t.get("velocity", vector()),
        coefficient=t.get("coefficient", number(0.0), 1.0),
    ),
    "radial": lambda t: build(
        t.path,
        forces.RadialField,
        t.get("center", vector()),
        t.get("strength", number()),
        softening=t.get("softening", positive(), 0.01),
        falloff=t.get("falloff", one_of("inverse_square", "linear"), "inverse_square"),
    ),
    "vortex": lambda t: build(
        t.path,
        forces.Vortex,
        t.get("center", vector()),
        t.get("axis", vector()),
        t.get("strength", number()),
        radius=t.get("radius", positive(), 1.0),
        pull=t.get("pull", number(), 0.0),
    ),
    "nbody_gravity": lambda t: build(
        t.path,
        forces.NBodyGravity,
        t.get("G", positive(), forces.nbody.G_SI),
        **_summation(t),
    ),
    "coulomb": lambda t: build(
        t.path,
        forces.Coulomb,
        k=t.get("k", positive(), forces.nbody.K_COULOMB),
        **_summation(t),
    ),
    "lennard_jones": lambda t: build(
        t.path,
        _lennard_jones,
        t.get("epsilon", positive()),
        t.get("sigma", positive()),
        t.get("cutoff", positive(), None),
        t.get("structure", one_of(*STRUCTURES), "grid"),
    ),
    "curl_noise": lambda t: build(
        t.path,
        forces.CurlNoise,
        t.get("strength", number()),
        t.get("scale", positive()),
        seed=t.get("seed", integer(0), 0),
        octaves=t.get("octaves", integer(1, 8), 1),
        time_scale=t.get("time_scale", number(), 0.0),
    ),
}


def _summation(t: Table) -> dict:
    """The keys shared by the inverse-square pair forces."""
    return {
        "softening": t.get("softening", number(0.0), 0.0),
        "method": t.get("method", one_of(*forces.nbody.METHODS), "auto"),
        "theta": t.get("theta", number(0.0, 1.0, low_open=True), 0.7),
        "quadrupole": t.get("quadrupole", boolean, False),
    }


def _lennard_jones(epsilon, sigma, cutoff, structure):
    return forces.PairForce(
        forces.lennard_jones(epsilon, sigma), cutoff=cutoff, structure=structure
    )


def force(table: Table):
    return _variant(table, _FORCES, "force")


def body_forces(table: Table) -> list:
    """The forces of a body's ``[[body.force]]`` tables, read as ``[[system.force]]``."""
    return [force(t) for t in table.tables("force")]


# --- colliders ----------------------------------------------------------------------------


def euler_rotation(value, path):
    """Rotation matrix from ``[x, y, z]`` angles [deg], applied in the order x, y, z."""
    ax, ay, az = (math.radians(a) for a in vector()(value, path))
    cx, sx, cy, sy, cz, sz = (
        math.cos(ax),
        math.sin(ax),
        math.cos(ay),
        math.sin(ay),
        math.cos(az),
        math.sin(az),
    )
    rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return rz @ ry @ rx


def collider(table: Table, base: Path):
    """A collider; returns ``(collider, drawable, colour)``: ``drawable`` is ``None`` for
    a hidden collider, else what to draw (the collider, or for a mesh its
    ``TriangleMesh``). Mesh files are read relative to ``base``."""
    kind = table.get("type", one_of("plane", "sphere", "box", "capsule", "mesh"))
    result = _mesh_collider(table, base) if kind == "mesh" else _shape_collider(table, kind)
    visible = table.get("visible", boolean, False)
    tint = table.get("color", color, (0.6, 0.6, 0.6, 1.0))
    table.finish()
    drawable = None
    if visible:
        drawable = result.mesh if kind == "mesh" else result
    return result, drawable, tint


def _mesh_collider(table: Table, base: Path):
    """A triangle mesh as a thin two-sided shell (rigid worlds, cloth): Coulomb friction
    from the penetration depth, restitution of swept hits."""
    from ..collide.mesh import TriangleMeshCollider

    mesh = placed_mesh(table, base, movable=True)
    return build(
        table.path,
        TriangleMeshCollider,
        mesh,
        thickness=table.get("thickness", number(0.0), 0.0),
        cell_size=table.get("cell_size", positive(), None),
        restitution=table.get("restitution", number(0.0), 0.5),
        friction=table.get("friction", number(0.0), 0.0),
        response=table.get("response", one_of(*_RESPONSES), "bounce"),
        detection=table.get("detection", one_of(*_DETECTIONS), "priori"),
    )


_RESPONSES = ("bounce", "stick", "kill", "event")
_DETECTIONS = ("posteriori", "priori")


def _shape_collider(table: Table, kind: str):
    # A capsule's friction acts on the penetration depth, as a rigid world needs it.
    friction_model = "depth" if kind == "capsule" else "scale"
    response = {
        "restitution": table.get("restitution", number(0.0), 0.5),
        "friction": table.get("friction", number(0.0), 0.0),
        "friction_model": table.get("friction_model", one_of("scale", "depth"), friction_model),
        "response": table.get("response", one_of(*_RESPONSES), "bounce"),
        "inside": table.get("inside", boolean, False),
        "detection": table.get("detection", one_of(*_DETECTIONS), "posteriori"),
    }
    if kind == "plane":
        return build(
            table.path,
            colliders.Plane,
            table.get("normal", vector(), (0.0, 1.0, 0.0)),
            table.get("offset", number(), 0.0),
            point=table.get("point", vector(), None),
            **response,
        )
    if kind == "sphere":
        return build(
            table.path,
            colliders.Sphere,
            table.get("center", vector(), (0.0, 0.0, 0.0)),
            table.get("radius", positive(), 1.0),
            **response,
        )
    if kind == "capsule":
        return build(
            table.path,
            colliders.Capsule,
            table.get("a", vector(), (0.0, 0.0, 0.0)),
            table.get("b", vector(), (0.0, 1.0, 0.0)),
            table.get("radius", positive(), 0.1),
            **response,
        )
    return build(
        table.path,
        colliders.Box,
        table.get("center", vector(), (0.0, 0.0, 0.0)),
        table.get("size", vector(), (1.0, 1.0, 1.0)),
        rotation=table.get("rotation", euler_rotation, None),
        **response,
    )


# --- life ---------------------------------------------------------------------------------


def _curve_value(value, path):
    return color(value, path) if isinstance(value, str) else _plain_value(value, path)


_MODIFIERS = {
    "color_over_life": lambda t: build(
        t.path,
        life.ColorOverLife,
        t.get("keys", keyed(_curve_value)),
        multiply=t.get("multiply", boolean, False),
    ),
    "size_over_life": lambda t: build(
        t.path,
        life.SizeOverLife,
        t.get("keys", keyed(_curve_value)),
        multiply=t.get("multiply", boolean, True),
    ),
    "speed_over_life": lambda t: build(
        t.path, life.SpeedOverLife, t.get("keys", keyed(_curve_value))
    ),
    "intensity_below": lambda t: build(
        t.path, life.IntensityBelow, t.get("threshold", number(0.0))
    ),
    "alpha_below": lambda t: build(t.path, life.AlphaBelow, t.get("threshold", number(0.0))),
    "distance_from": lambda t: build(
        t.path, life.DistanceFrom, t.get("center", vector()), t.get("distance", positive())
    ),
}


def particle_collisions(table: Table) -> colliders.ParticleCollisions:
    """A ``[system.collisions]`` table: the system's particles collide with each other
    (gravity, for the inelastic threshold and stacking, is the system's)."""
    made = build(
        table.path,
        colliders.ParticleCollisions,
        restitution=table.get("restitution", number(0.0, 1.0), 0.3),
        friction=table.get("friction", number(0.0, 10.0), 0.5),
        iterations=table.get("iterations", integer(1, 1000), 4),
        structure=table.get("structure", one_of(*STRUCTURES), "grid"),
        stacking=table.get("stacking", number(0.0, 20.0), 3.0),
    )
    table.finish()
    return made


def modifier(table: Table):
    return _variant(table, _MODIFIERS, "modifier")


INTEGRATORS = tuple(i.value for i in Integrator)
EVENT_KINDS = tuple(KINDS)


# --- particles placed at load time --------------------------------------------------------

#: Most particles one ``[[system.particles]]`` table may place.
MAX_PLACED = 10_000_000


def place_particles(table: Table, system) -> None:
    """Add the particles of a ``[[system.particles]]`` table to ``system``.

    ``type = "plummer"`` (a star cluster in equilibrium), ``"disc_galaxy"`` (stars on
    circular orbits around a heavy core), ``"ring"`` (bodies on circular orbits about a
    ``central_mass`` at ``center``: a planet's ring, a belt, one planet) or ``"body"``
    (one particle: a star, a planet launched by hand); the orbits are for the system's
    ``nbody_gravity`` force (its ``G`` and softening), which must come first. Moved to
    ``center``, given the bulk ``velocity``; coloured ``color`` at the centre shading to
    ``outer_color`` at the edge, radius ``size`` (a galaxy's core ``core_size``).
    """
    from ..emit import nbody

    kind = table.get("type", one_of("plummer", "disc_galaxy", "ring", "body"))
    if kind == "body":
        count = table.get("count", integer(1, 1), 1)
    elif kind == "ring":
        count = table.get("count", integer(1, MAX_PLACED), 1)
    else:
        count = table.get("count", integer(1, MAX_PLACED))
    gravity = next((f for f in system.forces if isinstance(f, forces.NBodyGravity)), None)
    if gravity is None:
        raise SceneError(
            table.key_path("type"),
            "placed particles orbit under the system's gravity: add a "
            '[[system.force]] with type = "nbody_gravity" before them',
        )
    free = system.store.capacity - system.store.count
    if count > free:
        raise SceneError(table.key_path("count"), f"{count} particles exceed the {free} free "
                         "places of the system's capacity")  # fmt: skip
    center = np.asarray(table.get("center", vector(), (0.0, 0.0, 0.0)))
    bulk = np.asarray(table.get("velocity", vector(), (0.0, 0.0, 0.0)))
    common = {"G": gravity.G, "seed": system.rng}
    if kind == "plummer":
        radius = table.get("radius", positive(), 1.0)
        position, velocity, mass = build(
            table.path, nbody.plummer_sphere, count,
            mass=table.get("mass", positive(), 1.0), radius=radius, **common,
        )  # fmt: skip
        extent = 3.0 * radius
    elif kind == "disc_galaxy":
        radius = table.get("radius", positive(), 1.0)
        position, velocity, mass = build(
            table.path, nbody.disc_galaxy, count - 1,
            core_mass=table.get("core_mass", positive(), 1.0),
            disc_mass=table.get("disc_mass", number(0.0), 0.1),
            radius=radius,
            inner_radius=table.get("inner_radius", number(0.0), 0.1 * radius),
            normal=table.get("normal", vector(), (0.0, 1.0, 0.0)),
            thickness=table.get("thickness", number(0.0), 0.02),
            softening=gravity.softening, **common,
        )  # fmt: skip
        extent = radius
    elif kind == "ring":
        radius = table.get("radius", positive(), 1.0)
        position, velocity, mass = build(
            table.path, nbody.ring, count,
            central_mass=table.get("central_mass", positive()),
            mass=table.get("mass", number(0.0), 0.0),
            radius=radius,
            inner_radius=table.get("inner_radius", positive(), radius),
            normal=table.get("normal", vector(), (0.0, 1.0, 0.0)),
            thickness=table.get("thickness", number(0.0), 0.0),
            softening=gravity.softening, **common,
        )  # fmt: skip
        # A massless ring is drawn but does not pull: its particles still need a mass.
        mass = np.maximum(mass, 1e-30)
        extent = radius
    else:  # one body, placed and launched as given
        position, velocity = np.zeros((3, 1)), np.zeros((3, 1))
        mass = np.array([table.get("mass", positive(), 1.0)])
        extent = 1.0
    inner = _rgba(table.get("color", color, (1.0, 1.0, 1.0, 1.0)))
    outer = _rgba(table.get("outer_color", color, tuple(inner)))
    size = table.get("size", positive(), 0.02)
    sizes = np.full(count, size)
    if kind == "disc_galaxy":
        sizes[0] = table.get("core_size", positive(), size)
    table.finish()
    t = np.clip(np.linalg.norm(position, axis=0) / extent, 0.0, 1.0)
    tint = inner[:, None] * (1.0 - t) + outer[:, None] * t
    nbody.add_particles(
        system, position + center[:, None], velocity + bulk[:, None], mass=mass,
        color=tint, size=sizes, lifetime=np.full(count, np.inf),
    )  # fmt: skip


def _rgba(value) -> np.ndarray:
    value = np.asarray(value, dtype=np.float64)
    return value if value.shape == (4,) else np.append(value, 1.0)
