"""The demo fire as Python code: the system the benchmarks and determinism tests use.

To watch a fire, run ``motes run fire`` (the built-in scene ``fire.toml``).
"""

from __future__ import annotations

from . import _validate as check
from . import colliders, shapes
from .emit import Emitter, PerFrame, Uniform
from .forces import CurlNoise, Drag, Gravity
from .life import ColorOverLife, SizeOverLife
from .system import ParticleSystem

FPS = 60


def build_fire(
    *,
    capacity: int = 200_000,
    rate: float = 2000.0,
    seed: int = 1,
    turbulence: bool = True,
    size: float = 1.0,
) -> ParticleSystem:
    """A fire: a disc of buoyant, turbulent particles fading from white-yellow to smoke.

    ``rate`` is the mean number of particles born per frame (Reeves' MeanParts; the
    variance is a fifth of it). ``turbulence=False`` leaves out the curl noise (the
    benchmark's fixed-cost system). ``size`` scales the particles' radii (3 to 6 cm
    at birth): a fire of a million particles draws each smaller.
    """
    size = check.positive("size", size)
    # Additive sprites do not depend on the particles' order: fill each hole from the
    # tail instead of shifting every survivor (a 1M fire: about 2 ms instead of 9).
    fire = ParticleSystem(capacity=capacity, seed=seed, compaction="swap")
    fire.add(
        Emitter(
            shapes.Disc(0.3),
            PerFrame(rate, rate / 5),
            speed=Uniform(0.3, 1.0),
            lifetime=Uniform(0.6, 1.2),
            color="#fff3b0",
            size=Uniform(0.03 * size, 0.06 * size),
        ),
        Gravity((0.0, 2.0, 0.0)),  # buoyancy: hot gas rises
        Drag(0.8),
        colliders.Plane((0.0, 1.0, 0.0), 0.0, friction=0.3),
        ColorOverLife([(0.0, "#fff3b0"), (0.4, "#ff7a1a"), (1.0, "#30303000")]),
        SizeOverLife([(0.0, 1.0), (1.0, 2.5)]),
    )
    if turbulence:
        fire.add(CurlNoise(strength=1.5, scale=0.4, seed=seed))
    return fire
