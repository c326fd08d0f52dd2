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


#: Alpha-blended smoke over a ground, under a sky gradient.
ALPHA_LOOK = '  color = [0.8, 0.6, 0.4, 0.5]\n\n  [system.render]\n  blend = "alpha"\n'
SMOKE = (
    SCENE.replace("  lifetime = 0.4\n", "  lifetime = 0.4\n" + ALPHA_LOOK)
    .replace("exposure = 1.5\n", 'exposure = 1.5\nbackground = ["#304060", "#a0b0c0"]\n')
    .replace("radius = 0.2 }\n", "radius = 0.2 }\n  position = [0.0, 1.0, 0.0]\n")  # the sky
)


def test_a_transparent_frame_composites_back_to_the_frame(tmp_path):
    scene = load_scene(SMOKE)
    for _ in range(3):
        scene.advance()
    renderer = scene.renderer((96, 54))
    plain = renderer.render_scene_hdr(scene)
    clear = renderer.render_scene_hdr(scene, transparent=True)
    alpha = clear.alpha
    assert alpha.shape == (54, 96) and alpha.min() >= 0 and alpha.max() <= 1
    ground = np.isfinite(clear.depth)
    assert ground.any() and (alpha[ground] == 1).all()
    sky = ~ground & (alpha == 0)
    assert sky.any() and (clear.color[sky] == 0).all()  # nothing over nothing
    assert ((alpha > 0) & (alpha < 1)).any()  # the smoke covers partly
    # premultiplied: over the background it is the frame drawn on the background
    background = np.zeros_like(plain.color)
    renderer.renderer.background.fill(_Holder(background))
    composite = clear.color + (1 - alpha[..., None]) * background
    np.testing.assert_allclose(composite, plain.color, atol=2e-6)
    # and in a file: RGBA in half float
    path = tmp_path / "smoke.toml"
    path.write_text(SMOKE)
    out = tmp_path / "smoke.exr"
    assert cli("run", path, "--frame", 3, "-o", out, "--alpha", "--resolution", "96x54") == 0
    rgba, _, _ = read_exr(out)
    assert rgba.shape == (54, 96, 4)
    np.testing.assert_allclose(rgba[..., 3], alpha, atol=1e-3)


class _Holder:
    """What Background.fill writes into: an object with ``color``, ``height``."""

    def __init__(self, color):
        self.color, self.height = color, color.shape[0]


def test_png_with_straight_alpha_and_16_bits(tmp_path, capsys):
    pytest.importorskip("png")
    from motes.io.frames import read_metadata, read_png16

    path = tmp_path / "smoke.toml"
    path.write_text(SMOKE)
    common = ("--frame", 3, "--resolution", "96x54", "-q")
    assert cli("run", path, "-o", tmp_path / "plain.png", *common) == 0
    assert cli("run", path, "-o", tmp_path / "alpha.png", "--alpha", *common) == 0
    assert cli("run", path, "-o", tmp_path / "deep.png", "--bits", 16, *common) == 0
    sequence = ("--frames", 3, "--resolution", "96x54", "-q")
    assert cli("run", path, "-o", tmp_path / "both", "--bits", 16, "--alpha", *sequence) == 0
    scene = load_scene(SMOKE)
    for _ in range(3):
        scene.advance()
    clear = scene.renderer((96, 54)).render_scene_hdr(scene, transparent=True)
    rgba = read_image(tmp_path / "alpha.png", alpha=True)
    assert rgba.shape == (54, 96, 4)
    assert_array_equal(rgba[..., 3], np.rint(clear.alpha * 255).astype(np.uint8))
    assert (rgba[..., :3][clear.alpha == 0] == 0).all()  # nothing where nothing covers
    covered = clear.alpha == 1  # the ground: the frame's own colours
    plain = read_image(tmp_path / "plain.png")
    assert np.abs(rgba[..., :3][covered].astype(int) - plain[covered]).max() <= 1
    deep = read_png16(tmp_path / "deep.png")
    assert deep.dtype == np.uint16 and deep.shape == (54, 96, 3)
    # 16 bits hold the 8-bit frame and 8 more bits below it
    assert np.abs(deep / 257.0 - plain).max() <= 0.5 + 1e-9
    assert len(np.unique(deep)) > len(np.unique(plain))
    assert read_metadata(tmp_path / "deep.png")["scene"] == "puff"
    *_, frame = sorted((tmp_path / "both").glob("frame_*.png"))
    both = read_png16(frame)
    assert both.shape == (54, 96, 4)
    assert_array_equal(both[..., 3], np.rint(clear.alpha * 65535).astype(np.uint16))


def test_alpha_and_bits_need_an_image_format(tmp_path, capsys):
    path = tmp_path / "puff.toml"
    path.write_text(PUFF)
    assert cli("run", path, "--frames", 1, "-o", tmp_path / "a.mp4", "--alpha") == 2
    assert "--alpha needs -o NAME.exr, NAME.png or a folder" in capsys.readouterr().err
    assert cli("run", path, "--frame", 1, "-o", tmp_path / "a.exr", "--bits", 16) == 2
    assert "--bits 16 needs -o NAME.png or a folder" in capsys.readouterr().err


def test_the_farm_refuses_what_it_cannot_draw_yet(tmp_path, capsys):
    scene = tmp_path / "puff.toml"
    scene.write_text(PUFF)
    cache = tmp_path / "c.h5"
    assert cli("run", scene, "--frames", 1, "--no-render", "--export", cache, "-q") == 0
    args = ("-o", tmp_path / "f", "--scene", scene, "--workers", 2)
    assert cli("render", cache, *args, "--alpha") == 2
    assert "--workers and --scheduler draw 8-bit frames" in capsys.readouterr().err
    assert not (tmp_path / "f").exists()
