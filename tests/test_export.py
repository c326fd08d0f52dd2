"""Exports read back by each ecosystem's own reader: counts, attributes and times.

USD through usd-core (``pxr``), VTK through the ``vtk`` package's XML reader, PLY through
plyfile; Houdini's ``.geo`` through a small parser of its documented ASCII layout here
(``hython`` needs a Houdini licence and is not available to CI). Each format's tests
skip cleanly when its package is not installed.
"""

from __future__ import annotations

import math
import os
import signal
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

from motes.io import load_cache
from motes.io.cache import CacheWriter
from motes.io.entry import Entry
from motes.io.export import ExportError, export_cache, frame_path, writer_for
from motes.io.export.attributes import quaternions, srgb_bytes
from particle_kinds import make_cloth, make_fluid, make_hair, make_system, make_world

FPS = 60.0
FRAMES = (1, 2, 3)


def surface_of(state):
    """A small made-up surface mesh (the scene's metaballs are tested elsewhere)."""
    corner = state.positions[:, 0].astype(np.float64)
    vertices = corner + np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0.1, 0.1, 0]])
    return vertices, np.array([[0, 1, 2], [1, 3, 2]])


@pytest.fixture(scope="module")
def frames():
    """Three frames of every kind, as entries: a system, a cloth (faces), hair (curves),
    a rigid world (one body) and a liquid (a surface)."""
    kinds = {
        "sys": make_system(),
        "cloth": make_cloth(),
        "hair": make_hair(),
        "world": make_world(),
        "fluid": make_fluid(),
    }
    out = []
    for frame in FRAMES:
        for kind in kinds.values():
            kind.step(1 / FPS)
        cloth, hair, world = kinds["cloth"], kinds["hair"], kinds["world"]
        fluid = kinds["fluid"].particle_state()
        entries = {
            "sys": Entry(kinds["sys"].particle_state()),
            "cloth": Entry(cloth.particle_state(), faces=cloth.faces),
            "hair": Entry(
                hair.particle_state(), curves=np.full(hair.strand_count, hair.per_strand)
            ),
            "world": Entry(world.particle_state(), transforms=world.transforms()),
            "fluid": Entry(fluid, surface=surface_of(fluid)),
        }
        # Copies: the live arrays change with the next step.
        entries = {
            name: Entry(
                e.state.take(np.arange(e.state.count)),
                faces=e.faces,
                curves=e.curves,
                transforms=None if e.transforms is None else tuple(a.copy() for a in e.transforms),
                surface=e.surface,
            )
            for name, e in entries.items()
        }
        out.append((frame, frame / FPS, entries))
    return out


def write(path, frames, **options):
    with writer_for(path, fps=FPS, scene="test", seed=7, **options) as writer:
        for frame, time, entries in frames:
            writer.write_frame(frame, time, entries)
    return writer


def f32(values):
    return np.asarray(values, dtype=np.float32)


# -- USD ------------------------------------------------------------------------------------


