"""Every force acts on any kind: cloth, hair, liquids and rigid worlds.

Verification against closed forms: a uniform force changes a free body's momentum by
``F t`` (a pinned one's by ``F t`` plus the pins' reaction), a linear attractor moves a
cloth's centre of mass along the implicit Euler map, a vortex spins a ring; curl noise
stirs a tank without spilling it; scene files give bodies the forces systems take.
"""

from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose, assert_array_equal

import motes as mo
from motes import rigid
from motes.cloth import Cloth
from motes.fluids import Fluid, FluidModel, Tank, lattice
from motes.forces import CallbackForce, CurlNoise, Drag, QuadraticDrag, RadialField, Vortex
from motes.forces.apply import add_forces, force_state
from motes.hair import Hair, Head
from motes.integrate.implicit import ImplicitEuler
from motes.scene import SceneError, load_scene
from naive_forces import radial_inverse_square, vortex

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
F = np.array([0.3, -0.1, 0.2])  # [N] per particle


def uniform(force=F):
    """The same force [N] on every particle."""
    return CallbackForce(lambda x, v, t: np.broadcast_to(force, x.shape))


# --- the evaluation --------------------------------------------------------------------


def test_field_forces_are_the_fused_kernels_terms_times_mass():
    # One explicit Euler step of a system gives m (v1 - v0) / h = f(v0) exactly as the
    # fused kernel evaluates it (it reads inverse masses); add_forces the same newtons.
    rng = np.random.default_rng(1)
    n, h = 7, 0.01
    field = [
        mo.Gravity((0.0, -9.81, 1.0)),
        Drag(0.3, wind=(1.0, 0.0, 0.0)),
        Drag(0.2, wind=(0.0, 2.0, 0.0)),
        QuadraticDrag(0.05, wind=(0.5, 0.0, -1.0)),
    ]
    system = mo.ParticleSystem(
        n, integrator="explicit_euler", dtype=np.float64, attributes=("inv_mass",)
    )
    for force in field:
        system.add(force)
    system.store.spawn(n)
    x, v, m = rng.normal(size=(n, 3)), rng.normal(size=(n, 3)), rng.uniform(0.5, 2.0, n)
    system["position"], system["velocity"], system["inv_mass"] = x, v, 1 / m
    system.step(h)
    expected = m[:, None] * (system["velocity"] - v) / h
    got = add_forces(field, x.T, v.T, m, 0.0)
    # Same formula, different operation order: a few ulps of |f| ~ 10 N.
    assert_allclose(got.T, expected, rtol=1e-9, atol=1e-12)


def test_forces_read_masses_through_the_particle_state():
    rng = np.random.default_rng(2)
    x, v, m = rng.normal(size=(3, 50)), rng.normal(size=(3, 50)), rng.uniform(0.1, 3, 50)
    state = force_state(x, v, m)
    assert state.has("mass") and not state.has("color")
    assert state.raw("mass") is m
    field = RadialField((0.5, 0, 0), 2.0, softening=0.1)
    swirl = Vortex((0, 0, 0), (0, 1, 0), 1.5, radius=0.3, pull=0.2)
    got = add_forces([field, swirl], x, v, m, 0.0)
    expected = radial_inverse_square(x.T, m, field.center, 2.0, 0.1) + vortex(
        x.T, m, swirl.center, swirl.axis, 1.5, 0.3, 0.2
    )
    assert_allclose(got.T, expected, rtol=1e-12, atol=1e-12)


def test_add_forces_refuses_wrong_shapes_and_non_forces():
    x = np.zeros((3, 4))
    with pytest.raises(ValueError, match=r"mass \(n,\)"):
        add_forces([uniform()], x, x, np.ones(3), 0.0)
    with pytest.raises(TypeError, match="Force or FieldForce"):
        add_forces([lambda x, v, t: x], x, x, np.ones(4), 0.0)
    with pytest.raises(TypeError, match="Force or FieldForce"):
        rigid.World().add_force("gravity")


# --- a uniform force: momentum changes by F t ------------------------------------------


def free_cloth(**options) -> Cloth:
    options = {"gravity": (0, 0, 0), "air_damping": 0.0, "strain_limit": None, **options}
    return Cloth.grid(8, 6, solver=ImplicitEuler(tolerance=1e-10), **options)


