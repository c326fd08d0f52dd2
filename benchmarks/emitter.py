"""Emitter-pipeline benchmarks: ballistic steps, a fire held at 1M particles, a small fire.

Run from the repository root::

    PYTHONPATH=src python -m benchmarks.emitter           # full sizes, 15-25 s on 2 cores
    PYTHONPATH=src python -m benchmarks.emitter --quick   # shrunk sizes, seconds

It prints a table, then one line of JSON with the figures. Every figure is a ratio
against a baseline measured in the same run, never against a stored time:

- **ballistic**: gravity, linear drag and a ground plane with friction on a store filled
  directly (no emitter, nobody dies), against the memory-bandwidth floor: the bytes the
  fused step must move (:func:`ballistic_bytes`) at the machine's bandwidth, measured in
  the same run by compiled STREAM-style kernels on every thread (the triad and an
  in-place update, :func:`stream_bandwidth`) and by ``np.copyto`` (the fastest of them);
- **fire**: the demo fire (:func:`motes.demo.build_fire`) held at a steady live count,
  against :class:`NumpyFire`, the same step in plain vectorised NumPy;
- **small**: 1,000 live particles, where per-step overhead dominates: the fire without
  its curl noise (fixed costs; the target), and the whole fire beside it.

Timings are the best of several single steps after warm-up steps (the first call of a
kernel loads or compiles it), with the median beside it; stage breakdowns are medians.
The cores other processes kept busy are reported too: on a small shared machine they
inflate parallel timings. See ``docs/performance.md`` for the figures and their reading.
"""

from __future__ import annotations

import copy
import datetime
import statistics
import time
from collections import defaultdict
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

import motes
from motes.demo import FPS, build_fire
from motes.forces.base import FieldTerms
from motes.forces.curl_noise import perlin_gradients
from motes.particles import BUILTIN

from ._common import (
    Timing,
    benchmark_main,
    copy_bandwidth,
    machine,
    stream_bandwidth,
    table,
    time_calls,
)

DT = 1.0 / FPS


@dataclass(frozen=True)
class Sizes:
    """Problem sizes and repetitions of one run."""

    ballistic: tuple[int, ...]
    fire: int
    small: int
    bandwidth_columns: int
    repeat: int  # timed steps per measurement (more for the small system)
    numpy_repeat: int

    @staticmethod
    def full() -> Sizes:
        return Sizes((1_000_000, 10_000_000), 1_000_000, 1_000, 10_000_000, 15, 3)

    @staticmethod
    def quick() -> Sizes:
        return Sizes((10_000, 100_000), 100_000, 1_000, 1_000_000, 5, 2)


#: JSON key prefixes; ``--quick`` runs keep them although its sizes are smaller (the
#: ``sizes`` entry of the JSON says what was measured).
BALLISTIC_KEYS = ("ballistic_1m", "ballistic_10m")
FIRE_KEY = "fire_1m"
SMALL_KEY = "small_1k"
SMALL_FIRE_KEY = "small_fire_1k"


# -- ballistic --------------------------------------------------------------------------
def ballistic_bytes(dtype=np.float32) -> dict[str, int]:
    """Bytes per particle a ballistic step must move, by array (read + write counted)."""
    s = np.dtype(dtype).itemsize
    return {
        "position r+w": 2 * 3 * s,
        "velocity r+w": 2 * 3 * s,
        "age r+w": 2 * s,
        "lifetime r": s,
        "keep flag w": np.dtype(np.bool_).itemsize,
    }


def ballistic_system(n: int, *, seed: int = 0) -> motes.ParticleSystem:
    """``n`` live float32 particles under gravity, linear drag and a frictional ground."""
    system = motes.ParticleSystem(capacity=n, seed=seed, dtype=np.float32)
    system.add(
        motes.Gravity((0.0, -9.81, 0.0)),
        motes.Drag(0.1),
        motes.colliders.Plane((0.0, 1.0, 0.0), 0.0, restitution=0.5, friction=0.2),
    )
    system.store.spawn(n)
    rng = np.random.default_rng(seed)
    position = system["position"]
    position[:, 0] = rng.uniform(-10.0, 10.0, n)
    position[:, 1] = rng.uniform(0.0, 10.0, n)
    position[:, 2] = rng.uniform(-10.0, 10.0, n)
    system["velocity"][:] = rng.standard_normal((n, 3), dtype=np.float32)
    # Nobody dies during the timing, so the step never compacts.
    system["lifetime"][:] = 1e9
    return system


