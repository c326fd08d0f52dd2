"""Compiled force kernels: twins, Jacobians, conservation laws, determinism, validation.

Each kernel is compared with its NumPy twin in ``naive_forces.py``. Tolerances:

- float64: ``rtol = 1e-10``. The kernels are compiled with ``fastmath`` (reassociation,
  FMA contraction) so they may differ from the twin by a few ulps per operation; 1e-10
  leaves six orders of magnitude for that and still catches any wrong term.
- float32: the kernel computes in float32 from float32 inputs, the twin in float64 from
  the same inputs, so they differ by float32 rounding (eps = 1.2e-7) times the
  conditioning of each formula; ``atol = 1e-4 * max|f|`` allows ~1000 ulps.
- Jacobians against central differences with step ``h``: truncation ``O(h^2 f''')`` plus
  rounding ``O(eps |f| / h)``; with ``h = 1e-6`` m and O(1) forces both are below 1e-9,
  so ``atol = 1e-6 * max|J|`` (the brief's ~1e-5) has ample margin.
"""

from __future__ import annotations

import numba
import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import naive_forces as naive
from motes.forces.curl_noise import CurlNoise, perlin_gradients
from motes.forces.radial import RadialField
from motes.forces.springs import Springs
from motes.forces.vortex import Vortex
from motes.particles import ParticleStore

RTOL64 = 1e-10
ATOL32 = 1e-4
FD_STEP = 1e-6
FD_ATOL = 1e-6


def make_store(n, dtype=np.float64, *, mass=True, seed=0, spread=2.0):
    """A store with ``n`` particles at random positions, velocities and masses."""
    store = ParticleStore(n + 3, attributes=("mass",) if mass else (), dtype=dtype)
    store.spawn(n)
    rng = np.random.default_rng(seed)
    store["position"] = rng.uniform(-spread, spread, (n, 3))
    store["velocity"] = rng.normal(size=(n, 3))
    if mass:
        store["mass"] = rng.uniform(0.5, 2.0, n)
    return store


def evaluate(force, store, time=0.0, position=None, velocity=None):
    """Force [N] as ``(n, 3)``, computed the way a system calls it: into a zero buffer.

    ``position`` / ``velocity`` (3, n) default to the store's live state (velocity to
    zero when only ``position`` is given).
    """
    n = store.count
    if position is None:
        position = store.raw("position")[:, :n]
        velocity = store.raw("velocity")[:, :n] if velocity is None else velocity
    elif velocity is None:
        velocity = np.zeros_like(position)
    out = np.zeros(position.shape, dtype=position.dtype)
    force.accumulate(store, position, velocity, time, out)
    return out.T


def live(points, dtype=np.float64):
    """``points`` (n, 3) as a C-ordered (3, n) array, the layout the forces take (its rows
    are contiguous like the store's, so no extra kernel specialisation is compiled)."""
    return np.ascontiguousarray(np.asarray(points, dtype=dtype).T)


def mass_of(store):
    return store["mass"].astype(np.float64) if store.has("mass") else None


def assert_close32(actual, expected):
    assert_allclose(actual, expected, rtol=0, atol=ATOL32 * np.abs(expected).max())


def fd_diagonal_blocks(force, store, h=FD_STEP):
    """Central-difference ∂f_i/∂x_i (n, 3, 3), perturbing every particle at once.

    Valid for forces where particle ``i`` feels only its own position.
    """
    n = store.count
    base = store.raw("position")[:, :n].copy()
    blocks = np.empty((n, 3, 3))
    for j in range(3):
        plus, minus = base.copy(), base.copy()
        plus[j] += h
        minus[j] -= h
        blocks[:, :, j] = (
            evaluate(force, store, position=live(plus.T))
            - evaluate(force, store, position=live(minus.T))
        ) / (2 * h)
    return blocks


def fd_dense(force, store, wrt, h=FD_STEP):
    """Central-difference dense (3n, 3n) ∂f/∂x (``wrt="position"``) or ∂f/∂v."""
    n = store.count
    pos = store.raw("position")[:, :n].copy()
    vel = store.raw("velocity")[:, :n].copy()
    dense = np.empty((3 * n, 3 * n))
    for i in range(n):
        for j in range(3):
            states = []
            for sign in (1, -1):
                p, v = pos.copy(), vel.copy()
                (p if wrt == "position" else v)[j, i] += sign * h
                states.append(evaluate(force, store, position=live(p.T), velocity=live(v.T)))
            dense[:, 3 * i + j] = (states[0] - states[1]).ravel() / (2 * h)
    return dense


