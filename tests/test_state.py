"""The particle-state contract: every kind shows its particles as one ParticleState."""

from __future__ import annotations

import numpy as np
import pytest

import motes as mo
from motes.fluids import Fluid, FluidModel
from motes.render.camera import Camera
from motes.render.renderer import Renderer
from motes.state import CORE, Field, HasParticles, ParticleState
from particle_kinds import DT, KINDS, make_cloth, make_fluid, make_hair, make_system, make_world


@pytest.mark.parametrize("kind", KINDS)
def test_every_kind_has_the_documented_shapes_dtypes_and_units(kind):
    make, units, radius = KINDS[kind]
    thing = make()
    for _ in range(2):
        thing.step(DT)
    assert isinstance(thing, HasParticles)
    state = thing.particle_state()
    n = state.count
    assert n > 0 and len(state) == n
    assert state.ids.shape == (n,) and state.ids.dtype == np.int64
    assert len(np.unique(state.ids)) == n
    for name, shape in (("positions", (3, n)), ("velocities", (3, n)), ("radius", (n,))):
        assert state[name].shape == shape and state[name].dtype.kind == "f"
        assert state[name] is getattr(state, name)
    assert np.all(state.radius >= 0)
    if radius is not None:
        np.testing.assert_array_equal(state.radius, state.radius.dtype.type(radius))
    assert state.names()[:4] == tuple(CORE) == ("ids", "positions", "velocities", "radius")
    assert [state.unit(c) for c in CORE] == ["", "m", "m/s", "m"]
    for name, unit in units.items():
        assert name in state.names() and state.unit(name) == unit
    for name in state.names():
        assert state[name].shape[-1] == n and state[name].ndim in (1, 2)
        assert isinstance(state.field(name).doc, str) and state.field(name).doc


def test_system_state_is_a_view_of_the_store_under_its_own_names():
    system = make_system()
    system.run(3, DT)
    store = system.store
    state = system.particle_state()
    n = store.count
    assert np.shares_memory(state.positions, store.raw("position"))
    assert state.positions.base is not None and state["color"].shape == (4, n)
    np.testing.assert_array_equal(state.positions, store["position"].T)
    np.testing.assert_array_equal(state.radius, store["size"])
    np.testing.assert_array_equal(state.ids, store["id"])
    assert "size" not in state and "position" not in state  # core names, not store names
    store["position"][0] = (7.0, 8.0, 9.0)  # the live data, written through the store
    np.testing.assert_array_equal(state.positions[:, 0], [7.0, 8.0, 9.0])
    assert state.unit("color") == "1" and state.unit("age") == "s"


def test_a_store_without_size_has_the_attribute_default_radius():
    store = mo.ParticleStore(10)
    store.spawn(3)
    state = store.particle_state()
    np.testing.assert_array_equal(state.radius, np.full(3, 0.05, np.float32))
    assert set(state.names()) == {*CORE, "age", "lifetime"}


@pytest.mark.parametrize(
    ("make", "rows"),
    [
        (make_cloth, lambda c: (c.position, c.velocity)),
        (make_hair, lambda h: (h.position, h.velocity)),
        (make_world, lambda w: (w.state.particle_position, None)),
        (make_fluid, lambda f: (f.state.positions, f.state.velocities)),
    ],
)
def test_states_are_views_of_the_live_arrays(make, rows):
    thing = make()
    thing.step(DT)
    state = thing.particle_state()
    positions, velocities = rows(thing)
    assert state.positions is positions
    assert velocities is None or state.velocities is velocities
    positions[1, 0] += 1.0
    assert state.positions[1, 0] == positions[1, 0]


def test_world_velocities_are_the_verlet_difference():
    world = make_world()
    np.testing.assert_array_equal(world.particle_state().velocities, 0.0)
    world.step(DT)
    state = world.particle_state()
    np.testing.assert_allclose(state.velocities, world.velocity.T)
    np.testing.assert_array_equal(state.radius[0], 0.1)
    assert state["previous"] is world.state.particle_previous


