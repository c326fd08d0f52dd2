"""The parameters of a grid fluid: walls, buoyancy, dissipation and the advection scheme."""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

import numpy as np

from .. import _validate as check

#: The faces of the domain, in the order kernels index them.
SIDES = ("-x", "+x", "-y", "+y", "-z", "+z")


class Advection(StrEnum):
    """How fields are carried by the flow."""

    #: Semi-Lagrangian back-tracing (Stam 1999): stable at any step, first order,
    #: diffusive.
    SEMI_LAGRANGIAN = "semi-lagrangian"
    #: Semi-Lagrangian with the MacCormack correction (Selle et al. 2008): second
    #: order, clamped to the values it interpolates. Two passes.
    MACCORMACK = "maccormack"
    #: Back and forth error compensation and correction (Kim et al. 2005): second
    #: order, clamped. Three passes.
    BFECC = "bfecc"


@dataclass(frozen=True)
class Wall:
    """One face of the domain.

    Parameters
    ----------
    open : bool
        Open: the flow leaves and enters freely (pressure 0 beyond it). Closed: the flow
        may not cross it.
    slip : bool
        A closed wall without slip holds the fluid beside it at its own velocity
        (felt through viscosity); with slip it exerts no shear.
    velocity : (3,) floats
        The wall's velocity [m/s] (a moving lid); its normal component must be 0 for
        the fluid to keep its volume.
    """

    open: bool = False
    slip: bool = True
    velocity: tuple = (0.0, 0.0, 0.0)

    def __post_init__(self):
        for name in ("open", "slip"):
            if not isinstance(getattr(self, name), bool):
                raise TypeError(f"wall {name} must be True or False, got {getattr(self, name)!r}")
        object.__setattr__(self, "velocity", tuple(check.vector("wall velocity", self.velocity)))


def walls_from(walls) -> tuple[Wall, ...]:
    """Six :class:`Wall` objects from a mapping ``{"-x": Wall | "open" | "closed" |
    "no-slip", ...}`` (sides left out are closed and slipping)."""
    if walls is None:
        walls = {}
    if not isinstance(walls, dict):
        raise TypeError(f"walls must be a mapping of side to Wall, got {walls!r}")
    unknown = set(walls) - set(SIDES)
    if unknown:
        raise ValueError(f"walls: unknown side(s) {sorted(unknown)}; the sides are {SIDES}")
    named = {
        "open": Wall(open=True),
        "closed": Wall(),
        "slip": Wall(),
        "no-slip": Wall(slip=False),
    }
    out = []
    for side in SIDES:
        wall = walls.get(side, Wall())
        if isinstance(wall, str):
            if wall not in named:
                raise ValueError(
                    f"walls.{side} must be one of {sorted(named)} or a Wall, got {wall!r}"
                )
            wall = named[wall]
        if not isinstance(wall, Wall):
            raise TypeError(f"walls.{side} must be a Wall or a name, got {wall!r}")
        out.append(wall)
    return tuple(out)


@dataclass(frozen=True)
class Buoyancy:
    """Buoyancy of hot, light gas (Fedkiw, Stam & Jensen 2001, eq. 8): an acceleration
    ``(-density_weight * density + heat_weight * (T - ambient)) * up``.

    Parameters
    ----------
    density_weight : float
        Sinking per unit density [m/s²], >= 0 (smoke's soot weighs it down).
    heat_weight : float
        Rise per kelvin above ambient [m/s²/K], >= 0.
    ambient : float
        Ambient temperature [K], > 0.
    up : (3,) floats
        The direction of rise (unit length after normalising).
    """

    density_weight: float = 0.0
    heat_weight: float = 0.0
    ambient: float = 293.0
    up: tuple = (0.0, 1.0, 0.0)

    def __post_init__(self):
        check.non_negative("buoyancy density_weight", self.density_weight)
        check.non_negative("buoyancy heat_weight", self.heat_weight)
        check.positive("buoyancy ambient", self.ambient)
        object.__setattr__(self, "up", tuple(check.unit_vector("buoyancy up", self.up)))

    @property
    def active(self) -> bool:
        return self.density_weight > 0.0 or self.heat_weight > 0.0


@dataclass(frozen=True)
class Dissipation:
    """Exponential decay rates [1/s], each >= 0: density fades (``density``),
    temperature cools toward ambient (``temperature``), velocity slows (``velocity``)."""

    density: float = 0.0
    temperature: float = 0.0
    velocity: float = 0.0

    def __post_init__(self):
        for name in ("density", "temperature", "velocity"):
            check.non_negative(f"dissipation {name}", getattr(self, name))


@dataclass(frozen=True)
class Solver:
    """Tolerances of the implicit parts.

    Parameters
    ----------
    tolerance : float
        Pressure: stop when the largest remaining divergence is at most this fraction of
        the largest divergence before projection, in (0, 1).
    max_iterations : int
        Pressure iterations at most (more is reported in ``GridFluid.last_solve``).
    viscosity_tolerance : float
        The same for the viscosity solve.
    """

    tolerance: float = 1e-4
    max_iterations: int = 100
    viscosity_tolerance: float = 1e-6

    def __post_init__(self):
        check.real("solver tolerance", self.tolerance, low=0.0, high=1.0, low_open=True)
        check.integer("solver max_iterations", self.max_iterations, low=1)
        check.real(
            "solver viscosity_tolerance", self.viscosity_tolerance, low=0.0, high=1.0, low_open=True
        )


def packed_walls(walls: tuple[Wall, ...]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``open_faces`` (6,) uint8, ``no_slip`` (6,) uint8 and ``wall_velocity`` (6, 3)
    float32, the kernels' form of six walls."""
    open_faces = np.array([w.open for w in walls], np.uint8)
    no_slip = np.array([not w.slip for w in walls], np.uint8)
    velocity = np.array([w.velocity for w in walls], np.float32)
    return open_faces, no_slip, velocity
