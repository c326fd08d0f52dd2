"""Per-frame Houdini ASCII geometry (``.geo``, ``PGEOMETRY V5``), written here.

No maintained Python package writes Houdini geometry outside Houdini itself (``hou`` and
``hython`` come with Houdini, under its licence), so this is the one format motes
writes by hand: the classic documented ASCII layout, which every Houdini still reads.
``--export out/drops.####.geo`` writes ``out/drops.0001.geo``, ... by the same ``####``
rule as PLY (:func:`~motes.io.export.base.frame_path`), a file per piece when there are
several.

A file holds::

    PGEOMETRY V5
    NPoints n NPrims m
    NPointGroups 0 NPrimGroups 0
    NPointAttrib a NVertexAttrib 0 NPrimAttrib 0 NAttrib 0
    PointAttrib
    v 3 vector 0 0 0            (one line per attribute: name, size, type, default)
    ...
    x y z 1 (values of each attribute, in the declared order)
    ...
    Run m Poly                  (a cloth's or a surface's triangles: " 3 < a b c";
     3 < a b c                   hair strands as open polygons: " k : i0 i1 ...")
    beginExtra
    endExtra

Point attributes follow the map of :mod:`motes.io.export.attributes`: ``P`` (w = 1),
``v`` (type ``vector``), ``pscale``, ``Cd`` and ``Alpha`` (linear), ``id`` (int),
``age``, ``life``, then every other attribute under its own name (booleans and integers
as ``int``, the rest ``float``); a rigid world's ``NAME_bodies`` has ``id`` and
``orient`` (quaternion x, y, z, w). Floats are written with 9 significant digits, which
read back to the same 32-bit value (Houdini's attributes are 32-bit).
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

from .._atomic import replacing
from .attributes import HOUDINI_ALPHA, houdini_name
from .base import PerPieceFiles, Piece

#: Rows formatted per string join: bounds the text held in memory at once.
_CHUNK = 65_536


def _declarations(piece: Piece) -> tuple[list[str], list[np.ndarray], list[str]]:
    """Attribute declaration lines, the value columns, and each column's format."""
    lines, columns, formats = [], [], []
    for attribute, values in piece.attributes.items():
        values = np.asarray(values)
        components = 1 if values.ndim == 1 else values.shape[1]
        rows = values.reshape(len(values), components)
        integer = rows.dtype.kind in "biu"
        if attribute == "color" and components == 4:
            parts = [
                ("Cd", rows[:, :3], "float", "1 1 1"),
                (HOUDINI_ALPHA, rows[:, 3:], "float", "1"),
            ]
        else:
            name = houdini_name(attribute)
            kind = "int" if integer else "vector" if attribute == "velocities" else "float"
            default = {"pscale": "1", "Cd": "1 1 1", "id": "-1", "orient": "0 0 0 1"}.get(
                name, " ".join(["0"] * components)
            )
            parts = [(name, rows, kind, default)]
        for name, block, kind, default in parts:
            lines.append(f"{name} {block.shape[1]} {kind} {default}")
            columns.append(block)
            formats += ["%d" if kind == "int" else "%.9g"] * block.shape[1]
    return lines, columns, formats


def geo_text(piece: Piece, out: io.TextIOBase) -> None:
    """Write ``piece`` as ``PGEOMETRY V5`` text to ``out``."""
    points = np.asarray(piece.points, dtype=np.float64)
    n = len(points)
    declarations, columns, formats = _declarations(piece)
    prims = 0
    if piece.faces is not None:
        prims = len(piece.faces)
    elif piece.curves is not None:
        prims = len(piece.curves)
    out.write("PGEOMETRY V5\n")
    out.write(f"NPoints {n} NPrims {prims}\n")
    out.write("NPointGroups 0 NPrimGroups 0\n")
    out.write(f"NPointAttrib {len(declarations)} NVertexAttrib 0 NPrimAttrib 0 NAttrib 0\n")
    if declarations:
        out.write("PointAttrib\n")
        out.write("".join(f"{line}\n" for line in declarations))
    # P as float32 values (9 digits) and w = 1; then the attributes in parentheses.
    table = np.column_stack([points.astype(np.float32).astype(np.float64), np.ones(n)]
                            + [c.astype(np.float64) for c in columns])  # fmt: skip
    row = "%.9g %.9g %.9g %d"
    if formats:
        row += " (" + " ".join(formats) + ")"
    row += "\n"
    for start in range(0, n, _CHUNK):
        block = table[start : start + _CHUNK]
        out.write((row * len(block)) % tuple(block.ravel().tolist()))
    if piece.faces is not None and len(piece.faces):
        out.write(f"Run {len(piece.faces)} Poly\n")
        faces = np.asarray(piece.faces)
        for start in range(0, len(faces), _CHUNK):
            block = faces[start : start + _CHUNK]
            out.write((" 3 < %d %d %d\n" * len(block)) % tuple(block.ravel().tolist()))
    elif piece.curves is not None and len(piece.curves):
        out.write(f"Run {len(piece.curves)} Poly\n")
        first = 0
        for count in piece.curves.tolist():  # one line per strand, not per particle
            indices = " ".join(map(str, range(first, first + count)))
            out.write(f" {count} : {indices}\n")
            first += count
    out.write("beginExtra\nendExtra\n")


class GeoWriter(PerPieceFiles):
    """Frames into per-frame Houdini ASCII ``.geo`` files (see the module docstring)."""

    suffixes = (".geo",)

    def _write_piece(self, path: Path, piece: Piece, frame: int, time: float) -> None:
        with replacing(path) as tmp, open(tmp, "w", encoding="ascii", newline="\n") as out:
            geo_text(piece, out)
