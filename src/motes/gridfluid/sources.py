"""Sources of a grid fluid: where smoke, heat and motion enter it.

:class:`Source` is a ball that adds density and heat at given rates and pulls the flow
inside it toward a velocity, with a smooth falloff to its edge. A particle source
(:class:`motes.gridfluid.coupling.ParticleSource`) does the same where particles are.
"""

from __future__ import annotations

import numpy as np
from numba import prange

from .. import _validate as check
from .._jit import parallel_kernel


@parallel_kernel
def inject_ball(
    scalars, u, v, w, origin, h, center, radius, density_rate, heat, velocity, pull, dt
):
    """Add ``density_rate * dt * f`` to density, raise temperature toward ``heat`` by
    ``f`` (never lowering it), and move face velocities toward ``velocity`` by
    ``pull * dt * f`` (at most all the way), where ``f = (1 - (r / radius)^2)^2`` is the
    falloff at distance ``r`` from ``center``."""
    _, nz, ny, nx = scalars.shape
    inv_r2 = 1.0 / (radius * radius)
    blend = min(pull * dt, 1.0)
    for row in prange((nz + 1) * (ny + 1)):
        k = row // (ny + 1)
        j = row - k * (ny + 1)
        for i in range(nx + 1):
            for part in range(4):  # cell centre, then the x, y and z face
                ox = 0.0 if part == 1 else 0.5
                oy = 0.0 if part == 2 else 0.5
                oz = 0.0 if part == 3 else 0.5
                if part == 0 and (i == nx or j == ny or k == nz):
                    continue
                if part == 1 and (j == ny or k == nz):
                    continue
                if part == 2 and (i == nx or k == nz):
                    continue
                if part == 3 and (i == nx or j == ny):
                    continue
                dx = origin[0] + (i + ox) * h - center[0]
                dy = origin[1] + (j + oy) * h - center[1]
                dz = origin[2] + (k + oz) * h - center[2]
                q = (dx * dx + dy * dy + dz * dz) * inv_r2
                if q >= 1.0:
                    continue
                f = (1.0 - q) * (1.0 - q)
                if part == 0:
                    scalars[0, k, j, i] += density_rate * dt * f
                    t = scalars[1, k, j, i]
                    if heat > t:
                        scalars[1, k, j, i] = t + f * (heat - t)
                elif blend > 0.0:
                    b = blend * f
                    if part == 1:
                        u[k, j, i] += b * (velocity[0] - u[k, j, i])
                    elif part == 2:
                        v[k, j, i] += b * (velocity[1] - v[k, j, i])
                    else:
                        w[k, j, i] += b * (velocity[2] - w[k, j, i])


class Source:
    """A ball where smoke, heat and motion enter a grid fluid.

    Parameters
    ----------
    center : (3,) floats
        Centre [m].
    radius : float
        Radius [m], > 0; the effect falls off smoothly to 0 at the edge.
    density : float
        Density added per second at the centre [1/s], >= 0.
    temperature : float or None
        Temperature [K] the gas inside is heated to (never cooled); None: no heating.
    velocity : (3,) floats
        Velocity [m/s] the flow inside is pulled toward.
    pull : float
        How fast the flow takes that velocity [1/s], >= 0 (0: no pull; large: set).
    """

    def __init__(
        self, center, radius: float, *, density: float = 1.0, temperature: float | None = None,
        velocity=(0.0, 0.0, 0.0), pull: float = 0.0,
    ):  # fmt: skip
        self.center = check.vector("source center", center)
        self.radius = check.positive("source radius", radius)
        self.density = check.non_negative("source density", density)
        self.temperature = (
            None if temperature is None else check.positive("source temperature", temperature)
        )
        self.velocity = check.vector("source velocity", velocity)
        self.pull = check.non_negative("source pull", pull)

    def apply(self, fluid, dt: float) -> None:
        """Inject into ``fluid`` (a :class:`~motes.gridfluid.GridFluid`) over ``dt`` [s]."""
        heat = -1.0 if self.temperature is None else self.temperature
        inject_ball(
            fluid.scalars, fluid.u, fluid.v, fluid.w, fluid.origin, fluid.cell_size,
            self.center, self.radius, self.density, heat, self.velocity.astype(np.float64),
            self.pull, dt,
        )  # fmt: skip
