"""The 2D smoke step of ``benchmarks.grid`` written plainly in NumPy and SciPy: the
baseline its speed-up is measured against.

:class:`NumpySmoke` takes a 2D :class:`motes.gridfluid.GridFluid` (its walls, buoyancy,
vorticity, ball sources and state) and steps the same equations the way a NumPy
programmer would write them (Stam 1999; Fedkiw, Stam & Jensen 2001; Selle et al. 2008):

1. sources: density added, temperature raised and the flow pulled toward the source's
   velocity inside each ball, with the smooth falloff ``(1 - (r / R)^2)^2``;
2. advection of density, temperature, u and v by MacCormack: semi-Lagrangian back-traces
   (midpoint rule, velocities interpolated with ``scipy.ndimage.map_coordinates``), the
   trace forward in time of the result, and the correction clamped to the four values
   the first sample mixed (gathered with fancy indexing);
3. buoyancy ``heat_weight (T - ambient) - density_weight * density`` along y, and
   vorticity confinement (``np.gradient`` differences, central inside and one-sided at
   the walls), both averaged from cells onto faces;
4. projection: closed walls set, the divergence computed, the pressure solved with an
   LU factorisation of the fixed Laplacian made once (``scipy.sparse.linalg.splu``, a
   direct solve, where motes iterates to a tolerance), its gradient subtracted.

Velocities live on the faces (u (ny, nx + 1), v (ny + 1, nx)), scalars at cell centres
(ny, nx), row 0 at the bottom; positions in cells; float64, NumPy's default. Obstacles,
viscosity, dissipation, moving walls and the sources' expansion, noise and turbulence are
left out: the benchmark's scene has none.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.ndimage import map_coordinates
from scipy.sparse.linalg import splu


def laplacian(nx: int, ny: int, open_faces) -> sp.csc_matrix:
    """``-h^2`` times the Laplacian on (ny, nx) cells, x fastest: a closed wall couples to
    nothing beyond it, an open one to pressure 0 (``open_faces``: -x, +x, -y, +y)."""

    def axis(n, low_open, high_open):
        main = np.full(n, 2.0)
        main[0] = 1.0 + low_open
        main[-1] = 1.0 + high_open
        return sp.diags([-np.ones(n - 1), main, -np.ones(n - 1)], [-1, 0, 1])

    along_x = axis(nx, open_faces[0], open_faces[1])
    along_y = axis(ny, open_faces[2], open_faces[3])
    return (sp.kron(sp.identity(ny), along_x) + sp.kron(along_y, sp.identity(nx))).tocsc()


class NumpySmoke:
    """The smoke step of a 2D :class:`~motes.gridfluid.GridFluid`, in NumPy and SciPy.

    Parameters
    ----------
    fluid : GridFluid
        A 2D fluid with MacCormack advection, slipping walls at rest, ball sources
        (:class:`~motes.gridfluid.Source`) and no obstacles, viscosity or dissipation;
        its parameters and current state are copied.
    """

    def __init__(self, fluid):
        if fluid.dimensions != 2 or fluid.advection.value != "maccormack":
            raise ValueError("NumpySmoke steps 2D fluids advected by MacCormack")
        if fluid.obstacles.colliders or fluid.viscosity or np.any(fluid.wall_velocity):
            raise ValueError("NumpySmoke has no obstacles, viscosity or moving walls")
        d = fluid.dissipation
        if d.density or d.temperature or d.velocity:
            raise ValueError("NumpySmoke has no dissipation")
        self.h = fluid.cell_size
        self.buoyancy = fluid.buoyancy
        self.vorticity = fluid.vorticity
        self.open_faces = fluid.open_faces[:4].astype(bool)
        self.density = fluid.density[0].astype(np.float64)
        self.temperature = fluid.temperature[0].astype(np.float64)
        self.u = fluid.u[0].astype(np.float64)
        self.v = fluid.v[0].astype(np.float64)
        self.time = fluid.time
        ny, nx = self.density.shape
        self.lu = splu(laplacian(nx, ny, self.open_faces))
        # lattice positions [cells]: cell centres, x faces, y faces
        self.centres = np.meshgrid(np.arange(nx) + 0.5, np.arange(ny) + 0.5)
        self.x_faces = np.meshgrid(np.arange(nx + 1.0), np.arange(ny) + 0.5)
        self.y_faces = np.meshgrid(np.arange(nx) + 0.5, np.arange(ny + 1.0))
        self.sources = []
        for source in fluid.sources:
            if source.expansion or source.noise or source.turbulence:
                raise ValueError("NumpySmoke's sources have no expansion, noise or turbulence")

            def falloff(x, y, source=source):
                """The source's weight at positions [cells] of the plane z = h / 2."""
                dx = fluid.origin[0] + x * self.h - source.center[0]
                dy = fluid.origin[1] + y * self.h - source.center[1]
                dz = fluid.origin[2] + 0.5 * self.h - source.center[2]
                q = (dx * dx + dy * dy + dz * dz) / source.radius**2
                return np.where(q < 1.0, (1.0 - q) ** 2, 0.0)

            weights = (falloff(*self.centres), falloff(*self.x_faces), falloff(*self.y_faces))
            self.sources.append((source, weights))

    # -- advection ----------------------------------------------------------------------

    def velocity(self, x, y):
        """Velocity [m/s] at positions [cells], bilinear on the faces, clamped."""
        return (
            map_coordinates(self.u, [y - 0.5, x], order=1, mode="nearest"),
            map_coordinates(self.v, [y, x - 0.5], order=1, mode="nearest"),
        )

    def trace(self, x, y, scale):
        """Where the flow carries positions in ``scale * h`` seconds (midpoint rule)."""
        ax, ay = self.velocity(x, y)
        bx, by = self.velocity(x + 0.5 * scale * ax, y + 0.5 * scale * ay)
        return x + scale * bx, y + scale * by

    @staticmethod
    def sample_range(field, x, y):
        """Bilinear samples of ``field`` at lattice coordinates (clamped) and the least
        and greatest of the four values each mixes."""
        ny, nx = field.shape
        x = np.clip(x, 0, nx - 1)
        y = np.clip(y, 0, ny - 1)
        i = np.minimum(x.astype(np.intp), nx - 2)
        j = np.minimum(y.astype(np.intp), ny - 2)
        tx, ty = x - i, y - j
        a, b = field[j, i], field[j, i + 1]
        c, d = field[j + 1, i], field[j + 1, i + 1]
        bottom, top = a + tx * (b - a), c + tx * (d - c)
        value = bottom + ty * (top - bottom)
        low = np.minimum(np.minimum(a, b), np.minimum(c, d))
        high = np.maximum(np.maximum(a, b), np.maximum(c, d))
        return value, low, high

    def maccormack(self, fields, lattice, offset, scale):
        """The fields on one lattice (positions ``lattice``, offset [cells]) carried by
        the flow over a step (``scale = dt / h``)."""
        x, y = lattice
        back_x, back_y = self.trace(x, y, -scale)
        ahead_x, ahead_y = self.trace(x, y, scale)
        out = []
        for field in fields:
            forward, low, high = self.sample_range(field, back_x - offset[0], back_y - offset[1])
            back = map_coordinates(
                forward, [ahead_y - offset[1], ahead_x - offset[0]], order=1, mode="nearest"
            )
            out.append(np.clip(forward + 0.5 * (field - back), low, high))
        return out

    # -- the step -----------------------------------------------------------------------

    def step(self, dt: float) -> None:
        """Advance by ``dt`` [s]."""
        for source, (cells, x_faces, y_faces) in self.sources:
            if not source.start <= self.time < source.stop:
                continue
            self.density += source.density * dt * cells
            if source.temperature is not None:
                t = self.temperature
                raised = t + np.minimum(cells, 1.0) * (source.temperature - t)
                self.temperature = np.where(source.temperature > t, raised, t)
            blend = min(source.pull * dt, 1.0)
            if blend > 0.0:
                self.u += blend * x_faces * (source.velocity[0] - self.u)
                self.v += blend * y_faces * (source.velocity[1] - self.v)
        scale = dt / self.h
        self.density, self.temperature = self.maccormack(
            (self.density, self.temperature), self.centres, (0.5, 0.5), scale
        )
        (u,) = self.maccormack((self.u,), self.x_faces, (0.0, 0.5), scale)
        (v,) = self.maccormack((self.v,), self.y_faces, (0.5, 0.0), scale)
        self.u, self.v = u, v
        self.add_forces(dt)
        self.project()
        self.time += dt

    def add_forces(self, dt: float) -> None:
        """Buoyancy, then vorticity confinement, on the interior faces."""
        b = self.buoyancy
        if b.density_weight or b.heat_weight:
            lift = b.heat_weight * (self.temperature - b.ambient) - b.density_weight * self.density
            for axis, face in enumerate((self.u, self.v)):
                if b.up[axis]:
                    _add_cell_force(face, axis, lift, dt * b.up[axis])
        if self.vorticity:
            cu = 0.5 * (self.u[:, :-1] + self.u[:, 1:])
            cv = 0.5 * (self.v[:-1] + self.v[1:])
            omega = (np.gradient(cv, axis=1) - np.gradient(cu, axis=0)) / self.h
            gy, gx = np.gradient(np.abs(omega))
            norm = np.sqrt(gx * gx + gy * gy)
            s = np.where(norm >= 1e-12, self.vorticity * self.h / np.maximum(norm, 1e-30), 0.0)
            _add_cell_force(self.u, 0, s * gy * omega, dt)
            _add_cell_force(self.v, 1, -s * gx * omega, dt)

    def project(self) -> None:
        """Make the velocity divergence-free: closed walls, then the pressure solve."""
        u, v, open_faces = self.u, self.v, self.open_faces
        for face, index, side in ((u, (slice(None), 0), 0), (u, (slice(None), -1), 1),
                                  (v, 0, 2), (v, -1, 3)):  # fmt: skip
            if not open_faces[side]:
                face[index] = 0.0
        divergence = u[:, 1:] - u[:, :-1] + v[1:] - v[:-1]
        q = self.lu.solve(-divergence.ravel()).reshape(divergence.shape)
        u[:, 1:-1] -= q[:, 1:] - q[:, :-1]
        v[1:-1] -= q[1:] - q[:-1]
        # beyond an open wall the pressure is 0
        if open_faces[0]:
            u[:, 0] -= q[:, 0]
        if open_faces[1]:
            u[:, -1] += q[:, -1]
        if open_faces[2]:
            v[0] -= q[0]
        if open_faces[3]:
            v[-1] += q[-1]


def _add_cell_force(face, axis, force, scale):
    """``face += scale`` times the mean of the cell values ``force`` on either side, on
    the interior faces normal to ``axis`` (0: x, 1: y)."""
    if axis == 0:
        face[:, 1:-1] += scale * 0.5 * (force[:, :-1] + force[:, 1:])
    else:
        face[1:-1] += scale * 0.5 * (force[:-1] + force[1:])
