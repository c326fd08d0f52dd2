"""Cloth and hair as a model, a state and a control; springs between chosen cloth
vertices, in Python and in scene files."""

import dataclasses
import typing

import numpy as np
import pytest
from numpy.testing import assert_array_equal

import motes as mo
from motes.cloth import Airflow, Cloth, ClothControl, ClothModel, ClothState, Keyframes
from motes.hair import Hair, HairControl, HairModel, HairState, Head
from motes.integrate.implicit import ImplicitEuler
from motes.scene import SceneError, load_scene

H = 1 / 60


def flag() -> Cloth:
    """Wind with gusts, a ball, a pin and a moving handle: every part of a step."""
    cloth = Cloth.grid(
        10,
        8,
        size=(0.9, 0.7),
        origin=(0.0, 1.0, 0.0),
        wind=Airflow((3.0, 0.0, 1.0), gust=0.5, seed=2),
        colliders=[mo.colliders.Sphere((0.4, 0.5, 0.1), 0.2)],
        forces=[mo.CurlNoise(1.0, 0.3, seed=1)],
    )
    cloth.pin(cloth.grid_index(0, 0))
    cloth.move(cloth.grid_index(0, -1), Keyframes([0.0, 0.5], [[0, 0, 0], [0.2, 0.1, 0]]))
    return cloth


def hair() -> Hair:
    head = Head((0.0, 1.6, 0.0), 0.1, rotation=Keyframes([0.0, 0.5], [[0, 0, 0], [40, 10, 0]]))
    return Hair(head, strands=12, particles=6, seed=3, forces=[mo.CurlNoise(1.0, 0.3)])


def run(body, steps: int):
    positions, iterations = [], []
    for _ in range(steps):
        body.step(H)
        positions.append(body.position.copy())
        iterations.append(body.last_report.iterations)
    return np.stack(positions), iterations


@pytest.mark.parametrize("make", [flag, hair], ids=["cloth", "hair"])
def test_restoring_a_copied_state_repeats_the_run_bit_for_bit(make):
    body = make()
    run(body, 5)  # under way: moving, and the solve has a warm start
    saved = body.state.copy()
    assert saved.warm_start is not None and saved.time == pytest.approx(5 * H)
    first, first_iterations = run(body, 10)
    body.state = saved
    again, again_iterations = run(body, 10)
    assert_array_equal(again, first)
    assert again_iterations == first_iterations  # the warm start came back with the state
    # Setting copies: stepping after the rewind left the saved state as it was.
    body.state = saved
    assert_array_equal(run(body, 10)[0], first)


def test_a_cold_solve_starts_elsewhere_so_the_warm_start_belongs_to_the_state():
    cloth = flag()
    run(cloth, 5)
    cold = cloth.state.copy()
    cold.warm_start = None
    saved = cloth.state.copy()
    warm_iterations = run(cloth, 1)[1]
    cloth.state = cold
    assert run(cloth, 1)[1] != warm_iterations
    cloth.state = saved
    assert run(cloth, 1)[1] == warm_iterations


@pytest.mark.parametrize("make", [flag, hair], ids=["cloth", "hair"])
def test_stepping_reads_the_model_and_never_rebuilds_it(make):
    body = make()
    model = body.model
    mass = model.springs.rest_length.copy(), body.mass.copy()
    run(body, 3)
    assert body.model is model
    assert_array_equal(model.springs.rest_length, mass[0])
    assert_array_equal(body.mass, mass[1])
    # A new force makes a new model and leaves the old one as it was.
    drag = body.add_force(mo.Drag(0.01))
    assert body.model is not model and body.forces[-1] is drag and drag not in model.forces


def test_retuning_takes_new_springs_and_damping_over_the_same_state():
    cloth = Cloth.grid(8, 8, structural=mo.SpringFamily(200.0, 0.2))
    cloth.step(1 / 60)
    stiffer = Cloth.grid(8, 8, structural=mo.SpringFamily(900.0, 0.3), air_damping=0.5)
    position = cloth.position.copy()
    cloth.retune(stiffer.model)
    assert cloth.model.structural.stiffness == 900.0 and cloth.model.air_damping == 0.5
    assert cloth.model.vertex_mass is not stiffer.model.vertex_mass  # masses kept
    assert_array_equal(cloth.position, position)
    with pytest.raises(ValueError, match="other vertices or topology"):
        cloth.retune(Cloth.grid(9, 7).model)  # 63 vertices, not 64


