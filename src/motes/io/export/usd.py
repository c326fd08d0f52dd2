"""OpenUSD (``.usd``, ``.usda``, ``.usdc``) through ``usd-core`` (Pixar's ``pxr``).

One stage for the whole run, every value time-sampled at the frame number, with
``timeCodesPerSecond`` = ``framesPerSecond`` = the scene's fps, ``startTimeCode`` and
``endTimeCode`` the first and last frame written, up axis Y, 1 metre per unit, and the
scene, seed, overrides and motes version in the root layer's ``customLayerData``
(under ``motes``). Under ``/motes`` (the default prim), per entry ``NAME``:

- particles: ``UsdGeom.Points`` ``/motes/NAME`` (``points``, ``velocities``, ``widths``
  = 2 × radius, ``ids``, ``extent``), colour as the ``displayColor`` and
  ``displayOpacity`` primvars, every other attribute a ``primvars:NAME`` of vertex
  interpolation (the names of :mod:`motes.io.export.attributes`);
- a cloth: ``UsdGeom.Mesh`` (its faces, constant; the same point attributes);
- hair: ``UsdGeom.BasisCurves``, linear, one curve per strand (``curveVertexCounts``);
- a liquid's surface: ``UsdGeom.Mesh`` ``/motes/NAME_surface``, its topology sampled
  per frame (it changes);
- a rigid world's bodies: ``Xform`` prims ``/motes/NAME_bodies/body_0000``, ... each
  with a time-sampled ``xformOp:transform`` (its rotation and centre of mass).

``.usdc`` and ``.usd`` (binary crate) are saved after every frame, so memory stays flat
and only the new samples are written each time; ``.usda`` (text, for reading) is saved
once at the end. The file is built under a temporary name and moved into place by
:meth:`~motes.io.export.base.ExportWriter.close`. Arrays go to USD through the buffer
protocol (``Vt.*Array.FromNumpy``, or ``FromBuffer``), never a Python loop over particles.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from .._atomic import discard, temporary_sibling
from ..entry import Entry
from .attributes import USD_OPACITY, usd_name
from .base import ExportWriter, Piece, PlainNames, pieces

_IDENTIFIER = re.compile(r"[^A-Za-z0-9_]")


def _vt(array_type, values: np.ndarray):
    """``values`` as a ``Vt`` array of ``array_type``: ``FromNumpy`` where usd-core has
    it (about 15 % faster than ``FromBuffer``, which older releases only have)."""
    convert = getattr(array_type, "FromNumpy", None) or array_type.FromBuffer
    return convert(values)


def prim_name(name: str) -> str:
    """``name`` as a USD prim name (an identifier)."""
    text = _IDENTIFIER.sub("_", name)
    return text if text and not text[0].isdigit() else f"_{text}"


class UsdWriter(ExportWriter):
    """Every frame into one time-sampled USD stage (see the module docstring)."""

    suffixes = (".usd", ".usda", ".usdc")
    package = ("pxr.Usd", "usd-core", "usd")

    def __init__(self, path, **options):
        super().__init__(path, **options)
        from pxr import Sdf, Usd, UsdGeom, Vt

        self._Sdf, self._Usd, self._UsdGeom, self._Vt = Sdf, Usd, UsdGeom, Vt
        self._text = self.path.suffix.lower() == ".usda"
        self._tmp: Path | None = None
        self._stage = None
        self._prims: dict[str, object] = {}
        self._plain = PlainNames(prim_name)

    # -- the stage ------------------------------------------------------------------------
    def _open(self, frame: int) -> None:
        Sdf, Usd, UsdGeom = self._Sdf, self._Usd, self._UsdGeom
        self._tmp = temporary_sibling(self.path)
        layer = Sdf.Layer.CreateNew(str(self._tmp))
        if layer is None:  # pragma: no cover - CreateNew raises on failure
            raise OSError(f"cannot create {self._tmp}")
        stage = Usd.Stage.Open(layer)
        UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.y)
        UsdGeom.SetStageMetersPerUnit(stage, 1.0)
        stage.SetTimeCodesPerSecond(self.fps)
        stage.SetFramesPerSecond(self.fps)
        stage.SetStartTimeCode(frame)
        stage.SetEndTimeCode(frame)
        root = UsdGeom.Xform.Define(stage, "/motes")
        stage.SetDefaultPrim(root.GetPrim())
        layer.customLayerData = {"motes": self.metadata()}
        layer.documentation = "particles written by motes"
        self._stage = stage

    def _write(self, frame: int, time: float, entries: dict[str, Entry]) -> None:
        found = [piece for name, entry in entries.items() for piece in pieces(name, entry)]
        for piece in found:  # every name checked before anything is written
            self._plain(piece.name)
        if self._stage is None:
            self._open(frame)
        for piece in found:
            self._write_piece(piece, frame)
        self._stage.SetEndTimeCode(frame)
        if not self._text:
            # Crate appends the new samples and drops them from memory.
            self._stage.GetRootLayer().Save()

    def _finish(self) -> None:
        if self._stage is None:
            return
        tmp, self._tmp = self._tmp, None
        try:
            self._stage.GetRootLayer().Save()
            self._stage = None
            os.replace(tmp, self.path)
        except BaseException:
            discard(tmp)
            raise

    # -- one piece ------------------------------------------------------------------------
    def _prim(self, piece: Piece):
        """The prim of ``piece``, defined on first use (with its constant topology)."""
        prim = self._prims.get(piece.name)
        if prim is not None:
            return prim
        UsdGeom, Vt = self._UsdGeom, self._Vt
        path = f"/motes/{self._plain(piece.name)}"
        if piece.kind == "points":
            prim = UsdGeom.Points.Define(self._stage, path)
            prim.SetWidthsInterpolation(UsdGeom.Tokens.vertex)
        elif piece.kind in ("mesh", "surface"):
            prim = UsdGeom.Mesh.Define(self._stage, path)
            prim.CreateSubdivisionSchemeAttr(UsdGeom.Tokens.none)
            prim.CreateDoubleSidedAttr(True)
            if piece.kind == "mesh":
                faces = np.ascontiguousarray(piece.faces, dtype=np.int32)
                prim.CreateFaceVertexCountsAttr(_vt(Vt.IntArray, np.full(len(faces), 3, np.int32)))
                prim.CreateFaceVertexIndicesAttr(_vt(Vt.IntArray, faces.reshape(-1)))
        elif piece.kind == "curves":
            prim = UsdGeom.BasisCurves.Define(self._stage, path)
            prim.CreateTypeAttr(UsdGeom.Tokens.linear)
            prim.CreateWrapAttr(UsdGeom.Tokens.nonperiodic)
            counts = np.ascontiguousarray(piece.curves, dtype=np.int32)
            prim.CreateCurveVertexCountsAttr(_vt(Vt.IntArray, counts))
            prim.SetWidthsInterpolation(UsdGeom.Tokens.vertex)
        else:  # bodies
            prim = UsdGeom.Xform.Define(self._stage, path)
        self._prims[piece.name] = prim
        return prim

    def _write_piece(self, piece: Piece, frame: int) -> None:
        prim = self._prim(piece)
        if piece.kind == "bodies":
            self._write_bodies(prim, piece, frame)
            return
        Vt = self._Vt
        points = piece.points
        prim.GetPointsAttr().Set(_vt(Vt.Vec3fArray, points), frame)
        if len(points):
            low = points.min(axis=0)
            high = points.max(axis=0)
            radius = piece.attributes.get("radius")
            if radius is not None and len(radius):
                reach = float(radius.max())
                low, high = low - reach, high + reach
            extent = np.array([low, high], dtype=np.float32)
        else:
            extent = np.zeros((2, 3), np.float32)
        prim.GetExtentAttr().Set(_vt(Vt.Vec3fArray, extent), frame)
        if piece.kind == "surface":
            faces = np.ascontiguousarray(piece.faces, dtype=np.int32)
            prim.GetFaceVertexCountsAttr().Set(
                _vt(Vt.IntArray, np.full(len(faces), 3, np.int32)), frame
            )
            prim.GetFaceVertexIndicesAttr().Set(_vt(Vt.IntArray, faces.reshape(-1)), frame)
            return
        for attribute, values in piece.attributes.items():
            self._write_attribute(prim, piece.kind, attribute, values, frame)

    def _write_attribute(self, prim, kind: str, attribute: str, values, frame: int) -> None:
        Sdf, UsdGeom, Vt = self._Sdf, self._UsdGeom, self._Vt
        if attribute == "velocities":
            prim.GetVelocitiesAttr().Set(_vt(Vt.Vec3fArray, values), frame)
            return
        if attribute == "radius":
            widths = _vt(Vt.FloatArray, np.multiply(values, 2.0, dtype=np.float32))
            if kind == "mesh":  # a mesh has no widths of its own: a primvar of the name
                UsdGeom.PrimvarsAPI(prim).CreatePrimvar(
                    "widths", Sdf.ValueTypeNames.FloatArray, UsdGeom.Tokens.vertex
                ).Set(widths, frame)
            else:
                prim.GetWidthsAttr().Set(widths, frame)
            return
        if attribute == "ids" and kind == "points":
            prim.GetIdsAttr().Set(_vt(Vt.Int64Array, np.ascontiguousarray(values)), frame)
            return
        primvars = UsdGeom.PrimvarsAPI(prim)
        if attribute == "color" and values.ndim == 2 and values.shape[1] in (3, 4):
            color = primvars.CreatePrimvar(
                "displayColor", Sdf.ValueTypeNames.Color3fArray, UsdGeom.Tokens.vertex
            )
            color.Set(_vt(Vt.Vec3fArray, values[:, :3]), frame)
            if values.shape[1] == 4:
                opacity = primvars.CreatePrimvar(
                    USD_OPACITY, Sdf.ValueTypeNames.FloatArray, UsdGeom.Tokens.vertex
                )
                opacity.Set(_vt(Vt.FloatArray, np.ascontiguousarray(values[:, 3])), frame)
            return
        value_type, array, element_size = self._typed(values)
        primvar = primvars.CreatePrimvar(
            usd_name(attribute), value_type, UsdGeom.Tokens.vertex, element_size
        )
        primvar.Set(array, frame)

    def _typed(self, values: np.ndarray):
        """``(Sdf value type, Vt array, element size)`` of an attribute's values."""
        Sdf, Vt = self._Sdf, self._Vt
        names = Sdf.ValueTypeNames
        components = 1 if values.ndim == 1 else values.shape[1]
        kind = values.dtype.kind
        if kind == "b":
            return names.BoolArray, _vt(Vt.BoolArray, values.reshape(-1)), components
        if kind in "iu":
            if values.dtype.itemsize == 8 or values.dtype == np.uint32:
                flat = np.ascontiguousarray(values, dtype=np.int64).reshape(-1)
                return names.Int64Array, _vt(Vt.Int64Array, flat), components
            flat = np.ascontiguousarray(values, dtype=np.int32).reshape(-1)
            return names.IntArray, _vt(Vt.IntArray, flat), components
        vectors = {2: (names.Float2Array, Vt.Vec2fArray), 3: (names.Float3Array, Vt.Vec3fArray),
                   4: (names.Float4Array, Vt.Vec4fArray)}  # fmt: skip
        if components in vectors:
            value_type, array_type = vectors[components]
            return value_type, _vt(array_type, values), 1
        flat = np.ascontiguousarray(values, dtype=np.float32).reshape(-1)
        return names.FloatArray, _vt(Vt.FloatArray, flat), components

    def _write_bodies(self, prim, piece: Piece, frame: int) -> None:
        from pxr import Gf

        UsdGeom = self._UsdGeom
        # USD transforms row vectors: a point p goes to p M, so M's upper 3x3 is the
        # transpose of the rotation (whose columns are the body's axes) and its last
        # row the centre.
        matrices = np.zeros((len(piece.points), 4, 4))
        matrices[:, :3, :3] = np.transpose(piece.rotations, (0, 2, 1))
        matrices[:, 3, :3] = piece.points
        matrices[:, 3, 3] = 1.0
        base = prim.GetPath()
        for index, matrix in enumerate(matrices):
            child = base.AppendChild(f"body_{index:04d}")
            body = self._prims.get(str(child))
            if body is None:
                body = UsdGeom.Xform.Define(self._stage, child)
                body.AddTransformOp()
                self._prims[str(child)] = body
            body.GetOrderedXformOps()[0].Set(Gf.Matrix4d(matrix.tolist()), frame)
