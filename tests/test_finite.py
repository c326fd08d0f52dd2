"""Stopping at the first NaN or infinity: the compiled scan against its NumPy twin, the
message, scenes (opt-in in Python, on in ``motes run``) and the outputs kept."""

from __future__ import annotations

import imageio_ffmpeg
import numpy as np
import pytest

import motes as mo
import naive
from motes.cli import main
from motes.finite import NonFiniteError, check_finite, first_at_least, first_non_finite
from motes.scene import SceneError, load_scene
from motes.scene.bodies import Body
from motes.state import Field, ParticleState

BITS = {
    np.float32: (np.uint32, np.uint32(0x7FFF_FFFF), np.uint32(0x7F80_0000)),
    np.float64: (np.uint64, np.uint64(0x7FFF_FFFF_FFFF_FFFF), np.uint64(0x7FF0_0000_0000_0000)),
}

# A drag of 1e18 /s at 2 frames per second overshoots its wind by a factor of 5e17 each
# step: the velocity is about 1e17 m/s after frame 1, 1e35 after frame 2 (float32 holds
# up to 3.4e38) and infinite in frame 3.
BLOWUP = """
[scene]
name = "blowup"
fps = 2
duration = 5.0
[camera]
resolution = [32, 18]
[[system]]
name = "jet"
capacity = 10
  [[system.emitter]]
  rate = { type = "burst", count = 4 }
  lifetime = 100.0
  speed = 1.0
  [[system.force]]
  type = "drag"
  coefficient = 1e18
  wind = [0.0, 1.0, 0.0]
"""


def one_error_line(capsys) -> str:
    err = capsys.readouterr().err
    assert err.startswith("motes: error: ") and err.count("\n") == 1, err
    return err


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("n", [1, 1023, 1024, 1025, 5000])
def test_the_scan_finds_what_its_twin_finds(dtype, n):
    rng = np.random.default_rng(n)
    view, mask, exponent = BITS[dtype]
    finfo = np.finfo(dtype)
    edge = [finfo.max, -finfo.max, finfo.smallest_subnormal, -0.0]  # finite, all of them
    for trial in range(12):
        values = rng.normal(size=n).astype(dtype)
        values[rng.integers(0, n, 3)] = rng.choice(edge, 3)
        bad = [np.nan, np.inf, -np.inf, -np.nan][trial % 4]
        if trial % 3:  # some rows are all finite
            # Block edges and random places, so both the reduction and the search run.
            at = [n - 1, min(n - 1, 1024), int(rng.integers(0, n))][trial % 3]
            values[at] = bad
        bits = values.view(view)
        for infinite_ok in (False, True):
            threshold = exponent + view(1) if infinite_ok else exponent
            expected = naive.first_non_finite(values, infinite_ok=infinite_ok)
            assert first_at_least(bits, mask, threshold) == expected


def _state(n=6, dtype=np.float32, **fields):
    zeros = np.zeros((3, n), dtype)
    return ParticleState(
        np.arange(100, 100 + n), zeros.copy(), zeros.copy(), np.full(n, 0.1, dtype), fields
    )


def test_velocity_is_named_before_position_and_ids_are_reported():
    state = _state()
    state.positions[0, 1] = np.nan
    state.velocities[2, 4] = -np.inf
    assert first_non_finite(state) == ("velocities", 4)
    with pytest.raises(NonFiniteError) as error:
        check_finite(state, owner="system 'fire'", frame=12, time=0.4)
    assert str(error.value) == (
        "system 'fire': particle 104 has a non-finite velocity (0, 0, -inf) at frame 12, t = 0.40 s"
    )
    assert (error.value.particle, error.value.attribute, error.value.frame) == (104, "velocity", 12)
    assert isinstance(error.value, ValueError)


