"""Mistakes a new user makes get one clear line, with a guess where one helps."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time

import imageio_ffmpeg
import pytest
from PIL import Image

from motes.cli import main
from motes.scene import SceneError, load_scene

SMALL = ["--resolution", "64x36", "--quiet"]


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


def _run_until_frames(out, frames: int, signum, *, group: bool) -> tuple[int, str]:
    """Start ``motes run fire -o OUT``, send ``signum`` after ``frames`` frames: to its
    process group (as a terminal's Ctrl-C does) or to the process (as ``kill`` does)."""
    process = subprocess.Popen(
        [sys.executable, "-m", "motes", "run", "fire", "-o", str(out), "--frames", "100000",
         "--resolution", "64x36"],
        stderr=subprocess.PIPE, stdout=subprocess.PIPE, start_new_session=group,
    )  # fmt: skip
    seen = b""
    deadline = time.monotonic() + 300
    try:
        while time.monotonic() < deadline:
            seen += os.read(process.stderr.fileno(), 4096)
            done = [int(n) for n in re.findall(rb"(\d+)/100000", seen)]
            if done and done[-1] >= frames:
                break
        (os.killpg if group else os.kill)(process.pid, signum)
        _, rest = process.communicate(timeout=300)
    finally:
        if process.poll() is None:  # pragma: no cover - only when the test fails
            process.kill()
            process.communicate()
    return process.returncode, (seen + rest).decode()


# Slow tier: from an empty kernel cache each run compiles the fire's kernels (a minute on
# two loaded cores), and a signal waits for the compile under way.
@pytest.mark.slow
@pytest.mark.skipif(not hasattr(os, "killpg"), reason="needs POSIX process groups")
@pytest.mark.parametrize(
    ("suffix", "signum", "status", "word"),
    [
        (".mp4", signal.SIGINT, 130, "interrupted"),  # Ctrl-C at a terminal
        (".mp4", signal.SIGTERM, 143, "terminated"),
        (".gif", signal.SIGTERM, 143, "terminated"),
    ],
)
def test_a_stopped_run_closes_its_output_with_the_frames_so_far(tmp_path, suffix, signum,
                                                                 status, word):  # fmt: skip
    """Ctrl-C and SIGTERM alike: the output plays, holds every finished frame, and no
    hidden temporary file is left."""
    out = tmp_path / f"fire{suffix}"
    returned, message = _run_until_frames(out, 5, signum, group=signum == signal.SIGINT)
    assert returned == status, message
    assert f"motes: {word} after" in message
    written = int(re.search(r"holds (\d+) frames", message).group(1))
    assert written >= 5
    if suffix == ".mp4":
        assert imageio_ffmpeg.count_frames_and_secs(str(out))[0] == written
    else:
        with Image.open(out) as gif:
            assert gif.n_frames >= 2  # Pillow merges identical neighbours; fire frames differ
    assert [p.name for p in tmp_path.iterdir()] == [out.name]  # no hidden .part file


def test_a_frame_folder_with_files_is_refused_unless_overwrite(tmp_path, capsys):
    folder = tmp_path / "frames"
    assert run_cli("run", "fire", "-o", folder, "--frames", 3, *SMALL) == 0
    assert len(list(folder.glob("frame_*.png"))) == 3
    (folder / "notes.txt").write_text("mine")
    assert run_cli("run", "fire", "-o", folder, "--frames", 2, *SMALL) == 2
    error = one_error_line(capsys)
    assert "is not empty" in error and "--overwrite" in error
    assert run_cli("run", "fire", "-o", folder, "--frames", 2, "--overwrite", *SMALL) == 0
    # Only this run's two frames remain, and the user's own file is untouched.
    assert sorted(p.name for p in folder.iterdir()) == [
        "frame_00000.png",
        "frame_00001.png",
        "frames.json",
        "notes.txt",
    ]


def test_births_dropped_at_capacity_are_reported(tmp_path, capsys):
    scene = tmp_path / "full.toml"
    scene.write_text(
        '[scene]\nduration = 0.2\n[[system]]\nname = "jet"\ncapacity = 50\n'
        '  [[system.emitter]]\n  rate = { type = "per_second", rate = 100000 }\n'
    )
    assert run_cli("run", scene, "--no-render") == 0
    captured = capsys.readouterr()
    assert captured.err.count("motes: warning: system 'jet' is full (50 particles)") == 1
    assert re.search(r"jet: \d+ births dropped at capacity", captured.out)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--export", "cache.txt"], "cannot export to cache.txt: the extension must be"),
        (["-o", "locked/out.mp4"], "cannot write to"),
    ],
)
def test_unwritable_outputs_are_refused_before_simulating(args, message, tmp_path, capsys,
                                                          monkeypatch):  # fmt: skip
    monkeypatch.chdir(tmp_path)
    (tmp_path / "locked").mkdir(mode=0o500)
    if os.geteuid() == 0 and "locked" in " ".join(args):
        pytest.skip("root writes anywhere")
    assert run_cli("run", "fire", *args, *SMALL) == 2
    assert message in one_error_line(capsys)


def test_progress_says_the_first_frame_may_compile_and_estimates_from_the_steady_rate(
    monkeypatch,
):
    import io

    from motes.cli import progress as progress_module

    clock = iter([0.0, 30.0, 31.0, 32.0])  # a 30 s first frame, then 1 s per frame
    monkeypatch.setattr(progress_module.time, "perf_counter", lambda: next(clock))
    stream = io.StringIO()
    bar = progress_module.Progress(10, label="fire", stream=stream)
    bar.begin()
    assert "first frame (kernels compile on a first run" in stream.getvalue()
    bar.update(1)
    assert "? s left" in stream.getvalue().splitlines()[-1]
    bar.update(2)
    bar.update(3)
    # Two steady frames in 2 s: 7 left take 7 s (not the 70 s the first frame implies).
    assert stream.getvalue().splitlines()[-1].endswith("7 s left")
