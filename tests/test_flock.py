"""Flocks: neighbour search against brute force, the rules' order and spacing, steering
behaviours, obstacles, determinism and input checks."""

import numba
import numpy as np
import pytest
from benchmarks.flock import NumpyFlock, benchmark_flock
from numpy.testing import assert_array_equal

from motes._jit import SERIAL_BELOW
from motes.collide.colliders import pack
from motes.colliders import Box, Plane, Sphere
from motes.flock import (
    Arrive,
    Avoid,
    AvoidColliders,
    Contain,
    Evade,
    Flee,
    Flock,
    FollowLeader,
    FollowPath,
    Limits,
    Pursue,
    Rule,
    Seek,
    Wander,
)
from motes.state import HasParticles
from naive_distance import signed_distance
from naive_flock import neighbor_sets

DT = 1 / 30


def by_id(flock, array):
    """``array`` (…, n) reordered by boid id."""
    return np.take(array, np.argsort(flock.ids), axis=-1)


@pytest.mark.parametrize(("radius", "fov"), [(0.7, 360.0), (1.1, 270.0), (0.4, 90.0)])
def test_neighbor_lists_equal_brute_force(radius, fov):
    flock = Flock.in_box(1500, (-3, -3, -3), (3, 3, 3), speed=1.0, seed=4)
    flock.step(DT)  # the arrays are now in grid order, not creation order
    rule = Rule(radius, 1.0, fov)
    lists = flock.neighbors(rule)
    expected, _ = neighbor_sets(flock.position, flock.heading, radius, rule.cos_half_fov)
    assert lists.offsets.shape == (flock.n + 1,)
    assert [set(lists.row(i).tolist()) for i in range(flock.n)] == expected
    assert lists.counts.sum() > 10 * flock.n * (fov / 360) * radius**3  # not trivially empty


def test_step_counts_the_neighbours_brute_force_finds():
    flock = Flock.in_box(1200, (-2.5, -2.5, -2.5), (2.5, 2.5, 2.5), speed=1.0, seed=8)
    flock.step(DT)
    ids, pos, head = flock.ids.copy(), flock.position.copy(), flock.heading.copy()
    flock.step(DT)
    counts = by_id(flock, flock.neighbor_count)
    seen = [neighbor_sets(pos, head, r.radius, r.cos_half_fov)[1].sum(axis=1)
            for r in (flock.separation, flock.alignment, flock.cohesion)]  # fmt: skip
    expected = np.max(seen, axis=0)[np.argsort(ids)]
    assert_array_equal(counts, expected)


# At 40,000 boids (a 54 m cube) most cells are out of the obstacles' reach, so the
# step's per-block collider cull leaves them out; at 3,000 it culls almost nothing.
@pytest.mark.parametrize("n", [3000, 40_000])
def test_one_step_equals_the_numpy_kdtree_step(n):
    flock = benchmark_flock(n, seed=2)
    flock.step(1 / 60)  # first step puts boids that started in the ball on its surface
    baseline = NumpyFlock(flock)
    ids = flock.ids.copy()  # the baseline keeps this order; the flock sorts again
    flock.step(1 / 60)
    baseline.step(1 / 60)
    # float32 against float64 over one step of 1/60 s: accelerations of up to 30 m/s²
    # agree to ~1e-5 relative, so positions to well under a micrometre and velocities
    # to ~1e-4 m/s; a few boids sit on a turn-limit or speed-limit edge and may round
    # to the other side, hence the loose bound and the 99.9 % quantile.
    order = np.argsort(ids)
    dp = np.abs(baseline.position.T[:, order] - by_id(flock, flock.position)).max(axis=0)
    dv = np.abs(baseline.velocity.T[:, order] - by_id(flock, flock.velocity)).max(axis=0)
    assert np.quantile(dp, 0.999) < 1e-5
    assert np.quantile(dv, 0.999) < 1e-3


def test_alignment_alone_orders_a_random_flock():
    # 2,000 boids in an 8 m cube, each seeing those within 2 m all around (~115): the
    # polarisation |mean heading| starts near 1/sqrt(n) ~ 0.03 and rises above 0.9
    # within 4 s (measured 0.96); separation and cohesion are off.
    flock = Flock.in_box(
        2000, (-4, -4, -4), (4, 4, 4), speed=1.0, seed=3,
        separation=Rule(0.5, 0.0), cohesion=Rule(2.0, 0.0),
        alignment=Rule(2.0, 10.0, 360.0), limits=Limits(0.1, 1.0, 50.0, 720.0),
    )  # fmt: skip
    assert flock.polarization() < 0.1
    for _ in range(120):
        flock.step(DT)
    assert flock.polarization() > 0.9


