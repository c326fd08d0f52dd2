"""SPH kernels against quadrature and closed forms; solver kernels against NumPy twins."""

import math

import numba
import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.integrate import quad

import naive_fluids as naive
from motes.fluids import Box, Plane, Sphere, Tank, kernels, sph
from motes.fluids.boundaries import pack
from motes.geometry.distance import row_signed_distance
from motes.geometry.layout import KIND, Kind
from motes.spatial import UniformGrid

H = 0.1


def radial_integral(f, h=H):
    return quad(lambda r: 4 * math.pi * r * r * f(r), 0, h, epsabs=1e-12, limit=200)[0]


@pytest.mark.parametrize(
    "kernel",
    [
        lambda r: sph.poly6(r * r, H),
        lambda r: sph.spiky(r, H),
        lambda r: sph.viscosity(max(r, 1e-12), H),
    ],
    ids=["poly6", "spiky", "viscosity"],
)
def test_kernels_integrate_to_one(kernel):
    # Adaptive quadrature of a polynomial (or r^-1 times r², integrable) to 1e-9.
    assert radial_integral(kernel) == pytest.approx(1.0, abs=1e-9)


def test_kernels_match_the_papers_closed_forms():
    r = np.linspace(0.001, 0.099, 50)
    poly6 = [sph.poly6(x * x, H) for x in r]
    assert_allclose(poly6, 315 / (64 * np.pi * H**9) * (H * H - r * r) ** 3, rtol=1e-12)
    # Spiky gradient and viscosity Laplacian by central differences of the kernels
    # (step 1e-6 h: truncation ~1e-9 relative, round-off ~1e-8).
    e = 1e-7
    dspiky = [(sph.spiky(x + e, H) - sph.spiky(x - e, H)) / (2 * e) for x in r]
    assert_allclose([sph.spiky_gradient_scale(x, H) * x for x in r], dspiky, rtol=1e-6)

    def lap(x, e=1e-5):  # second differences: a wider step keeps round-off ~1e-8
        w = lambda y: sph.viscosity(y, H)  # noqa: E731
        d2 = (w(x + e) - 2 * w(x) + w(x - e)) / e**2
        return d2 + 2 / x * (w(x + e) - w(x - e)) / (2 * e)

    r = np.linspace(0.01, 0.09, 9)
    assert_allclose([sph.viscosity_laplacian(x, H) for x in r], [lap(x) for x in r], rtol=1e-6)
    assert sph.poly6(H * H * 1.01, H) == 0 and sph.spiky_gradient_scale(0.0, H) == 0


@pytest.mark.parametrize("h", [1e-5, 0.1, 1e4])
def test_float32_shapes_scale_to_the_kernels_at_any_size(h):
    # The pair loops' float32 shapes times their float64 units give the kernels to
    # float32 round-off, at sizes where POLY6 / h⁹ alone leaves float32's range.
    for q in np.linspace(0.0, 1.1, 23):
        q2 = np.float32(q * q)
        shape = sph.poly6_shape(q2)
        assert shape * sph.POLY6 / h**3 == pytest.approx(sph.poly6(float(q2) * h * h, h),
                                                         rel=1e-6, abs=1e-12 / h**3)  # fmt: skip
        gradient = sph.spiky_gradient_shape(np.float32(q))
        r = float(np.float32(q)) * h
        assert gradient * sph.SPIKY_GRAD / h**5 == pytest.approx(
            sph.spiky_gradient_scale(r, h), rel=1e-6, abs=1e-12 / h**5
        )
    assert sph.spiky_gradient_shape(np.float32(0.0)) == 0
    # Compiled, they stay float32 (a float64 constant would widen the pair loops).
    for shape in (sph.poly6_shape, sph.spiky_gradient_shape):
        (signature,) = [s for s in shape.nopython_signatures if s.args == (numba.float32,)]
        assert signature.return_type == numba.float32


