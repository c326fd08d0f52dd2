"""Triangle meshes from and to Wavefront OBJ and Stanford PLY files.

Readers return a :class:`~motes.geometry.TriangleMesh`; polygons with more than three
corners are split into a fan of triangles. OBJ: ``v`` and ``f`` lines (``f 1/2/3``
index forms and negative, relative indices included); everything else (normals, texture
coordinates, groups, materials) is ignored. PLY: ``ascii`` and
``binary_little_endian`` / ``binary_big_endian`` files with a ``vertex`` element
holding ``x y z`` and a ``face`` element holding a ``vertex_indices`` (or
``vertex_index``) list; other properties and elements are skipped.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..geometry.mesh import TriangleMesh


class MeshFormatError(ValueError):
    """A mesh file that cannot be read; the message names the file and line."""


def read_mesh(path) -> TriangleMesh:
    """Read an ``.obj`` or ``.ply`` file (chosen by its suffix)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".obj":
        return read_obj(path)
    if suffix == ".ply":
        return read_ply(path)
    raise ValueError(f"mesh files must end in .obj or .ply, got {path.name!r}")


def _fan(polygon: list[int]) -> list[tuple[int, int, int]]:
    return [(polygon[0], polygon[k], polygon[k + 1]) for k in range(1, len(polygon) - 1)]


def _mesh(path, vertices, faces) -> TriangleMesh:
    v = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if len(f) == 0:
        raise MeshFormatError(f"{path}: no faces")
    if f.min() < 0 or f.max() >= len(v):
        raise MeshFormatError(f"{path}: a face refers to a vertex that does not exist")
    return TriangleMesh(v, f)


def read_obj(path) -> TriangleMesh:
    """Read a Wavefront OBJ file's vertices and faces."""
    vertices: list[list[float]] = []
    faces: list[tuple[int, int, int]] = []
    with open(path, encoding="utf-8") as handle:
        for number, line in enumerate(handle, 1):
            words = line.split("#", 1)[0].split()
            if not words:
                continue
            try:
                if words[0] == "v":
                    vertices.append([float(w) for w in words[1:4]])
                    if len(vertices[-1]) != 3:
                        raise ValueError("a vertex needs x y z")
                elif words[0] == "f":
                    corners = []
                    for word in words[1:]:
                        k = int(word.split("/")[0])
                        corners.append(k - 1 if k > 0 else len(vertices) + k)
                    if len(corners) < 3:
                        raise ValueError("a face needs at least 3 corners")
                    faces.extend(_fan(corners))
            except ValueError as error:
                raise MeshFormatError(f"{path}, line {number}: {error}") from None
    return _mesh(path, vertices, faces)


_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
    "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}  # fmt: skip


def _ply_header(handle, path):
    if handle.readline().strip() != b"ply":
        raise MeshFormatError(f"{path}: not a PLY file (no 'ply' line)")
    fmt = None
    elements: list[tuple[str, int, list]] = []
    while True:
        line = handle.readline()
        if not line:
            raise MeshFormatError(f"{path}: header has no end_header")
        words = line.decode("ascii", "replace").split()
        if not words or words[0] in ("comment", "obj_info"):
            continue
        if words[0] == "end_header":
            break
        if words[0] == "format":
            fmt = words[1]
        elif words[0] == "element":
            elements.append((words[1], int(words[2]), []))
        elif words[0] == "property":
            if not elements:
                raise MeshFormatError(f"{path}: property before any element")
            if words[1] == "list":
                elements[-1][2].append((words[4], words[2], words[3]))
            else:
                elements[-1][2].append((words[2], None, words[1]))
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise MeshFormatError(f"{path}: unknown PLY format {fmt!r}")
    return fmt, elements


def read_ply(path) -> TriangleMesh:
    """Read a PLY file's vertex positions and faces (ascii or binary)."""
    with open(path, "rb") as handle:
        fmt, elements = _ply_header(handle, path)
        data = handle.read()
    vertices = None
    faces: list[tuple[int, int, int]] = []
    if fmt == "ascii":
        tokens = data.split()
        at = 0
        for name, count, props in elements:
            rows = []
            for _ in range(count):
                row = {}
                for prop, count_type, _ in props:
                    if count_type is None:
                        row[prop] = float(tokens[at])
                        at += 1
                    else:
                        k = int(tokens[at])
                        row[prop] = [int(float(t)) for t in tokens[at + 1 : at + 1 + k]]
                        at += 1 + k
                rows.append(row)
            vertices, faces = _ply_collect(path, name, rows, vertices, faces)
    else:
        order = "<" if fmt == "binary_little_endian" else ">"
        at = 0
        for name, count, props in elements:
            rows = []
            for _ in range(count):
                row = {}
                for prop, count_type, value_type in props:
                    if count_type is None:
                        dt = np.dtype(order + _PLY_TYPES[value_type])
                        row[prop] = float(np.frombuffer(data, dt, 1, at)[0])
                        at += dt.itemsize
                    else:
                        ct = np.dtype(order + _PLY_TYPES[count_type])
                        vt = np.dtype(order + _PLY_TYPES[value_type])
                        k = int(np.frombuffer(data, ct, 1, at)[0])
                        at += ct.itemsize
                        row[prop] = np.frombuffer(data, vt, k, at).astype(int).tolist()
                        at += k * vt.itemsize
                rows.append(row)
            vertices, faces = _ply_collect(path, name, rows, vertices, faces)
    if vertices is None:
        raise MeshFormatError(f"{path}: no vertex element")
    return _mesh(path, vertices, faces)


def _ply_collect(path, name, rows, vertices, faces):
    if name == "vertex":
        try:
            vertices = [[r["x"], r["y"], r["z"]] for r in rows]
        except KeyError:
            raise MeshFormatError(f"{path}: vertex element lacks x, y or z") from None
    elif name == "face":
        for r in rows:
            corners = r.get("vertex_indices", r.get("vertex_index"))
            if corners is None:
                raise MeshFormatError(f"{path}: face element lacks vertex_indices")
            faces.extend(_fan(corners))
    return vertices, faces


def write_obj(path, mesh: TriangleMesh) -> None:
    """Write ``mesh`` as an OBJ file (vertices and triangles)."""
    lines = [f"v {x:.9g} {y:.9g} {z:.9g}" for x, y, z in mesh.vertices.astype(float)]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in mesh.faces]
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")


def write_ply(path, mesh: TriangleMesh, *, binary: bool = False) -> None:
    """Write ``mesh`` as a PLY file (ascii, or binary little-endian)."""
    v = mesh.vertices.astype("<f4")
    f = mesh.faces.astype("<i4")
    header = (
        f"ply\nformat {'binary_little_endian' if binary else 'ascii'} 1.0\n"
        f"element vertex {len(v)}\nproperty float x\nproperty float y\nproperty float z\n"
        f"element face {len(f)}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    with open(path, "wb") as handle:
        handle.write(header.encode("ascii"))
        if binary:
            record = np.dtype([("k", "u1"), ("i", "<i4", 3)])
            faces = np.empty(len(f), record)
            faces["k"] = 3
            faces["i"] = f
            handle.write(v.tobytes() + faces.tobytes())
        else:
            body = [f"{x:.9g} {y:.9g} {z:.9g}" for x, y, z in v.astype(float)]
            body += [f"3 {a} {b} {c}" for a, b, c in f]
            handle.write(("\n".join(body) + "\n").encode("ascii"))