def test_separation_keeps_boids_apart_after_settling():
    # 3,000 boids packed at ~14 per m³ (mean spacing 0.4 m) spread out; after 5 s no
    # pair is closer than half the separation radius (measured: 0.66 of it).
    from scipy.spatial import cKDTree

    radius = 0.6
    flock = Flock.in_box(
        3000, (-3, -3, -3), (3, 3, 3), speed=2.0, seed=1,
        separation=Rule(radius, 6.0, 360.0), alignment=Rule(1.0, 1.0, 360.0),
        cohesion=Rule(1.5, 1.0, 360.0), limits=Limits(1.0, 3.0, 10.0, 360.0),
    )  # fmt: skip
    for _ in range(100):
        flock.step(DT)
    closest = np.inf
    for _ in range(50):
        flock.step(DT)
        d, _ = cKDTree(flock.position.T).query(flock.position.T, k=2)
        closest = min(closest, d[:, 1].min())
    assert closest > 0.5 * radius


def test_boids_never_enter_spheres_boxes_planes_or_leave_a_tank():
    obstacles = [
        Sphere((0, 0, 0), 2.0),
        Box((5, 0, 0), (1, 6, 6), rotation=[[1, 0, 0], [0, 0.8, -0.6], [0, 0.6, 0.8]]),
        Plane((0, 1, 0), -3.0),
        Box((0, 1, 0), (30, 10, 12), inside=True),
    ]
    flock = Flock.in_box(2000, (-10, -2, -2), (-6, 2, 2), speed=3.0, direction=(1, 0, 0), seed=1,
                         limits=Limits(1.0, 6.0, 30.0, 360.0), radius=0.1)  # fmt: skip
    flock.add(Seek((12, 0, 0), 2.0), AvoidColliders(obstacles, lookahead=0.5, margin=1.0))
    table, _ = pack(obstacles)
    closest = np.inf
    for _ in range(150):
        flock.step(DT)
        for row in table:
            closest = min(closest, signed_distance(row, flock.position.T)[0].min())
    # Put back at the radius (float32 rounding of positions ~10 m: 1e-6 m).
    assert closest >= 0.1 - 1e-5
    assert flock.position[0].mean() > 5.0  # and they got past the obstacles toward x = 12


def test_boids_go_around_a_triangle_mesh_wall_and_never_cross_it():
    """A plate of 8 x 8 squares (a thin two-sided shell) stands across the flock's way to
    its goal: boids steer around its edges; none passes through it, even at 6 m/s
    (0.2 m per step, twice the plate's stand-off)."""
    from motes.colliders import TriangleMeshCollider

    side = np.linspace(-3.0, 3.0, 9)
    y, z = np.meshgrid(side, side, indexing="ij")
    vertices = np.stack([np.zeros(y.size), y.ravel(), z.ravel()], axis=1)
    quads = np.arange(81).reshape(9, 9)[:-1, :-1].ravel()
    faces = np.concatenate([np.stack([quads, quads + 9, quads + 10], 1),
                            np.stack([quads, quads + 10, quads + 1], 1)])  # fmt: skip
    wall = TriangleMeshCollider((vertices, faces))
    flock = Flock.in_box(1500, (-8, -1, -1), (-4, 1, 1), speed=4.0, direction=(1, 0, 0),
                         seed=3, limits=Limits(1.0, 6.0, 30.0, 360.0), radius=0.1)  # fmt: skip
    flock.add(Seek((10, 0, 0), 3.0), AvoidColliders([wall], lookahead=0.6, margin=1.0))
    crossed = 0
    closest = np.inf
    for _ in range(200):
        before = np.empty_like(flock.position)
        before[:, flock.ids] = flock.position  # the flock reorders its boids every step
        flock.step(DT)
        after = np.empty_like(flock.position)
        after[:, flock.ids] = flock.position
        through = (np.sign(before[0]) != np.sign(after[0])) & (
            np.maximum(np.abs(after[1]), np.abs(after[2])) < 3.0
        )
        crossed += int(through.sum())
        inside = np.maximum(np.abs(after[1]), np.abs(after[2])) < 3.0
        if inside.any():
            closest = min(closest, float(np.abs(after[0, inside]).min()))
    assert crossed == 0
    assert closest >= 0.1 - 1e-5  # kept a radius from the plate
    assert (flock.position[0] > 0).mean() > 0.5  # most got around it toward the goal