@pytest.mark.parametrize("suffix", [".usdc", ".usda"])
def test_usd_round_trip(tmp_path, frames, suffix):
    pytest.importorskip("pxr")
    from pxr import Usd, UsdGeom

    path = tmp_path / f"run{suffix}"
    write(path, frames)
    assert sorted(p.name for p in tmp_path.iterdir()) == [path.name]  # no temporary left
    stage = Usd.Stage.Open(str(path))
    assert stage.GetTimeCodesPerSecond() == stage.GetFramesPerSecond() == FPS
    assert (stage.GetStartTimeCode(), stage.GetEndTimeCode()) == (1, 3)
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.y
    assert UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    meta = stage.GetRootLayer().customLayerData["motes"]
    assert (meta["scene"], meta["seed"], float(meta["fps"])) == ("test", "7", FPS)
    assert stage.GetDefaultPrim().GetPath() == "/motes"

    points = UsdGeom.Points(stage.GetPrimAtPath("/motes/sys"))
    assert points
    assert points.GetPointsAttr().GetTimeSamples() == list(map(float, FRAMES))
    primvars = UsdGeom.PrimvarsAPI(points)
    for frame, _, entries in frames:
        state = entries["sys"].state
        np.testing.assert_array_equal(points.GetPointsAttr().Get(frame), state.positions.T)
        np.testing.assert_array_equal(points.GetVelocitiesAttr().Get(frame), state.velocities.T)
        np.testing.assert_array_equal(points.GetWidthsAttr().Get(frame), 2 * state.radius)
        np.testing.assert_array_equal(points.GetIdsAttr().Get(frame), state.ids)
        color = state["color"]
        np.testing.assert_array_equal(primvars.GetPrimvar("displayColor").Get(frame), color[:3].T)
        np.testing.assert_array_equal(primvars.GetPrimvar("displayOpacity").Get(frame), color[3])
        np.testing.assert_array_equal(primvars.GetPrimvar("age").Get(frame), state["age"])
        np.testing.assert_array_equal(primvars.GetPrimvar("life").Get(frame), state["lifetime"])
        assert primvars.GetPrimvar("age").GetInterpolation() == UsdGeom.Tokens.vertex
        low, high = np.array(points.GetExtentAttr().Get(frame))
        assert np.all(low <= state.positions.min(axis=1)) and np.all(high >= state.positions.max(1))
    assert points.GetWidthsInterpolation() == UsdGeom.Tokens.vertex

    cloth = UsdGeom.Mesh(stage.GetPrimAtPath("/motes/cloth"))
    faces = frames[0][2]["cloth"].faces
    np.testing.assert_array_equal(cloth.GetFaceVertexIndicesAttr().Get(), faces.ravel())
    np.testing.assert_array_equal(cloth.GetFaceVertexCountsAttr().Get(), [3] * len(faces))
    assert cloth.GetFaceVertexIndicesAttr().GetNumTimeSamples() == 0  # constant topology
    cloth_vars = UsdGeom.PrimvarsAPI(cloth)
    for frame, _, entries in frames:
        state = entries["cloth"].state
        np.testing.assert_array_equal(cloth.GetPointsAttr().Get(frame), f32(state.positions.T))
        np.testing.assert_array_equal(cloth_vars.GetPrimvar("mass").Get(frame), f32(state["mass"]))
        np.testing.assert_array_equal(cloth_vars.GetPrimvar("pinned").Get(frame), state["pinned"])
        np.testing.assert_array_equal(cloth_vars.GetPrimvar("ids").Get(frame), state.ids)

    hair = UsdGeom.BasisCurves(stage.GetPrimAtPath("/motes/hair"))
    assert hair.GetTypeAttr().Get() == UsdGeom.Tokens.linear
    np.testing.assert_array_equal(hair.GetCurveVertexCountsAttr().Get(), [5] * 8)
    state = frames[-1][2]["hair"].state
    np.testing.assert_array_equal(hair.GetPointsAttr().Get(3), f32(state.positions.T))
    np.testing.assert_array_equal(hair.GetWidthsAttr().Get(3), f32(2 * state.radius))

    bodies = stage.GetPrimAtPath("/motes/world_bodies")
    assert [c.GetName() for c in bodies.GetChildren()] == ["body_0000"]
    xform = UsdGeom.Xformable(bodies.GetChildren()[0])
    for frame, _, entries in frames:
        centers, rotations = entries["world"].transforms
        matrix = np.array(xform.ComputeLocalToWorldTransform(frame))
        # USD's row vectors: p' = p M, so M holds R transposed and the centre in row 3.
        np.testing.assert_allclose(matrix[:3, :3], rotations[0].T, atol=1e-12)
        np.testing.assert_allclose(matrix[3, :3], centers[0], atol=1e-12)

    surface = UsdGeom.Mesh(stage.GetPrimAtPath("/motes/fluid_surface"))
    vertices, faces = frames[0][2]["fluid"].surface
    np.testing.assert_array_equal(surface.GetPointsAttr().Get(1), f32(vertices))
    np.testing.assert_array_equal(surface.GetFaceVertexIndicesAttr().Get(1), faces.ravel())
    fluid = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/motes/fluid"))
    phase = frames[0][2]["fluid"].state["phase"]
    np.testing.assert_array_equal(fluid.GetPrimvar("phase").Get(1), phase)


