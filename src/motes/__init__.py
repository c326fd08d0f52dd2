"""motes: particle systems (Reeves 1983) in compiled kernels.

>>> import motes as mo
>>> fire = mo.ParticleSystem(capacity=10_000, seed=1)
>>> _ = fire.add(mo.Emitter(mo.shapes.Disc(0.3), mo.PerSecond(2000), lifetime=mo.Uniform(0.6, 1.2)),
...              mo.Gravity((0, 2.0, 0)), mo.Drag(0.8))
>>> fire.run(60, 1 / 60)
>>> 1000 < len(fire) < 2500
True
"""

from . import (
    colliders,
    constrain,
    fluids,
    geometry,
    gridfluid,
    io,
    render,
    rigid,
    scene,
    shapes,
    spatial,
)
from ._memory import InsufficientMemoryError
from ._version import __version__ as __version__
from .cloth import Airflow, Cloth, Keyframes, SpringFamily
from .collide import Capsule, Friction, ParticleCollisions, Response, TriangleMeshCollider
from .constrain import ConstraintBuilder
from .emit import (
    Burst,
    Cone,
    Constant,
    Direction,
    Distribution,
    Emitter,
    Function,
    Gradient,
    Isotropic,
    Normal,
    Path,
    PerFrame,
    PerSecond,
    Radial,
    Rate,
    ScreenScaled,
    ShapeNormal,
    Uniform,
)
from .finite import NonFiniteError, check_finite
from .fluids import Fluid, FluidModel
from .forces import (
    CallbackForce,
    Coulomb,
    CurlNoise,
    Drag,
    FieldForce,
    Force,
    ForceJacobian,
    Gravity,
    NBodyGravity,
    PairForce,
    QuadraticDrag,
    RadialField,
    Springs,
    Vortex,
    Wind,
)
from .geometry import TriangleMesh
from .gridfluid import Buoyancy, Dissipation, GridFlow, GridFluid
from .gridfluid import Solver as GridSolver
from .gridfluid import Source as GridSource
from .gridfluid import Wall as GridWall
from .hair import Hair, Head
from .hierarchy import SpawnOnEvent
from .integrate import Integrator
from .integrate.implicit import ConstraintFilter, ImplicitEuler, SolverError
from .life import (
    AlphaBelow,
    ColorOverLife,
    Curve,
    DistanceFrom,
    Extinction,
    IntensityBelow,
    ParticleEvent,
    SizeOverLife,
    SpeedOverLife,
)
from .particles import Attribute, ParticleStore
from .render.background import Background
from .render.bloom import Bloom
from .render.camera import Camera, Projection
from .render.occlusion import AmbientOcclusion
from .render.renderer import Renderer
from .render.sprites import SpriteStyle
from .render.water import Water
from .rigid import BodyShape, add_ragdoll
from .rigid import World as RigidWorld
from .scene import Scene, SceneError, load_scene
from .spatial import UniformGrid
from .system import ParticleSystem

__all__ = [
    "Airflow",
    "AlphaBelow",
    "AmbientOcclusion",
    "Attribute",
    "Background",
    "Bloom",
    "BodyShape",
    "Buoyancy",
    "Burst",
    "CallbackForce",
    "Camera",
    "Capsule",
    "Cloth",
    "ColorOverLife",
    "Cone",
    "Constant",
    "ConstraintBuilder",
    "ConstraintFilter",
    "Coulomb",
    "CurlNoise",
    "Curve",
    "Direction",
    "Dissipation",
    "DistanceFrom",
    "Distribution",
    "Drag",
    "Emitter",
    "Extinction",
    "FieldForce",
    "Fluid",
    "FluidModel",
    "Force",
    "ForceJacobian",
    "Friction",
    "Function",
    "Gradient",
    "Gravity",
    "GridFlow",
    "GridFluid",
    "GridSolver",
    "GridSource",
    "GridWall",
    "Hair",
    "Head",
    "ImplicitEuler",
    "InsufficientMemoryError",
    "Integrator",
    "IntensityBelow",
    "Isotropic",
    "Keyframes",
    "NBodyGravity",
    "NonFiniteError",
    "Normal",
    "PairForce",
    "ParticleCollisions",
    "ParticleEvent",
    "ParticleStore",
    "ParticleSystem",
    "Path",
    "PerFrame",
    "PerSecond",
    "Projection",
    "QuadraticDrag",
    "Radial",
    "RadialField",
    "Rate",
    "Renderer",
    "Response",
    "RigidWorld",
    "Scene",
    "SceneError",
    "ScreenScaled",
    "ShapeNormal",
    "SizeOverLife",
    "SolverError",
    "SpawnOnEvent",
    "SpeedOverLife",
    "SpringFamily",
    "Springs",
    "SpriteStyle",
    "TriangleMesh",
    "TriangleMeshCollider",
    "Uniform",
    "UniformGrid",
    "Vortex",
    "Water",
    "Wind",
    "add_ragdoll",
    "check_finite",
    "colliders",
    "constrain",
    "fluids",
    "geometry",
    "gridfluid",
    "io",
    "load_scene",
    "render",
    "rigid",
    "scene",
    "shapes",
    "spatial",
]
