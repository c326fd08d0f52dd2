"""Swept (a-priori) detection: the one path test against a twin, and in the fused step
of particle systems (time-of-impact bounces, thin walls, capsules and meshes)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

import motes as mo
from motes.collide import Box, Capsule, Plane, Sphere, TriangleMeshCollider
from motes.geometry.sweep import first_hit
from naive_distance import signed_distance


def _rotation(seed):
    q = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))[0]
    return q * np.sign(np.linalg.det(q))


ROTATION = _rotation(3)
SHAPES = {
    "sphere": Sphere((0.2, -0.1, 0.3), 0.7),
    "tank": Sphere((0.0, 0.1, 0.0), 1.2, inside=True),
    "capsule": Capsule((-0.4, -0.3, 0.1), (0.5, 0.4, -0.2), 0.35),
    "box": Box(
        (0.1, 0.0, -0.2),
        (1.0, 0.6, 1.4),
        rotation=ROTATION,
    ),
    "box tank": Box((0.0, 0.0, 0.0), (2.0, 1.6, 2.4), inside=True),
}


def twin_first_hit(row, x0, d, r, samples=20001):
    """First fraction where the chord's distance drops below ``r``: dense sampling, then
    bisection to round-off. Also the least sampled clearance (for grazing paths)."""
    f = np.linspace(0.0, 1.0, samples)
    dist, _ = signed_distance(row, x0 + f[:, None] * d)
    below = np.flatnonzero(dist < r)
    if dist[0] < r:
        return None, dist.min() - r  # starts in the solid: not an entry
    if below.size == 0:
        return None, dist.min() - r
    lo, hi = f[below[0] - 1], f[below[0]]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        inside = signed_distance(row, (x0 + mid * d)[None])[0][0] < r
        lo, hi = (lo, mid) if inside else (mid, hi)
    return hi, None


@pytest.mark.parametrize("shape", list(SHAPES))
def test_entry_matches_a_sampling_twin(shape):
    collider = SHAPES[shape]
    table = collider.packed()[None]
    rng = np.random.default_rng(5)
    hits = 0
    for _ in range(300):
        x0 = rng.uniform(-1.5, 1.5, 3)
        if collider.inside:  # from within, outward
            x0 *= 0.5
            d = rng.normal(scale=1.5, size=3)
        else:  # from around, mostly toward it
            d = (rng.uniform(-0.6, 0.6, 3) - x0) * rng.uniform(0.3, 1.5)
        # Boxes grow by slabs (square corners), the twin's distance rounds them: r = 0.
        r = 0.0 if "box" in shape else rng.uniform(0.0, 0.05)
        f, nx, ny, nz = first_hit(
            int(collider.kind), collider.inside, table, 0, *x0, *d, 0.0, 0.0, 0.0, r, 1.0
        )
        want, clearance = twin_first_hit(table[0], x0, d, r)
        if want is None:
            # No entry, or one the sampling steps over: a path grazing within a step.
            assert f > 1.0 or clearance < 1e-3 * np.linalg.norm(d)
            continue
        hits += 1
        # The twin's bisection and the closed forms agree to round-off on O(1) values.
        assert f == pytest.approx(want, abs=1e-9)
        _, normal = signed_distance(table[0], (x0 + f * d)[None])
        # Box corners and edges: the slab face's normal, not the rounded one.
        if shape != "box":
            assert_allclose((nx, ny, nz), normal[0], atol=1e-6)
    assert hits > 40


def test_a_bent_path_meets_a_plane_at_the_parabola_root():
    plane = Plane((0.0, 1.0, 0.0), 0.0)
    table = plane.packed()[None]
    # x(f) = x0 + (d - b) f + b f²: dropped from rest at 0.1 m under gravity for 0.2 s.
    h, g = 0.2, -9.81
    x0 = np.array([0.0, 0.1, 0.0])
    b = np.array([0.0, 0.5 * g * h * h, 0.0])
    d = b.copy()  # starting at rest: d - b = v0 h = 0
    f, *_ = first_hit(0, False, table, 0, *x0, *d, *b, 0.0, 1.0)
    assert f * h == pytest.approx(np.sqrt(2 * 0.1 / 9.81), rel=1e-12)


def dropped(integrator, restitution, detection, steps=90, dt=1 / 60):
    """Height [m] over time of a particle dropped from 1 m onto a plane."""
    system = mo.ParticleSystem(capacity=1, integrator=integrator)
    system.add(mo.forces.Gravity((0.0, -9.81, 0.0)))
    system.add(Plane((0.0, 1.0, 0.0), 0.0, restitution=restitution, detection=detection))
    system.store.spawn(1)
    system.store.raw("position")[:, 0] = (0.0, 1.0, 0.0)
    system.store.raw("velocity")[:, 0] = 0.0
    system.store.raw("lifetime")[0] = 100.0
    heights = []
    for _ in range(steps):
        system.step(dt)
        heights.append(float(system.store.raw("position")[1, 0]))
    return np.array(heights)


def apex_after_first_bounce(heights):
    rising = np.flatnonzero(np.diff(heights) > 0)[0]
    return heights[rising:].max()


# Each integrator compiles a step kernel of its own: the default tier keeps one.
@pytest.mark.parametrize(
    "integrator",
    [
        "semi_implicit_euler",
        pytest.param("explicit_euler", marks=pytest.mark.slow),
        pytest.param("verlet", marks=pytest.mark.slow),
    ],
)
@pytest.mark.parametrize("restitution", [0.8, 0.5])
def test_a_swept_bounce_rebounds_to_e_squared_of_the_drop(integrator, restitution):
    apex = apex_after_first_bounce(dropped(integrator, restitution, "priori"))
    # At steps of 1/60 s: the bounce at the time of impact on each scheme's own parabola
    # leaves only the apex's sampling by the steps (g h²/8 / e² < 0.1 %) and float32.
    assert apex == pytest.approx(restitution**2, rel=0.01)


@pytest.mark.slow
def test_after_the_move_the_same_bounce_misses_by_percents():
    apex = apex_after_first_bounce(dropped("semi_implicit_euler", 0.8, "posteriori"))
    assert abs(apex / 0.64 - 1) > 0.03  # what swept detection mends


def test_a_ball_at_rest_on_a_swept_plane_stays_there():
    heights = dropped("semi_implicit_euler", 0.5, "priori", steps=600)
    assert np.all(heights > -1e-6)
    assert heights[-60:].max() < 1e-3


def shot(collider, speed=100.0, n=256, steps=6, dt=1 / 60, **system_args):
    """x of ``n`` particles fired along +x at ``speed`` [m/s] toward x = 0."""
    rng = np.random.default_rng(9)
    system = mo.ParticleSystem(capacity=n, **system_args)
    system.add(collider)
    system.store.spawn(n)
    start = np.c_[-2.0 - rng.uniform(0, speed * dt, n), rng.uniform(-1, 1, (n, 2))]
    system.store.raw("position")[:, :n] = start.T
    system.store.raw("velocity")[:, :n] = np.array([[speed], [0.0], [0.0]])
    system.store.raw("lifetime")[:n] = 100.0
    system.run(steps, dt)
    return system.store.raw("position")[0, : len(system)]


WALLS = {
    "box": lambda det: Box((0.0, 0.0, 0.0), (0.01, 4.0, 4.0), restitution=0.3, detection=det),
    "mesh": lambda det: TriangleMeshCollider(
        (
            np.array([[0, -2, -2], [0, 2, -2], [0, 2, 2], [0, -2, 2]], float),
            [[0, 1, 2], [0, 2, 3]],
        ),
        restitution=0.3,
        detection=det,
    ),
}


# Slow tier: each wall compiles two kernels of its own (swept and after the move); swept
# boxes and meshes stay in the default tier through the kill and mesh-plate tests.
@pytest.mark.slow
@pytest.mark.parametrize("wall", ["box", "mesh"])
def test_a_100_m_s_spark_never_passes_a_1_cm_wall(wall):
    assert np.all(shot(WALLS[wall]("priori")) < 0.0)
    # After the move alone, nearly every one passes (the wall is 1/167 of a step thick).
    assert np.mean(shot(WALLS[wall]("posteriori")) > 0.0) > 0.9


@pytest.mark.slow
def test_a_swept_hit_can_kill_and_is_reported():
    system = mo.ParticleSystem(capacity=8)
    system.add(Box((0.0, 0.0, 0.0), (0.01, 4.0, 4.0), response="kill", detection="priori"))
    hits = []
    system.on("collision", lambda event: hits.append(event.collider.copy()))
    system.store.spawn(8)
    system.store.raw("position")[:, :8] = np.array([[-0.5], [0.0], [0.0]])
    system.store.raw("velocity")[:, :8] = np.array([[100.0], [0.0], [0.0]])
    system.store.raw("lifetime")[:8] = 100.0
    system.step(1 / 60)
    assert len(system) == 0
    assert np.concatenate(hits).tolist() == [0] * 8


def fallen(collider, start, steps=40, dt=1 / 60):
    """Positions (n, 3) [m] of particles dropped from ``start`` (n, 3) onto ``collider``,
    and the least signed distance to it over every step (capsules; meshes: None)."""
    n = len(start)
    system = mo.ParticleSystem(capacity=n)
    system.add(mo.forces.Gravity((0.0, -9.81, 0.0)), collider)
    system.store.spawn(n)
    system.store.raw("position")[:, :n] = start.T
    system.store.raw("velocity")[:, :n] = 0.0
    system.store.raw("lifetime")[:n] = 100.0
    least = np.inf
    for _ in range(steps):
        system.step(dt)
        p = system.store.raw("position")[:, :n].T.astype(np.float64)
        if not isinstance(collider, TriangleMeshCollider):
            least = min(least, signed_distance(collider.packed(), p)[0].min())
    return p, least


@pytest.mark.slow
def test_particles_slide_off_a_capsule_and_never_enter_it():
    rng = np.random.default_rng(2)
    start = np.c_[
        rng.uniform(-0.5, 0.5, 400), rng.uniform(0.5, 1.0, 400), rng.uniform(-0.2, 0.2, 400)
    ]
    capsule = Capsule((-1.0, 0.0, 0.0), (1.0, 0.0, 0.0), 0.3, friction=0.0)
    p, least = fallen(capsule, start)
    assert least > -1e-5  # float32 push-out, 1e-5 of a 0.3 m radius
    # Each one landed on the round top and slid off to its own side, clear of the axis.
    away = np.abs(start[:, 2]) > 0.01
    assert np.all(np.sign(p[away, 2]) == np.sign(start[away, 2]))
    assert np.all(np.hypot(p[away, 1], p[away, 2]) > 0.3 - 1e-5)


@pytest.mark.slow
def test_particles_land_on_a_zero_thickness_mesh_plate():
    plate = TriangleMeshCollider(
        (
            np.array([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], float),
            [[0, 1, 2], [0, 2, 3]],
        ),
        restitution=0.0,
    )
    rng = np.random.default_rng(4)
    start = np.c_[
        rng.uniform(-0.8, 0.8, 300), rng.uniform(0.2, 1.0, 300), rng.uniform(-0.8, 0.8, 300)
    ]
    p, _ = fallen(plate, start, steps=60)
    # A shell without thickness cannot be found after the move: only the swept path
    # stops them, at the gap above it.
    assert np.all(p[:, 1] > -1e-5)
    assert np.all(p[:, 1] < 1e-3)
    # After the move alone, every one falls through.
    posteriori = TriangleMeshCollider(plate.mesh, restitution=0.0, detection="posteriori")
    q, _ = fallen(posteriori, start, steps=60)
    assert np.all(q[:, 1] < -1.0)
