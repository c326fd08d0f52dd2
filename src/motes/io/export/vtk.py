"""VTK for ParaView: a ``.pvd`` collection of per-frame ``.vtp`` poly data.

``motes run SCENE --export out/run.pvd`` writes, per frame and per piece (an entry's
particles; ``NAME_surface`` for a liquid's surface; ``NAME_bodies`` for a rigid world's
bodies), ``out/run/PIECE_000012.vtp``: a ``vtkPolyData`` whose cells are vertices (one
per particle), triangles (a cloth's faces, a surface) or polylines (hair strands, one
per strand), with every attribute as a point-data array under its motes name
(``velocities``, ``radius``, ``color``, ``ids``, ...; :mod:`motes.io.export.attributes`).
The files are written by VTK's own ``vtkXMLPolyDataWriter`` (appended raw binary,
LZ4-compressed, 64-bit headers), each under a temporary name and then moved into place.

The ``.pvd`` lists them: one ``DataSet`` per frame and piece, with ``timestep`` the
simulation time [s] and ``part`` the piece, so ParaView shows the pieces as blocks of
one time series. VTK has no writer for ``.pvd`` (ParaView's own format, a few lines of
XML); it is written with the standard library's ``xml.etree`` when the writer is closed
(also when a run is interrupted, with the frames finished).
"""

from __future__ import annotations

import os
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from .._atomic import replacing
from ..entry import Entry
from .base import ExportError, ExportWriter, Piece, PlainNames, ensure_folder, pieces


class VtkWriter(ExportWriter):
    """Frames into per-frame ``.vtp`` files and one ``.pvd`` collection (see the module)."""

    suffixes = (".pvd",)
    package = ("vtkmodules.vtkIOXML", "vtk", "vtk")

    def __init__(self, path, **options):
        super().__init__(path, **options)
        self.folder = self.path.with_suffix("")
        if self.folder.exists() and not self.folder.is_dir():
            raise ExportError(f"{self.folder} exists and is not a folder: the .vtp files go there")
        self._datasets: list[tuple[float, int, str, str]] = []  # time, part, name, file
        self._parts: dict[str, int] = {}
        self._plain = PlainNames()

    def _write(self, frame: int, time: float, entries: dict[str, Entry]) -> None:
        found = [piece for name, entry in entries.items() for piece in pieces(name, entry)]
        plain = [self._plain(piece.name) for piece in found]  # all checked first
        ensure_folder(self.folder)
        for piece, stem in zip(found, plain, strict=True):
            part = self._parts.setdefault(piece.name, len(self._parts))
            file = self.folder / f"{stem}_{frame:06d}.vtp"
            write_vtp(file, piece)
            self._datasets.append((time, part, piece.name, f"{self.folder.name}/{file.name}"))

    def _finish(self) -> None:
        if not self._datasets:
            return
        root = ET.Element("VTKFile", type="Collection", version="0.1", byte_order="LittleEndian")
        collection = ET.SubElement(root, "Collection")
        for time, part, name, file in self._datasets:
            ET.SubElement(
                collection, "DataSet", timestep=repr(time), group="", part=str(part),
                name=name, file=file,
            )  # fmt: skip
        ET.indent(root)
        with replacing(self.path) as tmp:
            ET.ElementTree(root).write(tmp, encoding="utf-8", xml_declaration=True)


def poly_data(piece: Piece):
    """A ``vtkPolyData`` of ``piece``: points, cells by its kind, every attribute."""
    from vtkmodules.util.numpy_support import numpy_to_vtk
    from vtkmodules.vtkCommonCore import VTK_ID_TYPE, vtkPoints
    from vtkmodules.vtkCommonDataModel import vtkCellArray, vtkPolyData

    def id_array(values: np.ndarray):
        return numpy_to_vtk(np.ascontiguousarray(values, dtype=np.int64), deep=True,
                            array_type=VTK_ID_TYPE)  # fmt: skip

    def cells(offsets: np.ndarray, connectivity: np.ndarray):
        array = vtkCellArray()
        array.SetData(id_array(offsets), id_array(connectivity))
        return array

    data = vtkPolyData()
    points = vtkPoints()
    points.SetData(numpy_to_vtk(np.ascontiguousarray(piece.points), deep=True))
    data.SetPoints(points)
    n = len(piece.points)
    if piece.kind in ("mesh", "surface"):
        faces = np.asarray(piece.faces)
        data.SetPolys(cells(np.arange(0, 3 * len(faces) + 1, 3), faces.reshape(-1)))
    elif piece.kind == "curves":
        offsets = np.concatenate([[0], np.cumsum(piece.curves)])
        data.SetLines(cells(offsets, np.arange(n)))
    else:
        data.SetVerts(cells(np.arange(n + 1), np.arange(n)))
    point_data = data.GetPointData()
    for name, values in piece.attributes.items():
        if values.dtype.kind == "b":
            values = values.astype(np.uint8)
        array = numpy_to_vtk(np.ascontiguousarray(values), deep=True)
        array.SetName(name)
        point_data.AddArray(array)
    return data


def write_vtp(path: Path, piece: Piece) -> None:
    """Write ``piece`` as a ``.vtp`` file (atomically) with ``vtkXMLPolyDataWriter``."""
    from vtkmodules.vtkIOXML import vtkXMLPolyDataWriter

    writer = vtkXMLPolyDataWriter()
    writer.SetInputData(poly_data(piece))
    writer.SetDataModeToAppended()
    writer.EncodeAppendedDataOff()
    writer.SetCompressorTypeToLZ4()
    writer.SetHeaderTypeToUInt64()
    with replacing(path) as tmp:
        writer.SetFileName(os.fspath(tmp))
        if writer.Write() != 1:
            raise OSError(f"VTK could not write {path}")
