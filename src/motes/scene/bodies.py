"""Bodies in a scene: simulations with topology (cloth, hair, rigid bodies, liquids).

A ``[[system]]`` is an emitter-driven particle system; a ``[[body]]`` is anything else
that steps in time and draws itself: a cloth draws a mesh, a hair strand lines, a liquid
particles or a surface. Each ``type`` of body registers a builder with :func:`register`;
the builder reads its table (every key documented in ``docs/scene-format.md``) and returns
a :class:`Body`.
"""

from __future__ import annotations

import importlib
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..io.entry import Entry
from ..state import ParticleState
from .schema import SceneError, Table, one_of, shown


class Body(ABC):
    """Something a scene steps and draws that is not an emitter-driven system.

    A body shows its particles as its simulation's :class:`~motes.state.ParticleState`
    (:meth:`particle_state`, what the particle cache records), and what to draw as
    particles as ``(ParticleState, SpriteStyle)`` pairs (:meth:`particles`).
    """

    @abstractmethod
    def step(self, dt: float) -> None:
        """Advance by ``dt`` seconds (the scene's substep)."""

    def drawables(self) -> list:
        """Opaque geometry in the current state (``render.geometry`` objects)."""
        return []

    def particles(self) -> list:
        """``(ParticleState, SpriteStyle)`` pairs to draw as particles (see ``Renderer``)."""
        return []

    def particle_state(self) -> ParticleState:
        """The particles of the body's simulation now; empty for a body without any."""
        return ParticleState(np.zeros(0, np.int64), np.zeros((3, 0)), np.zeros((3, 0)), np.zeros(0))

    def entry(self, *, surface: bool = False) -> Entry:
        """What the cache and the exporters record of the body now: its
        :meth:`particle_state` and the shapes on it (a cloth's faces, hair's strands, a
        rigid world's body transforms; with ``surface``, a liquid's surface mesh, which
        costs a meshing). Bodies that are only particles need not override it."""
        return Entry(self.particle_state())

    def count(self) -> int:
        """Particles in the body (for progress lines and ``Scene.counts``)."""
        return 0

    #: Whether :meth:`show` can draw the body from a cached frame.
    replayable = False
    #: Why not, when it cannot (the error ``motes render`` gives).
    not_replayable = (
        "a trail is a path over the last steps, which a cache does not hold (draw it "
        "without trails)"
    )

    def show(self, entry: Entry, time: float) -> None:
        """Put a cached frame's particles (``entry``, as :meth:`entry` recorded them at
        ``time`` [s]) where :meth:`drawables` and :meth:`particles` read them, to draw
        the body again without simulating it (``motes render CACHE``)."""
        raise NotImplementedError(f"{type(self).__name__} cannot be drawn from a cache")

    def take_values(self, fresh: Body) -> None:
        """Adopt the values of :data:`LIVE_KEYS` for this body's type from ``fresh`` (the
        same body built from the scene file with new values), keeping everything that
        moves: what the live viewer does when such a value changes. Bodies without live
        keys keep theirs until the scene restarts."""
        return None

    def link(self, bodies: dict) -> None:
        """Resolve references to other bodies by name (``bodies``: every body of the
        scene, this one included), once all are built; raise :class:`SceneError` naming
        the key of a bad reference. Most bodies refer to none."""
        return None

    def link_systems(self, systems: dict) -> None:
        """Resolve references to the scene's emitter systems by name (``systems``: name
        -> :class:`~motes.system.ParticleSystem`), once all are built. Most bodies refer
        to none."""
        return None

    def flow(self, path: str, options: dict):
        """The force a ``[[system.force]] type = "grid_flow"`` at ``path`` naming this body
        adds to its system; only grid fluids have a flow to ride."""
        raise SceneError(
            path, f"a grid_flow force needs a grid_fluid body, not a {type(self).__name__}"
        )

    def contact(self, path: str, name: str, options: dict):
        """A contact an emitter system's particles have with this body (a
        :class:`~motes.collide.between.KindContact`), from a ``[[system.contact]]`` table
        at ``path``; bodies that particles cannot collide with refuse, naming themselves.
        """
        kind = type(self).__name__
        raise SceneError(path, f"emitter particles cannot collide with body {shown(name)} ({kind})")