class NumpyBallistic:
    """The ballistic step in plain NumPy on ``(3, n)`` arrays, from a system's state."""

    def __init__(self, system: motes.ParticleSystem):
        terms = field_terms(system)
        self.gravity = np.array(terms.gravity, dtype=np.float32)[:, None]
        self.drag = np.float32(terms.linear_drag)
        self.planes = [PlaneParams.of(c) for c in system.colliders]
        n = system.store.count
        self.position = system.store.raw("position")[:, :n].copy()
        self.velocity = system.store.raw("velocity")[:, :n].copy()
        self.age = system.store.raw("age")[:n].copy()
        self.lifetime = system.store.raw("lifetime")[:n].copy()
        self.keep = np.ones(n, dtype=np.bool_)

    def step(self, dt: float) -> None:
        dt = np.float32(dt)
        self.velocity += dt * (self.gravity - self.drag * self.velocity)
        self.position += dt * self.velocity
        for plane in self.planes:
            plane.collide(self.position, self.velocity)
        self.age += dt
        np.less(self.age, self.lifetime, out=self.keep)


def bench_ballistic(n: int, bandwidth: float, sizes: Sizes, *, numpy_baseline: bool) -> dict:
    """Time the ballistic step of ``n`` particles; its bandwidth floor; optionally NumPy's."""
    system = ballistic_system(n)
    timing = time_calls(lambda: system.step(DT), repeat=sizes.repeat, warmup=2)
    assert len(system) == n, "a ballistic particle died: the timing included compaction"
    floor = sum(ballistic_bytes().values()) * n / bandwidth
    result = {"timing": timing, "floor": floor, "floor_fraction": floor / timing.best}
    if numpy_baseline:
        baseline = NumpyBallistic(system)
        numpy = time_calls(lambda: baseline.step(DT), repeat=sizes.numpy_repeat)
        result |= {"numpy": numpy, "speedup_vs_numpy": numpy.best / timing.best}
    return result


# -- the NumPy fire ---------------------------------------------------------------------
def field_terms(system: motes.ParticleSystem) -> FieldTerms:
    """The summed coefficients of a system's gravity, drag and wind."""
    terms = FieldTerms()
    for force in system.field_forces:
        terms.add(force.terms())
    if terms.quadratic_drag:
        raise ValueError("the NumPy baselines implement linear drag only")
    return terms


@dataclass(frozen=True)
class PlaneParams:
    """A bouncing plane collider with velocity-scaling friction, as the baseline uses it."""

    normal: np.ndarray  # (3, 1) float32
    offset: np.float32
    restitution: np.float32
    friction: np.float32

    @staticmethod
    def of(collider) -> PlaneParams:
        bounce = collider.response == motes.Response.BOUNCE
        if not (
            isinstance(collider, motes.colliders.Plane)
            and bounce
            and collider.friction_model == motes.Friction.SCALE
        ):
            raise ValueError(
                f"the NumPy baselines implement bouncing planes with "
                f"scale friction only, got {collider!r}"
            )
        return PlaneParams(
            collider.normal.astype(np.float32)[:, None],
            np.float32(collider.offset),
            np.float32(collider.restitution),
            np.float32(collider.friction),
        )

    def collide(self, position: np.ndarray, velocity: np.ndarray) -> None:
        """Push penetrating particles out; restitution on the normal, friction on the tangent."""
        depth = self.offset - (self.normal * position).sum(axis=0)
        hit = np.flatnonzero(depth > 0)
        if hit.size == 0:
            return
        n = self.normal
        position[:, hit] += depth[hit] * n
        v = velocity[:, hit]
        vn = (n * v).sum(axis=0)
        # Only an approaching particle bounces (as in motes.collide.geometry.respond).
        vn_out = np.where(vn < 0, -self.restitution * vn, vn)
        velocity[:, hit] = (v - vn * n) * (1 - self.friction) + vn_out * n


def _fade(t):
    """Perlin's quintic fade and its derivative (as in ``motes.forces.curl_noise``)."""
    s = t * (t - 1)
    return t * t * t * (t * (t * 6 - 15) + 10), 30 * s * s


