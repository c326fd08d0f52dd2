"""Mistakes a new user makes get one clear line, with a guess where one helps."""

from __future__ import annotations

import subprocess
import sys

import pytest

from motes.cli import main
from motes.scene import SceneError, load_scene


def run_cli(*args):
    return main([str(a) for a in args])


def one_error_line(capsys) -> str:
    err = capsys.readouterr().err
    assert err.startswith("motes: error: ") and err.count("\n") == 1, err
    assert "Traceback" not in err
    return err


def test_a_misspelt_scene_name_gets_a_guess(capsys):
    assert run_cli("run", "fier") == 2
    assert "did you mean 'fire'?" in one_error_line(capsys)


def test_a_directory_as_the_scene_says_so(tmp_path, capsys):
    assert run_cli("run", tmp_path) == 2
    assert "is a directory; give a .toml scene file" in one_error_line(capsys)


def test_a_binary_scene_file_is_not_text(tmp_path, capsys):
    scene = tmp_path / "x.toml"
    scene.write_bytes(b"\x89PNG\r\n\x1a\n\xff\xfe")
    assert run_cli("run", scene) == 2
    assert "is not a text file (byte 0 is not UTF-8)" in one_error_line(capsys)


@pytest.mark.parametrize(
    ("text", "path", "message"),
    [
        ("[scene]\ndurashun = 1\n", "scene.durashun", "did you mean 'duration'?"),
        ("  [[system.emitter]]\n  rat = 100\n", "system[0].emitter[0].rat", "did you mean 'rate'"),
        ("  [[system.emitter]]\n  rate = { rat = 100 }\n", "system[0].emitter[0].rate.type",
         "is required (this table has 'rat')"),
    ],
)  # fmt: skip
def test_a_misspelt_key_is_named_rather_than_the_missing_one(text, path, message):
    source = '[[system]]\nname = "a"\n' + text if text.startswith(" ") else text
    if not text.startswith(" "):
        source += '[[system]]\nname = "a"\n'
    with pytest.raises(SceneError) as error:
        load_scene(source)
    assert error.value.path == path and message in error.value.message


def test_show_prints_a_builtin_scene_that_loads(capsys, tmp_path):
    assert run_cli("show", "rain") == 0
    text = capsys.readouterr().out
    (tmp_path / "mine.toml").write_text(text)
    assert "drops" in load_scene(tmp_path / "mine.toml").systems
    assert run_cli("show", "rian") == 2
    assert "did you mean 'rain'?" in one_error_line(capsys)


def test_a_closed_pipe_ends_the_listing_quietly():
    with subprocess.Popen(
        [sys.executable, "-m", "motes", "scenes"], stdout=subprocess.PIPE, stderr=subprocess.PIPE
    ) as listing:
        # Closed before the listing is written (the interpreter takes far longer to
        # start), as `motes scenes | head -0` would: the write meets a broken pipe.
        listing.stdout.close()
        assert listing.wait(timeout=60) == 0
        assert b"Traceback" not in listing.stderr.read()