def test_retuning_hair_takes_new_springs_over_the_same_strands():
    head = Head((0.0, 1.6, 0.0), 0.1)
    hair = Hair(head, strands=20, particles=6, seed=3, stretch=(500.0, 0.02))
    hair.step(1 / 60)
    position = hair.position.copy()
    stiffer = Hair(head, strands=20, particles=6, seed=3, stretch=(900.0, 0.02), air_damping=3.0)
    hair.retune(stiffer.model)
    assert hair.model.springs is stiffer.model.springs and hair.model.air_damping == 3.0
    assert_array_equal(hair.position, position)
    with pytest.raises(ValueError, match="other particles or topology"):
        hair.retune(Hair(head, strands=20, particles=6, seed=4).model)  # other roots


def test_a_state_of_another_size_is_refused():
    cloth, small = flag(), Cloth.grid(3, 3)
    with pytest.raises(ValueError, match="state must hold this cloth's 80 vertices, got 9"):
        cloth.state = small.state
    with pytest.raises(TypeError, match="state must be a ClothState"):
        cloth.state = hair().state
    strands = hair()
    with pytest.raises(ValueError, match="state must hold this hair's 72 particles, got 80"):
        strands.state = HairState(cloth.position, cloth.velocity)
    broken = cloth.state.copy()
    broken.warm_start = np.zeros((3, 3))
    with pytest.raises(ValueError, match=r"state must hold 80 particles, a warm start"):
        cloth.state = broken


def _dict_typed(hint) -> bool:
    return (
        hint is dict
        or typing.get_origin(hint) is dict
        or any(_dict_typed(a) for a in typing.get_args(hint))
    )


@pytest.mark.parametrize(
    ("cls", "instance"),
    [
        (ClothModel, lambda: flag().model),
        (ClothState, lambda: flag().state),
        (ClothControl, lambda: flag().control),
        (HairModel, lambda: hair().model),
        (HairState, lambda: hair().state),
        (HairControl, lambda: hair().control),
    ],
)
def test_models_states_and_controls_have_typed_fields_and_no_dicts(cls, instance):
    hints = typing.get_type_hints(cls)
    fields = dataclasses.fields(cls)
    assert fields and all(f.name in hints for f in fields)
    assert not any(_dict_typed(hints[f.name]) for f in fields)
    value = instance()
    assert not any(isinstance(getattr(value, f.name), dict) for f in fields)


def test_position_and_velocity_stay_assignable():
    cloth = Cloth.grid(4, 3, gravity=(0.0, 0.0, 0.0), air_damping=0.0)
    cloth.velocity = np.tile([[0.5], [0.0], [0.0]], cloth.n)
    start = cloth.position.copy()
    cloth.step(0.1)
    np.testing.assert_allclose(cloth.position, start + np.array([[0.05], [0.0], [0.0]]), atol=1e-12)
    cloth.position = start
    assert cloth.state.positions is cloth.position
    with pytest.raises(ValueError, match=r"velocity must have shape \(3, 12\)"):
        cloth.velocity = np.zeros((12, 3))


# -- springs between chosen vertices ---------------------------------------------------


def strip() -> Cloth:
    """A 1 m × 0.1 m strip in zero gravity, pleated so that it can bend out of its
    plane when its ends are pulled together."""
    return Cloth.grid(
        21,
        3,
        size=(1.0, 0.1),
        ripple=(0.01, 0.5),
        gravity=(0.0, 0.0, 0.0),
        air_damping=1.0,
    )


def stitched_strip() -> tuple[Cloth, np.ndarray]:
    cloth = strip()
    ends = np.stack([cloth.grid_index(slice(None), 0), cloth.grid_index(slice(None), -1)], 1)
    cloth.add_springs(ends, stiffness=20.0, damping=0.05, rest_length=0.0)
    return cloth, ends


def end_gap(cloth: Cloth, ends: np.ndarray) -> float:
    """Largest distance [m] between the stitched vertices."""
    return np.linalg.norm(np.diff(cloth.position[:, ends], axis=2), axis=0).max()