@pytest.mark.parametrize(
    ("scheme", "h"),
    # The explicit scheme needs h below ~2/ω of the stiffest spring on the lightest
    # (5 g) corner vertex.
    [("implicit_euler", 0.005), ("semi_implicit_euler", 0.001)],
)
def test_uniform_force_on_a_free_cloth_changes_its_momentum_by_f_t(scheme, h):
    cloth = free_cloth(scheme=scheme, forces=[uniform()])
    steps = 20
    for _ in range(steps):
        cloth.step(h)
    momentum = (cloth.mass * cloth.velocity).sum(axis=1)
    # Edge vertices weigh less, so they accelerate more and the springs work: the
    # implicit solve carries their internal forces to 1e-10 of its right-hand side.
    assert_allclose(momentum, cloth.n * F * steps * h, rtol=1e-7)


def test_uniform_force_on_hair_changes_momentum_by_f_t_plus_the_follicles_reaction():
    head = Head((0.0, 1.6, 0.0), 0.1)
    hair = Hair(
        head, strands=6, particles=6, comb=None, gravity=(0, 0, 0), air_damping=0.0,
        stretch_limit=None, solver=ImplicitEuler(tolerance=1e-10),
        forces=[uniform(1e-4 * F)],
    )  # fmt: skip
    steps, h = 10, 0.01
    reaction = np.zeros(3)
    for _ in range(steps):
        hair.step(h)
        reaction += hair.last_report.constraint_impulse
    momentum = (hair.mass * hair.velocity).sum(axis=1)
    expected = hair.n * 1e-4 * F * steps * h + reaction
    # The held follicles take a share of the force: the balance holds to the solve.
    assert np.linalg.norm(reaction) > 0.1 * np.linalg.norm(expected)
    assert_allclose(momentum, expected, rtol=1e-7)


def test_uniform_force_on_a_free_liquid_changes_its_momentum_by_f_t():
    model = FluidModel(spacing=0.05, gravity=(0.0, 0.0, 0.0))
    water = Fluid(model, lattice((0, 0, 0), (0.2, 0.2, 0.2), 0.05))
    f = water.masses[0] * np.array([1.0, -0.5, 0.25])  # 1 m/s² along x
    water.add_force(uniform(f))
    steps, h = 10, 1 / 240
    for _ in range(steps):
        water.step(h)
    # Pairwise terms cancel pair by pair; what is left is float32 round-off of the
    # positions: a move h v ~ 1e-4 m added to x ~ 0.1 m keeps it to ~1e-8 m, 1e-4 of
    # itself, and lattice particles share coordinates, so those errors do not average.
    assert_allclose(water.momentum(), len(water) * f * steps * h, rtol=1e-3)


def test_uniform_force_on_a_free_rigid_body_changes_its_momentum_by_f_t():
    world = rigid.World(gravity=(0, 0, 0), forces=[uniform()])
    world.add_body(rigid.BodyShape.box(size=(0.4, 0.2, 0.3), mass=2.0))
    steps, h = 30, 1 / 60
    for _ in range(steps):
        world.step(h)
    momentum = world.mass @ world.velocity
    # Position Verlet from rest gives v = k h F/m exactly; sticks are mass-weighted
    # projections (momentum-free); what is left is round-off.
    assert_allclose(momentum, world.count * F * steps * h, rtol=1e-9)


def test_gravity_as_a_body_force_adds_to_the_worlds_own():
    world = rigid.World(gravity=(0, -9.81, 0))
    world.add_particles([[0, 0, 0], [1, 0, 0]], mass=[1.0, 3.0])
    world.add_force(mo.Gravity((0, -0.19, 0)))
    for _ in range(60):
        world.step(1 / 60)
    assert_allclose(world.mass @ world.velocity, [0, -4.0 * 10.0, 0], rtol=1e-12)


# --- fields make the expected motion ---------------------------------------------------


def test_linear_attractor_moves_a_cloths_centre_of_mass_by_the_implicit_euler_map():
    centre, s, h = np.array([0.3, -0.5, 1.0]), 4.0, 0.02
    cloth = free_cloth(forces=[RadialField(centre, s, falloff="linear")])
    total = cloth.mass.sum()
    x = cloth.mass @ cloth.position.T / total
    v = np.zeros(3)
    start = np.linalg.norm(x - centre)
    for _ in range(40):
        cloth.step(h)
        # Springs are internal and the field's Jacobian -m s I is exact (the field is
        # linear): summed over particles, Baraff-Witkin's step is the scalar map
        # v1 = (v0 + h s (c - x0)) / (1 + h² s), x1 = x0 + h v1.
        v = (v + h * s * (centre - x)) / (1 + h * h * s)
        x = x + h * v
    assert_allclose(cloth.mass @ cloth.position.T / total, x, atol=1e-8)
    # A quarter period 2π/√s / 4 = 0.79 s: the centre of mass has nearly arrived.
    assert np.linalg.norm(x - centre) < 0.2 * start


