"""``motes render CACHE``: a cache drawn again with its scene, as ``motes run`` drew it."""

import contextlib

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from motes.cli.main import main
from motes.io.cache import CacheWriter, load_cache
from motes.io.frames import read_image
from motes.scene import SceneError, load_scene
from motes.scene.replay import Replay, ReplayError
from motes.state import ParticleState
from small_scene import PUFF

SCENE = PUFF


def cli(*args):
    return main([str(a) for a in args])


def frames(folder):
    return [read_image(p) for p in sorted(folder.glob("frame_*.png"))]


def test_a_cached_scene_file_draws_again_pixel_for_pixel(tmp_path, capsys):
    scene = tmp_path / "puff.toml"
    scene.write_text(SCENE)
    cache = tmp_path / "puff.h5"
    assert cli("run", scene, "-o", tmp_path / "live", "--export", cache, "-q") == 0
    # The cache records the scene's name, not the file: the file is asked for.
    assert cli("render", cache, "-o", tmp_path / "again", "-q") == 2
    assert "no built-in scene" in capsys.readouterr().err.lower()
    assert cli("render", cache, "-o", tmp_path / "again", "--scene", scene, "-q") == 0
    live, again = frames(tmp_path / "live"), frames(tmp_path / "again")
    assert len(live) == len(again) == 5
    for a, b in zip(live, again, strict=True):
        assert_array_equal(a, b)
    assert max(float(a.std()) for a in again) > 1.0  # not blank
    # Frames 2 and 3 alone, as a slice of the cache.
    out = tmp_path / "slice"
    assert cli("render", cache, "-o", out, "--scene", scene, "--frames", "2:4", "-q") == 0
    assert [f.tolist() for f in frames(out)] == [live[2].tolist(), live[3].tolist()]


def test_the_cloth_of_a_builtin_scene_draws_again_pixel_for_pixel(tmp_path):
    cache = tmp_path / "cloth.h5"
    live, again = tmp_path / "live", tmp_path / "again"
    common = ("--resolution", "96x54", "-q")
    assert cli("run", "cloth_drop", "--frames", 3, "-o", live, "--export", cache, *common) == 0
    assert cli("render", cache, "-o", again, *common) == 0
    for a, b in zip(frames(live), frames(again), strict=True):
        assert_array_equal(a, b)
    assert len(frames(again)) == 3


FLOCK = """
[scene]
fps = 30
seed = 2

[camera]
position = [0, 3, 30]
target = [0, 3, 0]
resolution = [96, 54]

[[body]]
name = "school"
type = "flock"
count = 300
center = [0, 3, 0]
extent = [4, 2, 3]
speed = 2.0
draw = "{draw}"
trail = {trail}
"""


def cache_of(scene, path):
    """A one-frame cache holding an empty entry for each of the scene's systems and bodies."""
    empty = ParticleState(np.zeros(0, np.int64), np.zeros((3, 0)), np.zeros((3, 0)), np.zeros(0))
    with CacheWriter(path, scene=scene.name) as writer:
        writer.add_frame(0.0, {name: empty for name in [*scene.systems, *scene.bodies]})
    return load_cache(path)


def test_a_body_that_cannot_be_drawn_from_a_cache_is_refused_by_name(tmp_path):
    scene = load_scene(FLOCK.format(draw="birds", trail=8))  # a trail: the last 8 steps
    with pytest.raises(ReplayError, match=r"cannot be drawn from a cache yet: 'school' \(Flock"):
        Replay(scene, cache_of(scene, tmp_path / "trail.npz"))