def flock_state(threads, seed=7, steps=15):
    previous = numba.get_num_threads()
    numba.set_num_threads(threads)
    try:
        prey = Flock.in_box(12_000, (-12, -12, -12), (12, 12, 12), speed=5.0, seed=seed)
        falcon = Flock.in_box(3, (-2, -2, -2), (2, 2, 2), speed=8.0, seed=seed + 1,
                              limits=Limits(5.0, 15.0, 40.0, 360.0))  # fmt: skip
        prey.add(Wander(1.0, 2.0, 3.0, 1.0), Evade(falcon, 6.0, 4.0))
        prey.add(Contain((-20,) * 3, (20,) * 3), AvoidColliders([Sphere((0, 0, 0), 3.0)]))
        falcon.add(Pursue(prey, 10.0, 3.0))
        for _ in range(steps):
            prey.step(1 / 60)
            falcon.step(1 / 60)
        return {name: by_id(prey, getattr(prey, name)) for name in
                ("position", "velocity", "heading", "bank", "flap", "wander")}  # fmt: skip
    finally:
        numba.set_num_threads(previous)


def test_same_seed_gives_the_same_flock_on_one_and_two_threads():
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("needs two Numba threads")
    one = flock_state(1)
    two = flock_state(2)
    assert SERIAL_BELOW < 12_000  # two threads really run in parallel
    for name in one:
        assert_array_equal(one[name], two[name], err_msg=name)
    other_seed = flock_state(2, seed=8)
    assert not np.array_equal(one["position"], other_seed["position"])


def run(flock, seconds, dt=DT):
    for _ in range(round(seconds / dt)):
        flock.step(dt)
    return flock


def small_flock(n=200, **options):
    options.setdefault("limits", Limits(0.0, 4.0, 20.0, 360.0))
    return Flock.in_box(n, (-1, -1, -1), (1, 1, 1), speed=1.0, seed=5, **options)


def test_seek_arrive_and_flee():
    seek = run(small_flock().add(Seek((20, 0, 0), 4.0)), 3.0)
    assert seek.velocity[0].mean() > 3.0  # heading for +x (cohesion holds them below 4 m/s)
    arrive = run(small_flock().add(Arrive((6, 0, 0), 3.0, 3.0)), 8.0)
    centre = arrive.position.mean(axis=1)
    assert np.linalg.norm(centre - (6, 0, 0)) < 1.0
    # Slowed down on arrival: 200 boids cannot all stop on a point (separation keeps
    # them apart, so they mill about it), but they mill far below the 4 m/s of a seek.
    assert np.linalg.norm(arrive.velocity, axis=0).mean() < 1.5
    flee = run(small_flock().add(Flee((0, 0, 0), 10.0, 3.0)), 3.0)
    assert np.linalg.norm(flee.position, axis=0).min() > 4.0


def test_containment_keeps_a_wandering_flock_near_its_box():
    flock = small_flock(500).add(Wander(1.0, 2.0, 4.0, 2.0), Contain((-5,) * 3, (5,) * 3, 2.0, 4.0))
    lo = np.inf
    hi = -np.inf
    for _ in range(300):
        flock.step(DT)
        lo, hi = min(lo, flock.position.min()), max(hi, flock.position.max())
    # Pushed back from 2 m inside each face at up to 4 m/s: they may overshoot a face
    # by a little, never by the 4 m they would cover in a second of free flight.
    assert lo > -6.0 and hi < 6.0
    assert hi - lo > 6.0  # they do wander through the box


def test_wander_turns_boids_seeded_and_smoothly():
    loners = small_flock(
        300, separation=Rule(0.5, 0.0), alignment=Rule(1.0, 0.0), cohesion=Rule(1.0, 0.0)
    )
    flock = run(loners.add(Wander(1.0, 2.0, 3.0, 2.0)), 2.0)
    assert flock.polarization() < 0.5  # every boid goes its own way
    assert np.allclose(np.linalg.norm(flock.wander, axis=0), 1.0, atol=1e-5)


