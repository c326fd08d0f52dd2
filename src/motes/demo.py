"""The fire demo: simulate a fire for 10 s and print what happened.

Run with ``python -m motes demo`` (options: ``--seconds``, ``--seed``, ``--rate``).
"""

from __future__ import annotations

import time

import numpy as np

from . import colliders, shapes
from .emit import Emitter, PerFrame, Uniform
from .forces import CurlNoise, Drag, Gravity
from .life import ColorOverLife, SizeOverLife
from .system import ParticleSystem

FPS = 60


def build_fire(
    *, capacity: int = 200_000, rate: float = 2000.0, seed: int = 1, turbulence: bool = True
) -> ParticleSystem:
    """A fire: a disc of buoyant, turbulent particles fading from white-yellow to smoke.

    ``rate`` is the mean number of particles born per frame (Reeves' MeanParts; the
    variance is a fifth of it). ``turbulence=False`` leaves out the curl noise (the
    benchmark's fixed-cost system).
    """
    fire = ParticleSystem(capacity=capacity, seed=seed)
    fire.add(
        Emitter(
            shapes.Disc(0.3),
            PerFrame(rate, rate / 5),
            speed=Uniform(0.3, 1.0),
            lifetime=Uniform(0.6, 1.2),
            color="#fff3b0",
            size=Uniform(0.03, 0.06),
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


def run(seconds: float = 10.0, *, seed: int = 1, rate: float = 2000.0, out=print) -> dict:
    """Simulate the fire and print a per-second summary; returns the final summary."""
    fire = build_fire(rate=rate, seed=seed)
    steps = round(seconds * FPS)
    out(
        f"motes fire demo: {seconds:g} s at {FPS} steps/s, mean {rate:g} births per frame, "
        f"seed {seed}"
    )
    out("(the first run on a machine compiles the kernels: allow a minute; later runs reuse them)")
    out(f"{'time [s]':>8} {'particles':>10} {'mean speed':>11}  bounding box [m]")
    started = time.perf_counter()
    summary = fire.summary()
    for step in range(1, steps + 1):
        fire.step(1 / FPS)
        if step % FPS == 0 or step == steps:
            summary = fire.summary()
            lo = np.round(summary["bbox_min"], 2).tolist() if summary["count"] else "-"
            hi = np.round(summary["bbox_max"], 2).tolist() if summary["count"] else "-"
            out(
                f"{fire.time:>8.2f} {summary['count']:>10d} {summary['mean_speed']:>9.3f}"
                f" m/s  {lo} .. {hi}"
            )
    elapsed = time.perf_counter() - started
    out(
        f"{steps} steps in {elapsed:.2f} s ({1e3 * elapsed / steps:.2f} ms/step incl. "
        f"first-call compilation); {fire.store.dropped} spawns dropped at capacity"
    )
    return summary