def _lerp(t, a, b):
    return a + t * (b - a)


def _trilerp(u, v, w, c):
    """Trilinear blend of corner values ``c[(i, j, k)]`` with weights u, v, w."""
    return _lerp(
        w,
        _lerp(v, _lerp(u, c[0, 0, 0], c[1, 0, 0]), _lerp(u, c[0, 1, 0], c[1, 1, 0])),
        _lerp(v, _lerp(u, c[0, 0, 1], c[1, 0, 1]), _lerp(u, c[0, 1, 1], c[1, 1, 1])),
    )


CORNERS = [(i, j, k) for k in (0, 1) for j in (0, 1) for i in (0, 1)]


def numpy_noise_gradient(
    p: np.ndarray, perm: np.ndarray, grads: np.ndarray, axes: tuple[int, ...]
) -> list[np.ndarray]:
    """Components ``axes`` of the gradient of Perlin's improved noise at ``p`` (3, n).

    Vectorised twin of ``motes.forces.curl_noise._noise``: Perlin (2002) hash of the
    eight corners, ramps ``g_c · (p - c)``, quintic fade, and the analytic derivative
    ``∂n/∂x_j = fade'(x_j) ∂trilerp/∂u_j + trilerp(g_c,j)``.
    """
    floor = np.floor(p)
    frac = p - floor
    cell = floor.astype(np.intp) & 255
    cx, cy, cz = cell
    a = perm[cx] + cy
    b = perm[cx + 1] + cy
    row = {
        (0, 0): perm[a] + cz,
        (0, 1): perm[a + 1] + cz,
        (1, 0): perm[b] + cz,
        (1, 1): perm[b + 1] + cz,
    }
    g, ramp = {}, {}
    for c in CORNERS:
        h = perm[row[c[0], c[1]] + c[2]] & 15
        g[c] = grads[:, h]  # (3, n): this corner's gradient vector
        ramp[c] = sum(g[c][j] * (frac[j] - c[j]) if c[j] else g[c][j] * frac[j] for j in range(3))
    weight, slope = zip(*(_fade(frac[j]) for j in range(3)), strict=True)
    out = []
    for j in axes:
        # ∂trilerp/∂u_j: the blend over the other two axes of the differences along j.
        k, m = (q for q in range(3) if q != j)
        diff = {}
        for c in CORNERS:
            if c[j] == 0:
                upper = tuple(1 if q == j else c[q] for q in range(3))
                diff[c[k], c[m]] = ramp[upper] - ramp[c]
        along = _lerp(
            weight[m],
            _lerp(weight[k], diff[0, 0], diff[1, 0]),
            _lerp(weight[k], diff[0, 1], diff[1, 1]),
        )
        corner_g = {c: g[c][j] for c in CORNERS}
        out.append(slope[j] * along + _trilerp(*weight, corner_g))
    return out


def numpy_curl_noise(
    noise: motes.CurlNoise, position: np.ndarray, time: float, out: np.ndarray
) -> None:
    """``out += strength · ∇×ψ(x / scale)`` in NumPy: the same field as ``CurlNoise``.

    Particles weigh 1 kg here (no ``mass`` attribute), so force equals acceleration.
    """
    real = position.dtype.type
    grads = np.ascontiguousarray(perlin_gradients().T.astype(position.dtype))
    shift = real(float(noise.time_scale * time) % 256)
    p = position * real(1.0 / noise.scale)
    d = []  # d[k][j]: ∂ψ_k/∂p_j, only the four components the curl uses
    for k in range(3):
        q = p.copy()
        q[k] += shift
        axes = tuple(j for j in range(3) if j != k)
        total = dict.fromkeys(axes, 0)
        frequency, amplitude = real(1), real(1)
        for _ in range(noise.octaves):
            parts = numpy_noise_gradient(
                frequency * q, noise.permutations[k].astype(np.intp), grads, axes
            )
            for j, part in zip(axes, parts, strict=True):
                total[j] = total[j] + amplitude * part
            frequency, amplitude = frequency + frequency, amplitude * real(0.5)
        d.append(total)
    s = real(noise.strength)
    out[0] += s * (d[2][1] - d[1][2])
    out[1] += s * (d[0][2] - d[2][0])
    out[2] += s * (d[1][0] - d[0][1])