def test_usd_passes_usd_cores_validators(tmp_path, frames):
    pytest.importorskip("pxr")
    from pxr import Usd

    try:
        from pxr import UsdValidation
    except ImportError:
        pytest.skip("usd-core before UsdValidation (25.05)")
    path = tmp_path / "run.usdc"
    write(path, frames)
    validators = UsdValidation.ValidationRegistry().GetOrLoadAllValidators()
    errors = UsdValidation.ValidationContext(validators).Validate(Usd.Stage.Open(str(path)))
    assert [e.GetMessage() for e in errors] == []


def test_usd_of_a_count_that_changes_and_of_no_frame(tmp_path, frames):
    pytest.importorskip("pxr")
    from pxr import Usd, UsdGeom

    path = tmp_path / "run.usdc"
    write(path, [])
    assert list(tmp_path.iterdir()) == []  # no frame: no file, no temporary
    write(path, frames)
    stage = Usd.Stage.Open(str(path))  # held: its prims live as long as it does
    points = UsdGeom.Points(stage.GetPrimAtPath("/motes/sys"))
    counts = [len(points.GetPointsAttr().Get(f)) for f in FRAMES]
    assert counts == [e["sys"].state.count for _, _, e in frames] and counts[0] < counts[-1]


# -- VTK ------------------------------------------------------------------------------------


def read_vtp(path: Path):
    from vtkmodules.util.numpy_support import vtk_to_numpy
    from vtkmodules.vtkIOXML import vtkXMLPolyDataReader

    reader = vtkXMLPolyDataReader()
    reader.SetFileName(str(path))
    reader.Update()
    data = reader.GetOutput()
    point_data = data.GetPointData()
    arrays = {
        point_data.GetArrayName(k): vtk_to_numpy(point_data.GetArray(k))
        for k in range(point_data.GetNumberOfArrays())
    }
    return data, vtk_to_numpy(data.GetPoints().GetData()), arrays


def test_vtk_round_trip(tmp_path, frames):
    pytest.importorskip("vtkmodules.vtkIOXML")
    from vtkmodules.util.numpy_support import vtk_to_numpy

    path = tmp_path / "run.pvd"
    write(path, frames)
    collection = ET.parse(path).getroot()
    assert collection.get("type") == "Collection"
    datasets = collection.find("Collection").findall("DataSet")
    pieces = ["sys", "cloth", "hair", "world", "world_bodies", "fluid", "fluid_surface"]
    assert len(datasets) == len(FRAMES) * len(pieces)
    by_piece = {}
    for d in datasets:
        by_piece.setdefault(d.get("name"), []).append(d)
    assert list(by_piece) == pieces
    for part, name in enumerate(pieces):
        assert [float(d.get("timestep")) for d in by_piece[name]] == [t for _, t, _ in frames]
        assert {d.get("part") for d in by_piece[name]} == {str(part)}
    for (frame, _, entries), d in zip(frames, by_piece["sys"], strict=True):
        assert d.get("file") == f"run/sys_{frame:06d}.vtp"
        data, points, arrays = read_vtp(tmp_path / d.get("file"))
        state = entries["sys"].state
        assert data.GetNumberOfVerts() == state.count
        np.testing.assert_array_equal(points, state.positions.T)
        assert list(arrays) == [a for a in state.names() if a != "positions"]
        for name, values in arrays.items():
            assert values.dtype == state[name].dtype
            np.testing.assert_array_equal(values, state[name].T)

    data, points, arrays = read_vtp(tmp_path / by_piece["cloth"][0].get("file"))
    faces = frames[0][2]["cloth"].faces
    assert data.GetNumberOfPolys() == len(faces) and data.GetNumberOfVerts() == 0
    polys = data.GetPolys()
    np.testing.assert_array_equal(vtk_to_numpy(polys.GetConnectivityArray()), faces.ravel())
    np.testing.assert_array_equal(arrays["pinned"], frames[0][2]["cloth"].state["pinned"])

    data, points, arrays = read_vtp(tmp_path / by_piece["hair"][-1].get("file"))
    assert data.GetNumberOfLines() == 8
    np.testing.assert_array_equal(np.diff(vtk_to_numpy(data.GetLines().GetOffsetsArray())), 5)
    np.testing.assert_array_equal(points, frames[-1][2]["hair"].state.positions.T)

    _, points, arrays = read_vtp(tmp_path / by_piece["world_bodies"][0].get("file"))
    centers, rotations = frames[0][2]["world"].transforms
    np.testing.assert_array_equal(points, centers)
    np.testing.assert_allclose(arrays["orient"], quaternions(rotations))