def test_wall_fraction_is_the_half_space_integral():
    d = np.linspace(0, H, 21)
    ours = np.array([sph.wall_fraction(x, H) for x in d])
    assert_allclose(ours, naive.wall_fraction(d, H), atol=1e-7)  # trapezoid on 4000 nodes
    assert ours[0] == pytest.approx(0.5) and ours[-1] == pytest.approx(0.0, abs=1e-15)
    # The same fraction from the 3D kernel: poly6 over z > d by 2D quadrature in (z, ρ).
    from scipy.integrate import dblquad

    for x in (0.0, 0.03, 0.07):
        direct = dblquad(
            lambda rho, z: 2 * math.pi * rho * sph.poly6(rho * rho + z * z, H),
            x, H, 0, lambda z: math.sqrt(max(H * H - z * z, 0.0)),
        )[0]  # fmt: skip
        assert sph.wall_fraction(x, H) == pytest.approx(direct, abs=1e-8)
    e = 1e-7
    for x in (0.01, 0.05, 0.09):
        slope = (sph.wall_fraction(x + e, H) - sph.wall_fraction(x - e, H)) / (2 * e)
        assert sph.wall_fraction_slope(x, H) == pytest.approx(slope, rel=1e-5)


def test_lattice_number_density_is_near_one_per_cell():
    # The poly6 lattice sum at h = 2 spacings is 1 % above 1/spacing³ (discretisation).
    assert sph.lattice_number_density(0.1, 0.2) * 0.1**3 == pytest.approx(1.0, abs=0.02)


def scene(rng, n_side=6, spacing=0.05):
    """A jittered block in a tank corner beside a solid box and ball: every wall kind."""
    g = (np.arange(n_side) + 0.5) * spacing
    p = np.stack(np.meshgrid(g, g, g, indexing="ij")).reshape(3, -1).T
    p = p + rng.normal(0, 0.1 * spacing, p.shape)
    rows = pack(
        [
            Tank((0, 0, 0), (1, 1, 1), closed=True),
            Box((0.4, 0.15, 0.15), (0.05, 0.05, 0.05)),
            Sphere((0.15, 0.4, 0.15), 0.06),
            Sphere((0.15, 0.15, 0.15), 1.0, inside=True),
            Plane((1, 1, 0), (0.0, 0.02, 0)),
        ]
    )
    return p, rows


def csr(p, h):
    grid = UniformGrid(h).build(p.T.astype(np.float32))
    return grid.neighbors(h), grid


@pytest.mark.parametrize("weights", ["mixed", "one phase"])
def test_density_lambda_and_correction_match_the_twin(rng, weights):
    p, rows = scene(rng)
    n, h = len(p), 0.1
    delta0 = sph.lattice_number_density(0.05, h)
    # One weight for all takes the kernel's path that gathers no weights.
    weight = rng.uniform(0.5, 1.5, n) if weights == "mixed" else np.full(n, 0.8)
    weight = weight.astype(np.float32)
    lists, _ = csr(p, h)
    pf = p.T.astype(np.float32)
    delta, lam = np.empty(n, np.float32), np.empty(n, np.float32)
    wall_gradient = np.empty((3, n))
    scale = sph.wall_scale(0.05, h)
    kernels.density_lambda(
        *pf, *lists.ranges, weight, rows, h, 0.05, scale, 1 / delta0, 30.0,
        delta, lam, wall_gradient,
    )  # fmt: skip
    ref_delta, ref_lam = naive.density_lambda(
        pf.T.astype(float), weight.astype(float), rows, h, 0.05, scale, delta0, 30.0
    )
    # float32 sums of ~30 terms of similar size: relative round-off ~1e-6.
    assert_allclose(delta, ref_delta, rtol=2e-5)
    assert (lam < 0).sum() > 10
    assert_allclose(lam, ref_lam, rtol=1e-4, atol=1e-5 * np.abs(ref_lam).max())
    out = np.empty((3, n), np.float32)
    radius = 0.025
    kernels.correction(
        *pf, *lists.ranges, weight, lam, rows, h, wall_gradient, 1 / delta0,
        1e-4, 1e-3, radius, out,
    )  # fmt: skip
    p64 = pf.T.astype(float)
    dp = naive.correction(
        p64, weight.astype(float), lam.astype(float), rows, h, 0.05, scale, delta0, 1e-4, 1e-3
    )
    ref, pushed = naive.project(p64 + dp, rows, radius)
    assert pushed.max() > 0  # some corrections ended inside a wall
    # Corrections of ~1e-3 m on positions of ~0.1 m, kept in float32: 1e-7 m round-off
    # on the position, 1e-4 of the largest correction on the correction.
    assert_allclose(out.T - p64, ref - p64, rtol=1e-4, atol=1e-4 * np.abs(dp).max() + 1e-7)