class NumpyFire:
    """A fire step in plain vectorised NumPy, read off a motes system: the baseline.

    State is one ``(3, n)`` / ``(4, n)`` / ``(n,)`` array per attribute, copied from the
    system's store. Each step emits with the system's own emitter samplers (motes'
    emission is already vectorised NumPy), then in NumPy: curl noise, gravity and linear
    drag, semi-implicit Euler, bouncing planes with friction, ageing, compaction of every
    array in the system's order (a boolean mask when stable; fancy-indexed moves from the
    tail into the holes when ``"swap"``), colour and size over life with ``np.interp``.
    """

    def __init__(self, system: motes.ParticleSystem, *, seed: int = 1):
        store = system.store
        n = store.count
        self.arrays = {
            name: store[name].T.copy() if store.raw(name).ndim == 2 else store[name].copy()
            for name in store.names
        }
        self.next_id = int(self.arrays["id"].max(initial=-1)) + 1
        # Own copies: a rate may carry state (PerSecond's fraction) between steps.
        self.emitters = [copy.copy(e) for e in system.emitters]
        for emitter in self.emitters:
            emitter.rate = copy.deepcopy(emitter.rate)
        self.noises = [f for f in system.forces if isinstance(f, motes.CurlNoise)]
        if len(self.noises) != len(system.forces):
            raise ValueError("the NumPy fire implements curl noise forces only")
        if store.has("mass") or store.has("inv_mass"):
            raise ValueError("the NumPy fire assumes 1 kg particles")
        terms = field_terms(system)
        acceleration = np.add(terms.gravity, terms.linear_drag_wind)  # the terms are tuples
        self.acceleration = acceleration.astype(np.float32)[:, None]
        self.drag = np.float32(terms.linear_drag)
        self.planes = [PlaneParams.of(c) for c in system.colliders]
        self.curves = [(m.attribute, m.curve, m.multiply) for m in system.modifiers]
        self.rng = np.random.default_rng(seed)
        self.time = system.time
        self.frame = system.frame
        self.count = n
        self.swap = store.compaction == "swap"
        #: Stage name -> seconds, filled by :meth:`step` when a dict (see stage_breakdown).
        self.timings: dict[str, float] | None = None

    def step(self, dt: float, *, emit: bool = True) -> None:
        clock = _Clock(self.timings)
        if emit:
            for emitter in self.emitters:
                self._emit(emitter, dt)
        clock.lap("emit")
        a = self.arrays
        position, velocity = a["position"], a["velocity"]
        force = np.zeros_like(position)
        for noise in self.noises:
            numpy_curl_noise(noise, position, self.time, force)
        clock.lap("curl noise")
        real = np.float32
        dt = real(dt)
        velocity += dt * (force + self.acceleration - self.drag * velocity)
        position += dt * velocity
        for plane in self.planes:
            plane.collide(position, velocity)
        a["age"] += dt
        keep = a["age"] < a["lifetime"]
        clock.lap("integrate, collide, age")
        self.time += float(dt)
        self.frame += 1
        if not keep.all():
            survivors = int(keep.sum())
            if self.swap:
                holes = np.flatnonzero(~keep[:survivors])
                sources = np.flatnonzero(keep[survivors:])[::-1] + survivors
                for name, array in a.items():
                    array[..., holes] = array[..., sources]
                    a[name] = array[..., :survivors]
            else:
                for name, array in a.items():
                    a[name] = array[..., keep]
            self.count = survivors
        clock.lap("compaction")
        t = a["age"] / a["lifetime"]
        for attribute, curve, multiply in self.curves:
            target = a[attribute]
            rows = target if target.ndim == 2 else target[None]
            base = a[f"birth_{attribute}"] if multiply else None
            base = None if base is None else (base if base.ndim == 2 else base[None])
            for c in range(rows.shape[0]):
                value = np.interp(t, curve.times, curve.values[:, c])
                rows[c] = value * base[c] if multiply else value
            clock.lap(f"{attribute} over life")

    def _emit(self, emitter: motes.Emitter, dt: float) -> None:
        rng = self.rng
        k = emitter.rate.count(rng, self.frame, self.time, dt, emitter)
        if k == 0:
            return
        local, normals = emitter.shape.sample(rng, k)
        new = {
            "position": (emitter.position_at(self.time) + local).T,
            "velocity": (
                emitter.direction.sample(rng, local, normals) * emitter.speed.sample(rng, k, 1)
            ).T,
            "lifetime": emitter.lifetime.sample(rng, k, 1)[:, 0],
            "age": np.zeros(k),
            "id": np.arange(self.next_id, self.next_id + k),
        }
        self.next_id += k
        for name, dist in emitter.initial.items():
            rows = self.arrays[name]
            values = dist.sample(rng, k, rows.shape[0] if rows.ndim == 2 else 1)
            new[name] = values.T if rows.ndim == 2 else values[:, 0]
        for name in self.arrays:
            if name.startswith("birth_") and name[6:] in new:
                new[name] = new[name[6:]]
            elif name not in new:
                new[name] = _defaults(name, self.arrays[name], k)
        for name, array in self.arrays.items():
            self.arrays[name] = np.concatenate([array, np.asarray(new[name], array.dtype)], axis=-1)
        self.count += k