# -- PLY ------------------------------------------------------------------------------------


def test_ply_round_trip(tmp_path, frames):
    pytest.importorskip("plyfile")
    from plyfile import PlyData

    pattern = tmp_path / "drops.####.ply"
    write(pattern, frames)
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == sorted(
        f"drops.{piece}.{f:04d}.ply"
        for piece in ("sys", "cloth", "hair", "world", "world_bodies", "fluid", "fluid_surface")
        for f in FRAMES
    )
    for frame, time, entries in frames:
        ply = PlyData.read(str(tmp_path / f"drops.sys.{frame:04d}.ply"))
        assert not ply.text and ply.byte_order == "<"
        assert f"motes frame {frame} time {time!r}" in ply.comments
        vertex = ply["vertex"]
        state = entries["sys"].state
        assert vertex.count == state.count
        names = [p.name for p in vertex.properties]
        assert names == ["x", "y", "z", "id", "vx", "vy", "vz", "pscale", "age", "life",
                         "red", "green", "blue", "alpha"]  # fmt: skip
        for axis, (p, v) in enumerate(zip("xyz", ("vx", "vy", "vz"), strict=True)):
            np.testing.assert_array_equal(vertex[p], state.positions[axis])
            np.testing.assert_array_equal(vertex[v], state.velocities[axis])
        np.testing.assert_array_equal(vertex["id"], state.ids)
        np.testing.assert_array_equal(vertex["pscale"], state.radius)
        np.testing.assert_array_equal(vertex["life"], state["lifetime"])
        color = state["color"]
        assert vertex["red"].dtype == np.uint8
        np.testing.assert_array_equal(vertex["red"], srgb_bytes(color[0]))
        np.testing.assert_array_equal(vertex["alpha"], np.rint(color[3] * 255))

    cloth = PlyData.read(str(tmp_path / "drops.cloth.0002.ply"))
    faces = np.stack(cloth["face"]["vertex_indices"])
    np.testing.assert_array_equal(faces, frames[1][2]["cloth"].faces)
    np.testing.assert_array_equal(cloth["vertex"]["pinned"], frames[1][2]["cloth"].state["pinned"])
    hair = PlyData.read(str(tmp_path / "drops.hair.0001.ply"))
    edges = hair["edge"]
    assert edges.count == 8 * 4  # 4 segments in each strand of 5
    assert np.all(edges["vertex2"] - edges["vertex1"] == 1) and np.all(edges["vertex2"] % 5 != 0)


def test_one_piece_keeps_the_pattern_as_given(tmp_path, frames):
    pytest.importorskip("plyfile")
    only = [(f, t, {"sys": e["sys"]}) for f, t, e in frames]
    write(tmp_path / "drops_##.ply", only)
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "drops_01.ply",
        "drops_02.ply",
        "drops_03.ply",
    ]


# -- Houdini .geo ---------------------------------------------------------------------------


