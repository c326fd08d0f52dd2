"""``motes wedge``: every combination of values, each run as ``motes run`` would, a contact
sheet, failures reported without stopping the rest, resuming, and the same files on Dask."""

import json

import numpy as np
import pytest
from numpy.testing import assert_array_equal

from motes.cli.main import main
from motes.io.frames import read_image
from motes.scene.wedge import WedgeError, parse_axes, split_values, variants
from small_scene import PUFF

SCENE = PUFF

#: Two speeds by three capacities, one of which the scene refuses.
AXES = ["system.puff.emitter.0.speed=0.5,2.0", "system.puff.capacity=300,-1,400"]


def cli(*args):
    return main([str(a) for a in args])


@pytest.fixture
def scene(tmp_path):
    path = tmp_path / "puff.toml"
    path.write_text(SCENE)
    return path


def wedge_args(scene, out, *extra):
    sets = [arg for axis in AXES for arg in ("--set", axis)]
    return ["wedge", scene, *sets, "--frames", 4, "--format", "png", "-o", out, "-q", *extra]


def test_values_split_at_top_level_commas_and_combine_first_key_slowest():
    assert split_values("1, 2.5,[0, 1, 0],'a,b',{ x = 1, y = 2 }") == [
        "1", "2.5", "[0, 1, 0]", "'a,b'", "{ x = 1, y = 2 }",
    ]  # fmt: skip
    axes = parse_axes(["a.b=1,2", "c=[0, 1],[2, 3]", "fixed=true"])
    assert axes == {"a.b": [1, 2], "c": [[0, 1], [2, 3]], "fixed": [True]}
    made = variants(axes)
    assert [v.overrides for v in made] == [
        {"a.b": 1, "c": [0, 1], "fixed": True},
        {"a.b": 1, "c": [2, 3], "fixed": True},
        {"a.b": 2, "c": [0, 1], "fixed": True},
        {"a.b": 2, "c": [2, 3], "fixed": True},
    ]
    assert made[1].label == "a.b=1, c=[2, 3]"  # a key with one value is not in the label
    assert made[1].name == "1_a.b-1_c-2__3"
    for bad, message in [
        (["novalue"], "KEY=V1,V2"),
        (["a=1,,2"], "an empty value"),
        (["a=1", "a=2"], "gives a twice"),
        ([], "at least one --set"),
    ]:
        with pytest.raises(WedgeError, match=message):
            parse_axes(bad)


def test_each_variant_is_what_motes_run_draws_and_a_failure_stops_no_other(tmp_path, scene, capsys):
    out = tmp_path / "wedge"
    assert cli(*wedge_args(scene, out)) == 1  # one capacity is refused: exit status 1
    err = capsys.readouterr().err
    assert err.count("failed: system[0].capacity: must be >= 1, got -1") == 2
    summary = json.loads((out / "wedge.json").read_text())
    statuses = [v["status"] for v in summary["variants"]]
    assert statuses == ["ok", "failed", "ok", "ok", "failed", "ok"]
    ok = [v for v in summary["variants"] if v["status"] == "ok"]
    for record in ok:
        (still,) = record["files"]
        speed, capacity = record["values"].values()
        again = tmp_path / f"run_{record['index']}.png"
        assert cli("run", scene, "--frames", 4, "-o", again, "-q",
                   "--set", f"system.puff.emitter.0.speed={speed}",
                   "--set", f"system.puff.capacity={capacity}") == 0  # fmt: skip
        assert_array_equal(read_image(out / still), read_image(again))
    # the speeds differ, so do the pictures
    assert not np.array_equal(
        read_image(out / ok[0]["files"][0]), read_image(out / ok[2]["files"][0])
    )
    sheet = read_image(out / "contact_sheet.png")
    # a table: three capacities across, two speeds down, a title and labels
    assert sheet.shape[1] == 8 + 3 * (320 + 8) and sheet.shape[0] > 2 * 180


def test_an_interrupted_wedge_resumes_with_the_missing_variants(tmp_path, scene):
    out = tmp_path / "wedge"
    cli(*wedge_args(scene, out))
    names = sorted(p.name for p in out.glob("*_system*.png"))
    assert len(names) == 4
    (out / names[1]).unlink()
    before = {n: (out / n).stat().st_mtime_ns for n in names if n != names[1]}
    cli(*wedge_args(scene, out))
    assert sorted(p.name for p in out.glob("*_system*.png")) == names
    assert {n: (out / n).stat().st_mtime_ns for n in before} == before  # kept, not redone
    summary = json.loads((out / "wedge.json").read_text())
    resumed = [v.get("resumed", False) for v in summary["variants"] if v["status"] == "ok"]
    assert resumed.count(False) == 1


def test_a_wedge_on_dask_writes_the_same_pictures(tmp_path, scene):
    pytest.importorskip("distributed")
    serial, farm = tmp_path / "serial", tmp_path / "farm"
    cli(*wedge_args(scene, serial))
    assert cli(*wedge_args(scene, farm, "--workers", 2)) == 1
    names = sorted(p.name for p in serial.glob("*_system*.png"))
    assert sorted(p.name for p in farm.glob("*_system*.png")) == names
    for name in names:
        assert_array_equal(read_image(farm / name), read_image(serial / name))
    statuses = [v["status"] for v in json.loads((farm / "wedge.json").read_text())["variants"]]
    assert statuses == ["ok", "failed", "ok", "ok", "failed", "ok"]


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--set", "nonsense"], "--set takes KEY=V1,V2"),
        (["--set", "a=1", "--set", "a=2"], "gives a twice"),
    ],
)
def test_mistakes_are_one_line(tmp_path, scene, capsys, extra, message):
    assert cli("wedge", scene, *extra, "-o", tmp_path / "w") == 2
    err = capsys.readouterr().err
    assert err.startswith("motes: error: ") and message in err and err.count("\n") == 1
    assert not (tmp_path / "w").exists()
    assert cli("wedge", "bonfire", "--set", "scene.seed=1,2", "-o", tmp_path / "w") == 2
    assert "no built-in scene 'bonfire'" in capsys.readouterr().err
    (tmp_path / "file").write_text("")
    assert cli("wedge", scene, "--set", "scene.seed=1,2", "-o", tmp_path / "file") == 2
    assert "-o must be a folder" in capsys.readouterr().err