@pytest.mark.slow  # compiles the flock's step
@pytest.mark.parametrize("draw", ["birds", "sprites"])
def test_a_flock_draws_again_pixel_for_pixel(tmp_path, draw):
    scene = tmp_path / "flock.toml"
    scene.write_text(FLOCK.format(draw=draw, trail=0))
    cache, live, again = tmp_path / "flock.h5", tmp_path / "live", tmp_path / "again"
    args = ("--frames", 4, "-q")
    assert cli("run", scene, "-o", live, "--export", cache, *args) == 0
    assert cli("render", cache, "-o", again, "--scene", scene, "-q") == 0
    for a, b in zip(frames(live), frames(again), strict=True):
        assert_array_equal(a, b)
    assert len(frames(again)) == 4


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (("--frames", "7:9"), "selects no frame"),
        (("--frames", "x"), "must look like 10:20"),
        (("--scene", "fire"), "draws system 'flame', system 'embers', which it does not"),
    ],
)
def test_mistakes_exit_2_with_one_line_and_write_nothing(tmp_path, capsys, extra, message):
    scene = tmp_path / "puff.toml"
    scene.write_text(SCENE.replace("duration = 0.5", "duration = 0.2"))
    cache = tmp_path / "puff.npz"
    assert cli("run", scene, "--no-render", "--export", cache, "-q") == 0
    capsys.readouterr()
    out = tmp_path / "out.mp4"
    args = ("--scene", scene, *extra) if "--scene" not in extra else extra
    with pytest.raises(SystemExit) if extra[1] == "x" else contextlib.nullcontext():
        assert cli("render", cache, "-o", out, *args) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_a_render_on_two_dask_workers_equals_the_serial_one_and_resumes(tmp_path, capsys):
    pytest.importorskip("distributed")
    from motes.scene.farm import render_on_dask

    scene = tmp_path / "puff.toml"
    scene.write_text(SCENE)
    cache = tmp_path / "puff.npz"
    assert cli("run", scene, "--no-render", "--export", cache, "-q") == 0
    serial, farm = tmp_path / "serial", tmp_path / "farm"
    assert cli("render", cache, "-o", serial, "--scene", scene, "--frames", "1:", "-q") == 0
    args = ("--scene", scene, "--frames", "1:", "--workers", 2)
    assert cli("render", cache, "-o", farm, *args) == 0
    assert "4 frames in" in capsys.readouterr().out
    names = sorted(p.name for p in farm.glob("frame_*.png"))
    assert names == sorted(p.name for p in serial.glob("frame_*.png"))
    assert names == [f"frame_{i:05d}.png" for i in range(1, 5)]  # numbered as cached
    for a, b in zip(frames(serial), frames(farm), strict=True):
        assert_array_equal(a, b)
    # An interrupted render: two frames missing. Only those are drawn again.
    (farm / "frame_00002.png").unlink()
    (farm / "frame_00004.png").unlink()
    seen = []
    drawn = render_on_dask(
        cache, farm, [1, 2, 3, 4], scene=str(scene), workers=2, progress=seen.append
    )
    assert drawn == 2 and seen[0] == 2 and seen[-1] == 4
    for a, b in zip(frames(serial), frames(farm), strict=True):
        assert_array_equal(a, b)


def puff_cache(tmp_path):
    scene = tmp_path / "puff.toml"
    scene.write_text(SCENE.replace("duration = 0.5", "duration = 0.2"))
    cache = tmp_path / "puff.npz"
    assert cli("run", scene, "--no-render", "--export", cache, "-q") == 0
    return scene, cache


def test_a_render_on_dask_writes_a_folder(tmp_path, capsys):
    scene, cache = puff_cache(tmp_path)
    capsys.readouterr()
    args = ("--scene", scene, "--workers", 2, "-q")
    assert cli("render", cache, "-o", tmp_path / "a.mp4", *args) == 2
    assert "write a folder of PNG frames" in capsys.readouterr().err


@pytest.mark.slow  # the client waits out its 10 s connection timeout
def test_an_unreachable_dask_scheduler_is_one_error_line(tmp_path, capsys):
    pytest.importorskip("distributed")
    scene, cache = puff_cache(tmp_path)
    capsys.readouterr()
    address = "tcp://127.0.0.1:9"  # the discard port: nothing listens there
    args = ("--scene", scene, "--scheduler", address, "-q")
    assert cli("render", cache, "-o", tmp_path / "f", *args) == 2
    assert "cannot reach the Dask scheduler" in capsys.readouterr().err


@pytest.mark.slow  # compiles the liquid's kernels
def test_a_shaken_liquid_draws_again_pixel_for_pixel(tmp_path):
    cache = tmp_path / "liquids.npz"
    live, again = tmp_path / "live", tmp_path / "again"
    common = ("--resolution", "96x54", "-q")
    assert cli("run", "two_liquids", "--frames", 12, "-o", live, "--export", cache, *common) == 0
    assert cli("render", cache, "-o", again, "--frames", "8:", *common) == 0
    assert len(frames(again)) == 4
    for a, b in zip(frames(live)[8:], frames(again), strict=True):
        assert_array_equal(a, b)


def moved_and_cached(name, move, path):
    """Scene ``name`` with ``move(scene)`` applied to its bodies (no step), its cache of
    that one frame, and the frame drawn live."""
    scene = load_scene(name)
    move(scene)
    with CacheWriter(path, scene=name, seed=scene.seed) as writer:
        writer.add_frame(0.0, scene.entries())
    return load_cache(path), scene.render((96, 54))