def test_attractor_pulls_hair_toward_it():
    centre = np.array([0.4, 1.6, 0.0])

    def tips(forces):
        hair = Hair(Head((0.0, 1.6, 0.0), 0.1), strands=20, particles=6, forces=forces)
        for _ in range(20):
            hair.step(0.01)
        return hair.strands()[:, -1]

    free = np.linalg.norm(tips([]) - centre, axis=1)
    pulled = np.linalg.norm(tips([RadialField(centre, 0.5, softening=0.05)]) - centre, axis=1)
    assert np.all(pulled < free)


def test_vortex_spins_a_ring_of_particles_about_its_axis():
    axis, radius, s = np.array([0.0, 0.0, 1.0]), 0.5, 2.0
    angle = np.linspace(0, 2 * np.pi, 12, endpoint=False)
    ring = np.stack([0.8 * np.cos(angle), 0.8 * np.sin(angle), np.zeros(12)], axis=1)
    world = rigid.World(gravity=(0, 0, 0), forces=[Vortex((0, 0, 0), axis, s, radius=radius)])
    world.add_particles(ring, mass=0.5)
    t, h = 0.1, 1 / 600
    for _ in range(60):
        world.step(h)
    spin = np.cross(world.position, world.mass[:, None] * world.velocity) @ axis
    assert np.all(spin > 0)  # counter-clockwise seen from +z, every particle
    # The torque m s ρ² / (ρ² + R²) about the axis is constant while ρ = 0.8 m holds; the
    # ring drifts out by ~a² t³ / ρ ~ 1e-4 m in 0.1 s, which changes it by ~1e-4.
    rho2 = 0.8**2
    assert_allclose(spin.sum(), world.mass.sum() * s * rho2 / (rho2 + radius**2) * t, rtol=1e-3)


def tank_fluid(forces=()) -> Fluid:
    tank = Tank((0, 0, 0), (0.4, 0.6, 0.4))
    model = FluidModel(spacing=0.05, boundaries=(tank,))
    return Fluid(model, lattice((0, 0, 0), (0.4, 0.2, 0.4), 0.05), forces=forces)


def kinetic(fluid: Fluid) -> float:
    v = fluid.velocities.astype(np.float64)
    return 0.5 * float(fluid.masses @ (v * v).sum(axis=0))


def test_curl_noise_stirs_a_tank_and_the_liquid_stays_in_it():
    still = tank_fluid()
    stirred = tank_fluid([CurlNoise(8.0, 0.15, seed=3, time_scale=2.0)])
    for _ in range(15):
        still.step(1 / 60)
        stirred.step(1 / 60)
    # A settled tank barely moves (density corrections only); eddies of 8 m/s² over 0.25 s
    # give speeds of order 1 m/s, kinetic energy orders of magnitude above.
    assert kinetic(stirred) > 100 * kinetic(still)
    radius = 0.5 * 0.05
    x = stirred.positions
    assert np.all(np.isfinite(x))
    tol = 1e-5  # float32 positions of order 1 m
    assert np.all(x >= radius - tol) and np.all(np.array([0.4, 0.6, 0.4]) - radius + tol >= x.T)


def test_a_fluid_refuses_forces_that_hold_particle_indices():
    with pytest.raises(TypeError, match="reorders its particles"):
        tank_fluid().add_force(mo.Springs([[0, 1]], 0.05, 10.0, 0.0))


# --- callbacks see each kind's arrays --------------------------------------------------


def kinds_with(force):
    cloth = Cloth.grid(4, 3, forces=[force])
    hair = Hair(Head((0, 1.6, 0), 0.1), strands=3, particles=4, forces=[force])
    water = tank_fluid([force])
    world = rigid.World(forces=[force])
    world.add_particles(np.zeros((5, 3)))
    return {"cloth": (cloth, 12), "hair": (hair, 12), "fluid": (water, len(water)),
            "world": (world, 5)}  # fmt: skip


def test_callbacks_receive_n_by_3_float64_arrays_and_the_time():
    seen = []

    def record(x, v, t):
        seen.append((x.shape, v.shape, x.dtype, v.dtype, type(t)))
        return np.zeros_like(x)

    for name, (body, n) in kinds_with(CallbackForce(record)).items():
        seen.clear()
        body.step(0.01)
        assert seen, name
        assert seen[0] == ((n, 3), (n, 3), np.float64, np.float64, float), name