def _defaults(name: str, array: np.ndarray, k: int) -> np.ndarray:
    """``k`` particles' worth of attribute ``name``'s default value, shaped like ``array``."""
    default = np.asarray(BUILTIN[name].default, dtype=array.dtype)
    if array.ndim == 1:
        return np.full(k, default)
    return np.broadcast_to(np.broadcast_to(default, array.shape[:1])[:, None], (array.shape[0], k))


class _Clock:
    """Adds the time since the previous lap to ``timings[name]`` (no-op without timings)."""

    def __init__(self, timings: dict | None):
        self.timings = timings
        self.last = time.perf_counter()

    def lap(self, name: str) -> None:
        if self.timings is None:
            return
        now = time.perf_counter()
        self.timings[name] = self.timings.get(name, 0.0) + now - self.last
        self.last = now


# -- the motes fire ---------------------------------------------------------------------
def fire_system(
    live: int, *, seed: int = 1, turbulence: bool = True, size: float = 1.0
) -> motes.ParticleSystem:
    """The demo fire with its birth rate set to hold ``live`` particles, pre-filled.

    Births balance deaths when ``rate = live / mean lifetime``. The store is filled with
    ``live`` particles in the steady state of that balance (:func:`prefill`), so timing
    can start at once instead of after a lifetime of ramp-up steps.
    """
    mean_lifetime = float(build_fire(capacity=1).emitters[0].lifetime.mean[0])
    per_frame = live / (mean_lifetime * FPS)
    # Headroom for the count's fluctuation about ``live`` (the rate has a variance).
    system = build_fire(
        capacity=int(1.25 * live) + 256,
        rate=per_frame,
        seed=seed,
        turbulence=turbulence,
        size=size,
    )
    prefill(system, live)
    return system


def prefill(system: motes.ParticleSystem, live: int) -> None:
    """Emit ``live`` particles at once, then give them steady-state ages and positions.

    At a constant birth rate, the particles alive at any time have lifetimes drawn with
    density proportional to ``L f(L)`` (long-lived ones are over-represented) and ages
    uniform in ``[0, L)``. Their state is that of a particle emitted ``age`` ago moving
    under gravity and linear drag alone (the closed-form solution); the curl noise and
    the ground then shape it during the warm-up steps.
    """
    emitter = system.emitters[0]
    rng = np.random.default_rng(12345)
    origins = np.broadcast_to(emitter.position_at(system.time), (live, 3))
    new = emitter.emit_at(system, origins, np.zeros((live, 3)))
    candidates = emitter.lifetime.sample(rng, 4 * live, 1)[:, 0]
    lifetime = rng.choice(candidates, size=new.stop - new.start, p=candidates / candidates.sum())
    age = rng.random(lifetime.shape) * lifetime
    terms = field_terms(system)
    k = terms.linear_drag
    g = np.add(terms.gravity, terms.linear_drag_wind)
    v0 = system["velocity"][new].astype(np.float64)
    x0 = system["position"][new].astype(np.float64)
    t = age[:, None]
    if k > 0:
        # x(t) = x0 + (g/k) t + (v0 - g/k)(1 - e^{-kt})/k,  v(t) = g/k + (v0 - g/k) e^{-kt}
        decay = np.exp(-k * t)
        terminal = g / k
        x = x0 + terminal * t + (v0 - terminal) * (1 - decay) / k
        v = terminal + (v0 - terminal) * decay
    else:
        x = x0 + v0 * t + 0.5 * g * t * t
        v = v0 + g * t
    system["position"][new] = x
    system["velocity"][new] = v
    system["lifetime"][new] = lifetime
    system["age"][new] = age


