"""OBJ and PLY mesh readers and writers."""

import numpy as np
import pytest

from motes.geometry import TriangleMesh
from motes.io.meshes import MeshFormatError, read_mesh, read_obj, read_ply, write_obj, write_ply

QUAD_OBJ = """# a unit quad and a triangle, with normals and texture coordinates to ignore
o quad
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
vt 0 0
vn 0 0 1
f 1/1/1 2/1/1 3/1/1 4/1/1
f -4 -2 -1
"""


def test_obj_reads_polygons_as_fans_and_relative_indices(tmp_path):
    path = tmp_path / "quad.obj"
    path.write_text(QUAD_OBJ)
    mesh = read_obj(path)
    np.testing.assert_array_equal(mesh.faces, [[0, 1, 2], [0, 2, 3], [0, 2, 3]])
    assert mesh.vertices.shape == (4, 3)
    assert mesh.area() == pytest.approx(1.5)


def test_ascii_ply_with_extra_properties(tmp_path):
    text = """ply
format ascii 1.0
comment made by hand
element vertex 4
property float x
property float y
property float z
property uchar red
element face 1
property list uchar int vertex_indices
property float quality
end_header
0 0 0 255
2 0 0 0
2 1 0 0
0 1 0 9
4 0 1 2 3 0.5
"""
    path = tmp_path / "quad.ply"
    path.write_text(text)
    mesh = read_ply(path)
    np.testing.assert_array_equal(mesh.faces, [[0, 1, 2], [0, 2, 3]])
    assert mesh.area() == pytest.approx(2.0)


@pytest.mark.parametrize("suffix", [".obj", ".ply", "binary.ply"])
def test_round_trip(tmp_path, suffix):
    from motes.cloth import topology

    top = topology.grid(5, 4, 2.0, 1.5)
    mesh = TriangleMesh(top.vertices, top.faces)
    path = tmp_path / f"grid{suffix}"
    if suffix == ".obj":
        write_obj(path, mesh)
    else:
        write_ply(path, mesh, binary=suffix.startswith("binary"))
    back = read_mesh(path)
    np.testing.assert_array_equal(back.faces, mesh.faces)
    np.testing.assert_allclose(back.vertices, mesh.vertices, rtol=1e-7)


@pytest.mark.parametrize(
    ("name", "text", "message"),
    [
        ("a.obj", "v 0 0\nf 1 2 3\n", "line 1: a vertex needs x y z"),
        ("b.obj", "v 0 0 0\nf 1 2\n", "line 2: a face needs at least 3 corners"),
        ("c.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "does not exist"),
        ("d.obj", "v 0 0 0\n", "no faces"),
        ("e.ply", "plx\n", "not a PLY file"),
        ("f.ply", "ply\nformat ascii 1.0\nelement vertex 0\n", "no end_header"),
        ("g.ply", "ply\nformat weird 1.0\nend_header\n", "unknown PLY format"),
        ("h.stl", "", "must end in .obj or .ply"),
    ],
)
def test_bad_files_name_the_problem(tmp_path, name, text, message):
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises((MeshFormatError, ValueError), match=message):
        read_mesh(path)