def test_a_stitch_of_rest_length_zero_closes_a_strip_into_a_loop():
    cloth, ends = stitched_strip()
    assert cloth.springs.spring_count == strip().springs.spring_count + 3
    assert end_gap(cloth, ends) == pytest.approx(1.0)
    for _ in range(round(3.0 / H)):
        cloth.step(H)
    # Measured 0.31 mm from 2 s on: the stitch's stretch that balances the bent strip's
    # springs (a loop of a strip that rests flat), not a motion still decaying.
    assert end_gap(cloth, ends) < 1e-3
    assert cloth.stretch().max() < 0.01  # closed by bending the strip, not stretching it


def two_panels(gap: float) -> Cloth:
    """Two 0.2 m squares ``gap`` apart along x, one cloth of two parts."""
    square = np.array([[0, 0, 0], [0.2, 0, 0], [0.2, 0.2, 0], [0, 0.2, 0]], dtype=float)
    vertices = np.concatenate([square, square + np.array([0.2 + gap, 0.0, 0.0])])
    faces = np.array([[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]])
    return Cloth(vertices, faces, gravity=(0.0, 0.0, 0.0), air_damping=2.0)


def test_a_stiff_tether_settles_at_its_rest_length():
    cloth = two_panels(0.3)
    # Vertex masses ~ 3e-3 kg: k / m ~ 3e6 /s², ω h ~ 30 at h = 1/60 s. Only an
    # implicit spring is stable at that step.
    cloth.add_springs([[1, 4], [2, 7]], stiffness=1e4, damping=1.0, rest_length=0.1)
    for _ in range(round(2.0 / H)):
        cloth.step(H)
    d = np.linalg.norm(cloth.position[:, [1, 2]] - cloth.position[:, [4, 7]], axis=0)
    # Nothing else pulls on the panels: what is left at 2 s is the decaying motion
    # (measured |d - 0.1| < 1e-8; the oscillation is damped by air_damping = 2 /s).
    np.testing.assert_allclose(d, 0.1, atol=1e-6)


def test_springs_default_to_the_current_distance():
    cloth = two_panels(0.3)
    cloth.add_springs([[1, 4]], 100.0)
    assert cloth.springs.rest_length[-1] == pytest.approx(0.3)
    assert cloth.springs.damping[-1] == 0.0


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (([[0, 8]], 1.0), r"pairs must index vertices in \[0, 7\], pair 0 is \[0, 8\]"),
        (([[0, -1]], 1.0), r"pairs must index vertices in \[0, 7\]"),
        (([[1, 4], [3, 3]], 1.0), "pairs must join two different vertices, pair 1 joins vertex 3"),
        (([0, 1, 2], 1.0), r"pairs must be a \(k, 2\) array"),
        (([[0.0, 1.0]], 1.0), "pairs must be integer vertex indices"),
        (([[0, 4]], -1.0), r"stiffness must be finite and >= 0 \[N/m\]"),
        (([[0, 4]], 1.0, -0.1), r"damping must be finite and >= 0 \[N s/m\]"),
        (([[0, 4]], 1.0, 0.0, -0.5), r"rest_length must be finite and >= 0 \[m\]"),
        (([[0, 4]], 1.0, 0.0, np.nan), "rest_length must be finite"),
        (([[0, 4], [1, 5]], [1.0, 2.0, 3.0]), r"stiffness must be a number or \(2,\)"),
    ],
)
def test_bad_springs_are_refused_with_the_argument_and_its_range(args, message):
    cloth = two_panels(0.3)
    model = cloth.model
    with pytest.raises(ValueError, match=message):
        cloth.add_springs(*args)
    assert cloth.model is model


# -- springs in scene files -------------------------------------------------------------

SCENE = """
[scene]
fps = 30
substeps = 2
duration = 1
[camera]
position = [0, 0, 3]
target = [0.5, 0, 0]
resolution = [64, 48]
[[body]]
name = "strip"
type = "cloth"
grid = [21, 3]
size = [1.0, 0.1]
ripple = [0.01, 0.5]
gravity = [0, 0, 0]
air_damping = 1.0
"""

STITCH = """
  [[body.spring]]
  a = [{row}, 0]
  b = [{row}, -1]
  stiffness = 20.0
  damping = 0.05
  rest_length = 0.0
"""