def test_the_lowest_particle_of_an_attribute_is_named_over_all_components():
    state = _state(n=3000, dtype=np.float64)
    state.positions[2, 2500] = np.nan
    state.positions[0, 2999] = np.inf
    state.positions[1, 1700] = np.nan
    assert first_non_finite(state) == ("positions", 1700)


def test_fields_strided_rows_lifetimes_and_integers():
    n = 2000
    wide = np.zeros((4, 2 * n), np.float32)
    fields = {
        "lifetime": Field(np.full(n, np.inf, np.float32), "s"),  # immortal: finite enough
        "phase": Field(np.zeros(n, np.int32), ""),
        "color": Field(wide[:, ::2], "1"),  # a strided view
    }
    state = _state(n, **fields)
    assert first_non_finite(state) is None
    wide[3, 2 * 1500] = np.nan
    assert first_non_finite(state) == ("color", 1500)
    wide[3, 2 * 1500] = 0.0
    state["lifetime"][7] = np.nan  # a NaN lifetime is still refused
    with pytest.raises(NonFiniteError, match=r"particle 107 has a non-finite lifetime \(nan\)$"):
        check_finite(state)
    assert first_non_finite(_state(0)) is None


def test_a_system_whose_force_overflows_float32():
    system = mo.ParticleSystem(10)
    system.store.spawn(3)
    system.add(mo.CallbackForce(lambda p, v, t: np.tile([0.0, 3e38, 0.0], (len(p), 1))))
    system.step(1.0)
    check_finite(system)  # 3e38 m/s: large, finite
    system.step(1.0)
    with pytest.raises(NonFiniteError, match="system 'x': particle 0 has a non-finite velocity"):
        check_finite(system, owner="system 'x'")


def test_scenes_check_each_frame_only_when_asked():
    unchecked = load_scene(BLOWUP)
    unchecked.advance()
    unchecked.advance()
    with pytest.raises(SceneError, match=r"^system\.jet: diverged in frame 3: particle positions"):
        unchecked.advance()  # off by default: only positions are scanned

    scene = load_scene(BLOWUP, check_finite=True)
    scene.advance()
    scene.advance()
    with pytest.raises(NonFiniteError) as error:
        scene.advance()
    assert str(error.value).startswith("system 'jet': particle 0 has a non-finite velocity (")
    assert str(error.value).endswith(" at frame 3, t = 1.50 s")
    assert not np.isfinite(error.value.value).any()


class _Blob(Body):
    """A body whose second particle is NaN."""

    def step(self, dt):
        pass

    def particle_state(self):
        positions = np.zeros((3, 2))
        positions[1, 1] = np.nan
        return ParticleState(np.array([7, 8]), positions, np.zeros((3, 2)), np.ones(2))


def test_a_body_is_named_as_a_body():
    scene = load_scene(BLOWUP, check_finite=True, overrides={"system.jet.force": []})
    scene.bodies["blob"] = _Blob()
    with pytest.raises(NonFiniteError, match=r"^body 'blob': particle 8 has a non-finite position"):
        scene.advance()


def test_motes_run_stops_with_one_line_and_keeps_the_frames_before(tmp_path, capsys):
    source = tmp_path / "blowup.toml"
    source.write_text(BLOWUP)
    out = tmp_path / "blowup.mp4"
    assert main(["run", str(source), "-o", str(out), "-q"]) == 2
    error = one_error_line(capsys)
    assert "motes: error: system 'jet': particle 0 has a non-finite velocity" in error
    assert f"at frame 3, t = 1.50 s; {out} holds the 2 frames before" in error
    assert imageio_ffmpeg.count_frames_and_secs(str(out))[0] == 2  # closed, playable
    assert sorted(p.name for p in tmp_path.iterdir()) == ["blowup.mp4", "blowup.toml"]
    # Without the check only positions are scanned: the same frame fails, less precisely.
    assert main(["run", str(source), "--no-render", "--no-check-finite", "-q"]) == 2
    assert "system.jet: diverged in frame 3: particle positions" in one_error_line(capsys)
