"""Per-frame PLY point clouds and meshes, binary little-endian, through ``plyfile``.

``--export out/drops.####.ply`` writes ``out/drops.0001.ply``, ``out/drops.0002.ply``,
... (the frame number in place of ``####``, zero-padded to its length: the pattern
Houdini's File SOP and Blender's sequence importers read). A scene with several pieces
(entries, a liquid's ``NAME_surface``, a rigid world's ``NAME_bodies``) writes a
sequence per piece, its name before the number: ``out/drops.cloth.0001.ply``.

Each file has a ``vertex`` element with one property per value, by the attribute map of
:mod:`motes.io.export.attributes`: ``x y z``, ``vx vy vz``, ``pscale`` (the radius),
``red green blue alpha`` (uchar, sRGB-encoded colour, linear alpha), ``id`` (uint32, or
double past 2³² − 1), ``age``, ``life``, then every other attribute (a vector one as
``NAME_0``, ``NAME_1``, ...). A cloth's and a surface's triangles are a ``face`` element
(``vertex_indices``: uchar count, int indices); hair strands an ``edge`` element
(``vertex1``, ``vertex2``: each segment of each strand). The header's comments record
the frame, its time and how it was made.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._atomic import replacing
from .attributes import linear_bytes, ply_names, srgb_bytes
from .base import PerPieceFiles, Piece

#: PLY holds no 64-bit integers: ids past this are written as doubles (exact to 2**53).
_UINT32_MAX = 2**32 - 1


def vertex_table(piece: Piece) -> np.ndarray:
    """The structured array of the ``vertex`` element: one field per PLY property."""
    columns: list[tuple[str, np.ndarray]] = []
    columns += zip(("x", "y", "z"), np.asarray(piece.points).T, strict=True)
    for attribute, values in piece.attributes.items():
        values = np.asarray(values)
        components = 1 if values.ndim == 1 else values.shape[1]
        names = ply_names(attribute, components)
        rows = values.reshape(len(values), components).T
        if attribute == "color" and components in (3, 4):
            rows = np.concatenate([srgb_bytes(rows[:3]), linear_bytes(rows[3:])])
        elif attribute == "ids":
            big = rows.size and rows.max() > _UINT32_MAX
            rows = rows.astype(np.float64 if big else np.uint32)
        elif rows.dtype.kind == "b":
            rows = rows.astype(np.uint8)
        elif rows.dtype.kind in "iu" and rows.dtype.itemsize == 8:
            rows = rows.astype(np.float64)  # no 64-bit integers in PLY
        columns += zip(names, rows, strict=True)
    table = np.empty(len(piece.points), dtype=[(name, col.dtype) for name, col in columns])
    for name, col in columns:
        table[name] = col
    return table


class PlyWriter(PerPieceFiles):
    """Frames into per-frame binary PLY files (see the module docstring)."""

    suffixes = (".ply",)
    package = ("plyfile", "plyfile", "ply")

    def _write_piece(self, path: Path, piece: Piece, frame: int, time: float) -> None:
        from plyfile import PlyData, PlyElement

        elements = [PlyElement.describe(vertex_table(piece), "vertex")]
        if piece.faces is not None:
            faces = np.empty(len(piece.faces), dtype=[("vertex_indices", np.int32, (3,))])
            faces["vertex_indices"] = piece.faces
            elements.append(PlyElement.describe(faces, "face", len_types={"vertex_indices": "u1"}))
        if piece.curves is not None:
            elements.append(PlyElement.describe(_edges(piece.curves), "edge"))
        comments = [f"motes frame {frame} time {time!r}"]
        comments += [f"motes {key} {value}" for key, value in self.metadata().items()]
        ply = PlyData(elements, text=False, byte_order="<", comments=comments)
        with replacing(path) as tmp:
            ply.write(str(tmp))


def _edges(curves: np.ndarray) -> np.ndarray:
    """Segments ``(vertex1, vertex2)`` joining consecutive points of each curve."""
    ends = np.cumsum(curves)
    first = np.arange(int(ends[-1]) if len(ends) else 0)
    keep = np.ones(len(first), bool)
    keep[ends - 1] = False  # a curve's last point starts no segment
    starts = first[keep]
    table = np.empty(len(starts), dtype=[("vertex1", np.int32), ("vertex2", np.int32)])
    table["vertex1"] = starts
    table["vertex2"] = starts + 1
    return table
