"""Property-based fuzzing of scene files (hypothesis; inputs from ``tests/fuzz_scenes.py``).

Seeds are the built-in scenes and ``examples/scenes``, mutated key by key, and damaged
bytes. The properties:

- loading gives a :class:`~motes.scene.Scene` or a :class:`~motes.scene.SceneError`
  whose message is one line of at most ``MESSAGE_MAX`` characters, starting with the key
  path; nothing else (no ``KeyError``, ``OverflowError``, ``RecursionError``,
  ``MemoryError``, numba error, and no warning: pytest makes warnings errors);
- a scene that loads steps (and renders a small image) without any exception or
  warning but a one-line ``SceneError`` naming a body that diverged;
- ``motes run`` on a damaged file exits 0, or 2 with one ``motes: error:`` line, within
  ``CLI_SECONDS`` and under ``CLI_MEMORY`` bytes of address space (``RLIMIT_AS``).

Each example has a hypothesis ``deadline``. The examples are derandomized (the same on
every run); ``MOTES_FUZZ_EXAMPLES=5000`` runs more of them (``docs/testing.md``).
"""

from __future__ import annotations

import contextlib
import json
import os
import subprocess
import sys
import tempfile
import textwrap
from datetime import timedelta
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings

import fuzz_scenes as fz
from motes.scene import Scene, SceneError, load_scene
from motes.scene.bodies import Body

#: Examples per property; the default keeps this file near 30 s on one core.
EXAMPLES = int(os.environ.get("MOTES_FUZZ_EXAMPLES", "0")) or None
MESSAGE_MAX = 1000
#: Address space [bytes] and wall time [s] the command line may use on one fuzzed file.
CLI_MEMORY = 2 << 30
CLI_SECONDS = 120


def fuzz_settings(default_examples: int, deadline: timedelta):
    return settings(
        max_examples=EXAMPLES or default_examples,
        derandomize=True,
        database=None,
        deadline=deadline,
        # Scene texts are large draws, and a slow first example compiles kernels.
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    )


@contextlib.contextmanager
def refused_cleanly():
    """Let a SceneError pass after checking that its message is one clean line."""
    try:
        yield
    except SceneError as error:
        message = str(error)
        assert "\n" not in message and len(message) <= MESSAGE_MAX, message[:2000]
        assert message.startswith(error.path), message


def load_or_refuse(source) -> Scene | None:
    """The loaded scene, or None after a clean refusal."""
    with refused_cleanly():
        return load_scene(source)
    return None


def advance_a_little(scene: Scene, substeps: int = 2) -> None:
    """A frame of at most ``substeps`` of the scene's own step (a frame may hold 1000)."""
    steps = min(scene.substeps, substeps)
    scene.fps, scene.substeps = scene.fps * scene.substeps / steps, steps  # the same dt
    scene.advance()


@pytest.fixture(scope="module", autouse=True)
def seeds_load():
    """Every seed loads as it is (and the first load imports the body modules)."""
    for name, text in fz.SEED_TEXTS.items():
        assert isinstance(load_scene(text), Scene), name


@fuzz_settings(400, timedelta(seconds=5))
@given(case=fz.mutated_scene())
def test_a_mutated_scene_loads_or_is_refused_in_one_line(case):
    load_or_refuse(case.text)


@fuzz_settings(150, timedelta(seconds=5))
@given(case=fz.renumbered_scene())
def test_extreme_numbers_load_or_are_refused_in_one_line(case):
    load_or_refuse(case.text)


@fuzz_settings(150, timedelta(seconds=5))
@given(data=fz.mangled_bytes())
def test_damaged_bytes_load_or_are_refused_in_one_line(data):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "scene.toml"
        path.write_bytes(data)
        load_or_refuse(path)


def seed(name: str, old: str, new: str) -> str:
    """Seed scene ``name`` with its one ``old`` replaced by ``new``."""
    assert fz.SEED_TEXTS[name].count(old) == 1, old
    return fz.SEED_TEXTS[name].replace(old, new)


