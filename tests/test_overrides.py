"""``motes run --set KEY=VALUE`` and ``load_scene(overrides=...)``: values set over a
scene file's, checked as the file's are, recorded in the output."""

from __future__ import annotations

import json

import pytest

from motes.cli import main
from motes.io import read_metadata
from motes.scene import SceneError, load_scene
from motes.scene.overrides import parse_assignment, parse_value, split_key

SCENE = """
[scene]
name = "pair"
fps = 10
seed = 5
[camera]
resolution = [32, 18]
position = [0.0, 1.0, 5.0]
fov = 50
[[system]]
name = "sparks"
capacity = 100
  [[system.emitter]]
  rate = { type = "per_second", rate = 100 }
[[system]]
name = "smoke"
capacity = 200
  [[system.emitter]]
  rate = { type = "burst", count = 5 }
  [[system.emitter]]
  rate = { type = "burst", count = 7 }
"""


@pytest.fixture
def scene_file(tmp_path):
    path = tmp_path / "pair.toml"
    path.write_text(SCENE)
    return path


def one_error_line(capsys) -> str:
    err = capsys.readouterr().err
    assert err.startswith("motes: error: ") and err.count("\n") == 1, err
    return err


@pytest.mark.parametrize(
    ("text", "value"),
    [
        ("7", 7),
        ("0.5", 0.5),
        ('"fire"', "fire"),
        ("[1, 2, 3]", [1, 2, 3]),
        ("true", True),
        ("{ type = 'burst', count = 3 }", {"type": "burst", "count": 3}),
        ("fire", "fire"),  # not TOML: a bare string
        ("", ""),
        ("1 2", "1 2"),
        ("7\nextra = 1", "7\nextra = 1"),  # never a second key
    ],
)
def test_values_are_toml_or_else_text(text, value):
    assert parse_value(text) == value


def test_assignments_split_at_the_first_equals_sign():
    assert parse_assignment("scene.name=a=b") == ("scene.name", "a=b")
    assert parse_assignment(" camera.fov = 40 ") == ("camera.fov", 40)
    for bad in ("scene.seed", "=7"):
        with pytest.raises(SceneError, match="KEY=VALUE"):
            parse_assignment(bad)


def test_keys_are_dotted_with_toml_quoting():
    assert split_key("system.0.emitter.1.rate") == ["system", "0", "emitter", "1", "rate"]
    assert split_key('system."my.fire".capacity') == ["system", "my.fire", "capacity"]
    for bad in ("system..capacity", "", 'system."open'):
        with pytest.raises(SceneError, match="dotted path"):
            split_key(bad)


def test_overrides_set_values_by_index_and_by_name(scene_file):
    scene = load_scene(
        scene_file,
        overrides={
            "scene.seed": 7,
            "camera.fov": 40,
            "camera.position.1": 2.5,  # an entry of an array of values
            "system.1.capacity": 300,
            "system.sparks.capacity": 150,  # an entry of an array of tables, by name
            "system.smoke.emitter.1.rate.count": 9,
            "render.exposure": 2.0,  # a table the file leaves out is made
        },
    )
    assert scene.seed == 7
    assert scene.camera.fov == 40.0
    assert tuple(scene.camera.position) == (0.0, 2.5, 5.0)
    assert scene.systems["smoke"].store.capacity == 300
    assert scene.systems["sparks"].store.capacity == 150
    assert [e.rate.size for e in scene.systems["smoke"].emitters] == [5, 9]
    assert scene.render_settings.exposure == 2.0
    assert scene.overrides["scene.seed"] == 7


def test_the_seed_argument_wins_over_an_override(scene_file):
    assert load_scene(scene_file, seed=3, overrides={"scene.seed": 7}).seed == 3


def test_an_override_seed_gives_the_same_run_as_the_file_seed(scene_file, tmp_path):
    other = tmp_path / "seven.toml"
    other.write_text(SCENE.replace("seed = 5", "seed = 7"))
    runs = []
    for scene in (load_scene(scene_file, overrides={"scene.seed": 7}), load_scene(other)):
        for _ in range(3):
            scene.advance()
        runs.append(scene.systems["sparks"]["position"].copy())
    assert runs[0].shape[0] > 0
    assert (runs[0] == runs[1]).all()


@pytest.mark.parametrize(
    ("key", "path", "message"),
    [
        # The reader's own messages, with the key path and a guess.
        ("scene.durashun", "scene.durashun", "unknown key; did you mean 'duration'?"),
        ("system.smoke.emitter.0.rat", "system[1].emitter[0].rat", "did you mean 'rate'?"),
        ("rendr.exposure", "rendr", "unknown key; did you mean 'render'?"),
        # What only an override can get wrong.
        ("system.5.capacity", "system",
         "index 5 in override 'system.5.capacity' is out of range (the array has 2 entries)"),
        ("system.smoek.capacity", "system",
         "no entry named 'smoek' in override 'system.smoek.capacity'; did you mean 'smoke'?"),
        ("scene.seed.x", "scene.seed", "is integer 5, not a table"),
        ("camera.key.0.time", "camera.key", "is not in the scene"),
        ("camera.fov.0", "camera.fov", "is integer 50, not a table"),
        ("scene.0", "scene", "is a table, not an array"),
        ("camera.resolution.x", "camera.resolution", "has no named entries"),
    ],
)  # fmt: skip
def test_mistakes_name_the_key_path(scene_file, key, path, message):
    with pytest.raises(SceneError) as error:
        load_scene(scene_file, overrides={key: 1.0})
    assert error.value.path == path
    assert message in error.value.message


def test_overridden_values_meet_the_files_checks(scene_file):
    with pytest.raises(SceneError) as error:
        load_scene(scene_file, overrides={"system.sparks.capacity": -5})
    assert error.value.path == "system[0].capacity"
    assert "must be >= 1, got -5" in error.value.message
    with pytest.raises(SceneError, match=r"camera\.fov: must be a number, got string 'wide'"):
        load_scene(scene_file, overrides={"camera.fov": "wide"})


def test_cli_set_is_repeatable_and_recorded(scene_file, tmp_path):
    out = tmp_path / "pair.png"
    args = ["run", str(scene_file), "-o", str(out), "--frames", "2", "-q"]
    assert main([*args, "--set", "scene.seed=11", "--set", "system.sparks.capacity=50"]) == 0
    record = read_metadata(out)
    assert record["seed"] == "11"  # the seed the run used
    assert json.loads(record["overrides"]) == {"scene.seed": 11, "system.sparks.capacity": 50}


@pytest.mark.parametrize(
    ("setting", "message"),
    [
        ("system.9.capacity=1", "motes: error: system: index 9 in override"),
        ("scene.durashun=1", "motes: error: scene.durashun: unknown key; did you mean 'duration'?"),
        ("scene.seed.x=1", "motes: error: scene.seed: is integer 5, not a table"),
        ("scene.seed", "motes: error: --set takes KEY=VALUE"),
        ("system.smoke.capacity=many",
         "motes: error: system[1].capacity: must be an integer, got string 'many'"),
    ],
)  # fmt: skip
def test_cli_mistakes_are_one_line_with_status_2(scene_file, tmp_path, capsys, setting, message):
    out = tmp_path / "never.png"
    assert main(["run", str(scene_file), "-o", str(out), "-q", "--set", setting]) == 2
    assert one_error_line(capsys).startswith(message)
    assert not out.exists()