def test_pursuit_closes_in_and_evasion_scatters():
    prey = Flock.in_box(2000, (-4, -4, -4), (4, 4, 4), speed=2.0, direction=(1, 0, 0), seed=2,
                        limits=Limits(1.0, 5.0, 30.0, 360.0))  # fmt: skip
    hawk = Flock(np.array([[-12.0], [0.0], [0.0]]), np.array([[6.0], [0.0], [0.0]]),
                 limits=Limits(4.0, 9.0, 40.0, 360.0))  # fmt: skip
    hawk.add(Pursue(prey, 30.0, 4.0))
    prey.add(Evade(hawk, 5.0, 6.0))

    def gap():
        return np.linalg.norm(prey.position - hawk.position, axis=0).min()

    start = gap()
    for _ in range(45):
        prey.step(DT)
        hawk.step(DT)
    assert gap() < 0.5 * start  # the hawk reached the flock...
    for _ in range(30):
        prey.step(DT)
        hawk.step(DT)
    near = np.linalg.norm(prey.position - hawk.position, axis=0) < 1.5
    assert near.sum() < 20  # ...which opened a hole around it


def test_strangers_keep_apart():
    a = Flock.in_box(500, (-3, -1, -1), (-0.5, 1, 1), speed=2.0, direction=(1, 0, 0), seed=1)
    b = Flock.in_box(500, (0.5, -1, -1), (3, 1, 1), speed=2.0, direction=(-1, 0, 0), seed=2)
    a.add(Avoid(b, 1.5, 8.0), Seek((10, 0, 0), 0.5))
    b.add(Avoid(a, 1.5, 8.0), Seek((-10, 0, 0), 0.5))
    closest = np.inf
    for _ in range(90):
        a.step(DT)
        b.step(DT)
        gaps = np.linalg.norm(a.position[:, :, None] - b.position[:, None, :], axis=0)
        closest = min(closest, gaps.min())
    assert closest > 0.1


def test_path_and_leader_following():
    path = np.array([[0, 0, 0], [10, 0, 0], [10, 0, 10], [20, 0, 10]], float)
    walkers = run(small_flock().add(FollowPath(path, 1.0, 0.5, 2.0, 3.0)), 8.0)
    # Spread along the path, close to it (its last segment runs along x at z = 10).
    assert walkers.position[0].mean() > 12.0
    assert np.abs(walkers.position[2] - 10.0).mean() < 2.0
    leader = Flock(np.array([[0.0], [0.0], [0.0]]), np.array([[2.0], [0.0], [0.0]]),
                   limits=Limits(2.0, 2.0, 10.0, 90.0))  # fmt: skip
    followers = small_flock(100).add(FollowLeader(leader, 50.0, 3.0, behind=2.0))
    for _ in range(240):
        leader.step(DT)
        followers.step(DT)
    # The followers' centre trails the leader by about the following distance (the
    # flock spreads a metre or two around the point behind it).
    behind = leader.position[:, 0] - (2.0, 0, 0)
    assert np.linalg.norm(followers.position.mean(axis=1) - behind) < 2.5


def test_particle_state_and_attributes_travel_with_their_boids():
    tag = np.arange(300, dtype=np.float32) * 2
    flock = small_flock(300, attributes={"tag": tag})
    run(flock, 0.5)
    state = flock.particle_state()
    assert isinstance(flock, HasParticles)
    assert state.count == 300 and sorted(state.ids.tolist()) == list(range(300))
    assert_array_equal(state["tag"], state.ids * 2)
    assert state.unit("bank") == "rad" and state["heading"].shape == (3, 300)
    np.testing.assert_allclose(np.linalg.norm(state["heading"], axis=0), 1.0, atol=1e-5)
    speed = np.linalg.norm(state.velocities, axis=0)
    assert speed.max() <= 4.0 * (1 + 1e-6)


def test_limits_hold_every_step():
    flock = small_flock(400, limits=Limits(1.0, 3.0, 5.0, 90.0)).add(Wander(1.0, 1.0, 20.0, 5.0))
    for _ in range(60):
        heading = flock.heading.copy()
        ids = flock.ids.copy()
        flock.step(DT)
        speed = np.linalg.norm(flock.velocity, axis=0)
        assert speed.min() >= 1.0 - 1e-5 and speed.max() <= 3.0 + 1e-5
        before = heading[:, np.argsort(ids)]
        turned = np.degrees(
            np.arccos(np.clip((by_id(flock, flock.heading) * before).sum(0), -1, 1))
        )
        assert turned.max() <= 90.0 * DT + 0.05  # degrees per step, float32 rounding