def test_walls_combine_as_independent_shares_at_a_tank_corner():
    rows = pack([Tank((0, 0, 0), (1, 1, 1), closed=True)])
    s, scale = H / 2, sph.wall_scale(H / 2, H)
    one, _ = sph.wall_share(0.0, s, H, scale)
    free, *_ = kernels.walls(rows, 0.0, 0.0, 0.0, H, s, scale)
    assert free == pytest.approx((1 - one) ** 3)
    free, gx, gy, gz = kernels.walls(rows, 0.5, 0.5, 0.0 + 0.3 * H, H, s, scale)
    share, slope = sph.wall_share(0.3 * H, s, H, scale)
    assert free == pytest.approx(1 - share)
    assert (gx, gy) == (0.0, 0.0) and gz == pytest.approx(slope)


@pytest.mark.parametrize("ratio", [1.5, 2.0, 3.0, 4.0])
def test_the_rest_lattice_at_a_wall_reads_rest_density(ratio):
    # A block made by `lattice` against a wall: each layer's lattice sum plus the wall's
    # share must be δ₀, or the layers along every wall start pushed apart (the continuous
    # half-space integral over-counted the first layer by 2.6 % of δ₀ at h = 2 spacings).
    s, h = 0.01, 0.01 * ratio
    delta0 = sph.lattice_number_density(s, h)
    scale = sph.wall_scale(s, h)
    reach = math.ceil(ratio) + 1
    k = np.arange(-reach, reach + 1) * s
    x, y, z = np.meshgrid(k, k, k, indexing="ij")
    w = naive.poly6(np.sqrt(x * x + y * y + z * z), h)
    for layer in range(3):
        d = (layer + 0.5) * s
        present = w[y >= -layer * s - 1e-9].sum()
        share, _ = sph.wall_share(d, s, h, scale)
        # Exact at the first layer by construction; deeper layers (ratio > 2) carry the
        # planes' smearing, well below the 2.6 % the continuum share made.
        tolerance = 1e-9 if layer == 0 else 5e-3
        assert (present + share * delta0) / delta0 == pytest.approx(1.0, abs=tolerance)


def test_wall_share_is_the_midpoint_rule_of_the_half_space_integral():
    d = np.linspace(0.0, H, 11)
    fine = H / 400  # planes close together: the midpoint rule converges to the integral
    ours = np.array([sph.wall_share(x, fine, H, 1.0)[0] for x in d])
    assert_allclose(ours, naive.wall_fraction(d, H), atol=1e-5)
    s, scale, e = H / 2, sph.wall_scale(H / 2, H), 1e-7
    assert_allclose(
        [sph.wall_share(x, s, H, scale) for x in d], np.transpose(naive.wall_share(d, s, H, scale))
    )
    for x in (0.01, 0.03, 0.07):
        numeric = (
            sph.wall_share(x + e, s, H, scale)[0] - sph.wall_share(x - e, s, H, scale)[0]
        ) / (2 * e)
        assert sph.wall_share(x, s, H, scale)[1] == pytest.approx(numeric, rel=1e-5)


