"""Grid and particles acting on each other.

- :class:`GridFlow`, a force on any particle kind: a drag toward the grid's velocity,
  ``F = m (u(x) - v) / tau``, so smoke sprites, embers and sparks ride the flow
  (``tau`` → 0: they move with it; larger: heavy particles lag and overshoot).
- :class:`ParticleSource`, a grid source: each particle of a system (or any kind) adds
  density and heat where it is and pulls the flow toward its own velocity, spread over
  the eight cells around it with trilinear weights (a burning ember heats the air it
  passes through; a burst of particles pushes the gas).
"""

from __future__ import annotations

import numpy as np
from numba import prange

from .. import _validate as check
from .._jit import block_bounds, block_count, parallel_kernel, serial_kernel
from ..forces.base import Force, check_buffers, particle_mass
from ..state import as_state
from .advect_kernels import velocity as grid_velocity


@parallel_kernel
def _flow_force(u, v, w, origin, inv_h, px, py, pz, vx, vy, vz, mass, inv_tau, ox, oy, oz):
    """``o += m (u(x) - v) / tau`` for each particle (``mass`` empty: 1 kg)."""
    n = px.shape[0]
    weighted = mass.shape[0] > 0
    for block in prange(block_count(n)):
        start, stop = block_bounds(block, n)
        for p in range(start, stop):
            gx, gy, gz = grid_velocity(
                u, v, w, (px[p] - origin[0]) * inv_h, (py[p] - origin[1]) * inv_h,
                (pz[p] - origin[2]) * inv_h,
            )  # fmt: skip
            k = (mass[p] if weighted else 1.0) * inv_tau
            ox[p] += k * (gx - vx[p])
            oy[p] += k * (gy - vy[p])
            oz[p] += k * (gz - vz[p])


class GridFlow(Force):
    """Drag toward a grid fluid's velocity: ``F = m (u(x) - v) / response_time``.

    Parameters
    ----------
    fluid : GridFluid
        The flow; outside its domain the velocity of its nearest boundary face.
    response_time : float
        ``tau`` [s], > 0: how fast a particle takes the flow's velocity (smoke: a few
        hundredths; embers: tenths).

    Examples
    --------
    >>> import motes as mo
    >>> air = mo.GridFluid((8, 8), 0.25)
    >>> air.u[...] = 1.0  # a uniform 1 m/s wind along x
    >>> dust = mo.ParticleSystem(100, seed=1)
    >>> _ = dust.add(mo.Emitter(mo.shapes.Point(), mo.PerFrame(10), speed=0.0, size=0.01))
    >>> _ = dust.add(mo.GridFlow(air, response_time=0.05))
    >>> for _ in range(30):
    ...     dust.step(1 / 60)
    >>> round(float(dust.particle_state().velocities[0].mean()), 2)
    1.0
    """

    reads = ("position", "velocity", "mass")
    #: It belongs with the fluid it samples: a system given another scene's forces
    #: (``motes view``'s live values) keeps this one.
    rides_body = True

    def __init__(self, fluid, *, response_time: float = 0.1):
        if not hasattr(fluid, "velocity_grids"):
            raise TypeError(f"fluid must be a GridFluid, got {fluid!r}")
        self.fluid = fluid
        self.response_time = check.positive("response_time", response_time)

    def bind(self, store) -> None:
        store.require("position", "velocity")

    def accumulate(self, store, position, velocity, time, out) -> None:
        check_buffers(position, out)
        n = position.shape[1]
        if n == 0:
            return
        f = self.fluid
        dtype = position.dtype
        _flow_force(
            *f.velocity_grids, f.origin.astype(dtype), dtype.type(1.0 / f.cell_size),
            *position, *velocity, particle_mass(store, n, dtype),
            dtype.type(1.0 / self.response_time), *out,
        )  # fmt: skip


