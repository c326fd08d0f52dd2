"""The ``motes`` command line: outputs, exit codes and messages."""

from __future__ import annotations

import imageio_ffmpeg
import numpy as np
import pytest
from PIL import Image

import motes
from motes.cli import main
from motes.io.cache import load_cache

SMALL = ["--resolution", "64x36", "--quiet"]


def run_cli(*args):
    return main([str(a) for a in args])


def test_version_and_help(capsys):
    assert run_cli("--version") == 0
    assert capsys.readouterr().out.strip() == f"motes {motes.__version__}"
    with pytest.raises(SystemExit) as exit_info:
        run_cli("run", "--help")
    assert exit_info.value.code == 0
    text = capsys.readouterr().out
    assert "examples:" in text and "motes run fire -o fire.gif --frames 60" in text


def test_scenes_lists_every_builtin_with_a_description(capsys):
    assert run_cli("scenes") == 0
    lines = capsys.readouterr().out.splitlines()
    names = {line.split()[0] for line in lines}
    assert {"fire", "smoke", "fireworks", "rain", "explosion", "snow", "waterfall", "lod"} <= names
    assert all(len(line.split()) > 3 for line in lines)


def test_run_writes_a_gif_and_a_cache_that_read_back(tmp_path, capsys):
    gif, cache = tmp_path / "fire.gif", tmp_path / "fire.h5"
    assert run_cli("run", "fire", "-o", gif, "--frames", 4, "--export", cache, *SMALL) == 0
    assert capsys.readouterr().err == ""
    with Image.open(gif) as image:
        assert image.size == (64, 36)
        assert image.n_frames >= 2  # Pillow merges identical frames; fire frames differ
    data = load_cache(cache)
    assert data.frame_count == 4
    np.testing.assert_allclose(data.times, np.arange(1, 5) / 30)
    first = data.frame(0, "flame")
    assert first["positions"].shape[1] == 3 and len(first["ids"]) > 0
    data.close()
    lossy = tmp_path / "lossy.h5"
    args = ("--frames", 4, "--export", lossy, "--significant-digits", 3, "--no-render")
    assert run_cli("run", "fire", *args, "-q") == 0
    with load_cache(lossy) as again:
        assert again.significant_digits == 3
        assert again.frame(0, "flame")["positions"].shape == first["positions"].shape


@pytest.mark.parametrize(
    ("scene", "body", "seed"), [("pendulums", "cradle", 3), ("cloth_drop", "cloth", 1)]
)
def test_export_of_a_scene_made_only_of_bodies_holds_the_bodies(tmp_path, scene, body, seed):
    path = tmp_path / "c.npz"
    assert run_cli("run", scene, "--no-render", "--frames", 2, "--export", path, "--quiet") == 0
    cache = load_cache(path)
    assert (cache.scene, cache.seed, cache.names) == (scene, seed, (body,))
    assert cache.overrides == {}
    live = motes.load_scene(scene)
    for _ in range(2):
        live.advance()
    state = live.states()[body]
    np.testing.assert_array_equal(cache.counts(body), [state.count] * 2)
    np.testing.assert_array_equal(cache.state(-1, body).positions, state.positions)
    assert cache.unit("positions", body) == "m"


def test_run_writes_mp4_png_and_sequences(tmp_path):
    mp4 = tmp_path / "smoke.mp4"
    assert run_cli("run", "smoke", "-o", mp4, "--frames", 3, *SMALL) == 0
    assert imageio_ffmpeg.count_frames_and_secs(str(mp4))[0] == 3
    png = tmp_path / "last.png"
    assert run_cli("run", "smoke", "-o", png, "--frames", 2, *SMALL) == 0
    with Image.open(png) as image:
        assert image.size == (64, 36)
        assert np.asarray(image).std() > 1  # a ground, a sky and smoke: not one colour
    frames = tmp_path / "frames"
    assert run_cli("run", "smoke", "-o", f"{frames}/", "--frames", 3, *SMALL) == 0
    assert sorted(p.name for p in frames.iterdir()) == [
        "frame_00000.png",
        "frame_00001.png",
        "frame_00002.png",
        "frames.json",  # what made them (tests/test_output_metadata.py)
    ]


