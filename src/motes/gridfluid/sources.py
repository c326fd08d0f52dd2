"""Sources of a grid fluid: where smoke, heat and motion enter it.

:class:`Source` is a ball that adds density and heat at given rates and pulls the flow
inside it toward a velocity, with a smooth falloff to its edge. A particle source
(:class:`motes.gridfluid.coupling.ParticleSource`) does the same where particles are.
"""

from __future__ import annotations

import numpy as np
from numba import prange

from .. import _validate as check
from .._jit import device, parallel_kernel


@device
def _hash_unit(i, j, k, part, key):
    """A value in [-1, 1] from integer coordinates and a key (a 32-bit mix, in the
    manner of the PCG output permutation): the same arguments, the same value."""
    # int64 arithmetic masked to 32 bits (Numba widens uint32 products to 64 bits)
    mask = 0xFFFFFFFF
    x = ((i * 73856093) ^ (j * 19349663) ^ (k * 83492791) ^ (part * 2654435761)) & mask
    x = ((x ^ key) * 747796405 + 2891336453) & mask
    x = (((x >> ((x >> 28) + 4)) ^ x) * 277803737) & mask
    x = (x >> 22) ^ x
    return x / 2147483647.5 - 1.0


@parallel_kernel
def inject_ball(
    scalars, u, v, w, origin, h, center, radius, density_rate, heat, velocity, expansion, pull,
    dt, noise, turbulence, key,
):  # fmt: skip
    """Add ``density_rate * dt * f`` to density, raise temperature toward ``heat`` by
    ``f`` (never lowering it), and move face velocities toward ``velocity + expansion *
    (x - center) / radius`` by ``pull * dt * f`` (at most all the way), where
    ``f = (1 - (r / radius)^2)^2`` is the falloff at distance ``r`` from ``center``.
    ``noise`` in [0, 1] varies the density and heat added cell by cell (by up to that
    fraction), ``turbulence`` [m/s] adds a random speed to each face's target; both
    drawn afresh for each ``key`` (the step)."""
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
                    if noise > 0.0:
                        f *= 1.0 + noise * _hash_unit(i, j, k, part, key)
                    scalars[0, k, j, i] += density_rate * dt * f
                    t = scalars[1, k, j, i]
                    if heat > t:
                        scalars[1, k, j, i] = t + min(f, 1.0) * (heat - t)
                elif blend > 0.0:
                    b = blend * f
                    spread = expansion / radius
                    jolt = turbulence * _hash_unit(i, j, k, part, key) if turbulence else 0.0
                    if part == 1:
                        u[k, j, i] += b * (velocity[0] + spread * dx + jolt - u[k, j, i])
                    elif part == 2:
                        v[k, j, i] += b * (velocity[1] + spread * dy + jolt - v[k, j, i])
                    else:
                        w[k, j, i] += b * (velocity[2] + spread * dz + jolt - w[k, j, i])


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
    expansion : float
        Outward speed [m/s] added at the ball's edge (in proportion to the distance from
        the centre inside it): a blast pushing the gas out.
    start, stop : float
        When the source acts [s] of the fluid's time, ``start`` <= t < ``stop`` (an
        explosion: a fraction of a second).
    noise : float
        In [0, 1]: the density and heat added vary cell by cell and step by step by up to
        this fraction (a fire's flicker, a blast's lumps).
    turbulence : float
        Random speed [m/s] added to the velocity the flow is pulled toward, face by face
        and step by step (breaks a smooth ball into billows), >= 0.
    seed : int
        Seed of the noise and turbulence (the same seed, the same source).
    """

    def __init__(
        self, center, radius: float, *, density: float = 1.0, temperature: float | None = None,
        velocity=(0.0, 0.0, 0.0), pull: float = 0.0, expansion: float = 0.0,
        start: float = 0.0, stop: float = float("inf"), noise: float = 0.0,
        turbulence: float = 0.0, seed: int = 0,
    ):  # fmt: skip
        self.center = check.vector("source center", center)
        self.radius = check.positive("source radius", radius)
        self.density = check.non_negative("source density", density)
        self.temperature = (
            None if temperature is None else check.positive("source temperature", temperature)
        )
        self.velocity = check.vector("source velocity", velocity)
        self.pull = check.non_negative("source pull", pull)
        self.expansion = check.real("source expansion", expansion)
        self.start = check.non_negative("source start", start)
        self.stop = check.real("source stop", stop, low=self.start, allow_inf=True)
        self.noise = check.unit_interval("source noise", noise)
        self.turbulence = check.non_negative("source turbulence", turbulence)
        self.seed = check.integer("source seed", seed, low=0)

    def apply(self, fluid, dt: float) -> None:
        """Inject into ``fluid`` (a :class:`~motes.gridfluid.GridFluid`) over ``dt`` [s]."""
        if not self.start <= fluid.time < self.stop:
            return
        heat = -1.0 if self.temperature is None else self.temperature
        inject_ball(
            fluid.scalars, fluid.u, fluid.v, fluid.w, fluid.origin, fluid.cell_size,
            self.center, self.radius, self.density, heat, self.velocity.astype(np.float64),
            self.expansion, self.pull, dt, self.noise, self.turbulence,
            (self.seed * 1_000_003 + fluid.steps) & 0xFFFFFFFF,
        )  # fmt: skip
