"""What every exporter shares: the frame loop, names, the ``####`` rule, pieces.

A writer takes frames one at a time (:meth:`ExportWriter.write_frame`: the frame number,
its time and, per entry name, an :class:`~motes.io.entry.Entry`), so a run streams its
frames out and memory stays flat. Each frame is handed over whole or not at all: Ctrl-C
is held back while a frame is written (:class:`~motes.io._atomic.DeferredInterrupt`),
and every file appears under its name only when complete
(:func:`~motes.io._atomic.replacing`). :meth:`ExportWriter.close` finishes the files
with the frames written so far, also when a run is interrupted.
"""

from __future__ import annotations

import json
import os
import re
from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar

import numpy as np

from ..._validate import positive
from .._atomic import DeferredInterrupt
from ..entry import Entry, as_entry
from .attributes import quaternions


class ExportError(ValueError):
    """An export that cannot be written as asked: the message is one line for the user."""


#: The placeholder for the frame number in per-frame names (Houdini's and Blender's).
FRAME_MARK = "####"
_HASHES = re.compile(r"#+")
_UNSAFE = re.compile(r"[^A-Za-z0-9_.-]")


def safe_name(name: str) -> str:
    """``name`` as a plain file-name part: letters, digits, ``_``, ``-``, ``.``; no
    leading dot, so it never names a folder above (``..``) or a hidden file."""
    text = _UNSAFE.sub("_", name).lstrip(".")
    return text or "entry"


def split_pattern(path: Path) -> tuple[str, int, str]:
    """``(before, width, after)`` of the one run of ``#`` in the file name of ``path``.

    Raises :class:`ExportError` if there is none, or more than one.
    """
    runs = list(_HASHES.finditer(path.name))
    example = path.with_name(f"drops.{FRAME_MARK}{path.suffix}")
    if len(runs) != 1:
        how = "holds no" if not runs else "holds more than one run of"
        raise ExportError(
            f"{path.suffix} writes a file per frame: the name must hold {FRAME_MARK} "
            f"once, replaced by the frame number (e.g. {example}); {path.name} {how} '#'"
        )
    run = runs[0]
    return path.name[: run.start()], run.end() - run.start(), path.name[run.end() :]


def frame_path(path: Path, frame: int, piece: str | None = None) -> Path:
    """The file of ``frame`` for the per-frame pattern ``path``.

    The ``#`` run becomes the frame number, zero-padded to the run's length
    (``drops.####.ply`` -> ``drops.0012.ply``). With ``piece`` (a scene with several
    entries), the piece's name goes before the number: ``drops.cloth.0012.ply``.
    """
    before, width, after = split_pattern(path)
    middle = f"{safe_name(piece)}." if piece is not None else ""
    return path.with_name(f"{before}{middle}{frame:0{width}d}{after}")


@dataclass
class Piece:
    """One thing a per-entry format writes: points with attributes, and their topology.

    ``kind`` is ``"points"``, ``"mesh"`` (``faces`` over the points: a cloth),
    ``"curves"`` (``curves``: points per curve, in order: hair), ``"surface"`` (a mesh
    of its own vertices: a liquid's surface, no attributes) or ``"bodies"`` (one point
    per rigid body at its centre, with ``ids``, ``orient`` and the ``rotations``).
    ``attributes`` are record major, ``(n,)`` or ``(n, c)``, by motes name (the
    positions are ``points``).
    """

    name: str
    kind: str
    points: np.ndarray
    attributes: dict[str, np.ndarray] = field(default_factory=dict)
    faces: np.ndarray | None = None
    curves: np.ndarray | None = None
    rotations: np.ndarray | None = None


def pieces(name: str, entry: Entry) -> list[Piece]:
    """The pieces of one entry: its particles (points, mesh or curves), then its surface
    (``NAME_surface``) and its bodies (``NAME_bodies``) where it has them."""
    state = entry.state
    attributes = {a: state[a].T for a in state.names() if a != "positions"}
    kind = "mesh" if entry.faces is not None else "curves" if entry.curves is not None else None
    out = [Piece(name, kind or "points", state.positions.T, attributes, entry.faces, entry.curves)]
    if entry.surface is not None:
        vertices, faces = entry.surface
        out.append(Piece(f"{name}_surface", "surface", vertices, faces=faces))
    if entry.transforms is not None and len(entry.transforms[0]):
        centers, rotations = entry.transforms
        bodies = {"ids": np.arange(len(centers), dtype=np.int64), "orient": quaternions(rotations)}
        out.append(Piece(f"{name}_bodies", "bodies", centers, bodies, rotations=rotations))
    return out


