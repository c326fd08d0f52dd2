"""A rigid world as model, state and control: rewinding, rebuilding, the step function."""

import dataclasses

import numpy as np
import pytest
from numpy.testing import assert_array_equal

import motes.rigid as mr
from motes.collide import Plane
from motes.rigid.model import BodyFrame, BodyRecord, RestBox

DT = 1 / 60


def ragdoll_on_boxes() -> mr.World:
    """A ragdoll thrown onto two boxes on a bouncy, rough ground: body contacts (with
    their rotation warm start), collider contacts, restitution and joint limits."""
    world = mr.World(iterations=8)
    world.add_collider(Plane((0, 1, 0), 0.0, friction=0.6, restitution=0.3))
    world.add_body(mr.BodyShape.box((0.0, 0.25, 0.0), (1.2, 0.5, 0.8), 20.0))
    world.add_body(mr.BodyShape.box((0.2, 0.75, 0.1), (0.5, 0.5, 0.5), 5.0))
    doll = mr.add_ragdoll(world, (0.0, 1.3, 0.0), height=1.6, mass=60)
    world.set_velocity(doll.indices, (0.4, 1.0, -0.3))
    return world


def run(world: mr.World, steps: int) -> None:
    for _ in range(steps):
        world.step(DT)


def test_a_restored_state_replays_the_run_bit_for_bit():
    world = ragdoll_on_boxes()
    run(world, 20)  # the rotation warm start now differs from the exact rotations
    saved = world.state.copy()
    run(world, 60)
    first = world.state.copy()
    assert world.contacts().sum() > 0  # the bodies touch: the warm start is used
    for _ in range(2):  # the saved state is copied in, so it can be restored twice
        world.state = saved
        assert world.time == saved.time
        run(world, 60)
        assert_array_equal(world.state.particle_position, first.particle_position)
        assert_array_equal(world.state.particle_previous, first.particle_previous)
        assert_array_equal(world.state.body_rotation, first.body_rotation)
        assert world.time == first.time
    assert not np.array_equal(saved.particle_position, first.particle_position)


def test_stepping_does_not_rebuild_the_model():
    world = ragdoll_on_boxes()
    model = world.model
    run(world, 3)
    assert world.model is model
    world.damping = 2.0  # a setting is read at each step, not built into the model
    run(world, 1)
    assert world.model is model and model.parameters.damping == 2.0


def test_a_builder_call_after_stepping_rebuilds_the_model():
    world = ragdoll_on_boxes()
    run(world, 3)
    model = world.model
    world.add_collider(Plane((1, 0, 0), -5.0))
    rebuilt = world.model
    assert rebuilt is not model
    assert len(rebuilt.collider_table) == len(model.collider_table) + 1
    ball = world.add_particles([(3.0, 2.0, 0.0)], radius=0.1)
    assert world.model.particle_count == model.particle_count + 1
    run(world, 1)
    assert world.position[ball[0], 1] < 2.0


def test_a_state_with_another_particle_count_is_refused():
    world = ragdoll_on_boxes()
    saved = world.state.copy()
    world.add_particles([(3.0, 2.0, 0.0)])
    n = world.count
    with pytest.raises(ValueError, match=rf"state holds {n - 1} particles, the world has {n}"):
        world.state = saved
    with pytest.raises(TypeError, match="state must be a WorldState"):
        world.state = saved.particle_position


def test_the_step_refuses_a_rotation_warm_start_of_other_bodies():
    world = ragdoll_on_boxes()
    state = world.state.copy()
    state.body_rotation = np.zeros((1, 3, 3))
    with pytest.raises(ValueError, match=r"state.body_rotation .* \(4, 3, 3\)"):
        mr.step(world.model, state, mr.WorldControl(), DT)


def test_the_step_function_of_model_state_and_control_is_the_world_s_step():
    world = ragdoll_on_boxes()
    model = world.model
    state = world.state.copy()
    control = mr.WorldControl(
        list(world.control.particle_velocity_sets), list(world.control.particle_velocity_changes)
    )
    for _ in range(30):
        mr.step(model, state, control, DT)
    run(world, 30)
    assert_array_equal(state.particle_position, world.state.particle_position)
    assert not control.particle_velocity_sets  # consumed by the first step


@pytest.mark.parametrize("kind", [mr.WorldModel, BodyFrame, BodyRecord, RestBox, mr.WorldState])
def test_models_and_states_declare_no_dict_fields(kind):
    for field in dataclasses.fields(kind):
        assert "dict" not in str(field.type), field.name


def test_a_built_model_holds_no_dicts():
    model = ragdoll_on_boxes().model
    for field in dataclasses.fields(mr.WorldModel):
        assert not isinstance(getattr(model, field.name), dict), field.name
    assert model.body_count == 4  # two boxes, the ragdoll's torso and pelvis
    assert [box is None for box in model.body_box] == [False, False, True, True]