SYSTEM = '[[system]]\nname = "a"\n'
EMITTER = SYSTEM + '[[system.emitter]]\nrate = { type = "per_second", rate = 10 }\n'
FLUID = '[[body]]\nname = "w"\ntype = "fluid"\nspacing = 0.05\n'
CLOTH = '[[body]]\nname = "c"\ntype = "cloth"\ngrid = [6, 5]\n'
HANDLE = "[[body.handle]]\ntimes = [0, 1]\noffsets = [[0, 0, 0], [1, 0, 0]]\n"


@pytest.mark.parametrize(
    ("text", "path", "message"),
    [
        # Each was a RecursionError, a message of 300 kB, an OverflowError, a RuntimeWarning
        # from a float32 cast, a MemoryError, a ValueError when the scene stepped or drew,
        # or an IndexError, before the fix that this case now checks.
        ("a = " + "[" * 5000 + "]" * 5000 + "\n" + SYSTEM, "<text>", "nested too deeply"),
        ("[scene]\nduration = [" + "0, " * 100_000 + "]\n" + SYSTEM, "scene.duration",
         r"got array \[0, 0, 0, 0, 0, 0, \.\.\.\]$"),
        ('[scene]\n"a\\nb" = 1\n' + SYSTEM, "scene.'a\\nb'", "unknown key"),
        ("[camera]\nposition = [1e300, 0, 0]\n" + SYSTEM, "camera.position[0]",
         "0 or between 1e-18 and 1e[+]18 in magnitude"),
        (f"[scene]\nduration = {'9' * 400}\n" + SYSTEM, "scene.duration", "got 9999"),
        ("[render]\nbackground = [1e300, 0, 0]\n" + SYSTEM, "render.background[0]",
         "in magnitude"),
        ('[[object]]\ntype = "box"\nsize = [1, 1, -0.3]\n' + SYSTEM, "object[0].size[2]",
         "must be > 0"),
        (FLUID.replace("0.05", "1e-9") + "[[body.block]]\nlower = [0, 0, 0]\nupper = [1, 1, 1]",
         "body[0].block[0]", "holds 1e[+]27 particles .* more than max_particles = 20000"),
        (FLUID + "[[body.source]]\nposition = [0, 0, 0]\nvelocity = [0, 1, 0]\nradius = 1e9",
         "body[0].source[0]", "layers of about 1.26e[+]21 particles"),
        (FLUID + "max_dt = 1e-300", "body[0].max_dt", "must be >= 1e-05"),
        (CLOTH.replace("[6, 5]", "[20000, 2]"), "body[0].grid", "at most 10000"),
        (CLOTH + HANDLE + "row = 99", "body[0].handle[0].row", "must be <= 4"),
        (CLOTH + HANDLE + "columns = [0, 1e300]", "body[0].handle[0].columns[1]",
         "must be an integer"),
        (EMITTER + "lifetime = [1, 2, 3]", "system[0].emitter[0].lifetime",
         "has 3 components, the attribute needs 1"),
        (EMITTER + "lifetime = { uniform = [[" + "0, " * 100_000 + "], 0.6] }",
         "system[0].emitter[0].lifetime.uniform[0]", r"1 to 4 numbers, got \[0, 0, 0, 0, 0"),
        (EMITTER + "lifetime = { normal = [1, 0.5] }", "system[0].emitter[0].lifetime",
         "least value is -inf [(]give it a low[)]"),
        (EMITTER + "size = { uniform = [-1, 1] }", "system[0].emitter[0].size", "must be >= 0"),
        (SYSTEM + '[[system.child]]\nsystem = "a"\ncount = "#0b0d14"', "system[0].child[0].count",
         "has 4 components, the attribute needs 1"),
        (SYSTEM + '[[system.modifier]]\ntype = "size_over_life"\nkeys = [[0, 1], [1, -1]]',
         "system[0].modifier[0]", "sizes >= 0"),
        (seed("floating", "size = [0.24, 0.12, 0.26]", "size = [0.24, 0.12, 2.6e-07]"),
         "body[0].float", "two kernel supports"),
        (seed("rope_bridge", "drop_height = 0.5", "drop_height = 3.3e16"), "body[0]",
         "coplanar"),
    ],
)  # fmt: skip
def test_what_the_fuzzer_found_is_refused_at_its_key(text, path, message):
    with pytest.raises(SceneError, match=message) as error:
        load_scene(text)
    assert error.value.path == path
    assert "\n" not in str(error.value) and len(str(error.value)) < 300, str(error.value)