def read_geo(path: Path) -> dict:
    """A parser of the classic ASCII ``PGEOMETRY V5`` layout (point attributes, points,
    ``Run N Poly`` primitives): what the writer is meant to produce, read independently."""
    lines = path.read_text().splitlines()
    assert lines[0] == "PGEOMETRY V5"
    head = {}
    for line in lines[1:4]:
        words = line.split()
        head.update(zip(words[::2], map(int, words[1::2]), strict=True))
    at = 4
    attributes = []
    if head["NPointAttrib"]:
        assert lines[at] == "PointAttrib"
        for line in lines[at + 1 : at + 1 + head["NPointAttrib"]]:
            name, size, kind, *default = line.split()
            assert kind in ("float", "int", "vector") and len(default) == int(size)
            attributes.append((name, int(size), kind))
        at += 1 + head["NPointAttrib"]
    rows = []
    for line in lines[at : at + head["NPoints"]]:
        position, _, values = line.partition("(")
        rows.append((list(map(float, position.split())), values.rstrip(")").split()))
    at += head["NPoints"]
    # Houdini holds 32-bit floats: the text's 9 digits are read back to those.
    points = np.array([r[0] for r in rows], dtype=np.float32).reshape(-1, 4)
    assert np.all(points[:, 3] == 1)
    values, column = {}, 0
    for name, size, kind in attributes:
        cast, dtype = (int, np.int64) if kind == "int" else (float, np.float32)
        values[name] = np.array(
            [[cast(v) for v in r[1][column : column + size]] for r in rows], dtype=dtype
        )
        values[name] = (
            values[name].reshape(len(rows), size).squeeze(axis=1) if size == 1 else values[name]
        )
        column += size
    prims = []
    if head["NPrims"]:
        count, kind = lines[at].split()[1:]
        assert kind == "Poly" and int(count) == head["NPrims"]
        for line in lines[at + 1 : at + 1 + int(count)]:
            n, closed, *indices = line.split()
            assert closed in "<:" and len(indices) == int(n)
            prims.append((closed == "<", list(map(int, indices))))
        at += 1 + int(count)
    assert lines[at:] == ["beginExtra", "endExtra"]
    return {
        "P": points[:, :3],
        "attributes": values,
        "kinds": dict((a[0], a[2]) for a in attributes),
        "prims": prims,
    }


def test_geo_round_trip(tmp_path, frames):
    write(tmp_path / "sim.####.geo", frames)
    frame, _, entries = frames[-1]
    geo = read_geo(tmp_path / f"sim.sys.{frame:04d}.geo")
    state = entries["sys"].state
    np.testing.assert_array_equal(geo["P"], state.positions.T)
    got = geo["attributes"]
    assert list(got) == ["id", "v", "pscale", "age", "life", "Cd", "Alpha"]
    assert geo["kinds"]["v"] == "vector" and geo["kinds"]["id"] == "int"
    np.testing.assert_array_equal(got["id"], state.ids)
    np.testing.assert_array_equal(got["v"], state.velocities.T)  # 9 digits: float32 exact
    np.testing.assert_array_equal(got["pscale"], state.radius)
    np.testing.assert_array_equal(got["life"], state["lifetime"])
    np.testing.assert_array_equal(got["Cd"], state["color"][:3].T)
    np.testing.assert_array_equal(got["Alpha"], state["color"][3])

    cloth = read_geo(tmp_path / "sim.cloth.0001.geo")
    faces = frames[0][2]["cloth"].faces
    assert cloth["prims"] == [(True, list(f)) for f in faces.tolist()]
    np.testing.assert_array_equal(cloth["P"], f32(frames[0][2]["cloth"].state.positions.T))
    np.testing.assert_array_equal(
        cloth["attributes"]["pinned"], frames[0][2]["cloth"].state["pinned"]
    )

    hair = read_geo(tmp_path / "sim.hair.0002.geo")
    assert hair["prims"] == [(False, list(range(5 * s, 5 * s + 5))) for s in range(8)]

    bodies = read_geo(tmp_path / "sim.world_bodies.0001.geo")
    centers, rotations = frames[0][2]["world"].transforms
    np.testing.assert_array_equal(bodies["P"], f32(centers))
    # Read back as 32-bit floats: components of a unit quaternion round by <= 6e-8.
    np.testing.assert_allclose(bodies["attributes"]["orient"], quaternions(rotations), atol=1e-7)


# -- the cache, and replaying it --------------------------------------------------------------