@pytest.mark.parametrize("phases", [2, 1])
def test_exchange_matches_the_twin_and_the_lecture(rng, phases):
    p, _ = scene(rng, n_side=5)
    n, h = len(p), 0.1
    v = rng.normal(0, 1, (n, 3))
    # One phase: one mass, the kernel's path that gathers no masses.
    phase = rng.integers(0, phases, n).astype(np.int32)
    mass = np.array([0.125, 0.2])[phase]
    delta = rng.uniform(900, 1100, n)
    gamma = np.array([0.5, 2.0])
    lists, _ = csr(p, h)
    coefficients = np.array([h, 0.004, 0.05, 3.0, 1 / (2 * 0.04**2), 20.0, 1000.0])
    out = np.empty((3, n), np.float32)
    pf, vf = p.T.astype(np.float32), v.T.astype(np.float32)
    args = (*lists.ranges, phase, mass.astype(np.float32), delta.astype(np.float32))
    normals = np.empty((3, n), np.float32)
    kernels.surface_normals(*pf, *lists.ranges, phase, args[-1], h, normals)
    ref_normals = naive.surface_normals(
        pf.T.astype(float), phase, delta.astype(np.float32).astype(float), h
    )
    assert_allclose(normals.T, ref_normals, rtol=1e-4, atol=1e-5)
    kernels.exchange(*pf, *vf, *args, normals, gamma, coefficients, out)
    ref = naive.exchange(
        pf.T.astype(float), vf.T.astype(float), phase, mass.astype(np.float32).astype(float),
        delta.astype(np.float32).astype(float), gamma, h, 0.004, 0.05, 3.0, 0.04, 20.0, 1000.0,
    )  # fmt: skip
    assert_allclose(out.T, ref, rtol=1e-4, atol=1e-5)
    # The lecture's viscosity alone, against its pair-by-pair loop.
    coefficients[[2, 5]] = 0.0
    kernels.exchange(*pf, *vf, *args, normals, np.zeros(2), coefficients, out)
    lecture = naive.momentum_exchange_pairs(
        pf.T.astype(float),
        vf.T.astype(float),
        mass.astype(np.float32).astype(float),
        3.0,
        0.04,
        h,
        0.004,
    )
    assert_allclose(out.T, lecture, rtol=1e-4, atol=1e-5)


def test_projection_puts_particles_at_the_radius_from_every_wall(rng):
    rows = pack(
        [
            Tank((0, 0, 0), (1, 1, 1), closed=True),
            Sphere((0.5, 0.5, 0.5), 0.2),
            Box((0.2, 0.2, 0.2), (0.1, 0.05, 0.1)),
        ]
    )
    p = rng.uniform(-0.5, 1.5, (3, 5000)).astype(np.float32)
    depth = np.empty(5000, np.float32)
    before = p.copy()
    kernels.project(*p, rows, 0.01, depth)
    assert np.all((p >= 0.01 - 1e-6) & (p <= 0.99 + 1e-6))
    for row in rows[6:]:
        d, _ = naive.signed_distance(row, p.T.astype(float))
        # The box may push into the ball's reach.
        assert d.min() > 0.01 - 1e-5 or row[KIND] == Kind.BOX
    moved = np.linalg.norm(p - before, axis=0)
    assert np.all(depth <= moved + 1e-5) and depth.max() > 0.4


def test_signed_distances_match_the_twin(rng):
    rows = pack(
        [
            Box((0.1, 0.2, 0.3), (0.2, 0.1, 0.3)),
            Sphere((0, 0, 0), 0.5, inside=True),
            Plane((1, 2, 3), (0.1, 0, 0)),
        ]
    )
    p = rng.uniform(-1, 1, (200, 3))
    for b, row in enumerate(rows):
        d, nrm = naive.signed_distance(row, p)
        ours = np.array([row_signed_distance(rows, b, *x, 1.0) for x in p])
        assert_allclose(ours[:, 0], d, atol=1e-12)
        assert_allclose(ours[:, 1:], nrm, atol=1e-12)