@contextmanager
def stage_timer(system: motes.ParticleSystem) -> Iterator[dict[str, float]]:
    """Accumulate the wall time [s] of each pipeline stage of the steps taken inside.

    Wraps, on the instances only, each emitter's ``emit``, each force's ``accumulate``,
    the system's fused-kernel and compaction calls and each modifier's ``apply``.
    Stages whose hook does not exist (the system's internals changed) are not reported.
    """
    totals: dict[str, float] = defaultdict(float)
    patched = []

    def wrap(obj, attr: str, name: str) -> None:
        original = getattr(obj, attr, None)
        if original is None:
            return

        def timed(*args, **kwargs):
            start = time.perf_counter()
            try:
                return original(*args, **kwargs)
            finally:
                totals[name] += time.perf_counter() - start

        setattr(obj, attr, timed)
        patched.append((obj, attr))

    for emitter in system.emitters:
        wrap(emitter, "emit", "emit")
    for force in system.forces:
        wrap(force, "accumulate", f"force: {type(force).__name__}")
    wrap(system, "_move", "fused kernel (field forces, integrate, collide, age)")
    wrap(system, "_extinguish", "compaction")
    for modifier in system.modifiers:
        wrap(modifier, "apply", type(modifier).__name__)
    try:
        yield totals
    finally:
        for obj, attr in patched:
            delattr(obj, attr)


def stage_breakdown(step, timer, steps: int) -> dict[str, float]:
    """Median time per step [s] of each stage, of the rest (``"other"``) and of the total.

    ``step()`` takes one step; ``timer()`` is a context manager yielding the dict into
    which the step's stages add their times.
    """
    per_step: dict[str, list[float]] = defaultdict(list)
    for _ in range(steps):
        with timer() as stages:
            start = time.perf_counter()
            step()
            total = time.perf_counter() - start
        for name, seconds in stages.items():
            per_step[name].append(seconds)
        per_step["other (orchestration)"].append(total - sum(stages.values()))
        per_step["total"].append(total)
    return {name: statistics.median(times) for name, times in per_step.items()}


@contextmanager
def _numpy_timer(baseline: NumpyFire) -> Iterator[dict[str, float]]:
    baseline.timings = {}
    try:
        yield baseline.timings
    finally:
        baseline.timings = None