def test_the_cache_records_faces_curves_transforms_surfaces_and_fps(tmp_path, frames):
    path = tmp_path / "run.npz"
    write(path, frames)
    cache = load_cache(path)
    assert cache.fps == FPS and cache.names == ("sys", "cloth", "hair", "world", "fluid")
    for index, (_, _, entries) in enumerate(frames):
        for name, want in entries.items():
            got = cache.entry(index, name)
            np.testing.assert_array_equal(got.state.positions, want.state.positions)
            for key in ("faces", "curves"):
                assert (getattr(got, key) is None) == (getattr(want, key) is None)
                if getattr(want, key) is not None:
                    np.testing.assert_array_equal(getattr(got, key), getattr(want, key))
            assert (got.surface is None) == (want.surface is None)
            if want.surface is not None:  # vertices kept in float32, as USD and VTK keep them
                np.testing.assert_array_equal(got.surface[0], want.surface[0].astype(np.float32))
                np.testing.assert_array_equal(got.surface[1], want.surface[1])
        np.testing.assert_array_equal(
            cache.entry(index, "world").transforms[1], entries["world"].transforms[1]
        )
    assert cache.entry(0, "sys").transforms is None
    # A cache written without an fps (older files too) reads with fps None.
    with CacheWriter(tmp_path / "bare.npz") as bare:
        bare.add_frame(0.5, {"sys": frames[0][2]["sys"].state})
    assert load_cache(tmp_path / "bare.npz").fps is None


def test_a_cache_replays_into_the_same_usd(tmp_path, frames):
    pytest.importorskip("pxr")
    from pxr import Usd, UsdGeom

    write(tmp_path / "run.npz", frames)
    write(tmp_path / "direct.usdc", frames)
    cache = load_cache(tmp_path / "run.npz")
    with writer_for(tmp_path / "replayed.usdc", fps=cache.fps) as writer:
        assert export_cache(cache, writer) == len(FRAMES)
    direct, replayed = (Usd.Stage.Open(str(tmp_path / n)) for n in ("direct.usdc", "replayed.usdc"))
    for prim in direct.Traverse():
        other = replayed.GetPrimAtPath(prim.GetPath())
        assert other.GetTypeName() == prim.GetTypeName()
        for attribute in prim.GetAuthoredAttributes():
            twin = other.GetAttribute(attribute.GetName())
            assert twin.GetTimeSamples() == attribute.GetTimeSamples(), attribute.GetName()
            for t in attribute.GetTimeSamples() or [Usd.TimeCode.Default()]:
                a, b = attribute.Get(t), twin.Get(t)
                if hasattr(a, "__len__") and not isinstance(a, str):
                    np.testing.assert_array_equal(np.array(b), np.array(a))
                else:
                    assert a == b
    assert UsdGeom.Points(replayed.GetPrimAtPath("/motes/sys"))


# -- rules and errors -------------------------------------------------------------------------


def test_the_frame_pattern_rule():
    assert frame_path(Path("out/drops.####.ply"), 12) == Path("out/drops.0012.ply")
    assert frame_path(Path("out/drops.####.ply"), 12345) == Path("out/drops.12345.ply")
    assert frame_path(Path("drops_##.geo"), 3, "cloth") == Path("drops_cloth.03.geo")
    assert frame_path(Path("####.ply"), 1, "../evil name") == Path("_evil_name.0001.ply")
    for bad in ("drops.ply", "a##b##.ply"):
        with pytest.raises(ExportError, match="####"):
            frame_path(Path(bad), 1)


@pytest.mark.parametrize(
    ("name", "message"),
    [
        ("run.obj", "the extension must be one of .h5, .hdf5, .npz, .usd"),
        ("run", "cannot export to run"),
        ("drops.ply", "must hold ####"),
        ("drops.geo", "must hold ####"),
        ("run.####.usdc", "#### is for the per-frame formats"),
        ("no/such/run.pvd", "export directory does not exist"),
    ],
)
def test_bad_targets_are_refused_when_the_writer_is_made(tmp_path, name, message):
    with pytest.raises(ExportError, match=message):
        writer_for(tmp_path / name, fps=30)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("suffix", "module", "extra"),
    [(".usdc", "pxr", "usd"), (".pvd", "vtkmodules", "vtk"), (".####.ply", "plyfile", "ply")],
)
def test_a_missing_package_names_the_extra(tmp_path, monkeypatch, suffix, module, extra):
    for loaded in [m for m in sys.modules if m == module or m.startswith(module + ".")]:
        monkeypatch.delitem(sys.modules, loaded)
    monkeypatch.setitem(sys.modules, module, None)  # import fails as if not installed
    with pytest.raises(ExportError, match=rf"pip install 'motes\[{extra}\]'"):
        writer_for(tmp_path / f"run{suffix}", fps=30)