class ExportWriter(ABC):
    """Base of the exporters: validation, the frame loop, metadata, closing.

    Parameters
    ----------
    path : str or os.PathLike
        The output (a file, or a per-frame pattern with ``####``).
    fps : float
        Frames per second of the frames to come [1/s]: frame ``f`` is at ``f / fps`` s.
    scene, seed, overrides : optional
        How the frames were made, recorded where the format has room for it.
    """

    #: Suffixes this writer is chosen for (lower case, with the dot).
    suffixes: ClassVar[tuple[str, ...]] = ()
    #: The optional package it needs: (module to import, its name on PyPI, the pip extra
    #: that installs it: ``pip install motes[EXTRA]``); None for none.
    package: ClassVar[tuple[str, str, str] | None] = None
    #: Whether the name is a per-frame pattern (``####``).
    per_frame: ClassVar[bool] = False
    #: Whether it writes liquid surfaces (asked of the scene only then: they cost time).
    surfaces: ClassVar[bool] = True

    def __init__(
        self,
        path,
        *,
        fps: float,
        scene: str | None = None,
        seed: int | None = None,
        overrides: Mapping[str, object] | None = None,
    ):
        path = Path(path)
        if path.suffix.lower() not in self.suffixes:
            raise ExportError(f"{type(self).__name__} writes {', '.join(self.suffixes)}: {path}")
        if self.per_frame:
            split_pattern(path)
        elif "#" in path.name:
            raise ExportError(
                f"{path.suffix} writes one file for every frame: {FRAME_MARK} is for the "
                f"per-frame formats (.ply, .geo); got {path}"
            )
        if not path.resolve().parent.is_dir():
            raise ExportError(f"export directory does not exist: {path.parent}")
        self.check_package()
        self.path = path
        self.fps = positive("fps", fps)
        self.scene = scene
        self.seed = seed
        self.overrides = dict(overrides or {})
        self.frames_written = 0
        self.closed = False
        self._last_frame: int | None = None

    @classmethod
    def check_package(cls) -> None:
        """Import the optional package this format needs, or raise :class:`ExportError`
        naming the extra that installs it."""
        if cls.package is None:
            return
        module, name, extra = cls.package
        import importlib

        try:
            importlib.import_module(module)
        except ImportError:
            suffixes = "/".join(cls.suffixes)
            raise ExportError(
                f"writing {suffixes} needs the {name} package: pip install 'motes[{extra}]'"
            ) from None

    def metadata(self) -> dict[str, str]:
        """How the frames were made, as text: motes version, scene, seed, fps, overrides."""
        from ..._version import __version__

        record = {"motes_version": __version__, "fps": repr(self.fps)}
        if self.scene is not None:
            record["scene"] = self.scene
        if self.seed is not None:
            record["seed"] = str(self.seed)
        if self.overrides:
            record["overrides"] = json.dumps(self.overrides, default=str, sort_keys=True)
        return record

    def write_frame(self, frame: int, time: float, entries: Mapping[str, object]) -> None:
        """Write frame number ``frame`` (increasing from call to call) at ``time`` [s].

        ``entries`` maps names to :class:`~motes.io.entry.Entry` items, or to anything
        :func:`~motes.io.entry.as_entry` takes (states, systems, bodies).
        """
        if self.closed:
            raise ValueError(f"write_frame on a closed writer ({self.path})")
        frame = int(frame)
        if self._last_frame is not None and frame <= self._last_frame:
            raise ValueError(f"frame {frame} after frame {self._last_frame}: frames must increase")
        if not isinstance(entries, Mapping) or not entries:
            raise TypeError("entries must be a non-empty mapping of name -> entry")
        for name in entries:
            if not isinstance(name, str) or not name or "/" in name:
                raise ValueError(f"entry names must be non-empty strings without '/', got {name!r}")
        items = {name: as_entry(item) for name, item in entries.items()}
        with DeferredInterrupt():
            self._write(frame, float(time), items)
            self._last_frame = frame
            self.frames_written += 1

    def close(self) -> None:
        """Finish the output with the frames written so far; calling again does nothing.

        With no frame written, nothing is written.
        """
        if self.closed:
            return
        self.closed = True
        with DeferredInterrupt():
            self._finish()

    @abstractmethod
    def _write(self, frame: int, time: float, entries: dict[str, Entry]) -> None:
        """Write one frame (Ctrl-C is held back meanwhile)."""

    def _finish(self) -> None:  # noqa: B027 - most formats have nothing left to do
        """Complete the output once no frame is to come."""

    def __enter__(self):
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"{type(self).__name__}({str(self.path)!r}, frames_written={self.frames_written})"


class PlainNames:
    """The plain forms of piece names a writer has used, to refuse two pieces that only
    differ in characters a file or prim name cannot hold (they would share a file)."""

    def __init__(self, plain=safe_name):
        self._plain = plain
        self._seen: dict[str, str] = {}

    def __call__(self, name: str) -> str:
        plain = self._plain(name)
        if self._seen.setdefault(plain, name) != name:
            raise ExportError(
                f"entries {self._seen[plain]!r} and {name!r} would both be written as "
                f"{plain!r}; rename one"
            )
        return plain


class PerPieceFiles(ExportWriter):
    """A writer of one file per frame and piece (PLY, ``.geo``), by the ``####`` rule.

    With one piece in the first frame the pattern is used as given; with several, each
    piece's name goes before the frame number (:func:`frame_path`).
    """

    per_frame = True

    def __init__(self, path, **options):
        super().__init__(path, **options)
        self._several: bool | None = None
        self._plain = PlainNames()

    def file_for(self, frame: int, piece: str) -> Path:
        """The file that piece ``piece`` of frame ``frame`` goes to."""
        return frame_path(self.path, frame, piece if self._several else None)

    def _write(self, frame: int, time: float, entries: dict[str, Entry]) -> None:
        found = [p for name, entry in entries.items() for p in pieces(name, entry)]
        if self._several is None:
            self._several = len(found) > 1
        for piece in found:  # every name checked before anything is written
            self._plain(piece.name)
        for piece in found:
            self._write_piece(self.file_for(frame, piece.name), piece, frame, time)

    @abstractmethod
    def _write_piece(self, path: Path, piece: Piece, frame: int, time: float) -> None:
        """Write one piece of one frame to ``path`` (atomically)."""


def ensure_folder(folder: Path) -> None:
    """Create ``folder`` (one level, in an existing parent) unless it exists."""
    try:
        os.mkdir(folder)
    except FileExistsError:
        if not folder.is_dir():
            raise ExportError(f"{folder} exists and is not a folder") from None
