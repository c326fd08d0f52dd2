"""OpenEXR stills (linear colour in half float, depth in float32, metadata) and stills of
any frame (``--frame N``, ``--time T``)."""

import sys

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from motes.cli.main import main
from motes.io.frames import read_image
from motes.render.tonemap import to_srgb8
from motes.scene import load_scene
from small_scene import PUFF

pytest.importorskip("OpenEXR")
from motes.io.exr import read_exr, write_exr

#: The puff over a ground plane (so the depth pass has a surface), brighter than 1.
SCENE = (
    PUFF
    + """
[render]
exposure = 1.5

[[object]]
type = "ground"
"""
)


def cli(*args):
    return main([str(a) for a in args])


def test_write_and_read_back_half_colour_float_depth_and_metadata(tmp_path):
    rng = np.random.default_rng(1)
    color = (rng.random((5, 7, 3)) * 40.0).astype(np.float32)  # HDR: far above 1
    depth = rng.random((5, 7)).astype(np.float32) * 10
    depth[0, 0] = np.inf  # no surface there
    write_exr(tmp_path / "a.exr", color, depth, {"scene": "puff", "seed": "3"})
    got, z, record = read_exr(tmp_path / "a.exr")
    np.testing.assert_allclose(got, color, rtol=2**-11)  # half float: 11 significant bits
    assert_array_equal(z, depth)  # float32 exactly, infinity kept
    assert record == {"scene": "puff", "seed": "3"}
    with pytest.raises(ValueError, match=r"depth must have shape \(5, 7\)"):
        write_exr(tmp_path / "b.exr", color, depth[:4])


def test_an_exr_still_is_the_png_still_before_tone_mapping(tmp_path):
    scene = tmp_path / "puff.toml"
    scene.write_text(SCENE)
    exr, png = tmp_path / "still.exr", tmp_path / "still.png"
    assert cli("run", scene, "--frame", 3, "-o", exr, "-q") == 0
    assert cli("run", scene, "--frame", 3, "-o", png, "-q") == 0
    color, depth, record = read_exr(exr)
    assert record["scene"] == "puff" and record["seed"] == "4"
    loaded = load_scene(scene)
    tonemap = loaded.renderer().renderer.tonemap
    # the EXR holds colour times the exposure: tone mapped, it is the PNG (half float
    # rounding moves a pixel by one level at most)
    again = to_srgb8(color, exposure=1.0, tonemap=tonemap)
    assert np.abs(again.astype(int) - read_image(png)).max() <= 1
    assert color.max() > 1.0  # not clipped: a compositor grades it
    # the depth pass: the ground below the horizon, nothing above it
    assert np.isinf(depth[0]).all() and np.isfinite(depth[-1]).all()
    column = depth[:, 0][np.isfinite(depth[:, 0])]
    assert 0 < column[-1] < column[0] < 1000  # farther up the image, up to the horizon
    assert np.all(np.diff(column) <= 0)


def test_a_still_at_a_time_is_the_still_of_the_nearest_frame(tmp_path):
    scene = tmp_path / "puff.toml"
    scene.write_text(PUFF)  # 10 fps
    by_time, by_frame = tmp_path / "t.png", tmp_path / "f.png"
    assert cli("run", scene, "--time", 0.31, "-o", by_time, "-q") == 0
    assert cli("run", scene, "--frame", 3, "-o", by_frame, "-q") == 0
    assert_array_equal(read_image(by_time), read_image(by_frame))


def test_a_cached_frame_draws_to_exr_as_the_run_did(tmp_path):
    scene = tmp_path / "puff.toml"
    scene.write_text(SCENE)
    cache, live, again = tmp_path / "c.h5", tmp_path / "live.exr", tmp_path / "again.exr"
    assert cli("run", scene, "--frame", 4, "-o", live, "--export", cache, "-q") == 0
    assert cli("render", cache, "-o", again, "--scene", scene, "-q") == 0
    for a, b in zip(read_exr(live)[:2], read_exr(again)[:2], strict=True):
        assert_array_equal(a, b)


def test_mistakes_are_one_line(tmp_path, capsys, monkeypatch):
    scene = tmp_path / "puff.toml"
    scene.write_text(PUFF)
    assert cli("run", scene, "--frame", 2, "-o", tmp_path / "x.mp4") == 2
    assert "--frame and --time draw one frame" in capsys.readouterr().err
    monkeypatch.setitem(sys.modules, "OpenEXR", None)  # not installed
    assert cli("run", scene, "-o", tmp_path / "x.exr") == 2
    err = capsys.readouterr().err
    assert "pip install 'motes[exr]'" in err and err.count("\n") == 1
