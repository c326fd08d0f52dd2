"""GridFluid: Stam's stable fluids on a staggered grid, in 2D and 3D.

One step (Stam 1999; Fedkiw, Stam & Jensen 2001; Bridson 2015, ch. 2-5):

1. obstacles: colliders rasterised into solid cells (again only when they moved);
2. sources: density, heat and velocity injected;
3. advection: density, temperature and the velocity itself carried by the velocity of
   the step's start (semi-Lagrangian, MacCormack or BFECC);
4. forces: buoyancy, vorticity confinement;
5. viscosity, implicit (backward Euler), when ``viscosity > 0``;
6. projection: walls and solids set the faces the flow may not cross, then the
   pressure that removes the divergence is solved (multigrid-preconditioned conjugate
   gradients, :mod:`.pressure`) and its gradient subtracted;
7. dissipation.

A 2D fluid is a 3D one a single cell thick whose z velocity stays 0: every kernel is the
same, and the z faces are closed walls.

Arrays are indexed ``[k, j, i]`` (z, y, x), x fastest, like an image's rows: a 2D
fluid's density is ``density[0]``, shape (ny, nx), row 0 at the bottom (y = origin).
"""

from __future__ import annotations

import math

import numpy as np

from .. import _validate as check
from .._jit import threads_for
from . import advect_kernels as adv
from . import face_kernels as faces
from .model import (
    Advection,
    Buoyancy,
    Dissipation,
    Solver,
    packed_walls,
    walls_from,
)
from .obstacles import Obstacles
from .pressure import PoissonSolver, SolveReport
from .viscosity import Diffusion

#: Grids of fewer cells step on one thread: a step launches ~100 parallel loops, and a
#: launch costs 0.02-0.2 ms (more while other processes load the cores), more than
#: the work of a 128² grid's loop.
SERIAL_BELOW = 65536

#: Lattice offsets (x, y, z) of cell centres and of the x, y, z faces, in cells.
CENTRE = (0.5, 0.5, 0.5)
FACE_OFFSETS = ((0.0, 0.5, 0.5), (0.5, 0.0, 0.5), (0.5, 0.5, 0.0))