# -- RadialField -------------------------------------------------------------------------
@pytest.mark.parametrize("mass", [True, False])
def test_radial_inverse_square_matches_twin(mass):
    store = make_store(500, mass=mass)
    force = RadialField((0.1, -0.2, 0.3), 2.5, softening=0.05)
    expected = naive.radial_inverse_square(
        store["position"], mass_of(store), force.center, 2.5, 0.05
    )
    assert_allclose(evaluate(force, store), expected, rtol=RTOL64)


def test_radial_linear_matches_twin():
    store = make_store(300)
    force = RadialField((1.0, 0.0, -1.0), -0.7, falloff="linear")
    expected = naive.radial_linear(store["position"], mass_of(store), force.center, -0.7)
    assert_allclose(evaluate(force, store), expected, rtol=RTOL64)


@pytest.mark.parametrize("falloff", ["inverse_square", "linear"])
def test_radial_float32_matches_twin(falloff):
    store = make_store(400, np.float32)
    force = RadialField((0.5, 0.5, 0.5), 1.5, softening=0.1, falloff=falloff)
    got = evaluate(force, store)
    assert got.dtype == np.float32
    x = store["position"].astype(np.float64)
    if falloff == "linear":
        expected = naive.radial_linear(x, mass_of(store), force.center, 1.5)
    else:
        expected = naive.radial_inverse_square(x, mass_of(store), force.center, 1.5, 0.1)
    assert_close32(got, expected)


def test_radial_adds_into_out_and_is_mass_independent():
    store = make_store(50)
    force = RadialField((0.0, 0.0, 0.0), 1.0)
    n = store.count
    out = np.ones((3, n))
    force.accumulate(store, store.raw("position")[:, :n], store.raw("velocity")[:, :n], 0.0, out)
    # Adding to 1 rounds to ulp(1) = 2.2e-16 (or not at all, if the add is fused).
    assert_allclose(out.T, 1.0 + evaluate(force, store), rtol=0, atol=2.3e-16)
    # The acceleration is the same for every mass: f / m equals the force on 1 kg.
    unit = make_store(50, mass=False)
    assert_allclose(
        evaluate(force, store) / store["mass"][:, None], evaluate(force, unit), rtol=RTOL64
    )


def test_radial_attracts_and_repels():
    store = make_store(100, mass=False)
    r = store["position"].copy()
    toward = -np.sum(evaluate(RadialField((0, 0, 0), 1.0), store) * r, axis=1)
    away = np.sum(evaluate(RadialField((0, 0, 0), -1.0), store) * r, axis=1)
    assert np.all(toward > 0) and np.all(away > 0)


@pytest.mark.parametrize("falloff", ["inverse_square", "linear"])
def test_radial_jacobian_matches_finite_differences(falloff):
    store = make_store(40, spread=1.0)
    force = RadialField((0.2, 0.1, -0.1), 0.8, softening=0.3, falloff=falloff)
    jac = force.jacobian(store, store.raw("position")[:, :40], store.raw("velocity")[:, :40])
    assert_array_equal(jac.rows, np.arange(40))
    assert_array_equal(jac.cols, np.arange(40))
    expected = fd_diagonal_blocks(force, store)
    assert_allclose(jac.dfdx, expected, rtol=0, atol=FD_ATOL * np.abs(expected).max())
    assert not np.any(jac.dfdv)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"center": (0, 0), "strength": 1.0}, "center"),
        ({"center": (0, 0, 0), "strength": float("nan")}, "strength"),
        ({"center": (0, 0, 0), "strength": 1.0, "softening": 0.0}, "softening"),
        ({"center": (0, 0, 0), "strength": 1.0, "falloff": "cubic"}, "falloff"),
    ],
)
def test_radial_rejects_bad_parameters(kwargs, match):
    with pytest.raises(ValueError, match=match):
        RadialField(**kwargs)