def test_same_seed_same_frames_other_seed_other_frames(tmp_path):
    def render(seed):
        path = tmp_path / f"s{seed}.png"
        assert run_cli("run", "fire", "-o", path, "--frames", 5, "--seed", seed, *SMALL) == 0
        return np.asarray(Image.open(path))

    assert np.array_equal(render(1), render(1))
    assert not np.array_equal(render(1), render(2))


def test_progress_and_summary_unless_quiet(tmp_path, capsys):
    out = tmp_path / "f.gif"
    assert run_cli("run", "fire", "-o", out, "--frames", 3, "--resolution", "32x18") == 0
    captured = capsys.readouterr()
    assert "3/3" in captured.err and "fps" in captured.err
    assert "3 frames in" in captured.out and "flame" in captured.out


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["run", "bonfire"], "no built-in scene 'bonfire'"),
        (["run", "fire", "-o", "out.avi"], "-o must end in .mp4, .gif, .png or .exr"),
        (["run", "fire", "-o", "no/such/dir/out.mp4"], "output directory does not exist"),
        (["run", "fire", "--export", "no/such/dir/c.npz"], "export directory does not exist"),
        (
            ["run", "fire", "--export", "c.npz", "--significant-digits", "3"],
            "--significant-digits needs --export CACHE.h5",
        ),
    ],
)
def test_user_mistakes_exit_2_with_one_line(args, message, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert run_cli(*args) == 2
    err = capsys.readouterr().err
    assert err.startswith("motes: error: ") and message in err
    assert err.count("\n") == 1 and "Traceback" not in err


def test_scene_file_mistakes_exit_2_with_the_key_path(tmp_path, capsys):
    scene = tmp_path / "bad.toml"
    scene.write_text('[[system]]\nname = "a"\ncapacity = -5\n')
    assert run_cli("run", scene, "-o", tmp_path / "x.gif") == 2
    err = capsys.readouterr().err
    assert err == "motes: error: system[0].capacity: must be >= 1, got -5\n"


def test_bad_option_values_exit_2(capsys):
    for args in (["--resolution", "640-480"], ["--frames", "0"], ["--seed", "-1"]):
        with pytest.raises(SystemExit) as exit_info:
            run_cli("run", "fire", *args)
        assert exit_info.value.code == 2
        assert "error: argument" in capsys.readouterr().err


@pytest.mark.parametrize("name", ["../../evil", "/tmp/evil", "sub/evil", "..", ".hidden", ""])
def test_a_scene_name_never_leaves_the_output_directory(name, tmp_path, capsys, monkeypatch):
    work = tmp_path / "a" / "b"
    work.mkdir(parents=True)
    monkeypatch.chdir(work)
    scene = work / "s.toml"
    scene.write_text(f'[scene]\nname = "{name}"\n[[system]]\nname = "x"\n')
    assert run_cli("run", scene, "--frames", 1, *SMALL) == 2
    err = capsys.readouterr().err
    assert err.startswith("motes: error: scene.name: must be a plain name")
    assert err.count("\n") == 1
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["a", "b", "s.toml"]


def test_a_scene_built_in_python_with_a_path_for_a_name_is_refused():
    from motes.cli.main import UserError, _default_output

    assert _default_output("fire") == "fire.mp4"
    for name in ("../evil", "/abs/evil", "a/b"):
        with pytest.raises(UserError, match=r"scene\.name"):
            _default_output(name)


def test_the_default_name_of_an_oddly_named_file_is_a_plain_name(tmp_path):
    from motes.scene import load_scene

    odd = tmp_path / "..my scene (v2).toml"
    odd.write_text('[[system]]\nname = "x"\n')
    assert load_scene(odd).name == "my_scene__v2_"
    assert load_scene('[[system]]\nname = "x"\n').name == "scene"


def test_the_cache_records_the_values_set_over_the_scene(tmp_path):
    path = tmp_path / "c.npz"
    args = ("--set", "scene.seed=4", "--set", "camera.fov=40", "--set", 'scene.name="x"')
    assert run_cli("run", "pendulums", "--no-render", "--frames", 1, "--export", path, *args) == 0
    cache = load_cache(path)
    assert cache.overrides == {"camera.fov": 40, "scene.name": "x", "scene.seed": 4}
    assert (cache.scene, cache.seed) == ("x", 4)
