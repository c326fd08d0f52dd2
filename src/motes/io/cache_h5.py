"""The HDF5 container of the particle cache (format version 3): streamed and compressed.

The keys are those of the ``.npz`` layout (``docs/cache-format.md``), as HDF5 datasets:
``flame/positions`` is the dataset ``positions`` in the group ``flame``. Per-particle
datasets are chunked (about 1 MiB a chunk) and grow by one frame's rows at each
:meth:`H5Sink.add`, so memory stays flat however long the run; they are compressed by
HDF5's own filters (byte shuffle, then deflate), which every HDF5 reader decodes without
a plugin (h5py, ParaView, MATLAB, Julia, ``h5dump``). ``significant_digits`` rounds the
mantissa of floating-point attributes to the bits that hold that many decimal digits
(Klöwer et al. 2021's "bit rounding", as netCDF's quantisation does): lossy, the values
stay ordinary floats that every reader reads, and the zeroed low bits compress away.

h5py is the Python binding of the HDF Group's library: a maintained, self-contained
wheel, read lazily (a frame's rows are read when asked for, not the whole file).
"""

from __future__ import annotations

import math
import os
import zlib
from collections import deque
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from ._atomic import discard, temporary_sibling

#: The first bytes of every HDF5 file (the superblock's signature at offset 0).
SIGNATURE = b"\x89HDF\r\n\x1a\n"
#: Rows per chunk are chosen so that a chunk holds about this many bytes.
CHUNK_BYTES = 1 << 20
#: HDF5's chunk cache per file opened for reading [bytes]: a few chunks per dataset.
CACHE_BYTES = 64 << 20
#: Threads that shuffle and deflate chunks (zlib lets go of the GIL while it works).
ENCODERS = min(4, os.cpu_count() or 1)
#: Chunks left encoding when a frame has been handed over (at most about this many MiB
#: of memory beyond the simulation's).
IN_FLIGHT = 4 * ENCODERS
#: Deflate level: 1 compresses particle data within 2 % of level 4 at about 1.2x the speed.
DEFLATE_LEVEL = 1


def _h5py():
    import h5py

    return h5py


def _filters(compress: bool) -> dict:
    """Keyword arguments of ``create_dataset`` for one per-particle attribute."""
    if not compress:
        return {}
    return {"compression": "gzip", "compression_opts": DEFLATE_LEVEL, "shuffle": True}


def round_significant(values: np.ndarray, digits: int) -> np.ndarray:
    """``values`` (float32 or float64) with each mantissa rounded, to nearest and ties to
    even, to the ``ceil(digits * log2(10))`` bits that hold ``digits`` significant decimal
    digits: relative error at most ``2**-(bits + 1) <= 0.5 * 10**-digits``.

    NaN and infinities are kept; a value that rounds past the largest finite float
    becomes infinite, as in any rounding of floats.
    """
    info = np.finfo(values.dtype)
    drop = info.nmant - math.ceil(digits * math.log2(10))
    if drop <= 0:
        return values
    unsigned = np.dtype(f"u{values.dtype.itemsize}")
    bits = values.view(unsigned)
    one = unsigned.type(1)
    shift = unsigned.type(drop)
    # add half a unit of the last kept bit, less one unless the kept bit is odd (ties to
    # even), then clear the dropped bits; a carry into the exponent is the right rounding
    half = (one << (shift - one)) - one + ((bits >> shift) & one)
    rounded = ((bits + half) & ~((one << shift) - one)).view(values.dtype)
    return np.where(np.isfinite(values), rounded, values)


def _text(values) -> np.ndarray:
    """A string or a sequence of strings as an HDF5 variable-length UTF-8 string array."""
    h5py = _h5py()
    return np.array(values, dtype=h5py.string_dtype())