@dataclass
class BuildContext:
    """What a body builder may use besides its own table.

    ``colliders`` are the scene's shared ``[[collider]]`` objects, ``seed`` a seed of the
    body's own, ``base`` the folder relative paths (meshes, textures) are read from.
    """

    camera: object
    base: Path
    seed: int
    colliders: list = field(default_factory=list)


Builder = Callable[[Table, BuildContext], Body]

#: Keys of a ``[[body]]`` table, by ``type``, whose values can act on a running body from
#: its next step (:meth:`Body.take_values`; the live viewer's controls). A body's other
#: values, and every value of the types not listed, act when the scene restarts: they
#: shape what the body is made of (its particles, mesh, grid, walls) or what it is
#: joined to.
LIVE_KEYS: dict[str, tuple[str, ...]] = {
    "fluid": (
        "iterations",
        "xsph",
        "viscosity",
        "viscosity_width",
        "repulsion",
        "tensile",
        "vorticity",
        "relaxation",
        "max_dt",
        "force",
    ),
    "cloth": ("structural", "shear", "bending", "gravity", "air_damping", "force"),
    "hair": ("stretch", "bending", "air_damping", "gravity", "force"),
    "grid_fluid": ("viscosity", "vorticity", "buoyancy", "dissipation", "max_dt"),
    "clouds": ("wind",),
    # Every type built on a rigid world (body_rigid, body_rigid_world; a test checks
    # the list against the registry): its world settings.
    **dict.fromkeys(
        ("rigid", "ragdoll_stairs", "rope_bridge", "pendulums", "box_tower", "swept_vs_posteriori"),
        ("gravity", "damping", "iterations", "substeps", "projection", "force"),
    ),
    "flock": (
        "separation",
        "alignment",
        "cohesion",
        "min_speed",
        "max_speed",
        "max_acceleration",
        "max_turn_rate",
        "flap_frequency",
        "bank_time",
    ),
}

#: Body type name -> builder. Filled by the modules in ``_BODY_MODULES`` at first use.
BODY_TYPES: dict[str, Builder] = {}

# Modules that register body types; imported lazily so that loading a scene without
# bodies does not import (or compile) the solvers.
_BODY_MODULES: tuple[str, ...] = (
    "motes.scene.body_cloth",
    "motes.scene.body_clouds",
    "motes.scene.body_flock",
    "motes.scene.body_fluids",
    "motes.scene.body_gridfluid",
    "motes.scene.body_rigid",
    "motes.scene.body_rigid_world",
)


def register(kind: str) -> Callable[[Builder], Builder]:
    """Decorator: make ``builder`` the reader of ``[[body]] type = kind``."""

    def decorate(builder: Builder) -> Builder:
        if kind in BODY_TYPES and BODY_TYPES[kind] is not builder:
            raise ValueError(f"body type {kind!r} is already registered")
        BODY_TYPES[kind] = builder
        return builder

    return decorate


def _load_types() -> None:
    for module in _BODY_MODULES:
        importlib.import_module(module)


def build_body(table: Table, context: BuildContext) -> tuple[str, Body]:
    """Read one ``[[body]]`` table: its ``name`` and the built body."""
    _load_types()
    if not BODY_TYPES:
        raise SceneError(table.path, "no body types are available")
    name = table.get("name", _name)
    kind = table.get("type", one_of(*sorted(BODY_TYPES)))
    body = BODY_TYPES[kind](table, context)
    table.finish()
    if not isinstance(body, Body):
        raise TypeError(f"builder of body type {kind!r} returned {type(body).__name__}")
    return name, body


def _name(value, path):
    if not isinstance(value, str) or not value:
        raise SceneError(path, f"must be a non-empty string, got {shown(value)}")
    return value