def test_a_callback_of_the_wrong_shape_is_an_error_on_every_kind():
    bad = CallbackForce(lambda x, v, t: np.zeros((2, 3)))
    for name, (body, _) in kinds_with(bad).items():
        with pytest.raises(ValueError, match="must return shape"):
            body.step(0.01)
        assert name


# --- scene files -----------------------------------------------------------------------

SCENE = """
[scene]
fps = 30
substeps = 1
duration = 1
[camera]
position = [0, 1, 4]
target = [0, 1, 0]
resolution = [32, 24]

[[body]]
name = "flag"
type = "cloth"
grid = [6, 4]
pin_columns = [0]
  [[body.force]]
  type = "curl_noise"
  strength = 2.0
  scale = 0.3
  seed = 4
  time_scale = 1.0

[[body]]
name = "hair"
type = "hair"
strands = 4
particles = 4
  [[body.force]]
  type = "vortex"
  center = [0, 1.6, 0]
  axis = [0, 1, 0]
  strength = 0.5

[[body]]
name = "water"
type = "fluid"
spacing = 0.05
  [[body.wall]]
  type = "tank"
  lower = [0, 0, 0]
  upper = [0.3, 0.3, 0.3]
  [[body.block]]
  lower = [0, 0, 0]
  upper = [0.15, 0.15, 0.15]
  [[body.force]]
  type = "radial"
  center = [0.3, 0.1, 0.3]
  strength = 0.1

[[body]]
name = "tower"
type = "box_tower"
  [[body.force]]
  type = "wind"
  velocity = [2, 0, 0]
  coefficient = 0.5
"""


def test_body_force_tables_build_the_forces_python_would():
    scene = load_scene(SCENE)
    (noise,) = scene.bodies["flag"].cloth.forces
    assert repr(noise) == repr(CurlNoise(2.0, 0.3, seed=4, time_scale=1.0))
    (swirl,) = scene.bodies["hair"].hair.forces
    assert repr(swirl) == repr(Vortex((0, 1.6, 0), (0, 1, 0), 0.5))
    (pull,) = scene.bodies["water"].fluid.forces
    assert repr(pull) == repr(RadialField((0.3, 0.1, 0.3), 0.1))
    (wind,) = scene.bodies["tower"].world.forces
    assert isinstance(wind, mo.Wind) and wind.coefficient == 0.5
    assert_array_equal(wind.wind, [2, 0, 0])

    # The scene's flag steps exactly as the same cloth built in Python.
    cloth = Cloth.grid(6, 4, forces=[CurlNoise(2.0, 0.3, seed=4, time_scale=1.0)])
    cloth.pin(cloth.grid_index(slice(None), 0))
    scene.advance()
    cloth.step(1 / 30)
    assert_array_equal(scene.bodies["flag"].cloth.position, cloth.position)


@pytest.mark.parametrize(
    ("replace", "bad", "path", "message"),
    [
        ('type = "curl_noise"', 'type = "curl"', "body[0].force[0].type", "must be one of"),
        ("strength = 2.0\n", "", "body[0].force[0].strength", "is required"),
        ("scale = 0.3", "scale = -1", "body[0].force[0].scale", "must be > 0"),
        ("strength = 0.5", "strength = 0.5\n  radius = 0", "body[1].force[0].radius", "> 0"),
        ("strength = 0.1", "strenght = 0.1", "body[2].force[0].strenght", "unknown key"),
        ("coefficient = 0.5", "coefficient = -1", "body[3].force[0].coefficient", ">= 0"),
    ],
)
def test_body_force_mistakes_name_the_key_path(replace, bad, path, message):
    with pytest.raises(SceneError, match=message) as error:
        load_scene(SCENE.replace(replace, bad, 1))
    assert error.value.path == path


def test_turbulent_flag_example_flutters_and_holds_its_edge():
    path = EXAMPLES / "scenes" / "turbulent_flag.toml"
    calm = load_scene(path.read_text().split("  # A breeze")[0])
    scene = load_scene(path)
    flag = scene.bodies["flag"].cloth
    edge = flag.grid_index(slice(None), 0)
    held = flag.position[:, edge].copy()
    for _ in range(20):
        scene.advance()
        calm.advance()
    assert not flag.diverged
    assert_array_equal(flag.position[:, edge], held)
    # Breeze and eddies move the free cloth far more than gravity alone lets it swing;
    # the breeze along +x streams it out from the pole.
    calm_flag = calm.bodies["flag"].cloth
    assert np.abs(flag.velocity[2]).mean() > 3 * np.abs(calm_flag.velocity[2]).mean()
    assert flag.position[0].max() > calm_flag.position[0].max()
