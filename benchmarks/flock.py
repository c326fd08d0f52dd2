"""Flock benchmark: one step of a million boids, and the same step in NumPy with a k-d tree.

Run from the repository root::

    PYTHONPATH=src python -m benchmarks.flock           # full sizes, about a minute on 2 cores
    PYTHONPATH=src python -m benchmarks.flock --quick   # shrunk sizes, seconds

The flock (:func:`benchmark_flock`) is ``n`` boids spread uniformly in a cube at 0.25
boids/m³ (the cube's side grows with ``n``), flying at 8 m/s in random directions, with
the default rules of :class:`motes.flock.Flock` (separation 0.5 m, alignment 1.5 m,
cohesion 2 m, fields of view 300°/270°/270°: about seven boids seen per boid) and obstacle
avoidance against a ground plane and a ball in the middle of the cube. Figures, all
measured in the same run:

- ``flock_1m_ms``, ``flock_100k_ms``: milliseconds per step (best of several, after a
  warm-up step) at 1,000,000 and 100,000 boids: the grid sort and the fused step;
- ``flock_speedup_vs_numpy``: the same step at 100,000 boids written with NumPy and
  ``scipy.spatial.cKDTree`` (:class:`NumpyFlock`: pairs from ``query_pairs``, the rules
  by ``np.bincount``), over motes' time.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from motes.colliders import Plane, Sphere
from motes.flock import AvoidColliders, Flock, Limits

from ._common import benchmark_main, machine, table, time_calls

DT = 1 / 60
DENSITY = 0.25  # boids per m³
LIMITS = Limits(min_speed=4.0, max_speed=12.0, max_acceleration=30.0, max_turn_rate=360.0)


def benchmark_flock(n: int, *, seed: int = 1) -> Flock:
    """The benchmark's flock of ``n`` boids (see the module docstring)."""
    side = (n / DENSITY) ** (1 / 3)
    half = side / 2
    flock = Flock.in_box(n, (-half,) * 3, (half,) * 3, speed=8.0, seed=seed, limits=LIMITS)
    obstacles = [Plane((0, 1, 0), -half - 1.0), Sphere((0, 0, 0), side / 8)]
    return flock.add(AvoidColliders(obstacles, lookahead=1.0, margin=2.0, weight=4.0))