# -- Vortex ------------------------------------------------------------------------------
@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_vortex_matches_twin(dtype):
    store = make_store(500, dtype)
    force = Vortex((0.3, 0.0, -0.2), (1.0, 2.0, 0.5), 1.7, radius=0.4, pull=0.6)
    got = evaluate(force, store)
    expected = naive.vortex(
        store["position"].astype(np.float64),
        mass_of(store),
        force.center,
        (1.0, 2.0, 0.5),
        1.7,
        0.4,
        0.6,
    )
    if dtype == np.float64:
        assert_allclose(got, expected, rtol=RTOL64)
    else:
        assert_close32(got, expected)


def test_vortex_profile_is_smoothed_rankine():
    # Points at distance rho from the y axis, at several heights and azimuths.
    rho = np.linspace(0.05, 5.0, 40)
    phi = np.linspace(0.0, 2 * np.pi, 40, endpoint=False)
    height = np.linspace(-3.0, 3.0, 40)
    points = np.stack([rho * np.cos(phi), height, rho * np.sin(phi)], axis=1)
    store = make_store(40, mass=False)
    s, p, radius = 2.0, 0.5, 0.8
    f = evaluate(
        Vortex((0, 0, 0), (0, 1, 0), s, radius=radius, pull=p), store, position=live(points)
    )
    radial_unit = points * [1, 0, 1] / rho[:, None]
    tangent_unit = np.cross([0, 1, 0], radial_unit)
    profile = rho / (rho**2 + radius**2)
    assert_allclose(np.sum(f * tangent_unit, axis=1), s * profile, rtol=1e-12)
    assert_allclose(np.sum(f * radial_unit, axis=1), -p * profile, rtol=1e-12)
    assert_allclose(f[:, 1], 0.0, atol=1e-15)
    # Peak swirl s / (2R) at rho = R.
    peak = rho[np.argmax(profile)]
    assert abs(peak - radius) < rho[1] - rho[0]


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"axis": (0, 0, 0)}, "axis"),
        ({"radius": 0.0}, "radius"),
        ({"strength": float("inf")}, "strength"),
        ({"pull": float("nan")}, "pull"),
    ],
)
def test_vortex_rejects_bad_parameters(kwargs, match):
    args = {"center": (0, 0, 0), "axis": (0, 1, 0), "strength": 1.0} | kwargs
    with pytest.raises(ValueError, match=match):
        Vortex(**args)


# -- CurlNoise ---------------------------------------------------------------------------
def test_gradient_table_is_perlins():
    table = perlin_gradients()
    eye = np.eye(3)
    for h in range(16):
        assert_array_equal(table[h], [naive.grad(np.array(h), *e) for e in eye])
    # The 12 cube-edge directions: two components of +-1 and one 0.
    assert np.all(np.sum(np.abs(table), axis=1) == 2)
    assert len({tuple(g) for g in table}) == 12


@pytest.mark.parametrize("mass", [True, False])
def test_curl_noise_matches_twin(mass):
    store = make_store(300, mass=mass, spread=6.0)
    force = CurlNoise(1.3, 0.7, seed=5, octaves=3, time_scale=0.25)
    time = 3.0
    expected = naive.curl_noise(
        store["position"], mass_of(store), force.permutations, 1.3, 0.7, 3, 0.25 * time
    )
    assert_allclose(
        evaluate(force, store, time), expected, rtol=RTOL64, atol=RTOL64 * np.abs(expected).max()
    )


def test_curl_noise_float32_matches_twin():
    store = make_store(300, np.float32, spread=6.0)
    force = CurlNoise(0.9, 1.1, seed=2, octaves=2)
    got = evaluate(force, store)
    assert got.dtype == np.float32
    expected = naive.curl_noise(
        store["position"].astype(np.float64), mass_of(store), force.permutations, 0.9, 1.1, 2, 0.0
    )
    assert_close32(got, expected)


