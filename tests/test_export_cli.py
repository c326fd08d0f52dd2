"""``motes run --export`` in every format, ``motes export CACHE OUT``, and their mistakes.

Each mistake gives one ``motes: error:`` line before anything is simulated: the tests
make ``Scene.advance`` fail if it is called.
"""

from __future__ import annotations

import sys
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import motes
from motes.cli import main
from motes.io import CacheWriter, load_cache
from motes.scene.scene import Scene


def run_cli(*args):
    return main([str(a) for a in args])


def one_error_line(capsys) -> str:
    err = capsys.readouterr().err
    assert err.startswith("motes: error: ") and err.count("\n") == 1, err
    assert "Traceback" not in err
    return err


def live(scene: str, frames: int):
    """The scene after ``frames`` frames, as ``motes run`` simulates it."""
    live = motes.load_scene(scene)
    for _ in range(frames):
        live.advance()
    return live


def test_run_exports_a_cloth_to_usd(tmp_path, capsys):
    pytest.importorskip("pxr")
    from pxr import Usd, UsdGeom

    path = tmp_path / "out.usdc"
    assert run_cli("run", "cloth_drop", "--no-render", "--frames", 3, "--export", path) == 0
    assert f"wrote {path}" in capsys.readouterr().out
    stage = Usd.Stage.Open(str(path))
    scene = live("cloth_drop", 3)
    assert stage.GetTimeCodesPerSecond() == scene.fps
    assert stage.GetRootLayer().customLayerData["motes"]["scene"] == "cloth_drop"
    mesh = UsdGeom.Mesh(stage.GetPrimAtPath("/motes/cloth"))
    faces = scene.bodies["cloth"].cloth.faces
    assert len(mesh.GetFaceVertexCountsAttr().Get()) == len(faces)
    assert mesh.GetPointsAttr().GetTimeSamples() == [1.0, 2.0, 3.0]
    want = scene.states()["cloth"].positions.T.astype(np.float32)
    np.testing.assert_array_equal(mesh.GetPointsAttr().Get(3), want)


def test_run_exports_hair_to_paraview(tmp_path):
    pytest.importorskip("vtkmodules.vtkIOXML")
    from vtkmodules.vtkIOXML import vtkXMLPolyDataReader

    path = tmp_path / "hair.pvd"
    assert run_cli("run", "hair", "--no-render", "--frames", 2, "--export", path, "-q") == 0
    datasets = ET.parse(path).getroot().find("Collection").findall("DataSet")
    scene = live("hair", 2)
    hair = next(iter(scene.bodies.values())).hair
    assert [float(d.get("timestep")) for d in datasets] == [1 / scene.fps, 2 / scene.fps]
    reader = vtkXMLPolyDataReader()
    reader.SetFileName(str(tmp_path / datasets[-1].get("file")))
    reader.Update()
    assert reader.GetOutput().GetNumberOfLines() == hair.strand_count
    assert reader.GetOutput().GetNumberOfPoints() == hair.n


def test_run_exports_rigid_bodies_to_houdini_and_a_liquid_to_ply(tmp_path):
    pytest.importorskip("plyfile")
    from plyfile import PlyData

    pattern = tmp_path / "tower.####.geo"
    assert run_cli("run", "box_tower", "--no-render", "--frames", 2, "--export", pattern, "-q") == 0
    bodies = len(live("box_tower", 0).bodies["tower"].world.transforms()[0])
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == [f"tower.tower{s}.000{f}.geo" for s in ("", "_bodies") for f in (1, 2)]
    lines = (tmp_path / "tower.tower_bodies.0002.geo").read_text().splitlines()
    assert lines[1] == f"NPoints {bodies} NPrims 0" and "orient 4 float 0 0 0 1" in lines

    drops = tmp_path / "drops" / "f.####.ply"
    drops.parent.mkdir()
    assert run_cli("run", "fountain", "--no-render", "--frames", 2, "--export", drops, "-q") == 0
    surface = PlyData.read(str(drops.parent / "f.fountain_surface.0002.ply"))
    particles = PlyData.read(str(drops.parent / "f.fountain.0002.ply"))
    assert (
        surface["face"].count > 0
        and particles["vertex"].count == live("fountain", 2).counts()["fountain"]
    )


def test_export_replays_a_cache_as_run_writes_it(tmp_path, capsys):
    pytest.importorskip("pxr")
    from pxr import Usd, UsdGeom

    cache, direct, replayed = tmp_path / "c.npz", tmp_path / "direct.usda", tmp_path / "again.usda"
    for out in (cache, direct):
        args = ("run", "pendulums", "--no-render", "--frames", 2, "--export", out, "-q")
        assert run_cli(*args) == 0
    assert load_cache(cache).fps == live("pendulums", 0).fps
    assert run_cli("export", cache, replayed) == 0
    assert "2 frames in" in capsys.readouterr().out
    stages = [Usd.Stage.Open(str(p)) for p in (direct, replayed)]
    prims = [[p.GetPath() for p in s.Traverse()] for s in stages]
    assert prims[0] == prims[1]
    for path in prims[0][1:]:
        a, b = (UsdGeom.PointBased(s.GetPrimAtPath(path)) for s in stages)
        if a:
            np.testing.assert_array_equal(a.GetPointsAttr().Get(2), b.GetPointsAttr().Get(2))