def test_a_scene_stitch_closes_the_gap_it_names():
    scene = load_scene(SCENE + "".join(STITCH.format(row=r) for r in range(3)))
    cloth = scene.bodies["strip"].cloth
    python, ends = stitched_strip()
    assert_array_equal(cloth.springs.pairs, python.springs.pairs)
    for _ in range(90):  # 3 s in substeps of 1/60 s
        scene.advance()
        for _ in range(2):
            python.step(H)
    assert end_gap(cloth, ends) < 1e-3
    # The scene's stitches step exactly as the same ones made in Python.
    assert_array_equal(cloth.position, python.position)
    plain = load_scene(SCENE).bodies["strip"].cloth
    assert plain.springs.spring_count == cloth.springs.spring_count - 3


def test_a_scene_spring_on_a_mesh_cloth_names_vertices_and_defaults_its_rest_length(tmp_path):
    (tmp_path / "sheet.obj").write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    text = SCENE.replace("grid = [21, 3]", 'mesh = "sheet.obj"').replace(
        "size = [1.0, 0.1]\nripple = [0.01, 0.5]\n", ""
    )
    path = tmp_path / "scene.toml"
    path.write_text(text + "[[body.spring]]\na = 0\nb = 2\nstiffness = 5.0\n")
    cloth = load_scene(path).bodies["strip"].cloth
    assert_array_equal(cloth.springs.pairs[-1], [0, 2])
    assert cloth.springs.rest_length[-1] == pytest.approx(np.sqrt(2.0))


@pytest.mark.parametrize(
    ("spring", "path", "message"),
    [
        ("a = [3, 0]\nb = [0, 1]\nstiffness = 1.0", "a", "inside 3 x 21"),
        ("a = [0, 0]\nb = [0, 21]\nstiffness = 1.0", "b", "inside 3 x 21"),
        ("a = [0, 0.5]\nb = [0, 1]\nstiffness = 1.0", "a", "grid vertex"),
        ("a = 4\nb = [0, 1]\nstiffness = 1.0", "a", r"grid vertex \[row, column\]"),
        ("a = [0, 0]\nb = [0, -21]\nstiffness = 1.0", "b", "another vertex than a"),
        ("a = [0, 0]\nb = [0, 1]\nstiffness = -1.0", "stiffness", "must be >= 0"),
        ("a = [0, 0]\nb = [0, 1]\nstiffness = 1.0\ndamping = 'x'", "damping", "a number"),
        ("a = [0, 0]\nb = [0, 1]\nstiffness = 1.0\nrest_length = -2", "rest_length", ">= 0"),
        ("a = [0, 0]\nb = [0, 1]", "stiffness", "is required"),
        ("a = [0, 0]\nb = [0, 1]\nstiffnes = 1.0", "stiffnes", "did you mean 'stiffness'"),
    ],
)
def test_a_bad_scene_spring_gives_one_error_naming_its_key(spring, path, message):
    with pytest.raises(SceneError, match=message) as error:
        load_scene(SCENE + "[[body.spring]]\n" + spring + "\n")
    assert error.value.path == f"body[0].spring[0].{path}"


def test_two_cloths_sharing_a_solver_step_as_if_each_had_its_own():
    def pair(shared: bool):
        own = ImplicitEuler(tolerance=1e-2)
        solvers = (own, own) if shared else (own, ImplicitEuler(tolerance=1e-2))
        a = Cloth.grid(8, 6, solver=solvers[0])
        a.pin(a.grid_index(0, slice(None)))
        b = Cloth.grid(8, 6, solver=solvers[1], wind=Airflow((2.0, 0.0, 1.0)))
        for _ in range(10):
            a.step(H)
            b.step(H)
        return a.position, b.position

    for shared, alone in zip(pair(True), pair(False), strict=True):
        assert_array_equal(shared, alone)


def test_positions_and_velocities_must_be_finite():
    from motes import Cloth

    cloth = Cloth.grid(4, 4)
    bad = cloth.position.copy()
    bad[1, 2] = np.nan
    with pytest.raises(ValueError, match="position must be finite"):
        cloth.position = bad
    with pytest.raises(ValueError, match=r"velocity must have shape \(3, 16\)"):
        cloth.velocity = np.zeros((3, 4))
