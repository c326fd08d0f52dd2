"""The 2D smoke step of ``benchmarks.grid`` written plainly in NumPy and SciPy: the
baseline of ``grid_speedup_vs_numpy``.

The same algorithm as :class:`motes.GridFluid` (MacCormack advection with the midpoint
trace and the clamp, buoyancy, vorticity confinement, projection with the same walls),
as a competent NumPy programmer writes it: ``scipy.ndimage.map_coordinates`` for the
interpolation, and the pressure Poisson matrix factorised once (``scipy.sparse.linalg
.splu``), so each step's solve is two triangular sweeps (a strong baseline: a direct
solve, not iterations).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spl
from scipy.ndimage import map_coordinates

from motes.gridfluid import GridFluid


class NumpySmoke:
    """A copy of a 2D :class:`GridFluid` (no obstacles, one ball source) stepped in NumPy.

    Arrays are float64, indexed ``[j, i]`` (y, x).
    """

    def __init__(self, fluid: GridFluid):
        if fluid.dimensions != 2 or fluid.obstacles.colliders or fluid.viscosity:
            raise ValueError("the NumPy twin takes a 2D fluid without obstacles or viscosity")
        self.h = fluid.cell_size
        self.origin = fluid.origin.copy()
        self.u = fluid.u[0].astype(np.float64)
        self.v = fluid.v[0].astype(np.float64)
        self.density = fluid.density[0].astype(np.float64)
        self.temperature = fluid.temperature[0].astype(np.float64)
        self.buoyancy = fluid.buoyancy
        self.vorticity = fluid.vorticity
        self.open = fluid.open_faces.astype(bool)
        self.sources = list(fluid.sources)
        self.time = fluid.time
        ny, nx = self.density.shape
        self.laplacian = spl.splu(_poisson(ny, nx, self.open[:4]).tocsc())

    # -- sampling ------------------------------------------------------------------------
    @staticmethod
    def _sample(field, x, y):
        """Bilinear samples at lattice coordinates, clamped to the lattice."""
        return map_coordinates(field, [y, x], order=1, mode="nearest")

    def _velocity(self, x, y):
        return self._sample(self.u, x, y - 0.5), self._sample(self.v, x - 0.5, y)

    def _trace(self, x, y, scale):
        ax, ay = self._velocity(x, y)
        bx, by = self._velocity(x + 0.5 * scale * ax, y + 0.5 * scale * ay)
        return x + scale * bx, y + scale * by

    def _maccormack(self, field, ox, oy, scale):
        ny, nx = field.shape
        jj, ii = np.meshgrid(np.arange(ny), np.arange(nx), indexing="ij")
        x, y = ii + ox, jj + oy
        bx, by = self._trace(x, y, -scale)
        fx = np.clip(bx - ox, 0, nx - 1)
        fy = np.clip(by - oy, 0, ny - 1)
        forward = self._sample(field, fx, fy)
        i0 = np.minimum(fx.astype(int), nx - 1)
        j0 = np.minimum(fy.astype(int), ny - 1)
        i1, j1 = np.minimum(i0 + 1, nx - 1), np.minimum(j0 + 1, ny - 1)
        corners = np.stack([field[j0, i0], field[j0, i1], field[j1, i0], field[j1, i1]])
        lo, hi = corners.min(axis=0), corners.max(axis=0)
        ax, ay = self._trace(x, y, scale)
        back = self._sample(forward, ax - ox, ay - oy)
        return np.clip(forward + 0.5 * (field - back), lo, hi)

    # -- the step ------------------------------------------------------------------------
    def step(self, dt: float) -> None:
        self._sources(dt)
        scale = dt / self.h
        density = self._maccormack(self.density, 0.5, 0.5, scale)
        temperature = self._maccormack(self.temperature, 0.5, 0.5, scale)
        u = self._maccormack(self.u, 0.0, 0.5, scale)
        v = self._maccormack(self.v, 0.5, 0.0, scale)
        self.density, self.temperature, self.u, self.v = density, temperature, u, v
        self._forces(dt)
        self._project()
        self.time += dt

    def _sources(self, dt):
        ny, nx = self.density.shape
        h, o = self.h, self.origin
        for s in self.sources:
            if not s.start <= self.time < s.stop:
                continue
            xc = o[0] + (np.arange(nx) + 0.5) * h
            yc = o[1] + (np.arange(ny) + 0.5) * h
            zc = o[2] + 0.5 * h

            def falloff(x, y, s=s, zc=zc):
                q = (x - s.center[0]) ** 2 + (y - s.center[1]) ** 2 + (zc - s.center[2]) ** 2
                q = q / s.radius**2
                return np.where(q < 1.0, (1.0 - q) ** 2, 0.0)

            f = falloff(xc[None, :], yc[:, None])
            self.density += s.density * dt * f
            if s.temperature is not None:
                t = self.temperature
                self.temperature = np.where(s.temperature > t, t + f * (s.temperature - t), t)
            blend = min(s.pull * dt, 1.0)
            if blend > 0.0:
                xf = o[0] + np.arange(nx + 1) * h
                fu = blend * falloff(xf[None, :], yc[:, None])
                self.u += fu * (s.velocity[0] - self.u)
                yf = o[1] + np.arange(ny + 1) * h
                fv = blend * falloff(xc[None, :], yf[:, None])
                self.v += fv * (s.velocity[1] - self.v)

    def _forces(self, dt):
        b = self.buoyancy
        accel = b.heat_weight * (self.temperature - b.ambient) - b.density_weight * self.density
        self.u[:, 1:-1] += dt * b.up[0] * 0.5 * (accel[:, :-1] + accel[:, 1:])
        self.v[1:-1, :] += dt * b.up[1] * 0.5 * (accel[:-1, :] + accel[1:, :])
        if self.vorticity > 0.0:
            uc = 0.5 * (self.u[:, :-1] + self.u[:, 1:])
            vc = 0.5 * (self.v[:-1, :] + self.v[1:, :])
            wz = (_d(vc, 1) - _d(uc, 0)) / self.h
            mag = np.abs(wz)
            gx, gy = _d(mag, 1), _d(mag, 0)
            norm = np.hypot(gx, gy)
            safe = np.where(norm < 1e-12, 1.0, norm)
            nx_, ny_ = (
                np.where(norm < 1e-12, 0.0, gx / safe),
                np.where(norm < 1e-12, 0.0, gy / safe),
            )
            fx = self.vorticity * self.h * (ny_ * wz)
            fy = self.vorticity * self.h * (-nx_ * wz)
            self.u[:, 1:-1] += dt * 0.5 * (fx[:, :-1] + fx[:, 1:])
            self.v[1:-1, :] += dt * 0.5 * (fy[:-1, :] + fy[1:, :])

    def _project(self):
        walls = self.open
        if not walls[0]:
            self.u[:, 0] = 0.0
        if not walls[1]:
            self.u[:, -1] = 0.0
        if not walls[2]:
            self.v[0, :] = 0.0
        if not walls[3]:
            self.v[-1, :] = 0.0
        div = np.diff(self.u, axis=1) + np.diff(self.v, axis=0)
        q = self.laplacian.solve(-div.ravel()).reshape(div.shape)
        self.u[:, 1:-1] -= np.diff(q, axis=1)
        self.v[1:-1, :] -= np.diff(q, axis=0)
        if walls[0]:
            self.u[:, 0] -= q[:, 0]
        if walls[1]:
            self.u[:, -1] += q[:, -1]
        if walls[2]:
            self.v[0, :] -= q[0, :]
        if walls[3]:
            self.v[-1, :] += q[-1, :]


def _d(f, axis):
    """Central differences per cell along ``axis``, one-sided at the edges."""
    return np.gradient(f, axis=axis)


def _poisson(ny: int, nx: int, open_faces) -> sp.csr_matrix:
    """``-h^2`` times the Laplacian over the cells with the walls' conditions."""
    n = nx * ny
    index = np.arange(n).reshape(ny, nx)
    diag = np.zeros((ny, nx))
    rows, cols = [], []
    for axis, (lo, hi) in ((1, (0, 1)), (0, (2, 3))):
        a = index[:, :-1] if axis == 1 else index[:-1, :]
        b = index[:, 1:] if axis == 1 else index[1:, :]
        rows += [a.ravel(), b.ravel()]
        cols += [b.ravel(), a.ravel()]
        if axis == 1:
            diag[:, :-1] += 1
            diag[:, 1:] += 1
            diag[:, 0] += open_faces[lo]
            diag[:, -1] += open_faces[hi]
        else:
            diag[:-1, :] += 1
            diag[1:, :] += 1
            diag[0, :] += open_faces[lo]
            diag[-1, :] += open_faces[hi]
    off = sp.csr_matrix(
        (-np.ones(sum(len(r) for r in rows)), (np.concatenate(rows), np.concatenate(cols))),
        shape=(n, n),
    )
    return off + sp.diags(diag.ravel())