def bench_fire(live: int, repeat: int, numpy_repeat: int, *, turbulence: bool = True) -> dict:
    """Time the motes fire and the NumPy fire from the same steady state."""
    system = fire_system(live, turbulence=turbulence)
    baseline = NumpyFire(system)
    timing = time_calls(lambda: system.step(DT), repeat=repeat, warmup=3)
    stages = stage_breakdown(
        lambda: system.step(DT), lambda: stage_timer(system), max(3, repeat // 3)
    )
    numpy = time_calls(lambda: baseline.step(DT), repeat=numpy_repeat)
    numpy_stages = stage_breakdown(
        lambda: baseline.step(DT), lambda: _numpy_timer(baseline), max(2, numpy_repeat // 3)
    )
    return {
        "timing": timing,
        "numpy": numpy,
        "speedup_vs_numpy": numpy.best / timing.best,
        "live_after": len(system),
        "numpy_live_after": baseline.count,
        "stages": stages,
        "numpy_stages": numpy_stages,
        "bytes_per_particle": system.store.bytes_per_particle,
    }


# -- report -----------------------------------------------------------------------------
def _time_text(timing: Timing, scale: float, unit: str) -> str:
    return f"{scale * timing.best:9.2f} {unit}/step (median {scale * timing.median:.2f})"


def _stage_rows(stages: dict[str, float], scale: float) -> list[tuple[str, str]]:
    total = stages["total"]
    return [
        (f"  {name}", f"{scale * t:9.2f}  {100 * t / total:5.1f} %") for name, t in stages.items()
    ]


def run(sizes: Sizes, *, quick: bool, out=print) -> dict:
    """Run the three benchmarks, print their tables and return the figures."""
    info = machine()
    threads = info["numba_threads"]
    one_thread = copy_bandwidth(16, sizes.bandwidth_columns)
    all_threads = copy_bandwidth(16, sizes.bandwidth_columns, threads=threads)
    # The floor must bound every kernel from below: the compiled in-place update on
    # every thread reaches rates NumPy's copies do not, so the floor is the fastest.
    stream = stream_bandwidth(4 * sizes.bandwidth_columns)
    bandwidth = max(one_thread, all_threads, *stream.values())
    figures: dict = {
        "date": datetime.date.today().isoformat(),
        "quick": quick,
        "sizes": {"ballistic": list(sizes.ballistic), "fire": sizes.fire, "small": sizes.small},
        "cpu_count": info["cpu_count"],
        "numba_threads": threads,
        "background_busy_cores": info["background_busy_cores"],
        "bandwidth_floor_gb_s": bandwidth / 1e9,
        "triad_bandwidth_gb_s": stream["triad"] / 1e9,
        "update_bandwidth_gb_s": stream["update"] / 1e9,
        "copy_bandwidth_gb_s": all_threads / 1e9,
        "copy_bandwidth_1thread_gb_s": one_thread / 1e9,
        "ballistic_bytes_per_particle": sum(ballistic_bytes().values()),
    }
    busy = info["background_busy_cores"]  # NaN without /proc/stat: no warning
    rows = [
        (
            "machine",
            f"{info['usable_cores']} usable cores (os.cpu_count {info['cpu_count']}), "
            f"{threads} Numba threads ({info['numba_threading_layer']}), "
            f"{info['processor']}",
        ),
        (
            "other load",
            f"{busy:.2f} cores busy with other processes at the start"
            + (" - parallel timings will be inflated" if busy > 0.25 else ""),
        ),
        ("versions", f"Python {info['python']}, NumPy {info['numpy']}, Numba {info['numba']}"),
        (
            "bandwidth floor",
            f"{bandwidth / 1e9:.2f} GB/s: the fastest of compiled STREAM kernels over "
            f"{4 * sizes.bandwidth_columns:,} float32 on {threads} threads (update "
            f"a += s b {stream['update'] / 1e9:.2f} GB/s, triad a = b + s c "
            f"{stream['triad'] / 1e9:.2f} GB/s, 12 B a value) and np.copyto of 16 x "
            f"{sizes.bandwidth_columns:,} float32, read + write "
            f"({all_threads / 1e9:.2f} GB/s on {threads} threads, "
            f"{one_thread / 1e9:.2f} on 1); best of 5 each",
        ),
        ("timings", "best of N single steps after warm-up steps (median in brackets)"),
    ]
    out(table(rows, title="motes emitter benchmark" + (" (--quick sizes)" if quick else "")))

    bytes_text = " + ".join(f"{name} {b}" for name, b in ballistic_bytes().items())
    rows = [("bytes moved / particle", f"{bytes_text} = {sum(ballistic_bytes().values())} B")]
    for i, (key, n) in enumerate(zip(BALLISTIC_KEYS, sizes.ballistic, strict=True)):
        r = bench_ballistic(n, bandwidth, sizes, numpy_baseline=i == 0)
        t = r["timing"]
        figures |= {
            f"{key}_ms": 1e3 * t.best,
            f"{key}_median_ms": 1e3 * t.median,
            f"{key}_floor_ms": 1e3 * r["floor"],
            f"{key}_floor_fraction": r["floor_fraction"],
        }
        rows.append((f"{n:>12,} particles", _time_text(t, 1e3, "ms")))
        rows.append(
            (
                "",
                f"floor {1e3 * r['floor']:.2f} ms -> {r['floor_fraction']:.2f} of the "
                "bandwidth floor (target >= 0.8)",
            )
        )
        if "numpy" in r:
            figures |= {
                f"{key}_numpy_ms": 1e3 * r["numpy"].best,
                f"{key}_speedup_vs_numpy": r["speedup_vs_numpy"],
            }
            rows.append(
                (
                    "",
                    f"NumPy (3, n) step {1e3 * r['numpy'].best:.2f} ms -> motes "
                    f"{r['speedup_vs_numpy']:.1f}x as fast",
                )
            )
    out()
    out(
        table(
            rows,
            title="1. Ballistic step: gravity, linear drag, ground plane with friction "
            "(float32, no deaths)",
        )
    )

    fire = bench_fire(sizes.fire, sizes.repeat, sizes.numpy_repeat)
    key = FIRE_KEY
    figures |= {
        f"{key}_ms": 1e3 * fire["timing"].best,
        f"{key}_median_ms": 1e3 * fire["timing"].median,
        f"{key}_numpy_ms": 1e3 * fire["numpy"].best,
        f"{key}_speedup_vs_numpy": fire["speedup_vs_numpy"],
        f"{key}_live": fire["live_after"],
        f"{key}_bytes_per_particle": fire["bytes_per_particle"],
    }
    figures |= {f"{key}_stage_{_slug(name)}_ms": 1e3 * t for name, t in fire["stages"].items()}
    figures |= {
        f"{key}_numpy_stage_{_slug(name)}_ms": 1e3 * t for name, t in fire["numpy_stages"].items()
    }
    rows = [
        (
            "live particles",
            f"{sizes.fire:,} held (after timing: motes {fire['live_after']:,}, "
            f"NumPy {fire['numpy_live_after']:,}); "
            f"store {fire['bytes_per_particle']} B/particle",
        ),
        ("motes", _time_text(fire["timing"], 1e3, "ms")),
        ("NumPy baseline", _time_text(fire["numpy"], 1e3, "ms")),
        ("", "(the same step: the emitter's own NumPy samplers, then NumPy Perlin curl noise"),
        ("", " = the same field, (3, n) arrays, boolean-mask compaction, np.interp curves)"),
        ("speed-up", f"{fire['speedup_vs_numpy']:9.1f}x (target >= 10x)"),
        ("motes stages", "ms/step, median"),
        *_stage_rows(fire["stages"], 1e3),
        ("NumPy stages", "ms/step, median"),
        *_stage_rows(fire["numpy_stages"], 1e3),
    ]
    out()
    out(
        table(
            rows,
            title="2. Fire held at a steady live count: the demo fire (disc emitter, "
            "buoyancy, drag, curl noise, ground, colour & size over life)",
        )
    )

    # The small system shows fixed per-step costs: the fire without its curl noise (a
    # compute-bound force, ~95 ns per particle per thread, that would be most of the step).
    # The same fire with turbulence is reported beside it.
    for key, turbulence, title in (
        (SMALL_KEY, False, "the fire without curl noise (fixed costs)"),
        (SMALL_FIRE_KEY, True, "the whole fire, curl noise included"),
    ):
        small = bench_fire(sizes.small, 20 * sizes.repeat, 10 * sizes.repeat, turbulence=turbulence)
        figures |= {
            f"{key}_us": 1e6 * small["timing"].best,
            f"{key}_median_us": 1e6 * small["timing"].median,
            f"{key}_numpy_us": 1e6 * small["numpy"].best,
            f"{key}_speedup_vs_numpy": small["speedup_vs_numpy"],
        }
        figures |= {f"{key}_stage_{_slug(name)}_us": 1e6 * t for name, t in small["stages"].items()}
        target = " (target <= 100 us)" if key == SMALL_KEY else ""
        rows = [
            ("motes", _time_text(small["timing"], 1e6, "us") + target),
            ("NumPy baseline", _time_text(small["numpy"], 1e6, "us")),
            ("speed-up", f"{small['speedup_vs_numpy']:9.2f}x"),
            ("motes stages", "us/step, median"),
            *_stage_rows(small["stages"], 1e6),
        ]
        out()
        out(table(rows, title=f"3. Small system, {sizes.small:,} live particles: {title}"))
    return figures


def _slug(name: str) -> str:
    word = "".join(ch if ch.isalnum() else "_" for ch in name.split("(")[0].lower())
    return "_".join(part for part in word.split("_") if part)


def main(argv: list[str] | None = None) -> dict:
    return benchmark_main(
        argv,
        prog="python -m benchmarks.emitter",
        doc=__doc__,
        quick_help="10k/100k ballistic, 100k fire",
        run=lambda quick: run(Sizes.quick() if quick else Sizes.full(), quick=quick),
    )


if __name__ == "__main__":
    main()
