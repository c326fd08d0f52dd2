"""Parameters of a fluid (the model), validated once, and the derived constants."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .. import _validate
from ..spatial.index import STRUCTURES
from . import boundaries as _boundaries
from .sph import SPIKY_GRAD, lattice_number_density, wall_scale


@dataclass(frozen=True)
class Phase:
    """One liquid of a fluid: its rest density and its cohesion.

    Attributes
    ----------
    rest_density : float
        Density at rest [kg/m³], > 0.
    cohesion : float
        Surface tension coefficient γ of Akinci, Akinci & Teschner 2013 (eq. 1)
        [m⁶/(kg s²)], >= 0; acts between particles of this phase only.
    """

    rest_density: float = 1000.0
    cohesion: float = 0.0

    def __post_init__(self):
        _validate.positive("rest_density", self.rest_density)
        _validate.non_negative("cohesion", self.cohesion)


@dataclass(frozen=True)
class FluidModel:
    """What stays fixed while a fluid runs: resolution, solver settings, forces, walls.

    Attributes
    ----------
    spacing : float
        Particle spacing at rest [m]; a particle stands for ``spacing³`` of liquid and
        is kept ``spacing / 2`` from walls.
    phases : tuple of Phase
        The liquids (particles carry a phase index). Different phases do not mix when
        ``repulsion`` > 0.
    kernel_ratio : float
        Kernel support ``h = kernel_ratio * spacing``, in [1.5, 4]; 2 gives about 33
        neighbours.
    iterations : int
        Density-constraint iterations per step (Macklin & Müller 2013 use 2-4), >= 1.
    gravity : sequence of 3 floats
        Acceleration [m/s²].
    xsph : float
        XSPH velocity smoothing c (Macklin & Müller 2013, eq. 17) in [0, 1].
    viscosity : float
        k [1/s] of the pairwise momentum exchange ``k G(d) Δt (m_j v_j - m_i v_i)``,
        >= 0 (the Gaussian ``G`` has width ``viscosity_width``). The exchange is
        explicit: ``k · max_dt · Σ_j G`` over a rest neighbourhood must stay <= 1,
        checked here (``k <= 22.5 /s`` at the default step and width).
    viscosity_width : float or None
        σ of the Gaussian [m]; None: one spacing.
    repulsion : float
        Acceleration scale pushing particles of different phases apart [m/s²], >= 0.
    tensile : float
        Macklin & Müller's artificial pressure ``k`` as a fraction of the interior
        constraint scale, >= 0 (0 turns it off).
    vorticity : float
        Vorticity confinement ε [1/s] (Fedkiw, Stam & Jensen 2001, as Macklin & Müller
        2013, eq. 16): each step adds ``Δt ε spacing (N × ω)`` to a particle's velocity,
        ``N`` the unit vector toward stronger vorticity; it puts back the swirl that
        the solver's numerical damping takes out. >= 0; 0 (the default) turns it off.
        It is a force field, not a pairwise exchange: momentum is not conserved.
    relaxation : float
        Constraint force mixing ε as a fraction of the interior ``Σ|∇C|²``, > 0.
    max_dt : float
        Longest internal step [s]; ``Fluid.step(dt)`` splits longer steps.
    boundaries : tuple
        ``Plane``, ``Tank``, ``Box``, ``Sphere`` objects.
    structure : {"grid", "octree", "kdtree"}
        Where neighbours are found each step (:func:`motes.spatial.spatial_index`); the
        particles are kept in its order. The grid (default) is the fastest for a liquid's
        evenly spread particles (``docs/spatial.md``); a tree suits a spray that flies
        far from its pool (the grid's cells grow with the spread).
    """

    spacing: float
    phases: tuple = (Phase(),)
    kernel_ratio: float = 2.0
    iterations: int = 4
    gravity: tuple = (0.0, -9.81, 0.0)
    xsph: float = 0.01
    viscosity: float = 0.0
    viscosity_width: float | None = None
    repulsion: float = 0.0
    tensile: float = 0.0
    vorticity: float = 0.0
    relaxation: float = 0.01
    max_dt: float = 1.0 / 240.0
    boundaries: tuple = ()
    structure: str = "grid"
    derived: dict = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        _validate.positive("spacing", self.spacing)
        phases = tuple(self.phases)
        if not phases or not all(isinstance(p, Phase) for p in phases):
            raise TypeError("phases must be a non-empty sequence of Phase")
        _validate.real("kernel_ratio", self.kernel_ratio, low=1.5, high=4.0)
        _validate.integer("iterations", self.iterations, low=1)
        _validate.vector("gravity", self.gravity)
        _validate.unit_interval("xsph", self.xsph)
        _validate.non_negative("viscosity", self.viscosity)
        if self.viscosity_width is not None:
            _validate.positive("viscosity_width", self.viscosity_width)
        _validate.non_negative("repulsion", self.repulsion)
        _validate.non_negative("tensile", self.tensile)
        _validate.non_negative("vorticity", self.vorticity)
        _validate.positive("relaxation", self.relaxation)
        _validate.positive("max_dt", self.max_dt)
        _validate.choice("structure", self.structure, STRUCTURES)
        walls = tuple(self.boundaries)
        for wall in walls:
            if not isinstance(wall, _boundaries.Boundary):
                raise TypeError(f"boundaries must hold Plane, Tank, Box or Sphere, got {wall!r}")
        object.__setattr__(self, "phases", phases)
        object.__setattr__(self, "boundaries", walls)
        object.__setattr__(self, "gravity", tuple(float(g) for g in self.gravity))
        object.__setattr__(self, "derived", self._derive())
        # The exchange is explicit: v_i gains k Δt Σ_j G(d_ij) (v_j - v_i), which
        # overshoots (and grows) once k Δt Σ G exceeds 1. Refuse such a viscosity here
        # instead of letting the liquid blow up.
        limit = 1.0 / (self.max_dt * self.derived["gaussian_sum"])
        if self.viscosity > limit:
            raise ValueError(
                f"viscosity must be <= {limit:.4g} 1/s at max_dt = {self.max_dt:g} s (the "
                f"explicit exchange is unstable beyond; lower max_dt), got {self.viscosity}"
            )

    @property
    def h(self) -> float:
        """Kernel support [m]."""
        return self.kernel_ratio * self.spacing

    def _derive(self) -> dict:
        s, h = self.spacing, self.kernel_ratio * self.spacing
        delta0 = lattice_number_density(s, h)
        # Σ_k |∇_k C|² for an interior particle of the rest lattice: the scale of the
        # constraint's denominator, which ε and the tensile k are fractions of.
        reach = math.ceil(h / s)
        k = np.arange(-reach, reach + 1) * s
        x, y, z = (a.ravel() for a in np.meshgrid(k, k, k, indexing="ij"))
        r = np.sqrt(x * x + y * y + z * z)
        # ∇W_spiky = scale · r⃗ (sph.spiky_gradient_scale, here in NumPy: calling the
        # compiled device function from Python would compile it in every process).
        safe = np.where(r > 0, r, 1.0)
        scale = np.where((r > 0) & (r <= h), SPIKY_GRAD / h**6 * (h - r) ** 2 / safe, 0.0)
        scale = scale / delta0
        own = (scale * x).sum() ** 2 + (scale * y).sum() ** 2 + (scale * z).sum() ** 2
        stiffness = float((scale * scale * r * r).sum() + own)
        # The discrete operator's response to a linear λ field, 1 in the continuum
        # (``Σ_j y_ij² |∇W_ij| / r_ij / δ₀`` over the lattice, 0.947 at h = 2 spacings):
        # the factor between the step's λ and the pressure that balances gravity.
        gradient_factor = float(-(scale * y * y).sum())
        sigma = self.viscosity_width if self.viscosity_width is not None else s
        near = (r > 0) & (r <= h)
        gaussian_sum = float(np.exp(-(r[near] ** 2) / (2 * sigma * sigma)).sum())
        densities = np.array([p.rest_density for p in self.phases])
        q = 0.2 * h  # Δq of Macklin & Müller 2013 (0.1-0.3 h)
        w_dq = 315.0 / (64.0 * math.pi * h**9) * (h * h - q * q) ** 3
        return {
            "h": h,
            "delta0": delta0,
            "wall_scale": wall_scale(s, h),
            "eps": self.relaxation * stiffness,
            "tensile_k": self.tensile / stiffness,
            "inv_wq": 1.0 / w_dq,
            "mass": densities * s**3,
            "weight": densities[0] / densities,
            "cohesion": np.array([p.cohesion for p in self.phases]),
            "gradient_factor": gradient_factor,
            "sigma": sigma,
            "gaussian_sum": gaussian_sum,
        }