@pytest.mark.parametrize(
    ("make", "words"),
    [
        (lambda: Rule(fov=400.0), "fov must be <= 360"),
        (lambda: Rule(radius=0.0), "radius must be > 0"),
        (lambda: Limits(min_speed=5.0, max_speed=2.0), "min_speed must be <= max_speed"),
        (lambda: Flock(np.zeros((2, 5))), "positions must have shape (3, n)"),
        (lambda: Flock(np.zeros((3, 5)), separation=3), "separation must be a Rule"),
        (lambda: Contain((0, 0, 0), (0, 1, 1)), "high must exceed low"),
        (lambda: FollowPath(np.zeros((1, 3))), "points needs at least 2 rows"),
        (lambda: Pursue("falcon"), "other must be a Flock"),
    ],
)
def test_bad_input_names_the_parameter(make, words):
    with pytest.raises(
        (ValueError, TypeError), match=words.replace("(", r"\(").replace(")", r"\)")
    ):
        make()


def test_an_empty_flock_steps():
    flock = Flock(np.zeros((3, 0)))
    flock.step(DT)
    assert flock.particle_state().count == 0 and flock.polarization() == 0.0


def test_birds_point_along_their_heading_and_bank_into_turns():
    from motes.flock.meshes import BIRD, FISH, faces, vertices

    pos = np.zeros((3, 2), np.float32)
    head = np.array([[1, 0], [0, 0], [0, 1]], np.float32)  # +x, then +z
    bank = np.array([0.0, 0.5], np.float32)  # the second rolls its right wing down
    flap = np.full(2, np.pi / 2 + 0.6, np.float32)  # the tip at the top of its beat
    out, normals = vertices(pos, head, bank, flap, 1.0, 0.0)  # amplitude 0: a glide
    v = len(BIRD.rest)
    first, second = out[:v], out[v:]
    np.testing.assert_allclose(first[0], (0.17, 0, 0), atol=1e-6)  # nose ahead
    # Heading +x: the right (heading × y) is +z; wing tips at ±half the span.
    np.testing.assert_allclose(first[14], (-0.16, 0, 0.5), atol=1e-6)
    np.testing.assert_allclose(first[9], (-0.16, 0, -0.5), atol=1e-6)
    # Heading +z: the right is -x; banked by 0.5 rad the right tip is 0.5 sin 0.5 down.
    np.testing.assert_allclose(second[0], (0, 0, 0.17), atol=1e-6)
    np.testing.assert_allclose(second[14][:2], (-0.5 * np.cos(0.5), -0.5 * np.sin(0.5)), atol=1e-6)
    assert second[9][1] > 0  # the left tip up
    np.testing.assert_allclose(normals[v], (-np.sin(0.5), np.cos(0.5), 0), atol=1e-6)
    assert faces(2).shape == (2 * len(BIRD.faces), 3) and faces(2).max() == 2 * v - 1
    out, _ = vertices(pos, head, bank, flap, 1.0, 1.0)
    assert out[9, 1] > 0.3  # beating: the tip raised by 0.35 of the span at this phase
    # A fish's tail beats sideways: its fin swings 0.12 of the length (0.8 rad behind
    # the phase) to the right of the body's axis; the snout stays on the axis ahead.
    out, _ = vertices(pos, head, bank, flap, 2.0, 1.0, FISH)
    np.testing.assert_allclose(out[0], (1.0, 0, 0), atol=1e-6)
    np.testing.assert_allclose(out[6], (-1.0, 0.28, 0.24 * np.cos(0.2)), atol=1e-6)


def test_a_right_turn_banks_the_right_wing_down():
    flock = Flock(np.zeros((3, 1)), np.array([[5.0], [0.0], [0.0]]), bank_time=0.05,
                  limits=Limits(5.0, 5.0, 50.0, 90.0))  # fmt: skip
    flock.add(Seek((0, 0, 100), 5.0))  # far to the right of +x (the right being +z)
    run(flock, 0.3)
    assert flock.heading[2, 0] > 0.1 and flock.bank[0] > 0.3  # turning right, banked right


def test_the_bank_angles_arctangent_is_within_2e_7_rad():
    from motes.flock.kernels import _atan

    atan = numba.njit(lambda x: np.array([_atan(v) for v in x]))
    x = np.concatenate(
        [np.linspace(-40, 40, 80_001), [0.0, -0.0, 1.0, -1.0, 1e-30, 1e30, -1e30, np.inf, -np.inf]]
    ).astype(np.float32)
    got = atan(x)
    assert got.dtype == np.float32
    assert np.abs(got - np.arctan(x.astype(np.float64))).max() < 2e-7
