"""``motes run``'s helper that compiles the drawing kernels in a second process on a
first run (motes.cli.compile_ahead): when it starts, how its cache is taken over, and
that frames do not depend on it."""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys
from pathlib import Path

import numba
import numpy as np
import pytest
from PIL import Image

import motes
from motes.cli import compile_ahead as ahead
from motes.render.frame import Frame
from motes.scene import load_scene

RENDER = Path(motes.__file__).resolve().parent / "render"


def helper_subfolder(source: Path) -> str:
    """The folder Numba caches ``source``'s functions in under ``NUMBA_CACHE_DIR``."""
    absolute = os.path.abspath(source)
    return f"{os.path.basename(absolute)}_{hashlib.sha1(absolute.encode()).hexdigest()}"


def fake_cache(root: Path, name: str, data: dict[int, bytes]) -> Path:
    """An index ``name.nbi`` and data files ``name.K.nbc`` under ``root``'s folder for
    motes/render, as the helper's Numba writes them."""
    folder = root / helper_subfolder(RENDER)
    folder.mkdir(parents=True, exist_ok=True)
    for number, content in data.items():
        (folder / f"{name}.{number}.nbc").write_bytes(content)
    (folder / f"{name}.nbi").write_bytes(b"index of " + name.encode())
    return folder


def test_adopt_copies_index_and_data_where_this_process_caches_them(tmp_path, monkeypatch):
    helper, own = tmp_path / "helper", tmp_path / "own"
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(own))
    fake_cache(helper, "bloom_kernels.halve-20.py311", {1: b"one", 2: b"two"})
    fake_cache(helper, "tonemap._tonemap_kernel-57.py311", {1: b"tone"})
    # A function this process has cached already is left as it is.
    target = own / helper_subfolder(RENDER)
    target.mkdir(parents=True)
    (target / "tonemap._tonemap_kernel-57.py311.nbi").write_bytes(b"mine")
    (target / "tonemap._tonemap_kernel-57.py311.1.nbc").write_bytes(b"my data")
    # A folder of sources that are not motes' is not copied anywhere.
    (helper / "elsewhere_0123").mkdir()
    (helper / "elsewhere_0123" / "f-1.py311.nbi").write_bytes(b"?")

    assert ahead.adopt(helper) == 3
    assert (target / "bloom_kernels.halve-20.py311.nbi").read_bytes().startswith(b"index")
    assert (target / "bloom_kernels.halve-20.py311.1.nbc").read_bytes() == b"one"
    assert (target / "bloom_kernels.halve-20.py311.2.nbc").read_bytes() == b"two"
    assert (target / "tonemap._tonemap_kernel-57.py311.nbi").read_bytes() == b"mine"
    assert (target / "tonemap._tonemap_kernel-57.py311.1.nbc").read_bytes() == b"my data"
    assert not list(own.rglob("*.partial"))


def test_adopt_takes_names_with_glob_characters_literally(tmp_path, monkeypatch):
    monkeypatch.setattr(numba.config, "CACHE_DIR", str(tmp_path / "own"))
    fake_cache(tmp_path / "helper", "k.kernel[a]-3.py311", {1: b"x"})
    fake_cache(tmp_path / "helper", "k.kernela-3.py311", {1: b"y"})
    assert ahead.adopt(tmp_path / "helper") == 4
    target = tmp_path / "own" / helper_subfolder(RENDER)
    assert (target / "k.kernel[a]-3.py311.1.nbc").read_bytes() == b"x"
    assert (target / "k.kernela-3.py311.1.nbc").read_bytes() == b"y"


@pytest.mark.parametrize(
    ("first_run", "switch", "cores", "memory"),
    [(False, "1", 2, None), (True, "0", 2, None), (True, "1", 1, None), (True, "1", 2, "1000")],
)
def test_no_helper_where_it_cannot_help(monkeypatch, first_run, switch, cores, memory):
    monkeypatch.setenv(ahead.SWITCH, switch)
    monkeypatch.setattr(ahead, "_usable_cores", lambda: cores)
    if memory is not None:
        monkeypatch.setenv("MOTES_MEMORY_LIMIT", memory)
    started = []
    monkeypatch.setattr(ahead.subprocess, "Popen", lambda *a, **k: started.append(a))
    helper = ahead.CompileAhead.start(
        "fire", seed=None, overrides=[], resolution=(64, 36), check_finite=True,
        first_run=first_run,
    )  # fmt: skip
    assert helper is None and not started


def test_kernels_cached_says_whether_the_tone_kernel_is_in_the_cache(tmp_path, monkeypatch):
    from motes.render.tonemap import _tonemap_kernel, to_srgb8

    to_srgb8(np.zeros((1, 1, 3), np.float32))  # compiled (and cached) or loaded
    assert ahead.kernels_cached()
    cache_file = _tonemap_kernel._cache._cache_file
    monkeypatch.setattr(cache_file, "_index_path", str(tmp_path / "absent.nbi"))
    assert not ahead.kernels_cached()
    monkeypatch.delattr(cache_file, "_index_path")
    assert ahead.kernels_cached()  # a Numba laid out otherwise: no guess, no helper