def test_noise_gradient_matches_finite_differences():
    force = CurlNoise(1.0, 0.6, seed=11, octaves=3)
    points = np.random.default_rng(1).uniform(-5, 5, (200, 3))
    _, gradient = force.potential(live(points))
    h = 1e-6  # lattice units are x / 0.6, so the lattice step is 1.7e-6
    fd = np.empty((3, 3, len(points)))
    for j in range(3):
        step = h * np.eye(3)[j]
        plus, _ = force.potential(live(points + step))
        minus, _ = force.potential(live(points - step))
        fd[:, j] = (plus - minus) / (2 * h) * force.scale  # ∂/∂x -> ∂/∂p
    assert_allclose(gradient, fd, rtol=0, atol=1e-6 * np.abs(fd).max())
    # The twin's corner-by-corner product rule agrees too (octave 0 of potential 0).
    single = CurlNoise(1.0, 1.0, seed=11)
    psi, grad = single.potential(live(points))
    value, expected = naive.noise(points, single.permutations[0])
    assert_allclose(psi[0], value, rtol=RTOL64, atol=1e-14)
    assert_allclose(grad[0].T, expected, rtol=RTOL64, atol=1e-14)


def test_curl_noise_is_the_curl_of_its_potential():
    force = CurlNoise(2.0, 0.5, seed=4, octaves=2, time_scale=1.0)
    store = make_store(100, mass=False, spread=3.0)
    _, g = force.potential(store.raw("position")[:, :100], time=0.7)
    curl = np.stack([g[2, 1] - g[1, 2], g[0, 2] - g[2, 0], g[1, 0] - g[0, 1]], axis=1)
    assert_allclose(evaluate(force, store, 0.7), 2.0 * curl, rtol=RTOL64, atol=1e-14)


def field_jacobian(force, points, h):
    """Central-difference ∂a_i/∂x_j (n, 3, 3) of the curl-noise field at ``points``."""
    store = make_store(1, mass=False)
    shifted = np.concatenate([points + s * h * e for e in np.eye(3) for s in (1, -1)])
    f = evaluate(force, store, position=live(shifted)).reshape(3, 2, len(points), 3)
    return np.transpose((f[:, 0] - f[:, 1]) / (2 * h), (1, 2, 0))


def test_curl_noise_is_divergence_free():
    # A grid off the lattice (noise cells are 1 m here) over several cells.
    axis = np.linspace(-3.3, 3.7, 7) + 0.123
    points = np.stack(np.meshgrid(axis, axis, axis), axis=-1).reshape(-1, 3)
    force = CurlNoise(1.0, 1.0, seed=3, octaves=2)
    divergence = {}
    for h in (1e-3, 1e-4):
        jac = field_jacobian(force, points, h)
        divergence[h] = np.abs(np.trace(jac, axis1=1, axis2=2)).max()
    typical = np.sqrt(np.mean(jac**2))  # RMS of ∂a_i/∂x_j, about 4 [1/s^2] here
    # Central differences of a smooth field have truncation error O(h^2) and rounding
    # O(eps |a| / h) ~ 1e-12. A divergence-free field shows only the truncation error:
    # measured 7e-7 * typical at h = 1e-4, so 1e-5 * typical has a 10x margin, and the
    # error falls 100-fold when h does 10-fold (a real divergence would not fall).
    assert typical > 1.0
    assert divergence[1e-4] < 1e-5 * typical
    assert divergence[1e-3] / divergence[1e-4] > 50
    # The test has teeth: the gradient of the potential is not solenoidal.
    h = 1e-4
    _, g_plus = force.potential(live(points + h * np.array([1.0, 0, 0])))
    _, g_minus = force.potential(live(points - h * np.array([1.0, 0, 0])))
    d_gx = (g_plus[0, 0] - g_minus[0, 0]) / (2 * h)
    assert np.abs(d_gx).max() > 0.1 * typical


def test_curl_noise_seed_and_time():
    store = make_store(200, spread=4.0)
    # The legacy global RNG must stay untouched (seeding goes through default_rng).
    state = np.random.get_state()[1].copy()  # noqa: NPY002
    a = evaluate(CurlNoise(1.0, 1.0, seed=7), store)
    assert_array_equal(np.random.get_state()[1], state)  # noqa: NPY002
    assert_array_equal(a, evaluate(CurlNoise(1.0, 1.0, seed=7), store))
    b = evaluate(CurlNoise(1.0, 1.0, seed=8), store)
    assert np.abs(a - b).max() > 0.1 * np.abs(a).max()
    frozen = CurlNoise(1.0, 1.0, seed=7)
    assert_array_equal(evaluate(frozen, store, 0.0), evaluate(frozen, store, 12.5))
    moving = CurlNoise(1.0, 1.0, seed=7, time_scale=0.5)
    assert np.abs(evaluate(moving, store, 1.0) - a).max() > 0.1 * np.abs(a).max()
    # The noise repeats every 256 cells, so the drift wraps exactly: 0.5 * 512 s = 256.
    assert_array_equal(evaluate(moving, store, 512.0), a)


