"""A position-based fluid: the state, and the step that orchestrates the kernels.

The solver is position-based fluids (Macklin & Müller 2013, "Position based fluids",
ACM TOG 32(4)): each step predicts positions under gravity, then a few Jacobi iterations
move particles so that every particle's density constraint ``ρ_i / ρ₀ = 1`` holds. It
stays stable at the large steps of a frame-driven scene (no sound-speed limit as in
weakly compressible SPH), and the density error is set by the iteration count.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import _jit, _memory, _validate
from ..collide.contact import Detection, project_contacts
from ..collide.contact import pack as pack_colliders
from ..collide.swept import sweep_contacts
from ..forces.apply import add_forces, check_force
from ..forces.base import Force
from ..spatial import UniformGrid, spatial_index
from ..spatial.index import sorted_neighbors
from ..spatial.kernels import permute_rows
from ..state import Field, ParticleState
from . import kernels
from .boundaries import MeshWall, pack
from .model import FluidModel

#: Memory per particle [bytes] of a liquid that steps (measured peak at 125,000 and
#: 512,000 particles: about 700 B): the state, the neighbour grid's fixed-capacity rows
#: and CSR lists, and the step's predicted positions, multipliers and corrections.
BYTES_PER_PARTICLE = 768


def check_memory(what: str, count: float) -> None:
    """Refuse, before allocating, a liquid of ``count`` particles that would not fit."""
    _memory.check(
        what, count * BYTES_PER_PARTICLE, per=f"about {BYTES_PER_PARTICLE} B per particle"
    )


#: A push-out radius [m] no particle is within: the correction kernel then pushes none.
_NO_PUSH = -1e30


@dataclass
class FluidState:
    """Per-particle arrays of a fluid, all in the solver's current (grid-sorted) order.

    Attributes
    ----------
    positions : ndarray, float32, shape (3, n)
        Positions [m].
    velocities : ndarray, float32, shape (3, n)
        Velocities [m/s].
    phase : ndarray, int32, shape (n,)
        Index into ``FluidModel.phases``.
    ids : ndarray, int64, shape (n,)
        The particle's index at creation (the solver reorders particles every step).
    density : ndarray, float32, shape (n,)
        Density [kg/m³] at the last constraint iteration (walls included).
    pressure : ndarray, float32, shape (n,)
        Pressure [Pa] implied by the step's position corrections:
        ``p_i = -κ ρ₀ Σ_iterations λ_i / Δt²``, with ``κ`` the discrete gradient's
        response to a linear field (0.947 at ``h`` = 2 spacings; 1 in the continuum).
    """

    positions: np.ndarray
    velocities: np.ndarray
    phase: np.ndarray
    ids: np.ndarray
    density: np.ndarray
    pressure: np.ndarray

    def permute(self, order: np.ndarray) -> None:
        """Reorder every array so that new particle ``k`` is old particle ``order[k]``."""
        self.positions = _permuted(self.positions, order)
        self.velocities = _permuted(self.velocities, order)
        self.phase = _permuted(self.phase, order)
        self.ids = _permuted(self.ids, order)
        self.density = _permuted(self.density, order)
        self.pressure = _permuted(self.pressure, order)


def _permuted(values: np.ndarray, order: np.ndarray) -> np.ndarray:
    """A new C array, ``values[..., order]`` of a (c, n) or (n,) array, in parallel."""
    out = np.empty(values.shape, values.dtype)
    source = np.ascontiguousarray(values)
    if values.ndim == 1:
        permute_rows(source[None], order, out[None])
    else:
        permute_rows(source, order, out)
    return out


def lattice_cells(lower, upper, spacing: float) -> np.ndarray:
    """Particles along x, y and z of :func:`lattice`'s box, as floats (3,).

    Floats, so that a tiny spacing in a large box gives a large (or infinite) count
    rather than an overflowed integer: callers compare ``prod`` with a limit before
    allocating.
    """
    lower = _validate.vector("lower", lower)
    upper = _validate.vector("upper", upper)
    spacing = _validate.positive("spacing", spacing)
    with np.errstate(over="ignore"):
        return np.maximum(np.floor((upper - lower) / spacing + 1e-6), 0.0)


def lattice(lower, upper, spacing: float) -> np.ndarray:
    """Particles on a cubic lattice filling the box ``[lower, upper]`` [m], shape (3, n).

    Cells of ``spacing`` tile the box from ``lower``; a particle sits at each cell's
    centre, so a block against a wall starts half a spacing from it.
    """
    cells = lattice_cells(lower, upper, spacing)
    lower, upper = np.asarray(lower, np.float64), np.asarray(upper, np.float64)
    if np.any(cells < 1):
        raise ValueError(f"the box {lower.tolist()}-{upper.tolist()} holds no particle")
    with np.errstate(over="ignore"):
        total = float(np.prod(cells))
    if total > np.iinfo(np.int64).max:
        raise ValueError(f"the box {lower.tolist()}-{upper.tolist()} holds {total:.3g} particles")
    check_memory(f"spacing = {spacing:g} ({total:.0f} particles in the box)", total)
    counts = cells.astype(np.int64)
    axes = [lower[a] + (np.arange(counts[a]) + 0.5) * spacing for a in range(3)]
    grid = np.meshgrid(*axes, indexing="ij")
    return np.stack([g.ravel() for g in grid]).astype(np.float32)


class Fluid:
    """A liquid of particles under a :class:`FluidModel`.

    Parameters
    ----------
    model : FluidModel
        The parameters.
    positions : array, shape (3, n)
        Initial positions [m] (see :func:`lattice`).
    velocities : array, shape (3, n), optional
        Initial velocities [m/s]; zero by default.
    phase : array of int, shape (n,), optional
        Phase of each particle; 0 by default.
    forces : sequence of Force or FieldForce
        Forces besides the model's gravity (curl noise, vortices, radial fields,
        callbacks, drag...), evaluated every step; see :meth:`add_force`.

    Examples
    --------
    >>> from motes.fluids import FluidModel, Tank, lattice
    >>> model = FluidModel(spacing=0.05, boundaries=(Tank((0, 0, 0), (0.5, 1, 0.5)),))
    >>> water = Fluid(model, lattice((0, 0, 0), (0.25, 0.25, 0.25), 0.05))
    >>> water.step(1 / 60)
    >>> len(water)
    125
    """

    def __init__(self, model: FluidModel, positions, *, velocities=None, phase=None, forces=()):
        if not isinstance(model, FluidModel):
            raise TypeError(f"model must be a FluidModel, got {type(model).__name__}")
        self.model = model
        pos = np.asarray(positions, dtype=np.float64)
        if pos.ndim != 2 or pos.shape[0] != 3:
            raise ValueError(f"positions must have shape (3, n), got shape {pos.shape}")
        if not np.all(np.isfinite(pos)):
            raise ValueError("positions must be finite (no NaN or inf)")
        n = pos.shape[1]
        check_memory(f"positions ({n} particles)", n)
        vel = np.zeros((3, n)) if velocities is None else np.asarray(velocities, np.float64)
        if vel.shape != (3, n) or not np.all(np.isfinite(vel)):
            raise ValueError(f"velocities must be finite with shape (3, {n})")
        ph = np.zeros(n, np.int32) if phase is None else np.asarray(phase)
        if ph.shape != (n,) or not np.issubdtype(ph.dtype, np.integer):
            raise ValueError(f"phase must be integers with shape ({n},)")
        if n and (ph.min() < 0 or ph.max() >= len(model.phases)):
            raise ValueError(f"phase must be in [0, {len(model.phases) - 1}]")
        self.state = FluidState(
            pos.astype(np.float32),
            vel.astype(np.float32),
            ph.astype(np.int32),
            np.arange(n, dtype=np.int64),
            np.zeros(n, np.float32),
            np.zeros(n, np.float32),
        )
        d = model.derived
        self._index = (
            UniformGrid(d["h"], capacity=96)
            if model.structure == "grid"
            else spatial_index(model.structure)
        )
        self.time = 0.0
        #: Forces besides gravity (:meth:`add_force`).
        self.forces = []
        for force in forces:
            self.add_force(force)
        #: Mean relative compression ``mean(max(ρ/ρ₀ - 1, 0))`` at the last iteration of
        #: the last step (measured before that iteration's correction).
        self.density_error = 0.0
        #: :class:`~motes.fluids.reaction.WallReaction` objects told of every step.
        self.reactions: list = []

    def add_reaction(self, reaction) -> None:
        """Report, after each step, what the liquid gave to some of its walls (a
        :class:`~motes.fluids.reaction.WallReaction`): how moving bodies feel it."""
        from .reaction import WallReaction

        if not isinstance(reaction, WallReaction):
            raise TypeError(f"reaction must be a WallReaction, got {type(reaction).__name__}")
        self.reactions.append(reaction)

    def __len__(self) -> int:
        return self.state.positions.shape[1]

    def add(self, positions, *, velocities=None, phase: int = 0) -> None:
        """Append particles (an emitter): ``positions`` (3, k) [m], ``velocities`` (3, k)
        [m/s] (zero by default), all of one ``phase``."""
        pos = np.asarray(positions, dtype=np.float64)
        if pos.ndim != 2 or pos.shape[0] != 3 or not np.all(np.isfinite(pos)):
            raise ValueError(f"positions must be finite with shape (3, k), got {pos.shape}")
        k = pos.shape[1]
        vel = np.zeros((3, k)) if velocities is None else np.asarray(velocities, np.float64)
        if vel.shape != (3, k) or not np.all(np.isfinite(vel)):
            raise ValueError(f"velocities must be finite with shape (3, {k})")
        if not 0 <= phase < len(self.model.phases):
            raise ValueError(f"phase must be in [0, {len(self.model.phases) - 1}], got {phase}")
        s = self.state
        first = int(s.ids.max()) + 1 if len(self) else 0
        s.positions = np.concatenate([s.positions, pos.astype(np.float32)], axis=1)
        s.velocities = np.concatenate([s.velocities, vel.astype(np.float32)], axis=1)
        s.phase = np.concatenate([s.phase, np.full(k, phase, np.int32)])
        s.ids = np.concatenate([s.ids, np.arange(first, first + k, dtype=np.int64)])
        rho = np.float32(self.model.phases[phase].rest_density)
        s.density = np.concatenate([s.density, np.full(k, rho, np.float32)])
        s.pressure = np.concatenate([s.pressure, np.zeros(k, np.float32)])

    # -- what users read -----------------------------------------------------------------
    @property
    def positions(self) -> np.ndarray:
        """Positions [m], shape (3, n), in the solver's current order (see ``ids``)."""
        return self.state.positions

    @property
    def velocities(self) -> np.ndarray:
        """Velocities [m/s], shape (3, n)."""
        return self.state.velocities

    @property
    def masses(self) -> np.ndarray:
        """Particle masses [kg], float64, shape (n,): ``ρ₀(phase) spacing³``."""
        return self.model.derived["mass"][self.state.phase]

    def particle_state(self) -> ParticleState:
        """The particles as a :class:`~motes.state.ParticleState`, in the solver's order.

        ``ids``, ``positions`` and ``velocities`` are the solver's arrays (a step
        replaces them: take a new state after it); ``radius`` is half the spacing [m],
        the distance kept from walls. Fields: ``phase`` (int32, index into
        ``model.phases``), ``density`` [kg/m³] and ``pressure`` [Pa] (views, see
        :class:`FluidState`) and ``mass`` [kg] (computed, float64).
        """
        s = self.state
        radius = np.full(len(self), 0.5 * self.model.spacing, np.float32)
        fields = {
            "phase": Field(s.phase, "", "index into FluidModel.phases"),
            "density": Field(s.density, "kg/m³", "density at the last constraint iteration"),
            "pressure": Field(s.pressure, "Pa", "pressure implied by the step's corrections"),
            "mass": Field(self.masses, "kg", "particle mass"),
        }
        return ParticleState(s.ids, s.positions, s.velocities, radius, fields)

    def total_mass(self) -> float:
        """Total mass [kg]."""
        return float(self.masses.sum())

    def momentum(self) -> np.ndarray:
        """Total momentum [kg m/s], float64, shape (3,)."""
        return (self.state.velocities.astype(np.float64) * self.masses).sum(axis=1)

    # -- stepping ----------------------------------------------------------------------
    def add_force(self, force):
        """Make ``force`` (a :class:`~motes.forces.Force` or ``FieldForce``) act from the
        next step on; returns it.

        Each (internal) step evaluates the forces at the start-of-step state and adds
        ``dt F / m`` to the velocities with gravity, before positions are predicted, so
        the density constraints and walls then act on the pushed liquid. Forces that hold
        particle indices (springs) are refused: the solver reorders its particles every
        step.
        """
        check_force(force)
        # Forces holding particle indices are the ones that override ``remap``.
        if isinstance(force, Force) and type(force).remap is not Force.remap:
            raise TypeError(
                f"{type(force).__name__} joins particles by index, and a fluid reorders "
                "its particles every step"
            )
        self.forces.append(force)
        return force

    def _force_acceleration(self) -> np.ndarray:
        """Acceleration [m/s²] of :attr:`forces`, float32 (3, n), at the current state."""
        s, masses = self.state, self.masses
        force = add_forces(self.forces, s.positions, s.velocities, masses, self.time)
        return (force / masses).astype(np.float32)

    def step(self, dt: float) -> None:
        """Advance by ``dt`` [s], in equal internal steps no longer than ``max_dt``."""
        dt = _validate.positive("dt", dt)
        count = max(1, math.ceil(dt / self.model.max_dt - 1e-9))
        for reaction in self.reactions:
            reaction.start()
        with _jit.threads_for(len(self)):
            for _ in range(count):
                self._step(dt / count)

    def _step(self, dt: float) -> None:
        m, d, s = self.model, self.model.derived, self.state
        n = len(self)
        if n == 0:
            self.time += dt
            return
        rows = pack(m.boundaries)
        for reaction in self.reactions:
            reaction.begin(m.boundaries, rows)
        h, radius = d["h"], 0.5 * m.spacing
        g = np.asarray(m.gravity, np.float32)[:, None]
        if self.forces:
            g = g + self._force_acceleration()
        s.velocities += np.float32(dt) * g
        predicted = s.positions + np.float32(dt) * s.velocities
        if not np.isfinite(predicted).all():
            raise FloatingPointError(
                f"the fluid's state is not finite at t = {self.time:.6g} s: a step diverged "
                "(lower max_dt, viscosity or cohesion) or non-finite values were written "
                "into positions or velocities"
            )
        depth = np.zeros(n, np.float32)
        for reaction in self.reactions:
            reaction.pushed(predicted, radius, d["mass"][s.phase])
        kernels.project(*predicted, rows, radius, depth)

        # Sort into the structure's order: neighbours then sit in nearby memory.
        begin, end, nbr, order = sorted_neighbors(self._index, predicted, h)
        s.permute(order)
        predicted = _permuted(predicted, order)
        depth = _permuted(depth, order)

        weight = d["weight"][s.phase].astype(np.float32)
        delta = np.empty(n, np.float32)
        lam = np.empty(n, np.float32)
        lam_sum = np.zeros(n, np.float32)
        spare = np.empty((3, n), np.float32)
        wall_gradient = np.empty((3, n))
        inv_delta0 = 1.0 / d["delta0"]
        for _ in range(m.iterations):
            kernels.density_lambda(
                *predicted, begin, end, nbr, weight, rows, h, m.spacing, d["wall_scale"],
                inv_delta0, d["eps"], delta, lam, wall_gradient,
            )  # fmt: skip
            # With reacting walls the push-out runs as its own pass, so that what it
            # moves can be counted (same result: each particle's push is its own).
            reacting = bool(self.reactions)
            kernels.correction(
                *predicted, begin, end, nbr, weight, lam, rows, h, wall_gradient, inv_delta0,
                d["tensile_k"], d["inv_wq"], _NO_PUSH if reacting else radius, spare,
            )  # fmt: skip
            if reacting:
                masses = d["mass"][s.phase]
                for reaction in self.reactions:
                    reaction.corrected(
                        predicted, spare, lam, weight, masses, radius, h, m.spacing,
                        d["wall_scale"],
                    )  # fmt: skip
                kernels.project(*spare, rows, radius, np.empty(n, np.float32))
            predicted, spare = spare, predicted
            lam_sum += lam
        rho0 = np.float32(m.phases[0].rest_density)
        s.density = (
            delta
            * np.float32(inv_delta0)
            * d["mass"][s.phase].astype(np.float32)
            / (np.float32(m.spacing**3))
        )
        s.pressure = lam_sum * np.float32(-rho0 * d["gradient_factor"] / (dt * dt))
        self.density_error = float(np.maximum(delta * inv_delta0 - 1.0, 0.0).mean())

        s.velocities = (predicted - s.positions) / np.float32(dt)
        start, s.positions = s.positions, predicted
        meshes = [w.collider for w in m.boundaries if isinstance(w, MeshWall)]
        if meshes:
            self._collide_meshes(meshes, start, dt, radius)
        masses = d["mass"][s.phase].astype(np.float32)
        sigma = d["sigma"]
        coefficients = np.array(
            [h, dt, m.xsph, m.viscosity, 1.0 / (2.0 * sigma * sigma), m.repulsion, d["delta0"]]
        )
        if m.vorticity > 0:
            omega = np.empty((3, n), np.float32)
            kernels.vorticity(*s.positions, *s.velocities, begin, end, nbr, delta, h, omega)
            confined = np.empty_like(s.velocities)
            kernels.confinement(
                *s.positions, *s.velocities, begin, end, nbr, delta, omega, h,
                dt * m.vorticity * m.spacing, confined,
            )  # fmt: skip
            s.velocities = confined
        normals = np.zeros((3, n), np.float32)
        if d["cohesion"].max() > 0:
            kernels.surface_normals(*s.positions, begin, end, nbr, s.phase, delta, h, normals)
        out = np.empty_like(s.velocities)
        kernels.exchange(
            *s.positions, *s.velocities, begin, end, nbr, s.phase, masses, delta, normals,
            d["cohesion"], coefficients, out,
        )  # fmt: skip
        s.velocities = out
        if rows.shape[0]:
            walls = np.array([h, radius, dt, m.phases[0].rest_density * m.spacing])
            kernels.boundary_velocity(*s.positions, *s.velocities, depth, rows, walls)
        for reaction in self.reactions:
            reaction.end(dt)
        self.time += dt

    def _collide_meshes(self, meshes, start, dt: float, radius: float) -> None:
        """Sweep each particle's path ``start -> position`` against the meshes, then
        project out what lies within ``radius``; touched particles take the velocity of
        their corrected travel (see :class:`~motes.fluids.boundaries.MeshWall`)."""
        s, n = self.state, len(self)
        table, tri, cell_start, cell_tris = pack_colliders(meshes, [Detection.PRIORI] * len(meshes))
        # The collision kernels run in float64 (as in rigid worlds): one compiled version.
        x = s.positions.astype(np.float64)
        q = start.astype(np.float64)
        hits = np.zeros(n, dtype=np.int64)
        data = (np.full(n, radius), np.ones(n), table, tri, cell_start, cell_tris, hits)
        sweep_contacts(*x, *q, *data)
        project_contacts(*x, *q, *data)
        touched = hits > 0
        s.positions[:, touched] = x[:, touched]
        s.velocities[:, touched] = (x[:, touched] - q[:, touched]) / dt
