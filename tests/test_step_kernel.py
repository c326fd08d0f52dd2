"""The fused step kernel against its NumPy twin, for every scheme, collider and response."""

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import naive
from motes.collide.colliders import Box, Plane, Sphere, pack
from motes.collide.contact import pack as pack_all
from motes.integrate.kernels import ONE, PARAM_COUNT, Scheme, step_kernel

#: The triangle-mesh arrays of a table without meshes.
NO_MESHES = pack_all([])[1:]

SCHEMES = {
    "explicit": Scheme.EXPLICIT_EULER,
    "semi": Scheme.SEMI_IMPLICIT_EULER,
    "verlet": Scheme.VERLET,
    "none": Scheme.NONE,
}


def rotation(angle, axis):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


COLLIDER_SETS = {
    "none": [],
    "ground": [Plane((0, 1, 0), -0.5, restitution=0.6, friction=0.3)],
    "sphere_depth": [Sphere((0.3, 0, 0), 1.0, friction=2.0, friction_model="depth")],
    "box_solid_rotated": [Box((0, 0.2, 0), (1.5, 1.0, 2.0), rotation=rotation(0.4, (1, 2, 3)))],
    "tank": [
        Box((0, 0, 0), (3, 3, 3), inside=True, restitution=0.2, friction=0.1),
        Sphere((0, 0, 0), 1.8, inside=True, restitution=1.0),
    ],
    "responses": [
        Plane((0, 1, 0), 0.0, response="stick"),
        Sphere((1, 1, 0), 0.7, response="kill"),
        Box((-1, 0.5, 0), (1, 1, 1), response="event"),
        Plane((1, 0, 0), -1.5, restitution=0.0, friction=1.0),
    ],
}

FIELDS = (
    np.array([0.0, -9.81, 0.5]),
    0.7,
    0.7 * np.array([1.0, 0.0, -0.5]),
    0.2,
    np.array([0.3, 0.0, 0.0]),
)


def run_kernel(scheme, colliders, state, *, with_force, with_mass, dt=0.05, damping=0.1):
    p, v, age, life, w, force = (np.array(a) for a in state)
    n = len(p)
    table, structure = pack(colliders)
    params = np.zeros(PARAM_COUNT)
    params[:11] = np.concatenate([FIELDS[0], [FIELDS[1]], FIELDS[2], [FIELDS[3]], FIELDS[4]])
    params[11], params[12], params[ONE] = dt, damping, 1.0
    kernel = step_kernel(int(SCHEMES[scheme]), structure, with_force, with_mass, True, True)
    pos, vel = (np.ascontiguousarray(a.T) for a in (p, v))
    keep = np.ones(n, dtype=bool)
    hits = np.full(n, -7, dtype=np.int32)
    dead = kernel(
        n,
        pos,
        vel,
        age,
        life,
        w if with_mass else np.ones(1),
        np.ascontiguousarray(force.T),
        params,
        table,
        *NO_MESHES,
        keep,
        hits,
    )
    return pos.T, vel.T, age, keep, hits, dead


def random_state(rng, n=2000):
    p = rng.uniform(-2, 2, (n, 3))
    v = rng.normal(0, 2, (n, 3))
    age = rng.uniform(0, 1, n)
    life = rng.uniform(0.5, 1.5, n)
    w = np.where(rng.random(n) < 0.1, 0.0, rng.uniform(0.5, 2, n))
    force = rng.normal(0, 1, (n, 3))
    return p, v, age, life, w, force


# Every scheme with the two richest collider sets, every collider set with one scheme:
# each combination compiles its own kernel (seconds), so the full product is not run.
# The default tier keeps every scheme with the richest set and every other set with one
# scheme; the ground cases (a plane, as in "responses") and the empty set (every scene
# without colliders runs it) are in the slow tier.
CASES = [
    pytest.param(s, c, marks=pytest.mark.slow) if c in ("ground", "none") else (s, c)
    for s, c in sorted(
        {(s, c) for s in SCHEMES for c in ("ground", "responses")}
        | {("semi", c) for c in COLLIDER_SETS}
    )
]


@pytest.mark.parametrize(("scheme", "collider_set"), CASES)
def test_kernel_matches_naive(rng, scheme, collider_set):
    colliders = COLLIDER_SETS[collider_set]
    state = random_state(rng)
    got = run_kernel(scheme, colliders, state, with_force=True, with_mass=True)
    p, v, age, life, w, force = state
    want = naive.step(
        scheme,
        p,
        v,
        age,
        life,
        w,
        force if scheme != "none" else 0 * force,
        FIELDS,
        colliders,
        0.05,
        0.1,
    )
    # float64 with fastmath reassociation: agreement to ~1e-12 relative; 1e-9 leaves margin.
    for g, e in zip(got[:3], want[:3], strict=True):
        assert_allclose(g, e, rtol=1e-9, atol=1e-9)
    assert_array_equal(got[3], want[3])
    assert_array_equal(got[4], want[4])
    assert got[5] == np.count_nonzero(~want[3])


def test_pinned_particles_do_not_move(rng):
    state = list(random_state(rng, 100))
    state[4] = np.zeros(100)  # inverse mass 0 everywhere
    p0, v0 = state[0].copy(), np.zeros((100, 3))
    state[1] = v0
    got = run_kernel("semi", [], state, with_force=True, with_mass=True)
    assert_array_equal(got[0], p0)
    assert_array_equal(got[1], v0)


def test_float32_kernel_close_to_float64(rng):
    state = random_state(rng)
    state32 = [a.astype(np.float32) for a in state]
    colliders = COLLIDER_SETS["ground"]
    p, v, age, life, _, force = state32
    table, structure = pack(colliders)
    params = np.zeros(PARAM_COUNT, np.float32)
    params[1], params[3], params[11], params[ONE] = -9.81, 0.5, 0.05, 1.0
    kernel = step_kernel(int(Scheme.SEMI_IMPLICIT_EULER), structure, False, False, False, False)
    pos, vel = np.ascontiguousarray(p.T), np.ascontiguousarray(v.T)
    keep = np.ones(len(p), bool)
    kernel(
        len(p),
        pos,
        vel,
        age,
        life,
        np.ones(1, np.float32),
        pos,
        params,
        table.astype(np.float32),
        *NO_MESHES,
        keep,
        np.empty(1, np.int32),
    )
    assert pos.dtype == np.float32
    ones = np.ones(len(p))
    want = naive.step(
        "semi",
        *(a.astype(np.float64) for a in state32[:4]),
        ones,
        0 * force,
        (np.array([0, -9.81, 0]), 0.5, np.zeros(3), 0.0, np.zeros(3)),
        colliders,
        0.05,
    )
    # float32 round-off on values of order 1: a few ulps (~1e-6).
    assert_allclose(pos.T, want[0], rtol=1e-5, atol=1e-5)
    assert_allclose(vel.T, want[1], rtol=1e-5, atol=1e-5)