class GridFluid:
    """A gas (smoke, fire, air) on a staggered grid: velocity on cell faces, density and
    temperature at cell centres.

    Parameters
    ----------
    resolution : (nx, ny) or (nx, ny, nz) ints
        Cells per axis, each >= 2 (a pair: a 2D fluid in the xy plane).
    cell_size : float
        Edge of a cell ``h`` [m], > 0.
    origin : (3,) floats
        The domain's lower corner [m]; it spans ``origin + resolution * h``.
    advection : Advection or str
        ``"maccormack"`` (default), ``"bfecc"`` or ``"semi-lagrangian"``.
    viscosity : float
        Kinematic viscosity ``nu`` [m²/s], >= 0 (0: none, and no solve).
    vorticity : float
        Vorticity confinement strength ``epsilon`` [-], >= 0 (Fedkiw et al. 2001).
    buoyancy : Buoyancy, optional
    dissipation : Dissipation, optional
    walls : mapping, optional
        Side (``"-x"``, ``"+x"``, ``"-y"``, ``"+y"``, ``"-z"``, ``"+z"``) to a
        :class:`~motes.gridfluid.model.Wall` or ``"open"``, ``"closed"``, ``"no-slip"``;
        sides left out are closed walls with slip.
    obstacles : sequence of colliders
        Colliders (planes, spheres, boxes, capsules) the flow goes around; a moving one
        pushes the flow.
    solver : Solver, optional
        Tolerances of the pressure and viscosity solves.

    Examples
    --------
    >>> import motes as mo
    >>> smoke = mo.GridFluid((32, 48), 0.05, buoyancy=mo.Buoyancy(heat_weight=0.02),
    ...                      walls={"+y": "open"})
    >>> _ = smoke.add(mo.GridSource((0.8, 0.3, 0.025), 0.2, density=2.0, temperature=600))
    >>> for _ in range(20):
    ...     smoke.step(1 / 30)
    >>> smoke.density.shape, bool(smoke.v.max() > 0.1)
    ((1, 48, 32), True)
    """

    def __init__(
        self,
        resolution,
        cell_size: float,
        *,
        origin=(0.0, 0.0, 0.0),
        advection: Advection | str = Advection.MACCORMACK,
        viscosity: float = 0.0,
        vorticity: float = 0.0,
        buoyancy: Buoyancy | None = None,
        dissipation: Dissipation | None = None,
        walls=None,
        obstacles=(),
        solver: Solver | None = None,
    ):
        resolution = tuple(resolution)
        if len(resolution) not in (2, 3):
            raise ValueError(f"resolution must be (nx, ny) or (nx, ny, nz), got {resolution!r}")
        res = [check.integer(f"resolution[{a}]", n, low=2) for a, n in enumerate(resolution)]
        self.dimensions = len(res)
        nx, ny, nz = (*res, 1) if self.dimensions == 2 else res
        self.cell_size = check.positive("cell_size", cell_size)
        self.origin = check.vector("origin", origin)
        try:
            self.advection = Advection(advection)
        except ValueError:
            allowed = [a.value for a in Advection]
            raise ValueError(f"advection must be one of {allowed}, got {advection!r}") from None
        self.viscosity = check.non_negative("viscosity", viscosity)
        self.vorticity = check.non_negative("vorticity", vorticity)
        self.buoyancy = Buoyancy() if buoyancy is None else buoyancy
        self.dissipation = Dissipation() if dissipation is None else dissipation
        self.solver_options = Solver() if solver is None else solver
        for name, value, kind in (
            ("buoyancy", self.buoyancy, Buoyancy),
            ("dissipation", self.dissipation, Dissipation),
            ("solver", self.solver_options, Solver),
        ):
            if not isinstance(value, kind):
                raise TypeError(f"{name} must be a {kind.__name__}, got {value!r}")
        walls = dict(walls or {})
        if self.dimensions == 2:
            for side in ("-z", "+z"):
                if side in walls:
                    raise ValueError(f"walls.{side}: a 2D fluid has no z walls")
        self.walls = walls_from(walls)
        self.open_faces, self.no_slip, self.wall_velocity = packed_walls(self.walls)
        self.obstacles = Obstacles(obstacles)
        self.sources: list = []

        cells = (nz, ny, nx)
        self.scalars = np.zeros((2, *cells), np.float32)
        self.scalars[1] = self.buoyancy.ambient
        self.u = np.zeros((nz, ny, nx + 1), np.float32)
        self.v = np.zeros((nz, ny + 1, nx), np.float32)
        self.w = np.zeros((nz + 1, ny, nx), np.float32)
        self.solid = np.zeros(cells, np.uint8)
        self.solid_velocity = np.zeros((3, *cells), np.float32)
        self._q = np.zeros(cells, np.float32)
        self._b = np.zeros(cells, np.float32)
        self._pressure = PoissonSolver(
            self.solid, self.open_faces, tolerance=self.solver_options.tolerance,
            max_iterations=self.solver_options.max_iterations,
        )  # fmt: skip
        self._diffusion = [
            Diffusion(f.shape, a, tolerance=self.solver_options.viscosity_tolerance)
            for a, f in enumerate(self.velocity_grids)
        ]
        for diffusion in self._diffusion:
            diffusion.set_solid(self.solid)
        self._scratch = _Scratch(cells, self.velocity_grids)
        self.time = 0.0
        self.steps = 0
        #: What the last pressure solve did (:class:`~motes.gridfluid.pressure.SolveReport`).
        self.last_solve = SolveReport(0, 0.0, True)
        #: Iterations of the last viscosity solve, per component.
        self.last_viscosity_iterations = (0, 0, 0)
        self._update_obstacles(0.0)

    # -- views -------------------------------------------------------------------------

    @property
    def resolution(self) -> tuple[int, ...]:
        """Cells per axis, (nx, ny) or (nx, ny, nz)."""
        nz, ny, nx = self.solid.shape
        return (nx, ny) if self.dimensions == 2 else (nx, ny, nz)

    @property
    def density(self) -> np.ndarray:
        """Smoke density [-] at cell centres, (nz, ny, nx) float32 (a view)."""
        return self.scalars[0]

    @property
    def temperature(self) -> np.ndarray:
        """Temperature [K] at cell centres, (nz, ny, nx) float32 (a view)."""
        return self.scalars[1]

    @property
    def velocity_grids(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The face velocities [m/s]: u (nz, ny, nx + 1), v (nz, ny + 1, nx), w (nz + 1,
        ny, nx)."""
        return self.u, self.v, self.w

    @property
    def pressure(self) -> np.ndarray:
        """Kinematic pressure ``p / rho`` [m²/s²] of the last step's projection at cell
        centres, (nz, ny, nx)."""
        return self._q * (self.cell_size / self._last_dt) if self.steps else self._q * 0.0

    def cell_centers(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """World coordinates [m] of cell centres along x, y and z (1D arrays)."""
        nz, ny, nx = self.solid.shape
        h = self.cell_size
        return tuple(self.origin[a] + (np.arange(n) + 0.5) * h for a, n in enumerate((nx, ny, nz)))

    def velocity_at(self, positions) -> np.ndarray:
        """Velocity [m/s] at world ``positions`` (3, n), trilinear on the staggered grid,
        clamped to the domain; (3, n) float32."""
        positions = np.ascontiguousarray(positions, dtype=np.float32)
        if positions.ndim != 2 or positions.shape[0] != 3:
            raise ValueError(f"positions must have shape (3, n), got {positions.shape}")
        out = np.empty_like(positions)
        adv.sample_velocity(
            self.u, self.v, self.w, self.origin.astype(np.float32),
            np.float32(1.0 / self.cell_size), positions, out,
        )  # fmt: skip
        return out

    def divergence(self) -> np.ndarray:
        """Divergence of the velocity [1/s] at fluid cells (0 in solids), (nz, ny, nx)."""
        out = np.empty_like(self._b)
        faces.divergence(self.u, self.v, self.w, self.solid, out)
        return out / self.cell_size

    # -- building ----------------------------------------------------------------------

    def add(self, *sources) -> GridFluid:
        """Add sources (anything with ``apply(fluid, dt)``); returns the fluid."""
        for source in sources:
            if not callable(getattr(source, "apply", None)):
                raise TypeError(f"a grid fluid source needs apply(fluid, dt), got {source!r}")
            self.sources.append(source)
        return self

    # -- stepping ----------------------------------------------------------------------

    def step(self, dt: float) -> None:
        """Advance by ``dt`` [s] (> 0)."""
        dt = check.positive("dt", dt)
        with threads_for(self.solid.size, SERIAL_BELOW):
            self._step(dt)

    def _step(self, dt: float) -> None:
        self._update_obstacles(dt)
        for source in self.sources:
            source.apply(self, dt)
        self._advect(dt)
        if self.obstacles.colliders:
            faces.clear_solids(self.scalars, self.solid, np.array([0.0, self.buoyancy.ambient]))
        self._add_forces(dt)
        if self.viscosity > 0.0:
            alpha = self.viscosity * dt / self.cell_size**2
            self.last_viscosity_iterations = tuple(
                diffusion.solve(face, alpha, self.open_faces, self.no_slip, self.wall_velocity)
                for diffusion, face in zip(self._diffusion, self.velocity_grids, strict=True)
            )
        self.project()
        self._dissipate(dt)
        self._last_dt = dt
        self.time += dt
        self.steps += 1

    def project(self) -> SolveReport:
        """Make the velocity divergence-free (walls and solids set first)."""
        self._enforce_boundaries()
        faces.divergence(self.u, self.v, self.w, self.solid, self._b)
        np.negative(self._b, out=self._b)
        self.last_solve = self._pressure.solve(self._b, self._q)
        if not math.isfinite(self.last_solve.residual):
            raise FloatingPointError(
                f"grid fluid: the velocity holds NaN or infinity after step {self.steps} "
                f"(t = {self.time:g} s); check the sources' and obstacles' values"
            )
        for axis, face in enumerate(self.velocity_grids):
            faces.subtract_gradient(face, axis, self._q, self.solid, self.open_faces)
        return self.last_solve

    def _update_obstacles(self, dt: float) -> None:
        if not self.obstacles.colliders:
            return
        h = self.cell_size
        if self.obstacles.rasterise(self.origin, h, dt, self.solid, self.solid_velocity):
            self._pressure.set_solid(self.solid)
            for diffusion in self._diffusion:
                diffusion.set_solid(self.solid)

    def _enforce_boundaries(self) -> None:
        for axis, face in enumerate(self.velocity_grids):
            faces.enforce_boundaries(
                face, axis, self.solid, self.solid_velocity, self.open_faces, self.wall_velocity
            )
        if self.dimensions == 2:
            self.w[...] = 0.0

    def _advect(self, dt: float) -> None:
        scale = dt / self.cell_size
        u, v, w = self.velocity_grids
        s = self._scratch
        new_scalars = s.scalars_out
        self._carry(self.scalars, CENTRE, u, v, w, scale, s.scalar_work, new_scalars)
        moved = []
        for axis, face in enumerate(self.velocity_grids):
            out = s.faces_out[axis]
            self._carry(
                face[None], FACE_OFFSETS[axis], u, v, w, scale, s.face_work(face.shape), out
            )
            moved.append(out)
        for axis, out in enumerate(moved):
            self.velocity_grids[axis][...] = out[0]
        self.scalars[...] = new_scalars

    def _carry(self, fields, offset, u, v, w, scale, work, out) -> None:
        """Advect ``fields`` (c, ...) on the lattice at ``offset`` into ``out``."""
        ox, oy, oz = offset
        forward, lo, hi = work
        if self.advection is Advection.SEMI_LAGRANGIAN:
            adv.advect_semi_lagrangian(fields, ox, oy, oz, u, v, w, scale, out)
        elif self.advection is Advection.MACCORMACK:
            adv.advect_forward(fields, ox, oy, oz, u, v, w, scale, forward, lo, hi)
            adv.maccormack_correct(fields, forward, ox, oy, oz, u, v, w, scale, lo, hi, out)
        else:
            adv.advect_semi_lagrangian(fields, ox, oy, oz, u, v, w, scale, forward)
            adv.bfecc_estimate(fields, forward, ox, oy, oz, u, v, w, scale, out)
            adv.advect_forward(out, ox, oy, oz, u, v, w, scale, forward, lo, hi)
            out[...] = forward
            adv.clamp_to(out, lo, hi)

    def _add_forces(self, dt: float) -> None:
        s = self._scratch
        if self.buoyancy.active:
            b = self.buoyancy
            accel = s.cell_work[0]
            faces.buoyancy(self.scalars, b.density_weight, b.heat_weight, b.ambient, accel)
            for axis, face in enumerate(self.velocity_grids):
                if b.up[axis] != 0.0:
                    faces.add_cell_force(face, axis, accel, dt * b.up[axis], self.solid)
        if self.vorticity > 0.0:
            faces.cell_velocity(self.u, self.v, self.w, s.cell_work[:3])
            faces.vorticity(s.cell_work[:3], 1.0 / self.cell_size, s.omega)
            faces.confinement(s.omega, self.vorticity, self.cell_size, s.cell_work[:3])
            for axis, face in enumerate(self.velocity_grids):
                faces.add_cell_force(face, axis, s.cell_work[axis], dt, self.solid)

    def _dissipate(self, dt: float) -> None:
        d = self.dissipation
        if d.density or d.temperature:
            factor = np.exp(-dt * np.array([d.density, d.temperature]))
            target = np.array([0.0, self.buoyancy.ambient])
            faces.decay(self.scalars, factor, target)
        if d.velocity:
            keep = np.float32(np.exp(-dt * d.velocity))
            for face in self.velocity_grids:
                face *= keep


class _Scratch:
    """Work arrays of a step, allocated once."""

    def __init__(self, cells, grids):
        self.scalars_out = np.empty((2, *cells), np.float32)
        self.scalar_work = tuple(np.empty((2, *cells), np.float32) for _ in range(3))
        size = max(g.size for g in grids)
        self._flat = tuple(np.empty(size, np.float32) for _ in range(3))
        self.faces_out = tuple(np.empty((1, *g.shape), np.float32) for g in grids)
        self.cell_work = np.empty((3, *cells), np.float32)
        self.omega = np.empty((4, *cells), np.float32)

    def face_work(self, shape) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Three (1, *shape) work arrays for advecting one face grid (shared by all)."""
        size = int(np.prod(shape))
        return tuple(a[:size].reshape(1, *shape) for a in self._flat)