@pytest.mark.parametrize("name", ["box_tower", "floating", "ragdoll_stairs"])
def test_rigid_bodies_and_floating_boxes_draw_where_the_cache_holds_them(tmp_path, name):
    def move(scene):  # every rigid body somewhere it never starts: up and turned
        for item in scene.bodies.values():
            world = getattr(item, "world", None) or item.floating.world
            turn = np.array([[0.8, -0.6, 0.0], [0.6, 0.8, 0.0], [0.0, 0.0, 1.0]])
            for rows in (world.position, world.previous):
                rows[:] = rows @ turn.T + [0.2, 0.5, 0.0]

    cache, live = moved_and_cached(name, move, tmp_path / f"{name}.h5")
    fresh = load_scene(name)
    unmoved = fresh.render((96, 54))
    drawn = Replay(fresh, cache).render(0, (96, 54))
    assert_array_equal(drawn, live)
    assert not np.array_equal(drawn, unmoved)  # drawn where the cache holds them
    cache.close()


def test_a_rigid_world_with_trails_is_refused_by_name(tmp_path):
    scene = load_scene("swept_vs_posteriori")
    with pytest.raises(ReplayError, match=r"'shots' \(RigidScene: a trail is a path"):
        Replay(scene, cache_of(scene, tmp_path / "trails.npz"))


def test_a_cache_of_another_cloth_under_the_same_name_is_one_error_line(tmp_path, capsys):
    cache = tmp_path / "cloth.npz"
    common = ("--frames", 1, "--resolution", "96x54", "-q")
    assert cli("run", "cloth_drop", "--no-render", "--export", cache, *common) == 0
    assert cli("show", "cloth_drop") == 0
    finer = tmp_path / "finer.toml"  # the same scene, a cloth of 20 x 20 particles
    finer.write_text(capsys.readouterr().out.replace("grid = [48, 48]", "grid = [20, 20]"))
    out = tmp_path / "again.png"
    assert cli("render", cache, "-o", out, "--scene", finer, "-q") == 2
    error = capsys.readouterr().err
    assert "cannot be drawn as body 'cloth': holds 2304 particles; the cloth has 400" in error
    assert error.count("\n") == 1 and not out.exists()


def test_another_camera_draws_what_motes_run_draws_with_it(tmp_path, capsys):
    scene = tmp_path / "puff.toml"
    scene.write_text(SCENE)
    cache, live, again = tmp_path / "puff.h5", tmp_path / "live", tmp_path / "again"
    look = ("--set", "camera.fov=20", "--set", "camera.position=[1, 1.5, 3]")
    assert cli("run", scene, "--frames", 3, "-o", live, *look, "-q") == 0
    assert cli("run", scene, "--frames", 3, "--no-render", "--export", cache, "-q") == 0
    assert cli("render", cache, "-o", again, "--scene", scene, *look, "-q") == 0
    for a, b in zip(frames(live), frames(again), strict=True):
        assert_array_equal(a, b)
    assert len(frames(again)) == 3
    out = tmp_path / "refused"
    assert cli("render", cache, "-o", out, "--scene", scene, "--set", "system.puff.capacity=9") == 2
    error = capsys.readouterr().err
    assert "--set system.puff.capacity: a cache is drawn as it was simulated" in error
    assert error.count("\n") == 1 and not out.exists()


def test_a_pre_rolled_scene_starts_mid_flight_and_draws_again(tmp_path):
    rolled = SCENE.replace("seed = 4\n", "seed = 4\npreroll = 0.3\n")
    scene = load_scene(rolled)
    plain = load_scene(SCENE)
    scene.advance()
    for _ in range(4):  # 0.3 s at 10 fps, then the first frame
        plain.advance()
    assert (scene.frame, scene.time) == (1, 0.1)  # the shot's clock starts after it
    assert_array_equal(scene.systems["puff"]["position"], plain.systems["puff"]["position"])
    path = tmp_path / "rolled.toml"
    path.write_text(rolled)
    cache, live, again = tmp_path / "r.h5", tmp_path / "live", tmp_path / "again"
    assert cli("run", path, "--frames", 2, "-o", live, "--export", cache, "-q") == 0
    assert cli("render", cache, "-o", again, "--scene", path, "-q") == 0
    for a, b in zip(frames(live), frames(again), strict=True):
        assert_array_equal(a, b)
    with pytest.raises(SceneError, match=r"scene.preroll: must be"):
        load_scene(SCENE.replace("seed = 4\n", "seed = 4\npreroll = -1\n"))