@pytest.mark.parametrize("name", ["run.usdc", "run.pvd", "run.####.ply", "run.####.geo", "run.npz"])
def test_an_interruption_keeps_the_frames_written(tmp_path, frames, name):
    pytest.importorskip(
        {"usdc": "pxr", "pvd": "vtkmodules", "ply": "plyfile"}.get(name[-4:].lstrip("."), "numpy")
    )
    only = [(f, t, {"sys": e["sys"]}) for f, t, e in frames]
    with pytest.raises(KeyboardInterrupt), writer_for(tmp_path / name, fps=FPS) as writer:
        for frame, time, entries in only[:2]:
            writer.write_frame(frame, time, entries)
        raise KeyboardInterrupt
    assert writer.frames_written == 2
    left = sorted(p.name for p in tmp_path.rglob("*"))
    assert not any(".part" in n for n in left), left
    assert len(left) == {"run.pvd": 4}.get(name, 2 if "#" in name else 1)


def test_frames_must_increase_and_entries_be_named(tmp_path, frames):
    writer = writer_for(tmp_path / "a.####.geo", fps=FPS)
    writer.write_frame(2, 2 / FPS, {"sys": frames[0][2]["sys"]})
    with pytest.raises(ValueError, match="frames must increase"):
        writer.write_frame(2, 2 / FPS, {"sys": frames[0][2]["sys"]})
    with pytest.raises(ValueError, match="names"):
        writer.write_frame(3, 3 / FPS, {"a/b": frames[0][2]["sys"]})
    writer.close()
    with pytest.raises(ValueError, match="closed"):
        writer.write_frame(4, 4 / FPS, {"sys": frames[0][2]["sys"]})


def test_quaternions_of_rotations():
    from scipy.spatial.transform import Rotation

    rotations = Rotation.random(200, random_state=4)
    want = rotations.as_quat()  # (x, y, z, w)
    want *= np.where(want[:, 3:] < 0, -1, 1)
    # The four branches of Shepperd's method, each exercised: turns of about pi about
    # each axis make x, y or z the largest term.
    extra = Rotation.from_rotvec(np.diag([math.pi * 0.999] * 3))
    extra_q = extra.as_quat() * np.where(extra.as_quat()[:, 3:] < 0, -1, 1)
    np.testing.assert_allclose(quaternions(rotations.as_matrix()), want, atol=1e-12)
    np.testing.assert_allclose(quaternions(extra.as_matrix()), extra_q, atol=1e-12)


@pytest.mark.parametrize("name", ["run.####.geo", "run.usda"])
def test_names_that_would_share_a_file_or_prim_are_refused(tmp_path, frames, name):
    if name.endswith(".usda"):
        pytest.importorskip("pxr")
    state = frames[0][2]["sys"]
    writer = writer_for(tmp_path / name, fps=FPS)
    with pytest.raises(ExportError, match="'a b' and 'a_b' would both be written as 'a_b'"):
        writer.write_frame(1, 1 / FPS, {"a b": state, "a_b": state})


def test_ctrl_c_in_the_middle_of_a_frame_lands_after_the_frame(tmp_path, frames, monkeypatch):
    from motes.io.export.geo import GeoWriter

    written = []
    write_piece = GeoWriter._write_piece

    def interrupted(self, path, piece, frame, time):
        if frame == 2 and not any(".0002." in name for name in written):
            os.kill(os.getpid(), signal.SIGINT)  # Ctrl-C before the frame's first file
        write_piece(self, path, piece, frame, time)
        written.append(path.name)

    monkeypatch.setattr(GeoWriter, "_write_piece", interrupted)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        writer = writer_for(tmp_path / "a.####.geo", fps=FPS)
        writer.write_frame(1, 1 / FPS, frames[0][2])
        with pytest.raises(KeyboardInterrupt):
            writer.write_frame(2, 2 / FPS, frames[1][2])
    finally:
        signal.signal(signal.SIGINT, previous)
    # The frame was finished, and counted, before the interruption was raised.
    assert writer.frames_written == 2
    assert sum(".0002." in name for name in written) == 7  # every piece of frame 2