@pytest.mark.parametrize(
    ("kwargs", "match", "error"),
    [
        ({"scale": 0.0}, "scale", ValueError),
        ({"octaves": 0}, "octaves", ValueError),
        ({"octaves": 17}, "octaves", ValueError),
        ({"seed": -1}, "seed", ValueError),
        ({"seed": 1.5}, "seed", TypeError),
        ({"strength": float("nan")}, "strength", ValueError),
        ({"time_scale": float("inf")}, "time_scale", ValueError),
    ],
)
def test_curl_noise_rejects_bad_parameters(kwargs, match, error):
    args = {"strength": 1.0, "scale": 1.0} | kwargs
    with pytest.raises(error, match=match):
        CurlNoise(**args)


# -- Springs -----------------------------------------------------------------------------
def random_springs(n, m, seed=0):
    rng = np.random.default_rng(seed)
    a = rng.integers(0, n, m)
    b = (a + rng.integers(1, n, m)) % n  # never equal to a
    return (
        np.stack([a, b], axis=1),
        rng.uniform(0.1, 1.0, m),
        rng.uniform(1, 50, m),
        rng.uniform(0, 2, m),
    )


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_springs_match_twin(dtype):
    store = make_store(200, dtype)
    pairs, rest, ks, kd = random_springs(200, 700)
    force = Springs(pairs, rest, ks, kd)
    got = evaluate(force, store)
    assert got.dtype == dtype
    expected = naive.springs(store["position"], store["velocity"], pairs, rest, ks, kd)
    if dtype == np.float64:
        assert_allclose(got, expected, rtol=RTOL64, atol=RTOL64 * np.abs(expected).max())
    else:
        assert_close32(got, expected)


def test_springs_scalar_parameters_broadcast():
    store = make_store(30)
    pairs = np.array([[0, 1], [1, 2], [5, 29], [3, 0]])
    got = evaluate(Springs(pairs, 0.5, 10.0, 0.3), store)
    expected = naive.springs(store["position"], store["velocity"], pairs, 0.5, 10.0, 0.3)
    assert_allclose(got, expected, rtol=RTOL64)


def test_springs_conserve_momentum_and_angular_momentum():
    store = make_store(300)
    force = Springs(*random_springs(300, 1000, seed=3))
    f = evaluate(force, store)
    scale = np.abs(f).sum()
    # Each spring adds +f and -f; only the summation order differs, so the totals
    # vanish to rounding: a few eps times the sum of magnitudes.
    assert np.abs(f.sum(axis=0)).max() < 1e-14 * scale
    torque = np.cross(store["position"], f).sum(axis=0)  # central forces: no net torque
    assert np.abs(torque).max() < 1e-13 * scale


def test_springs_force_is_minus_energy_gradient_and_damping_dissipates():
    store = make_store(12, spread=1.0)
    pairs, rest, ks, kd = random_springs(12, 30, seed=4)
    elastic = Springs(pairs, rest, ks, 0.0)
    x = store.raw("position")[:, :12].copy()
    grad = np.empty((12, 3))
    h = 1e-6
    for i in range(12):
        for j in range(3):
            plus, minus = x.copy(), x.copy()
            plus[j, i] += h
            minus[j, i] -= h
            grad[i, j] = (elastic.energy(plus) - elastic.energy(minus)) / (2 * h)
    f_elastic = evaluate(elastic, store)
    assert_allclose(f_elastic, -grad, rtol=0, atol=FD_ATOL * np.abs(grad).max())
    # Damping power is -Σ kd (ḋ·d̂)^2 <= 0.
    f_damping = evaluate(Springs(pairs, rest, ks, kd), store) - f_elastic
    power = np.sum(f_damping * store["velocity"])
    d = store["position"][pairs[:, 0]] - store["position"][pairs[:, 1]]
    dv = store["velocity"][pairs[:, 0]] - store["velocity"][pairs[:, 1]]
    closing = np.sum(dv * d, axis=1) / np.linalg.norm(d, axis=1)
    assert power < 0
    assert_allclose(power, -np.sum(kd * closing**2), rtol=1e-10)