class NumpyFlock:
    """The step of :class:`~motes.flock.Flock` (the three rules, obstacle avoidance
    against planes and spheres, the limits and the move) in NumPy, float64, with
    neighbours from ``scipy.spatial.cKDTree.query_pairs``: the baseline of the speed-up.
    """

    def __init__(self, flock: Flock):
        self.flock = flock
        self.position = flock.position.T.astype(np.float64)
        self.velocity = flock.velocity.T.astype(np.float64)
        self.heading = flock.heading.T.astype(np.float64)
        self.obstacles = flock.avoidance.table if flock.avoidance is not None else np.zeros((0, 23))

    def step(self, dt: float) -> None:
        f, lim = self.flock, self.flock.limits
        p, v, h = self.position, self.velocity, self.heading
        n = len(p)
        rules = [r for r in (f.separation, f.alignment, f.cohesion) if r.weight > 0]
        pairs = cKDTree(p).query_pairs(max(r.radius for r in rules), output_type="ndarray")
        i = np.concatenate([pairs[:, 0], pairs[:, 1]])
        j = np.concatenate([pairs[:, 1], pairs[:, 0]])
        d = p[j] - p[i]
        d2 = np.einsum("ij,ij->i", d, d)
        dist = np.sqrt(d2)
        ahead = np.einsum("ij,ij->i", d, h[i])

        def seen(rule):
            return (d2 <= rule.radius**2) & (ahead >= rule.cos_half_fov * dist)

        def total(values):
            return np.stack([np.bincount(i, values[:, k], n) for k in range(3)], axis=1)

        ms = seen(f.separation) & (dist > 0)
        ma, mc = seen(f.alignment), seen(f.cohesion)
        s = np.where(ms, 1 / np.where(dist > 0, dist, 1) - 1 / f.separation.radius, 0)
        acc = f.separation.weight * lim.max_speed * -total(d * s[:, None])
        ali = total(v[j] * ma[:, None])
        has = np.bincount(i, ma, n) > 0
        acc[has] += f.alignment.weight * (_toward(ali[has], lim.max_speed) - v[has])
        count = np.bincount(i, mc, n)
        has = count > 0
        centre = total(d * mc[:, None])[has] / count[has, None]
        reach = np.minimum(1.0, np.linalg.norm(centre, axis=1) / f.cohesion.radius)
        acc[has] += f.cohesion.weight * (_toward(centre, lim.max_speed * reach) - v[has])
        acc += self._avoid(p, v, h)
        norm = np.linalg.norm(acc, axis=1)
        acc *= np.minimum(1.0, lim.max_acceleration / np.maximum(norm, 1e-30))[:, None]
        w = v + acc * dt
        speed = np.linalg.norm(w, axis=1)
        u = np.where(speed[:, None] > 1e-6, w / np.maximum(speed, 1e-30)[:, None], h)
        turn = min(np.radians(lim.max_turn_rate) * dt, np.pi)
        c = np.einsum("ij,ij->i", u, h)
        far = c < np.cos(turn)
        q = u[far] - c[far, None] * h[far]
        q /= np.maximum(np.linalg.norm(q, axis=1), 1e-30)[:, None]
        u[far] = _toward(np.cos(turn) * h[far] + np.sin(turn) * q, 1.0)
        speed = np.clip(speed, lim.min_speed, lim.max_speed)
        v = u * speed[:, None]
        p = p + v * dt
        p, v = self._keep_out(p, v)
        vs = np.linalg.norm(v, axis=1)
        self.heading = np.where(vs[:, None] > 1e-6, v / np.maximum(vs, 1e-30)[:, None], u)
        self.position, self.velocity = p, v

    def _distance(self, row, p):
        g = row[8:]
        if int(row[0]) == 0:  # plane
            return p @ g[:3] - g[3], np.broadcast_to(g[:3], p.shape)
        off = p - g[:3]
        dist = np.linalg.norm(off, axis=1)
        return dist - g[3], off / np.maximum(dist, 1e-30)[:, None]

    def _avoid(self, p, v, h):
        f = self.flock
        acc = np.zeros_like(p)
        if f.avoidance is None:
            return acc
        margin = f.avoidance.margin
        gain = f.avoidance.weight * f.limits.max_speed / margin
        probe = p + v * f.avoidance.lookahead
        for row in self.obstacles:
            d, normal = self._distance(row, p)
            acc += (gain * np.maximum(margin - d, 0))[:, None] * normal
            d, normal = self._distance(row, probe)
            side = normal - np.einsum("ij,ij->i", normal, h)[:, None] * h
            length = np.linalg.norm(side, axis=1)
            near = (d < margin) & (length >= 1e-3)
            acc[near] += (gain * (margin - d[near]) / length[near])[:, None] * side[near]
        return acc

    def _keep_out(self, p, v):
        radius = self.flock.radius
        for _ in range(2):
            for row in self.obstacles:
                d, normal = self._distance(row, p)
                inside = d < radius
                p = p + np.where(inside, radius - d, 0)[:, None] * normal
                vn = np.minimum(np.einsum("ij,ij->i", v, normal), 0)
                v = v - np.where(inside, vn, 0)[:, None] * normal
        return p, v


def _toward(d, speed):
    length = np.linalg.norm(d, axis=1, keepdims=True)
    return d * (np.asarray(speed).reshape(-1, 1) / np.where(length > 0, length, np.inf))


def time_motes(n: int, repeat: int) -> float:
    flock = benchmark_flock(n)
    return time_calls(lambda: flock.step(DT), repeat=repeat, warmup=2).best


def time_numpy(n: int, repeat: int) -> float:
    baseline = NumpyFlock(benchmark_flock(n))
    return time_calls(lambda: baseline.step(DT), repeat=repeat, warmup=1).best


def run(quick: bool) -> dict:
    big, small = (100_000, 20_000) if quick else (1_000_000, 100_000)
    repeat = 3 if quick else 5
    big_s = time_motes(big, repeat)
    small_s = time_motes(small, repeat)
    numpy_s = time_numpy(small, 2 if quick else 3)
    figures = {
        "quick": quick,
        "flock_1m_ms": big_s * 1e3,
        "flock_100k_ms": small_s * 1e3,
        "flock_numpy_100k_ms": numpy_s * 1e3,
        "flock_speedup_vs_numpy": numpy_s / small_s,
        **machine(),
    }
    print(
        table(
            [
                (f"motes, {big:,} boids", f"{big_s * 1e3:9.1f} ms per step (target <= 100)"),
                (f"motes, {small:,} boids", f"{small_s * 1e3:9.1f} ms per step"),
                (f"NumPy + cKDTree, {small:,}", f"{numpy_s * 1e3:9.1f} ms per step"),
                ("speed-up", f"{numpy_s / small_s:9.1f}x (target >= 20)"),
            ],
            title="Flock step: three rules, obstacle avoidance, limits, move",
        )
    )
    return figures


def main(argv: list[str] | None = None) -> dict:
    return benchmark_main(
        argv,
        prog="python -m benchmarks.flock",
        doc=__doc__,
        quick_help="100,000 and 20,000 boids",
        run=run,
    )


if __name__ == "__main__":
    main()
