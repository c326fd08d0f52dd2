"""The ``.npz`` container of the particle cache (format version 2), spooled to disk.

A ZIP archive holds each array as one member, written whole, so frames cannot be
appended to it as they come. :class:`NpzSink` appends each frame's rows to one raw file
per array in a hidden folder beside the output (memory stays flat), and :meth:`finish`
streams those files into the archive, then removes the folder: the disk holds the cache
twice for a moment, the memory never.
"""

from __future__ import annotations

import shutil
import tempfile
import zipfile
from pathlib import Path

import numpy as np

from ._atomic import replacing

#: Bytes copied at a time from a spool file into the archive.
COPY_BYTES = 16 << 20


def put(archive: zipfile.ZipFile, key: str, array: np.ndarray) -> None:
    """Write ``array`` as the member ``key.npy``."""
    with archive.open(f"{key}.npy", "w", force_zip64=True) as member:
        np.lib.format.write_array(member, np.asanyarray(array), allow_pickle=False)


class NpzSink:
    """Spools frames to disk as they come and writes the ``.npz`` archive at the end.

    Parameters
    ----------
    path : Path
        The cache file.
    header : dict of str to value
        The file-wide keys (``format``, ``version``, ...), written first.
    compress : bool
        Deflate the archive's members.
    """

    def __init__(self, path: Path, header: dict, *, compress: bool):
        self.path = path
        self.header = header
        self.compress = compress
        self._layouts: dict | None = None
        self._spool: Path | None = None
        self._files: dict[str, object] = {}
        self._times: list[float] = []
        self._counts: dict[str, list[int]] = {}
        self._surface_counts: dict[str, list[tuple[int, int]]] = {}

    def start(self, layouts: dict) -> None:
        """Make the spool folder and one raw file per array of the layouts."""
        self._layouts = layouts
        self._spool = Path(
            tempfile.mkdtemp(prefix=f".{self.path.stem}.", suffix=".spool", dir=self.path.parent)
        )
        for name, layout in layouts.items():
            self._counts[name] = []
            keys = list(layout.attributes)
            if layout.bodies is not None:
                keys += ["body_centers", "body_rotations"]
            if layout.surface:
                keys += ["surface_vertices", "surface_faces"]
                self._surface_counts[name] = []
            for key in keys:
                spool = self._spool / f"{len(self._files)}.raw"
                self._files[f"{name}/{key}"] = spool.open("wb")  # closed in abort()

    def add(self, time: float, record: dict[str, dict[str, np.ndarray]]) -> None:
        """Append one frame's rows to the spool files."""
        for name, arrays in record.items():
            for key, values in arrays.items():
                self._files[f"{name}/{key}"].write(memoryview(values.reshape(-1).view(np.uint8)))
            self._counts[name].append(len(arrays["ids"]))
            if name in self._surface_counts:
                counts = (len(arrays["surface_vertices"]), len(arrays["surface_faces"]))
                self._surface_counts[name].append(counts)
        self._times.append(time)

    def finish(self) -> None:
        """Write the archive from the spool files (atomically), then remove the spool."""
        try:
            frames = len(self._times)
            for stream in self._files.values():
                stream.close()
            compression = zipfile.ZIP_DEFLATED if self.compress else zipfile.ZIP_STORED
            with replacing(self.path) as tmp, zipfile.ZipFile(tmp, "w", compression) as archive:
                for key, value in self.header.items():
                    put(archive, key, np.array(value))
                put(archive, "times", np.array(self._times, dtype=np.float64))
                put(archive, "names", np.array(list(self._layouts), dtype=str))
                for name, layout in self._layouts.items():
                    offsets = np.zeros(frames + 1, dtype=np.int64)
                    np.cumsum(self._counts[name][:frames], out=offsets[1:])
                    rows = int(offsets[-1])
                    put(archive, f"{name}/attributes", np.array(layout.attributes, dtype=str))
                    put(archive, f"{name}/units", np.array(layout.units, dtype=str))
                    put(archive, f"{name}/docs", np.array(layout.docs, dtype=str))
                    put(archive, f"{name}/offsets", offsets)
                    for attribute, dtype, components in zip(
                        layout.attributes, layout.dtypes, layout.components, strict=True
                    ):
                        self._copy(archive, name, attribute, dtype, (rows, *components))
                    if layout.faces is not None:
                        put(archive, f"{name}/faces", layout.faces)
                    if layout.curves is not None:
                        put(archive, f"{name}/curves", layout.curves)
                    if layout.bodies is not None:
                        for key, tail in (("body_centers", (3,)), ("body_rotations", (3, 3))):
                            shape = (frames, layout.bodies, *tail)
                            self._copy(archive, name, key, np.dtype(np.float64), shape)
                    if layout.surface:
                        ends = np.zeros((frames + 1, 2), dtype=np.int64)
                        np.cumsum(self._surface_counts[name][:frames], axis=0, out=ends[1:])
                        put(archive, f"{name}/surface_offsets", ends)
                        for key, column, dtype in (
                            ("surface_vertices", 0, np.float32),
                            ("surface_faces", 1, np.int64),
                        ):
                            shape = (int(ends[-1, column]), 3)
                            self._copy(archive, name, key, np.dtype(dtype), shape)
        finally:
            self.abort()

    def _copy(self, archive, name: str, key: str, dtype: np.dtype, shape: tuple) -> None:
        """Stream one spool file into the member ``name/key.npy`` of the given shape."""
        header = {
            "descr": np.lib.format.dtype_to_descr(dtype),
            "fortran_order": False,
            "shape": shape,
        }
        size = int(np.prod(shape)) * dtype.itemsize
        with (
            archive.open(f"{name}/{key}.npy", "w", force_zip64=True) as member,
            open(self._files[f"{name}/{key}"].name, "rb") as source,
        ):
            np.lib.format.write_array_header_1_0(member, header)
            while size > 0:
                block = source.read(min(size, COPY_BYTES))
                member.write(block)
                size -= len(block)

    def abort(self) -> None:
        """Close and remove the spool folder; the cache's path is left as it was."""
        for stream in self._files.values():
            stream.close()
        if self._spool is not None:
            shutil.rmtree(self._spool, ignore_errors=True)
            self._spool = None


def open_keys(path):
    """``(keys, read, close)`` of an ``.npz`` cache for :func:`~motes.io.cache.load_cache`
    (``read(key, lazy=False)`` reads the whole array: a ZIP member is read whole)."""
    data = np.load(path, allow_pickle=False)
    if not isinstance(data, np.lib.npyio.NpzFile):
        raise TypeError("a single NumPy array, not an .npz file")

    def read(key: str, lazy: bool = False):
        return data[key]

    return set(data.files), read, data.close