def test_boundary_friction_and_adhesion():
    rows = pack(
        [
            Plane((0, 1, 0), (0, 0, 0), friction=0.25),
            Plane((0, -1, 0), (0, 1, 0), adhesion=2.0, friction=0.5, friction_model="depth"),
        ]
    )
    h, radius, dt = 0.1, 0.025, 0.01
    x = np.array([0.0, 0.0], np.float32)
    y = np.array([0.025, 0.975], np.float32)
    z = np.zeros(2, np.float32)
    vx, vy, vz = (
        np.array([1.0, 1.0], np.float32),
        np.array([0.0, 0.0], np.float32),
        np.zeros(2, np.float32),
    )
    depth = np.array([0.0, 0.001], np.float32)
    kernels.boundary_velocity(
        x, y, z, vx, vy, vz, depth, rows, np.array([h, radius, dt, 1000 * 0.05])
    )
    # Scale friction keeps 75 %; depth friction removes μ·depth/dt; the second particle
    # touches the lid, which pulls it with the whole wall integral of the adhesion spline.
    assert vx[0] == pytest.approx(0.75)
    assert vx[1] == pytest.approx(1.0 - 0.5 * 0.001 / dt, rel=1e-5)
    pull = dt * 2.0 * 1000 * 0.05 * kernels.wall_adhesion(0.025, h)
    assert pull > 0 and vy[1] == pytest.approx(pull, rel=1e-5)


def test_cell_density_matches_brute_force(rng):
    pts = rng.random((3, 3000), dtype=np.float32)
    h = 0.08
    grid = UniformGrid(h / 2).build(pts)
    out = np.empty(3000, np.float32)
    kernels.cell_density(*grid.sorted_positions, grid.cell_start, grid.origin,
                          1.0 / grid.cell, grid.dims, h, out)  # fmt: skip
    p = grid.sorted_positions.T.astype(np.float64)
    r = np.linalg.norm(p[:, None] - p[None, :], axis=2)
    # float32 sums of ~40 kernel values: 1e-5 relative.
    assert_allclose(out, naive.poly6(r, h).sum(axis=1), rtol=1e-5)


def test_vorticity_and_confinement_match_the_twins(rng):
    p, _ = scene(rng)
    n, h = len(p), 0.1
    v = rng.normal(0, 1, (n, 3))
    delta = rng.uniform(800, 1200, n)
    lists, _ = csr(p, h)
    pf, vf = p.T.astype(np.float32), v.T.astype(np.float32)
    omega = np.empty((3, n), np.float32)
    kernels.vorticity(*pf, *vf, *lists.ranges, delta.astype(np.float32), h, omega)
    ref = naive.vorticity(pf.T.astype(float), vf.T.astype(float), delta, h)
    # float32 sums of ~30 terms of either sign: round-off ~1e-6 of the largest term.
    assert_allclose(omega.T, ref, rtol=1e-4, atol=1e-5 * np.abs(ref).max())
    out = np.empty((3, n), np.float32)
    kernels.confinement(*pf, *vf, *lists.ranges, delta.astype(np.float32), omega, h, 0.01, out)
    want = naive.confinement(pf.T.astype(float), vf.T.astype(float), delta, omega.T, h, 0.01)
    assert_allclose(out.T, want, rtol=1e-4, atol=1e-5 * np.abs(want).max())


def test_vorticity_of_a_rigid_rotation_is_twice_its_angular_velocity():
    from motes.fluids import FluidModel, lattice

    s = 0.05
    model = FluidModel(spacing=s)
    h, delta0 = model.derived["h"], model.derived["delta0"]
    p = lattice((0, 0, 0), (0.5, 0.5, 0.5), s)
    spin = np.array([0.3, -1.0, 2.0])
    v = np.cross(spin, p.T - 0.25).T.astype(np.float32)
    lists, _ = csr(p.T.astype(float), h)
    omega = np.empty_like(p)
    delta = np.full(p.shape[1], delta0, np.float32)
    kernels.vorticity(*p, *v, *lists.ranges, delta, h, omega)
    inner = np.all(np.abs(p - 0.25) < 0.25 - h, axis=0)
    # The SPH curl of a linear field is the field's curl times the discrete gradient's
    # response to a linear field (0.947 at h = 2 spacings), up to float32 round-off.
    expected = 2 * spin * model.derived["gradient_factor"]
    assert_allclose(omega[:, inner].T, np.broadcast_to(expected, (inner.sum(), 3)), rtol=1e-4)