def test_the_helper_draws_frame_0_and_a_failed_helper_is_ignored(tmp_path):
    """The helper's own entry point, in this process: it loads the scene and draws its
    frame 0. A helper that fails (here: an unknown scene) adopts nothing."""
    assert (
        ahead.main(["fire", "--resolution", "64x36", "--seed", "3", "--set", "scene.fps=30"]) == 0
    )
    process = subprocess.Popen([sys.executable, "-c", "raise SystemExit(3)"])
    folder = tmp_path / "helper"
    folder.mkdir()
    fake_cache(folder, "k-1.py311", {1: b"x"})
    assert ahead.CompileAhead(process, folder).finish() == 0
    assert not folder.exists()


def test_close_stops_a_running_helper_and_removes_its_folder(tmp_path):
    process = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    folder = tmp_path / "helper"
    folder.mkdir()
    helper = ahead.CompileAhead(process, folder)
    helper.close()
    helper.close()  # idempotent
    assert process.poll() is not None and not folder.exists()


def test_finish_runs_meanwhile_only_while_the_helper_works(tmp_path):
    calls = []
    busy = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(1)"])
    (tmp_path / "a").mkdir()
    ahead.CompileAhead(busy, tmp_path / "a").finish(lambda: calls.append("busy"))
    done = subprocess.Popen([sys.executable, "-c", "pass"])
    done.wait()
    (tmp_path / "b").mkdir()
    ahead.CompileAhead(done, tmp_path / "b").finish(lambda: calls.append("done"))
    assert calls == ["busy"]


def test_draw_particles_draws_the_particles_alone():
    scene = load_scene("fire", overrides={"camera.resolution": [96, 54]})
    for _ in range(3):
        scene.advance()
    drawing = scene.renderer()
    frame = Frame(96, 54)
    drawing.renderer.draw_particles(frame, [scene.systems["flame"]])
    assert frame.color.sum() > 0 and np.isinf(frame.depth).all()
    drawing.draw_particles(scene)  # the scene's particles and its bloom, into scratch


@pytest.mark.slow
def test_a_first_run_with_the_helper_draws_the_frames_of_one_without(tmp_path):
    """Two first runs of ``motes run`` (empty kernel caches), with and without the
    helper, write the same PNG frames; so does a run from the cache left behind."""
    frames = {}
    for name, switch, cache in (("ahead", "1", "a"), ("alone", "0", "b"), ("warm", "1", "a")):
        out = tmp_path / name
        environment = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / cache), ahead.SWITCH: switch}
        subprocess.run(
            [sys.executable, "-m", "motes", "run", "fire", "--frames", "3", "--resolution",
             "160x90", "-o", str(out), "-q"],
            env=environment, check=True,
        )  # fmt: skip
        frames[name] = [np.asarray(Image.open(p)) for p in sorted(out.glob("*.png"))]
    assert len(frames["ahead"]) == 3
    for name in ("alone", "warm"):
        assert all(np.array_equal(a, b) for a, b in zip(frames["ahead"], frames[name], strict=True))


def test_the_helper_is_started_with_the_runs_scene_and_a_cache_of_its_own(monkeypatch):
    monkeypatch.setenv(ahead.SWITCH, "1")
    monkeypatch.delenv("MOTES_MEMORY_LIMIT", raising=False)
    monkeypatch.setattr(ahead, "_usable_cores", lambda: 2)
    monkeypatch.setattr(ahead, "_memory_for_helper", lambda: True)
    seen = {}

    class Finished:
        def poll(self):
            return 0

    def popen(command, env, **options):
        seen.update(command=command, env=env)
        return Finished()

    monkeypatch.setattr(ahead.subprocess, "Popen", popen)
    helper = ahead.CompileAhead.start(
        "my scene.toml", seed=7, overrides=["camera.fov=40"], resolution=(320, 180),
        check_finite=False, first_run=True,
    )  # fmt: skip
    assert seen["command"][1:] == [
        "-m", "motes.cli.compile_ahead", "my scene.toml", "--resolution", "320x180",
        "--seed", "7", "--set", "camera.fov=40", "--no-check-finite",
    ]  # fmt: skip
    assert seen["env"]["NUMBA_CACHE_DIR"] == str(helper.folder) and helper.folder.is_dir()
    assert seen["env"][ahead.SWITCH] == "0"
    helper.close()
    assert not helper.folder.exists()


def test_a_cache_that_cannot_be_written_is_compiled_into_as_usual(tmp_path, monkeypatch):
    def refuse(folder):
        raise PermissionError("read-only")

    monkeypatch.setattr(ahead, "adopt", refuse)
    done = subprocess.Popen([sys.executable, "-c", "pass"])
    (tmp_path / "helper").mkdir()
    assert ahead.CompileAhead(done, tmp_path / "helper").finish() == 0
    assert not (tmp_path / "helper").exists()