class H5Sink:
    """Writes frames into an HDF5 cache as they come: a temporary sibling file, moved
    into place by :meth:`finish`.

    Parameters
    ----------
    path : Path
        The cache file.
    header : dict of str to value
        The file-wide keys (``format``, ``version``, ``motes_version``, ``scene``,
        ``seed``, ``fps``, ``overrides``), written first.
    compress : bool
        Shuffle and deflate the per-particle datasets.
    significant_digits : int or None
        Significant decimal digits kept of floating-point attributes
        (:func:`round_significant`); None keeps every bit.
    """

    def __init__(self, path: Path, header: dict, *, compress: bool, significant_digits: int | None):
        self.path = path
        self.header = header
        self.compress = compress
        self.significant_digits = significant_digits
        self._file = None
        self._tmp: Path | None = None
        self._frames = 0
        self._rows: dict[str, int] = {}
        self._surface_rows: dict[str, tuple[int, int]] = {}
        # The growing datasets, held open while frames come, and the per-particle ones'
        # chunk streams.
        self._datasets: dict[str, object] = {}
        self._chunks: dict[str, _Chunks] = {}
        self._pool: ThreadPoolExecutor | None = None
        self._inflight: deque = deque()

    def start(self, layouts: dict) -> None:
        """Create the file and its datasets for the layouts the first frame fixed."""
        h5py = _h5py()
        self._tmp = temporary_sibling(self.path)
        try:
            self._file = h5py.File(self._tmp, "w")
            root = self._file
            for key, value in self.header.items():
                root[key] = _text(value) if isinstance(value, str) else value
            root.create_dataset("times", (0,), np.float64, maxshape=(None,), chunks=(4096,))
            root["names"] = _text(list(layouts))
            for name, layout in layouts.items():
                group = root.create_group(name)
                group["attributes"] = _text(layout.attributes)
                group["units"] = _text(layout.units)
                group["docs"] = _text(layout.docs)
                group.create_dataset(
                    "offsets", data=np.zeros(1, np.int64), maxshape=(None,), chunks=(4096,)
                )
                for attribute, dtype, components in zip(
                    layout.attributes, layout.dtypes, layout.components, strict=True
                ):
                    rows = max(1024, CHUNK_BYTES // (dtype.itemsize * int(np.prod(components))))
                    dataset = group.create_dataset(
                        attribute,
                        (0, *components),
                        dtype,
                        maxshape=(None, *components),
                        chunks=(rows, *components),
                        **_filters(self.compress),
                    )
                    self._chunks[f"{name}/{attribute}"] = _Chunks(dataset, self.compress)
                if layout.faces is not None:
                    group["faces"] = np.asarray(layout.faces, np.int64)
                if layout.curves is not None:
                    group["curves"] = np.asarray(layout.curves, np.int64)
                if layout.surface:
                    group.create_dataset(
                        "surface_offsets", data=np.zeros((1, 2), np.int64),
                        maxshape=(None, 2), chunks=(4096, 2),
                    )  # fmt: skip
                    for key, dtype in (
                        ("surface_vertices", np.float32),
                        ("surface_faces", np.int64),
                    ):
                        rows = CHUNK_BYTES // (3 * np.dtype(dtype).itemsize)
                        dataset = group.create_dataset(
                            key, (0, 3), dtype, maxshape=(None, 3), chunks=(rows, 3),
                            **_filters(self.compress),
                        )  # fmt: skip
                        self._chunks[f"{name}/{key}"] = _Chunks(dataset, self.compress)
                    self._surface_rows[name] = (0, 0)
                if layout.bodies is not None:
                    for key, tail in (("body_centers", (3,)), ("body_rotations", (3, 3))):
                        shape = (layout.bodies, *tail)
                        group.create_dataset(
                            key, (0, *shape), np.float64, maxshape=(None, *shape),
                            chunks=(max(1, 4096 // max(1, layout.bodies)), *shape),
                        )  # fmt: skip
            self._datasets = {}
            root.visititems(self._keep_growing)
            self._rows = dict.fromkeys(layouts, 0)
            self._pool = ThreadPoolExecutor(ENCODERS, thread_name_prefix="motes-cache")
        except BaseException:
            self.abort()
            raise

    def _keep_growing(self, key: str, item) -> None:
        """Hold ``item`` open if it is a dataset that grows with the frames."""
        if getattr(item, "maxshape", None) and item.maxshape[0] is None:
            self._datasets[key] = item

    def add(self, time: float, record: dict[str, dict[str, np.ndarray]]) -> None:
        """Append one frame: every entry's rows, then its offsets, then the time (a frame
        is only counted once its time is written; :meth:`finish` trims rows beyond)."""
        datasets = self._datasets
        for name, arrays in record.items():
            offsets = datasets[f"{name}/offsets"]
            start = self._rows[name]
            stop = start + len(arrays["ids"])
            for key, values in arrays.items():
                dataset = datasets[f"{name}/{key}"]
                if key.startswith("body_"):
                    _reserve(dataset, self._frames + 1)
                    dataset[self._frames] = values
                elif key.startswith("surface_"):
                    continue  # below
                elif stop > start:
                    _reserve(dataset, stop)
                    if self.significant_digits is not None and values.dtype.kind == "f":
                        values = round_significant(values, self.significant_digits)
                    self._chunks[f"{name}/{key}"].push(values, self._pool, self._inflight)
            _reserve(offsets, self._frames + 2)
            offsets[self._frames + 1] = stop
            self._rows[name] = stop
            if name in self._surface_rows:
                self._add_surface(name, arrays["surface_vertices"], arrays["surface_faces"])
        times = datasets["times"]
        _reserve(times, self._frames + 1)
        times[self._frames] = time
        self._frames += 1
        # Encoding goes on while the next frame is simulated; only a few chunks wait.
        self._write_encoded(keep=IN_FLIGHT)

    def _add_surface(self, name: str, vertices: np.ndarray, faces: np.ndarray) -> None:
        """Append one frame's surface mesh and its end offsets."""
        ends = self._datasets[f"{name}/surface_offsets"]
        ends_now = list(self._surface_rows[name])
        for column, (key, rows) in enumerate(
            (("surface_vertices", vertices), ("surface_faces", faces))
        ):
            if len(rows):
                _reserve(self._datasets[f"{name}/{key}"], ends_now[column] + len(rows))
                self._chunks[f"{name}/{key}"].push(rows, self._pool, self._inflight)
                ends_now[column] += len(rows)
        _reserve(ends, self._frames + 2)
        ends[self._frames + 1] = ends_now
        self._surface_rows[name] = tuple(ends_now)

    def _write_encoded(self, keep: int) -> None:
        """Write encoded chunks, oldest first, until at most ``keep`` are in flight."""
        while len(self._inflight) > keep:
            chunks, index, encoded = self._inflight.popleft()
            chunks.write(index, encoded.result())

    def finish(self) -> None:
        """Cut the datasets to the frames whole in them, close the file and move it into
        place."""
        try:
            for chunks in self._chunks.values():
                chunks.flush(self._pool, self._inflight)
            self._write_encoded(keep=0)
        except BaseException:
            self.abort()
            raise
        root, self._file = self._file, None
        self._datasets, self._chunks = {}, {}
        self._pool.shutdown()
        try:
            frames = self._frames
            root["times"].resize(frames, axis=0)
            for name in (str(n) for n in root["names"].asstr()[:]):
                group = root[name]
                offsets = group["offsets"]
                offsets.resize(frames + 1, axis=0)
                rows = int(offsets[-1])
                surface = None
                if "surface_offsets" in group:
                    group["surface_offsets"].resize(frames + 1, axis=0)
                    surface = group["surface_offsets"][-1]
                for key in group:
                    dataset = group[key]
                    if key.startswith("body_"):
                        dataset.resize(frames, axis=0)
                    elif key in ("surface_vertices", "surface_faces"):
                        dataset.resize(int(surface[1 if key == "surface_faces" else 0]), axis=0)
                    elif dataset.maxshape[0] is None and key not in ("offsets", "surface_offsets"):
                        dataset.resize(rows, axis=0)
            root.close()
            os.replace(self._tmp, self.path)
        except BaseException:
            root.close()
            discard(self._tmp)
            raise

    def abort(self) -> None:
        """Close and remove the temporary file; the cache's path is left as it was."""
        self._datasets, self._chunks = {}, {}
        if self._pool is not None:
            self._pool.shutdown(cancel_futures=True)
            self._inflight.clear()
        if self._file is not None:
            self._file.close()
            self._file = None
        if self._tmp is not None:
            discard(self._tmp)


class _Chunks:
    """The rows of one per-particle dataset, cut into whole chunks as they come, each
    encoded on a worker thread as HDF5's filters would (byte shuffle, then deflate) and
    written with ``write_direct_chunk``: compression runs on every core, and beside the
    simulation, rather than in HDF5's one thread."""

    def __init__(self, dataset, compress: bool):
        self.dataset = dataset
        self.compress = compress
        self.rows = dataset.chunks[0]
        self.pending: list[np.ndarray] = []
        self.pending_rows = 0
        self.next_chunk = 0

    def push(self, values: np.ndarray, pool, inflight: deque) -> None:
        """Queue ``values`` (whole rows); encode every chunk they complete."""
        self.pending.append(values)
        self.pending_rows += len(values)
        while self.pending_rows >= self.rows:
            rows = np.concatenate(self.pending) if len(self.pending) > 1 else self.pending[0]
            block, rest = rows[: self.rows], rows[self.rows :]
            self.pending, self.pending_rows = ([rest] if len(rest) else []), len(rest)
            self._submit(block, pool, inflight)

    def flush(self, pool, inflight: deque) -> None:
        """Encode the last, partly filled chunk (zero-padded; the dataset's extent ends
        within it)."""
        if self.pending_rows:
            rows = np.concatenate(self.pending)
            block = np.zeros((self.rows, *rows.shape[1:]), rows.dtype)
            block[: len(rows)] = rows
            self.pending, self.pending_rows = [], 0
            self._submit(block, pool, inflight)

    def _submit(self, block: np.ndarray, pool, inflight: deque) -> None:
        inflight.append((self, self.next_chunk, pool.submit(_encode, block, self.compress)))
        self.next_chunk += 1

    def write(self, index: int, encoded: bytes) -> None:
        """Store chunk ``index``, encoded, in the file."""
        start = (index * self.rows,) + (0,) * (self.dataset.ndim - 1)
        self.dataset.id.write_direct_chunk(start, encoded)


def _encode(block: np.ndarray, compress: bool) -> bytes:
    """One chunk's bytes as HDF5 stores them with the shuffle and deflate filters: the
    k-th bytes of every element together for each k, then zlib's deflate stream."""
    raw = np.ascontiguousarray(block).reshape(-1).view(np.uint8)
    if not compress:
        return raw.tobytes()
    shuffled = raw.reshape(-1, block.dtype.itemsize).T.tobytes()
    return zlib.compress(shuffled, DEFLATE_LEVEL)


def _reserve(dataset, rows: int) -> None:
    """Grow ``dataset`` to hold at least ``rows`` rows, by half its length or more at a
    time: growing a chunked dataset by a frame at a time makes HDF5 write out and
    compress its partly filled last chunk again at every frame."""
    length = dataset.shape[0]
    if rows > length:
        dataset.resize(max(rows, length + length // 2), axis=0)


def is_hdf5(path) -> bool:
    """Whether the file at ``path`` starts with HDF5's signature."""
    with open(path, "rb") as stream:
        return stream.read(len(SIGNATURE)) == SIGNATURE


def open_keys(path) -> tuple[set[str], Callable, Callable[[], None]]:
    """``(keys, read, close)`` of an HDF5 cache for :func:`~motes.io.cache.load_cache`.

    ``read(key, lazy=False)`` gives a dataset's values as NumPy (strings as ``str``), or
    with ``lazy`` the dataset itself, whose slices are read from the file when taken.
    """
    h5py = _h5py()
    handle = h5py.File(path, "r", rdcc_nbytes=CACHE_BYTES, rdcc_nslots=10007)
    keys: set[str] = set()
    handle.visit(lambda key: keys.add(key) if isinstance(handle[key], h5py.Dataset) else None)

    def read(key: str, lazy: bool = False):
        dataset = handle[key]
        if dataset.dtype.kind == "O" or h5py.check_string_dtype(dataset.dtype) is not None:
            return np.array(dataset.asstr()[()], dtype=str)
        if lazy:
            return dataset
        return dataset[()]

    return keys, read, handle.close