@serial_kernel
def _splat(scalars, u, v, w, origin, inv_h, px, py, pz, vx, vy, vz, density, heat, pull):
    """Each particle adds ``density`` and raises the temperature toward ``heat`` (when
    ``heat > 0``) in the eight cells around it, and pulls the faces around it toward its
    velocity by ``pull`` (a fraction), all with trilinear weights. Serial: particles
    write to shared cells, and the order fixes the sums."""
    _, nz, ny, nx = scalars.shape
    for p in range(px.shape[0]):
        x = (px[p] - origin[0]) * inv_h
        y = (py[p] - origin[1]) * inv_h
        z = (pz[p] - origin[2]) * inv_h
        if not (0.0 <= x < nx and 0.0 <= y < ny and 0.0 <= z < nz):
            continue
        # cells: lattice at +0.5
        cx = min(max(x - 0.5, 0.0), nx - 1.0)
        cy = min(max(y - 0.5, 0.0), ny - 1.0)
        cz = min(max(z - 0.5, 0.0), nz - 1.0)
        i0 = min(int(cx), nx - 1)
        j0 = min(int(cy), ny - 1)
        k0 = min(int(cz), nz - 1)
        tx, ty, tz = cx - i0, cy - j0, cz - k0
        for dk in range(2):
            k = min(k0 + dk, nz - 1)
            wk = tz if dk else 1.0 - tz
            for dj in range(2):
                j = min(j0 + dj, ny - 1)
                wj = ty if dj else 1.0 - ty
                for di in range(2):
                    i = min(i0 + di, nx - 1)
                    wt = wk * wj * (tx if di else 1.0 - tx)
                    if wt <= 0.0:
                        continue
                    scalars[0, k, j, i] += density * wt
                    if heat > 0.0:
                        t = scalars[1, k, j, i]
                        if heat > t:
                            scalars[1, k, j, i] = t + wt * (heat - t)
                    if pull > 0.0:
                        b = pull * wt
                        u[k, j, i] += b * (vx[p] - u[k, j, i])
                        u[k, j, i + 1] += b * (vx[p] - u[k, j, i + 1])
                        v[k, j, i] += b * (vy[p] - v[k, j, i])
                        v[k, j + 1, i] += b * (vy[p] - v[k, j + 1, i])
                        if nz > 1:
                            w[k, j, i] += b * (vz[p] - w[k, j, i])
                            w[k + 1, j, i] += b * (vz[p] - w[k + 1, j, i])


class ParticleSource:
    """Particles of a system (or any kind) feeding a grid fluid where they are.

    Parameters
    ----------
    particles : ParticleSystem, ParticleState or anything with ``particle_state()``
        Read each time the fluid steps (a scene steps systems before bodies).
    density : float
        Density each particle adds per second [1/s], >= 0.
    temperature : float or None
        Temperature [K] each particle heats its cells toward (never cools); None: none.
    pull : float
        How fast the gas takes the particles' velocity [1/s], >= 0 (0: not at all).
    """

    def __init__(self, particles, *, density: float = 1.0, temperature: float | None = None,
                 pull: float = 0.0):  # fmt: skip
        self.particles = particles
        as_state(particles)  # fails now, naming the type, if it shows no particles
        self.density = check.non_negative("particle source density", density)
        self.temperature = (
            None
            if temperature is None
            else check.positive("particle source temperature", temperature)
        )
        self.pull = check.non_negative("particle source pull", pull)

    def apply(self, fluid, dt: float) -> None:
        """Feed ``fluid`` over ``dt`` [s] from the particles as they are now."""
        state = as_state(self.particles)
        if state.count == 0:
            return
        p = np.ascontiguousarray(state.positions, dtype=np.float64)
        vel = np.ascontiguousarray(state.velocities, dtype=np.float64)
        _splat(
            fluid.scalars, fluid.u, fluid.v, fluid.w, fluid.origin, 1.0 / fluid.cell_size,
            *p, *vel, self.density * dt, -1.0 if self.temperature is None else self.temperature,
            min(self.pull * dt, 1.0),
        )  # fmt: skip