def test_fluid_ids_follow_particles_through_the_solver_permutation():
    # Isolated particles (no neighbours, no walls) fall ballistically; listed in an
    # order the grid sort changes, so a step permutes every array.
    model = FluidModel(spacing=0.05, max_dt=DT)
    x0 = np.array([[2.0, 0.0, 1.0, -1.0], [0.0, 1.0, -2.0, 3.0], [0.0, 0.0, 0.0, 0.0]])
    v0 = np.array([[0.0, 1.0, 0.0, -1.0], [0.5, 0.0, 0.0, 0.0], [0.0, 0.0, 2.0, 0.0]])
    fluid = Fluid(model, x0, velocities=v0)
    permuted = False
    x, v = x0.copy(), v0.copy()
    g = np.array(model.gravity)[:, None]
    for _ in range(5):
        fluid.step(DT)
        v = v + DT * g  # symplectic Euler, as the solver's prediction
        x = x + DT * v
        state = fluid.particle_state()
        permuted |= not np.array_equal(state.ids, np.arange(4))
        order = np.argsort(state.ids)
        np.testing.assert_array_equal(state.ids[order], np.arange(4))
        # float32 state: round-off of a few 1e-7 m on values of a few metres
        np.testing.assert_allclose(state.positions[:, order], x, atol=1e-5)
        np.testing.assert_allclose(state.velocities[:, order], v, atol=1e-4)
    assert permuted


def test_take_and_replace_make_derived_states():
    state = ParticleState(
        np.arange(4),
        np.arange(12.0).reshape(3, 4),
        np.zeros((3, 4)),
        np.full(4, 0.1),
        {"color": Field(np.ones((4, 4)), "1", "linear RGBA")},
    )
    some = state.take(np.array([True, False, True, False]))
    np.testing.assert_array_equal(some.ids, [0, 2])
    assert some.positions.shape == (3, 2) and some["color"].shape == (4, 2)
    bigger = state.replace(radius=np.full(4, 0.5), mass=Field(np.ones(4), "kg", "mass"))
    assert bigger.names() == (*CORE, "color", "mass")
    assert bigger.positions is state.positions
    np.testing.assert_array_equal(bigger.radius, 0.5)


@pytest.mark.parametrize(
    ("args", "error", "message"),
    [
        ((np.arange(3.0),), ValueError, "ids must be a 1-D int64"),
        ((np.arange(3), np.zeros((3, 2))), ValueError, r"positions must be .* shape \(3, 3\)"),
        ((np.arange(3), np.zeros((3, 3)), np.zeros((2, 3))), ValueError, "velocities"),
        ((np.arange(3), np.zeros((3, 3)), np.zeros((3, 3)), np.zeros(2)), ValueError, "radius"),
    ],
)
def test_bad_states_are_refused(args, error, message):
    full = (*args, *(np.zeros((3, 3)), np.zeros((3, 3)), np.zeros(3))[len(args) - 1 :])
    with pytest.raises(error, match=message):
        ParticleState(*full[:4])


def test_bad_fields_and_names_are_refused():
    core = (np.arange(2), np.zeros((3, 2)), np.zeros((3, 2)), np.zeros(2))
    with pytest.raises(ValueError, match=r"field 'mass' must have shape \(2,\)"):
        ParticleState(*core, {"mass": Field(np.ones(3), "kg")})
    with pytest.raises(TypeError, match="must be a Field"):
        ParticleState(*core, {"mass": np.ones(2)})
    with pytest.raises(ValueError, match="identifiers other than"):
        ParticleState(*core, {"radius": Field(np.ones(2), "m")})
    with pytest.raises(KeyError, match="no attribute 'mass'"):
        ParticleState(*core)["mass"]


def test_the_renderer_draws_any_kind_and_a_system_as_its_state():
    camera = Camera((0, 1, 3), (0, 1, 0), resolution=(48, 32))
    system = make_system()
    system.run(5, DT)
    renderer = Renderer(camera)
    image = renderer.render([system])
    assert image.any()
    np.testing.assert_array_equal(renderer.render([system.particle_state()]), image)
    for make, *_ in KINDS.values():
        thing = make()
        thing.step(DT)
        assert renderer.render([thing]).any()
    with pytest.raises(TypeError, match="ParticleState or an object with particle_state"):
        renderer.render([np.zeros((3, 3))])