def oscillate(damping, steps, dt):
    """Two 1 kg particles on one spring (ks 100 N/m, rest 1 m), semi-implicit Euler."""
    store = ParticleStore(2, dtype=np.float64)
    store.spawn(2)
    store["position"] = [[0.0, 0.0, 0.0], [1.2, 0.0, 0.0]]
    spring = Springs([[0, 1]], 1.0, 100.0, damping)
    x, v = store.raw("position")[:, :2], store.raw("velocity")[:, :2]

    def energy():
        return spring.energy(x) + 0.5 * np.sum(v**2)

    e0 = energy()
    energies = []
    f = np.empty((3, 2))
    for _ in range(steps):
        f[:] = 0.0
        spring.accumulate(store, x, v, 0.0, f)
        v += dt * f
        x += dt * v
        energies.append(energy())
    return e0, np.array(energies)


@pytest.fixture
def one_thread():
    """Run on one Numba thread: a 2-particle system gains nothing from threads, and each
    parallel launch can cost a scheduler time slice (~8 ms) on a busy machine."""
    original = numba.get_num_threads()
    numba.set_num_threads(1)
    yield
    numba.set_num_threads(original)


@pytest.mark.usefixtures("one_thread")
def test_spring_energy_is_bounded_undamped_and_decays_damped():
    dt, steps = 1e-3, 2000
    omega = np.sqrt(100.0 / 0.5)  # reduced mass 0.5 kg
    e0, energies = oscillate(0.0, steps, dt)
    # Semi-implicit Euler is symplectic: the energy error oscillates with amplitude
    # O(omega dt) E0 and does not drift.
    assert np.abs(energies - e0).max() < omega * dt * e0
    # Relative motion mu x'' = -ks x - kd x' decays at rate kd/(2 mu) = kd per second, so
    # the energy as exp(-2 kd t); the oscillation between kinetic and potential form
    # modulates that by O(kd / omega) = 4%, allowed for by rtol 0.1.
    kd = 0.5
    e0, energies = oscillate(kd, steps, dt)
    assert_allclose(energies[-1] / e0, np.exp(-2 * kd * steps * dt), rtol=0.1)
    assert np.all(np.diff(energies) <= 1e-12 * e0)


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_results_are_bitwise_independent_of_thread_count(dtype):
    # Springs are the case that matters (a naive parallel scatter would race); the
    # per-particle kernels are checked too, since vectorised and remainder iterations
    # could round differently when the thread count moves the chunk boundaries.
    n = 2001
    store = make_store(n, dtype)
    forces = [
        Springs(*random_springs(n, 7001, seed=9)),
        RadialField((0.1, 0.2, 0.3), 1.0),
        RadialField((0.1, 0.2, 0.3), 1.0, falloff="linear"),
        Vortex((0, 0, 0), (0, 1, 1), 1.0, pull=0.3),
        CurlNoise(1.0, 0.7, octaves=2),
    ]
    original = numba.get_num_threads()
    most = numba.config.NUMBA_NUM_THREADS
    try:
        results = []
        for threads in (1, most, 1):
            numba.set_num_threads(threads)
            results.append([evaluate(force, store) for force in forces])
    finally:
        numba.set_num_threads(original)
    for run in results[1:]:
        for force, got, first in zip(forces, run, results[0], strict=True):
            assert_array_equal(got, first, err_msg=repr(force))
    if most < 2:
        pytest.skip("only one Numba thread available: thread-count independence untested")


def test_springs_jacobian_matches_finite_differences():
    store = make_store(6, spread=1.0, seed=2)
    pairs = np.array([[0, 1], [1, 2], [2, 0], [3, 4], [4, 5], [5, 0], [1, 4], [0, 1]])
    rest = np.array([0.5, 1.0, 2.5, 0.3, 0.0, 1.2, 0.8, 3.0])  # stretched and compressed
    force = Springs(pairs, rest, np.linspace(5, 40, 8), np.linspace(0, 3, 8))
    x, v = store.raw("position")[:, :6], store.raw("velocity")[:, :6]
    jac = force.jacobian(store, x, v, exact=True)
    dfdx, dfdv = jac.dense(6)
    for analytic, wrt in ((dfdx, "position"), (dfdv, "velocity")):
        expected = fd_dense(force, store, wrt)
        assert_allclose(analytic, expected, rtol=0, atol=FD_ATOL * np.abs(expected).max())