def test_a_child_count_past_every_capacity_is_dropped_not_allocated():
    scene = load_scene(
        EMITTER.replace("per_second", "burst").replace("rate = 10", "count = 5")
        + f'[[system.child]]\nsystem = "b"\non = "birth"\ncount = {10**30}\n'
        + '[[system]]\nname = "b"\ncapacity = 1000\n'
    )
    scene.advance()
    children = scene.systems["b"].store
    assert children.count == 1000 and children.dropped == 5 * 10**30 - 1000


def test_a_diverging_system_stops_the_scene_naming_it():
    scene = load_scene(EMITTER + '[[system.force]]\ntype = "drag"\ncoefficient = 1e15\n')
    with pytest.raises(SceneError, match=r"diverged in frame \d: particle positions") as error:
        for _ in range(5):
            scene.advance()
    assert error.value.path == "system.a"


def test_a_cloth_whose_implicit_solve_breaks_down_is_drawn_as_diverged():
    text = seed("flag", "bending = [2.0, 0.002]", "bending = [2.0, 6.1e16]")
    scene = load_scene(text.replace("center = [-0.03, 1.55, 0.0]", "center = [-0.03, 6.1e16, 0]"))
    scene.advance()
    scene.advance()  # the solve breaks down in the second frame
    assert scene.bodies["flag"].diverged_at is not None


def test_a_body_that_diverges_stops_the_scene_naming_it():
    class Diverging(Body):
        def step(self, dt):
            raise FloatingPointError("the state is not finite")

    scene = load_scene(SYSTEM)
    scene.bodies["pool"] = Diverging()
    with pytest.raises(SceneError, match="diverged in frame 1: the state is not finite") as error:
        scene.advance()
    assert error.value.path == "body.pool"


@pytest.mark.slow
def test_a_surface_too_far_out_for_its_grid_is_a_scene_error_when_drawn():
    # The floor, lifted 3.5e15 m: the liquid follows it in one step.
    scene = load_scene(seed("honey", "point = [0, 0, 0]", "point = [0, 3.5e15, 0]"))
    advance_a_little(scene, 1)
    with pytest.raises(SceneError, match="cannot draw its surface in frame 1") as error:
        scene.render((32, 18))
    assert error.value.path == "body.honey"


def test_a_tank_shaken_far_out_keeps_its_walls_drawable():
    from motes import fluids
    from motes.scene.body_fluids import _TankWalls

    tank = fluids.Tank((0.0, 0.0, 0.0), (0.5, 0.4, 0.02))
    walls = _TankWalls(tank, 0.02, (0.5, 0.5, 0.5))
    tank.moved((5.3e16, 0.0, 0.0))  # the width, 0.5 m, is lost in round-off out there
    assert len(walls.boxes()) == 4


@pytest.mark.slow
@fuzz_settings(300, timedelta(seconds=120))
@given(case=fz.renumbered_scene())
def test_a_scene_with_extreme_numbers_that_loads_also_steps(case):
    scene = load_or_refuse(case.text)
    if scene is not None:
        with refused_cleanly():
            advance_a_little(scene)


@pytest.mark.slow
@fuzz_settings(300, timedelta(seconds=120))
@given(case=fz.mutated_scene())
def test_a_mutated_scene_that_loads_also_steps_and_renders(case):
    scene = load_or_refuse(case.text)
    if scene is not None:
        with refused_cleanly():
            advance_a_little(scene)
            assert scene.render((32, 18)).shape == (18, 32, 3)