@pytest.fixture
def no_simulation(monkeypatch, tmp_path):
    """Fail if a frame is simulated; work in an empty folder."""

    def advance(self):
        raise AssertionError("simulated before the export was checked")

    monkeypatch.setattr(Scene, "advance", advance)
    monkeypatch.chdir(tmp_path)
    return tmp_path


@pytest.mark.parametrize(
    ("export", "message"),
    [
        (
            "out.obj",
            "cannot export to out.obj: the extension must be one of .h5, .hdf5, .npz, .usd",
        ),
        ("drops.ply", ".ply writes a file per frame: the name must hold #### once"),
        ("drops.geo", ".geo writes a file per frame: the name must hold #### once"),
        ("run.####.usdc", "#### is for the per-frame formats (.ply, .geo)"),
        ("no/such/run.usdc", "export directory does not exist: no/such"),
        ("taken.pvd", "taken exists and is not a folder"),
    ],
)
def test_export_mistakes_are_one_line_before_simulating(export, message, no_simulation, capsys):
    (no_simulation / "taken").write_text("a file where the .vtp files would go")
    assert run_cli("run", "fire", "--no-render", "--export", export) == 2
    assert message in one_error_line(capsys)
    assert sorted(p.name for p in no_simulation.iterdir()) == ["taken"]


@pytest.mark.parametrize(
    ("export", "module", "package", "extra"),
    [
        ("run.usdc", "pxr", "usd-core", "usd"),
        ("run.pvd", "vtkmodules", "vtk", "vtk"),
        ("run.####.ply", "plyfile", "plyfile", "ply"),
    ],
)
def test_a_missing_package_is_one_line_naming_the_extra(
    export, module, package, extra, no_simulation, monkeypatch, capsys
):
    for loaded in [m for m in sys.modules if m == module or m.startswith(module + ".")]:
        monkeypatch.delitem(sys.modules, loaded)
    monkeypatch.setitem(sys.modules, module, None)  # as if not installed
    assert run_cli("run", "fire", "--no-render", "--export", export) == 2
    err = one_error_line(capsys)
    assert f"needs the {package} package: pip install 'motes[{extra}]'" in err
    assert run_cli("export", "any.npz", export) == 2  # checked before the cache is read
    assert f"pip install 'motes[{extra}]'" in one_error_line(capsys)
    assert list(no_simulation.iterdir()) == []


def test_ctrl_c_keeps_a_whole_usd_of_the_frames_done(tmp_path, monkeypatch, capsys):
    pytest.importorskip("pxr")
    from pxr import Usd

    calls = {"n": 0}
    advance = Scene.advance

    def interrupted(self):
        calls["n"] += 1
        if calls["n"] == 3:
            raise KeyboardInterrupt
        advance(self)

    monkeypatch.setattr(Scene, "advance", interrupted)
    path = tmp_path / "out.usdc"
    assert run_cli("run", "pendulums", "--no-render", "--frames", 5, "--export", path) == 130
    assert "interrupted after 2 frames" in capsys.readouterr().err
    assert [p.name for p in tmp_path.iterdir()] == ["out.usdc"]  # no temporary left
    stage = Usd.Stage.Open(str(path))
    assert stage.GetEndTimeCode() == 2
    points = next(p for p in stage.Traverse() if p.GetTypeName() == "Points")
    assert points.GetAttribute("points").GetTimeSamples() == [1.0, 2.0]


def test_export_command_mistakes(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert run_cli("export", "missing.npz", "out.####.geo") == 2
    assert "no such cache: missing.npz" in one_error_line(capsys)
    (tmp_path / "text.npz").write_text("not a cache")
    assert run_cli("export", "text.npz", "out.####.geo") == 2
    assert "is not a motes cache" in one_error_line(capsys)
    # A cache written without a frame rate (by Python, or an older motes) needs --fps.
    state = live("pendulums", 1).states()["cradle"]
    with CacheWriter(tmp_path / "bare.npz") as cache:
        cache.add_frame(0.5, {"cradle": state})
        cache.add_frame(1.0, {"cradle": state})
    assert run_cli("export", "bare.npz", "out.####.geo") == 2
    assert "give it with --fps" in one_error_line(capsys)
    assert run_cli("export", "bare.npz", "out.####.geo", "--fps", 2, "-q") == 0
    assert sorted(p.name for p in tmp_path.glob("out.*")) == ["out.0001.geo", "out.0002.geo"]
    assert run_cli("export", "bare.npz", "bare.npz") == 2
    assert "OUT is the cache itself" in one_error_line(capsys)


def test_an_unwritable_export_folder_is_one_line_before_simulating(
    no_simulation, monkeypatch, capsys
):
    # As root every folder is writable: stand in for a read-only one.
    cli = sys.modules["motes.cli.main"]  # the module (motes.cli.main is the function)
    monkeypatch.setattr(cli.os, "access", lambda path, mode: False)
    assert run_cli("run", "fire", "--no-render", "--export", "run.####.geo") == 2
    assert "cannot write to" in one_error_line(capsys)
    assert list(no_simulation.iterdir()) == []