def test_zero_length_spring_gives_no_nan():
    store = make_store(3)
    store["position"] = [[1.0, 2.0, 3.0], [1.0, 2.0, 3.0], [0.0, 0.0, 0.0]]
    force = Springs([[0, 1], [1, 2]], [0.5, 0.0], 10.0, 1.0)
    f = evaluate(force, store)
    assert np.all(np.isfinite(f))
    expected = naive.springs(store["position"], store["velocity"], [[1, 2]], 0.0, 10.0, 1.0)
    assert_allclose(f, expected, rtol=RTOL64)
    jac = force.jacobian(store, store.raw("position")[:, :3], store.raw("velocity")[:, :3])
    assert np.all(np.isfinite(jac.dfdx)) and np.all(np.isfinite(jac.dfdv))


def test_springs_remap_drops_dead_and_renumbers():
    store = make_store(5)
    pairs = [[0, 1], [1, 2], [2, 3], [3, 4], [0, 4]]
    rest, ks, kd = [0.1, 0.2, 0.3, 0.4, 0.5], [1.0, 2.0, 3.0, 4.0, 5.0], [0.0, 0.1, 0.2, 0.3, 0.4]
    force = Springs(pairs, rest, ks, kd)
    new_index = store.kill([2])
    force.remap(new_index)
    assert_array_equal(force.pairs, [[0, 1], [2, 3], [0, 3]])
    assert_array_equal(force.rest_length, [0.1, 0.4, 0.5])
    assert_array_equal(force.stiffness, [1.0, 4.0, 5.0])
    assert_array_equal(force.damping, [0.0, 0.3, 0.4])
    expected = naive.springs(
        store["position"],
        store["velocity"],
        force.pairs,
        force.rest_length,
        force.stiffness,
        force.damping,
    )
    assert_allclose(evaluate(force, store), expected, rtol=RTOL64)
    force.remap(store.kill([0, 1, 2, 3]))
    assert force.spring_count == 0
    assert not np.any(evaluate(force, store))


def test_springs_reject_indices_past_the_live_particles():
    store = make_store(3)
    with pytest.raises(ValueError, match="remap"):
        evaluate(Springs([[0, 3]], 1.0, 1.0, 0.0), store)
    with pytest.raises(ValueError, match="new_index"):
        Springs([[0, 3]], 1.0, 1.0, 0.0).remap(np.arange(3))


@pytest.mark.parametrize(
    ("args", "match", "error"),
    [
        (([[0, 1]], 1.0, -1.0, 0.0), "stiffness", ValueError),
        (([[0, 1]], 1.0, 1.0, -0.1), "damping", ValueError),
        (([[0, 1]], -1.0, 1.0, 0.0), "rest_length", ValueError),
        (([[0, 1]], 1.0, float("nan"), 0.0), "stiffness", ValueError),
        (([[0, 1], [1, 2]], [1.0, 2.0, 3.0], 1.0, 0.0), "rest_length", ValueError),
        (([[0, 1], [1, 2]], 1.0, [[1.0, 2.0]], 0.0), "stiffness", ValueError),
        (([0, 1, 2], 1.0, 1.0, 0.0), "pairs", ValueError),
        (([[0, 1, 2]], 1.0, 1.0, 0.0), "pairs", ValueError),
        (([[0, -1]], 1.0, 1.0, 0.0), "pairs", ValueError),
        (([[0, 1], [2, 2]], 1.0, 1.0, 0.0), "pairs", ValueError),
        (([[0.0, 1.0]], 1.0, 1.0, 0.0), "pairs", TypeError),
        (([[0, 1]], 1.0, "stiff", 0.0), "stiffness", TypeError),
    ],
)
def test_springs_reject_bad_parameters(args, match, error):
    with pytest.raises(error, match=match):
        Springs(*args)
