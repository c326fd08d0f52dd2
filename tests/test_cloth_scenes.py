"""The cloth and hair scenes run headless and keep their invariants; scene-file mistakes
in cloth and hair bodies name their key."""

import numpy as np
import pytest

from motes.scene import SceneError, load_scene

SIZE = (96, 54)


def advance(scene, seconds):
    for _ in range(round(seconds * scene.fps)):
        scene.advance()


def test_flag_flutters_in_the_gusts():
    scene = load_scene("flag")
    cloth = scene.bodies["flag"].cloth
    corner = cloth.grid_index(-1, -1)[0]  # bottom of the free edge
    pole = cloth.grid_index(slice(None), 0)
    on_pole = cloth.position[:, pole].copy()
    advance(scene, 1.0)
    depth = []
    for _ in range(30):
        scene.advance()
        depth.append(cloth.position[2, corner])
    assert not cloth.diverged
    # Fluttering, not leaning: the free corner keeps moving across the wind (measured
    # standard deviation ~0.1 m over one second).
    assert np.std(depth) > 0.02
    np.testing.assert_array_equal(cloth.position[:, pole], on_pole)


def test_cloth_drop_drapes_over_the_ball_onto_the_table():
    scene = load_scene("cloth_drop")
    cloth = scene.bodies["cloth"].cloth
    advance(scene, 2.0)
    centre = np.array([0.0, 1.15, 0.0])
    distance = np.linalg.norm(cloth.position.T - centre, axis=1)
    assert distance.min() >= 0.35 + cloth.thickness - 1e-9
    middle = cloth.grid_index(24, 24)[0]
    assert cloth.position[1, middle] > 1.45  # held up by the ball (top at 1.5 m)
    over_table = (np.abs(cloth.position[0]) < 0.65) & (np.abs(cloth.position[2]) < 0.45)
    assert np.all(cloth.position[1, over_table] >= 0.8 + cloth.thickness - 1e-9)
    assert scene.render(SIZE).std() > 2


def test_curtain_opens():
    scene = load_scene("curtain")
    left, right = scene.bodies["left"].cloth, scene.bodies["right"].cloth
    inner_left = left.grid_index(0, -1)[0]
    inner_right = right.grid_index(0, 0)[0]
    gap0 = right.position[0, inner_right] - left.position[0, inner_left]
    advance(scene, 4.6)
    gap = right.position[0, inner_right] - left.position[0, inner_left]
    # The handles' leading ends moved 1.2 m each along the rail, exactly.
    assert gap - gap0 == pytest.approx(2.4, abs=1e-9)
    # Tapered: the outer ends stayed put, so each panel is gathered to 0.3 m of rail.
    assert left.position[0, left.grid_index(0, 0)[0]] == pytest.approx(-1.5)
    assert not left.diverged and not right.diverged


def test_hair_follows_the_turning_head():
    scene = load_scene("hair")
    hair = scene.bodies["hair"].hair
    advance(scene, 1.5)
    r, c = hair.head.pose(hair.time)
    assert not np.allclose(r, np.eye(3))  # the head has turned
    roots = hair.strands()[:, 0]
    np.testing.assert_allclose(np.linalg.norm(roots - c, axis=1), hair.head.radius)
    assert np.isfinite(hair.position).all()
    assert scene.render(SIZE).std() > 2


def test_explicit_cloth_blows_up_beside_the_implicit_one():
    scene = load_scene("implicit_vs_explicit")
    advance(scene, 0.5)
    implicit, explicit = scene.bodies["implicit"], scene.bodies["explicit"]
    assert implicit.diverged_at is None and not implicit.cloth.diverged
    assert explicit.diverged_at is not None and explicit.diverged_at < 0.5
    drawn = explicit.drawables()[0].mesh.vertices
    assert np.isfinite(drawn).all()  # still drawable, clamped near its start
    assert scene.render(SIZE).std() > 2


BASE = """
[scene]
fps = 30
duration = 1
[camera]
position = [0, 1, 4]
target = [0, 0.5, 0]
resolution = [64, 48]
[[body]]
name = "c"
type = "cloth"
grid = [6, 5]
"""


@pytest.mark.parametrize(
    ("extra", "path", "message"),
    [
        ("grid = [1, 5]", "body[0].grid", "two integers >= 2"),
        ("structural = [-1.0, 0.0]", "body[0].structural", "stiffness must be >= 0"),
        ("scheme = 'rk4'", "body[0].scheme", "must be one of"),
        ("pin = [[9, 0]]", "body[0].pin[0]", "inside 5 x 6"),
        ("pin_rows = [7]", "body[0].pin_rows[0]", "must be <= 4"),
        ("tolerance = 2.0", "body[0].tolerance", "must be <= 1"),
        ("preconditioner = 'ilu'", "body[0].preconditioner", "must be one of"),
        ("wind = { velocity = [1, 0] }", "body[0].wind.velocity", "array of 3"),
        ("wind = { velocity = [1, 0, 0], gust = 2 }", "body[0].wind.gust", "must be <= 1"),
        ("stripes = ['#ff0000', 'blue']", "body[0].stripes[1]", "colour"),
        (
            "[body.handle]\ntimes = [1, 0]\noffsets = [[0, 0, 0], [1, 0, 0]]",
            "body[0].handle[0]",
            "strictly increasing",
        ),
        ("colour = 1", "body[0].colour", "unknown key"),
    ],
)
def test_cloth_body_mistakes_name_the_key(extra, path, message):
    text = BASE.replace("grid = [6, 5]", extra) if extra.startswith("grid") else BASE + extra
    with pytest.raises(SceneError, match=message) as error:
        load_scene(text)
    assert error.value.path == path


def test_a_scene_picks_the_solve_s_preconditioner():
    default = load_scene(BASE)
    jacobi = load_scene(BASE + "preconditioner = 'jacobi'\n")
    assert default.bodies["c"].cloth.solver.preconditioner == "multigrid"
    assert jacobi.bodies["c"].cloth.solver.preconditioner == "jacobi"


def test_cloth_from_a_mesh_file_and_hair_mistakes(tmp_path):
    (tmp_path / "sheet.obj").write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n")
    text = BASE.replace("grid = [6, 5]", 'mesh = "sheet.obj"\npin_vertices = [2, 3]')
    path = tmp_path / "scene.toml"
    path.write_text(text)
    scene = load_scene(path)
    advance(scene, 0.2)
    cloth = scene.bodies["c"].cloth
    assert cloth.n == 4 and np.all(cloth.position[:, 2:] == [[1, 0], [1, 1], [0, 0]])
    path.write_text(text.replace("sheet.obj", "missing.obj"))
    with pytest.raises(SceneError, match="cannot read") as error:
        load_scene(path)
    assert error.value.path == "body[0].mesh"
    hair = BASE.replace('type = "cloth"\ngrid = [6, 5]', 'type = "hair"\nstrands = 0')
    with pytest.raises(SceneError, match="must be >= 1") as error:
        load_scene(hair)
    assert error.value.path == "body[0].strands"
    head = BASE.replace('type = "cloth"\ngrid = [6, 5]', 'type = "hair"\n[body.head]\nradius = -1')
    with pytest.raises(SceneError, match="must be > 0") as error:
        load_scene(head)
    assert error.value.path == "body[0].head.radius"