# --- the command line, in a process of its own under a memory limit ----------------------

#: Runs ``motes run FILE --no-render --frames 1`` on each file named on its command line
#: in one process under ``RLIMIT_AS``, and prints per file the exit status and stderr, or
#: the traceback that escaped ``main``.
CLI_DRIVER = textwrap.dedent(
    """
    import contextlib, faulthandler, io, json, resource, sys, traceback
    resource.setrlimit(resource.RLIMIT_AS, ({memory}, {memory}))
    from motes.cli import main
    for path in sys.argv[1:]:
        faulthandler.dump_traceback_later({seconds}, exit=True)  # a hang ends the run
        err = io.StringIO()
        try:
            with contextlib.redirect_stderr(err):
                rc = main(["run", path, "--no-render", "--frames", "1", "--quiet"])
        except BaseException:
            rc, err = "traceback", io.StringIO(traceback.format_exc())
        print(json.dumps({{"path": path, "rc": rc, "stderr": err.getvalue()}}), flush=True)
    """
).format(memory=CLI_MEMORY, seconds=CLI_SECONDS)


def run_cli_on(files: list[Path]) -> list[dict]:
    paths = [str(fz.ROOT / "src"), *filter(None, [os.environ.get("PYTHONPATH")])]
    done = subprocess.run(
        [sys.executable, "-c", CLI_DRIVER, *map(str, files)],
        capture_output=True,
        text=True,
        env={**os.environ, "PYTHONPATH": os.pathsep.join(paths)},
    )
    results = [json.loads(line) for line in done.stdout.splitlines()]
    stuck = files[len(results)] if len(results) < len(files) else None
    assert done.returncode == 0, f"stopped at {stuck}: {done.stderr[-3000:]}"
    return results


def assert_clean(result: dict) -> None:
    rc, err = result["rc"], result["stderr"]
    assert rc in (0, 2), f"{result['path']}: {err[-3000:]}"
    if rc == 2:
        assert err.startswith("motes: error: ") and err.count("\n") == 1, err[:2000]


def test_the_command_line_reports_damaged_files_in_one_line(tmp_path):
    texts = {
        "deep.toml": "a = " + "[" * 5000 + "]" * 5000 + "\n",
        "huge.toml": '[[system]]\nname = "a"\ncapacity = [' + "1, " * 100_000 + "]\n",
        "nan.toml": fz.SEED_TEXTS["fire"].replace("duration = 8.0", "duration = nan"),
        "far.toml": fz.SEED_TEXTS["rain"] + '[[object]]\ntype = "sphere"\nradius = 1e300\n',
        "tiny.toml": fz.SEED_TEXTS["floating"].replace("spacing = 0.025", "spacing = 1e-9"),
        "cut.toml": fz.SEED_TEXTS["dam_break"][: fz.SEED_TEXTS["dam_break"].index("[[body]]") + 5],
    }
    files = []
    for name, text in texts.items():
        files.append(tmp_path / name)
        files[-1].write_text(text)
    files.append(tmp_path / "noise.toml")
    files[-1].write_bytes(bytes(range(256)) * 4)
    results = run_cli_on(files)
    assert len(results) == len(files)
    for result in results:
        assert_clean(result)
        assert result["rc"] == 2


@pytest.mark.slow
def test_the_command_line_runs_or_reports_fuzzed_files_in_one_line(tmp_path):
    files = []

    @fuzz_settings(60, None)
    @given(case=fz.mutated_scene(), data=fz.mangled_bytes())
    def collect(case, data):
        files.append(tmp_path / f"scene_{len(files)}.toml")
        files[-1].write_text(case.text)
        files.append(tmp_path / f"bytes_{len(files)}.toml")
        files[-1].write_bytes(data)

    collect()
    for result in run_cli_on(files):
        assert_clean(result)
