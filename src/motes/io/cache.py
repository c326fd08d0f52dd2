"""Particle cache: per-frame particle arrays of named systems, in one ``.npz`` file.

This is what ``motes ... --export CACHE.npz`` writes, for other tools (renderers, DCC
importers, analysis notebooks) to read back, with :func:`load_cache` or with NumPy
alone.

File layout (format version 1)
------------------------------
A ZIP archive of ``.npy`` arrays, readable with ``numpy.load(path)`` (no pickles:
``allow_pickle=False`` works). ``F`` is the number of frames; for each system ``S``,
``N_S`` is its total number of particle records over all frames.

==================  ==============  =======  ==============================================
key                 shape           dtype    meaning
==================  ==============  =======  ==============================================
``format``          ()              str      always ``"motes-cache"``
``version``         ()              int64    format version, ``1``
``times``           (F,)            float64  simulation time of each frame [s]
``systems``         (S,)            str      system names, in the order first given
``S/attributes``    (A,)            str      attributes recorded for ``S``, a subset of
                                             ``position, velocity, color, size, id``
``S/offsets``       (F+1,)          int64    frame ``f``'s particles of ``S`` are rows
                                             ``offsets[f]:offsets[f+1]`` of every ``S/*``
                                             array; ``offsets[0] = 0``,
                                             ``offsets[F] = N_S``
``S/position``      (N_S, 3)        float32  position [m]
``S/velocity``      (N_S, 3)        float32  velocity [m/s]
``S/color``         (N_S, 4)        float32  linear RGBA, in [0, 1]
``S/size``          (N_S,)          float32  radius [m]
``S/id``            (N_S,)          int64    particle id, unique within ``S``, never
                                             reused: follows a particle across frames
==================  ==============  =======  ==============================================

``S`` stands for the system's name as given (``"fire/position"`` for a system named
``fire``); names must be non-empty and contain no ``/``. An attribute is recorded when
the system's store has it at the first frame (``position``, ``velocity`` and ``id``
always exist); the list is fixed from then on. Within a frame, particles are in store
order. A reader should ignore keys it does not know; a file whose ``version`` is
greater than the one it knows needs a newer reader.

Writing is atomic: the file is built under a temporary name and moved into place when
complete, also when :class:`CacheWriter` is closed by an exception or Ctrl-C, with the
frames added so far. A writer closed with no frame writes nothing and leaves an existing
file as it was.

Examples
--------
>>> with CacheWriter("run.npz") as cache:  # doctest: +SKIP
...     for _ in range(100):
...         fire.step(1 / 60)
...         cache.add_frame(fire.time, {"fire": fire, "smoke": smoke})
>>> cache = load_cache("run.npz")  # doctest: +SKIP
>>> cache.frame(10, "fire")["position"].shape  # doctest: +SKIP
(1234, 3)
"""

from __future__ import annotations

import os
import zipfile
import zlib
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .. import _validate as check
from ..particles import ParticleStore
from ._atomic import replacing

#: Value of the ``format`` entry.
FORMAT = "motes-cache"
#: Format version this module writes and the newest it reads.
VERSION = 1
#: Attributes a cache records, with their file dtype and components (1: scalar).
ATTRIBUTES: dict[str, tuple[np.dtype, int]] = {
    "position": (np.dtype("<f4"), 3),
    "velocity": (np.dtype("<f4"), 3),
    "color": (np.dtype("<f4"), 4),
    "size": (np.dtype("<f4"), 1),
    "id": (np.dtype("<i8"), 1),
}


def _store_of(name: str, system) -> ParticleStore:
    store = getattr(system, "store", system)
    if not isinstance(store, ParticleStore):
        raise TypeError(
            f"systems[{name!r}] must be a ParticleSystem or ParticleStore, "
            f"got {type(system).__name__}"
        )
    return store


def _check_name(name) -> str:
    if not isinstance(name, str) or not name or "/" in name:
        raise ValueError(f"system names must be non-empty strings without '/', got {name!r}")
    return name


class CacheWriter:
    """Collects frames of particle systems and writes them as one cache file on close.

    Parameters
    ----------
    path : str or os.PathLike
        Output file, ending in ``.npz``.
    compress : bool
        Deflate the arrays (smaller, slower to write and read). Off by default, like
        :func:`numpy.savez`.

    Notes
    -----
    Each :meth:`add_frame` copies the live particles' recorded attributes (about 48
    bytes per particle with every attribute) and keeps them in memory until
    :meth:`close`, which streams them into the file without concatenating them first.
    A long run of a large system needs memory for the whole cache.
    """

    def __init__(self, path, *, compress: bool = False):
        path = Path(path)
        if path.suffix.lower() != ".npz":
            raise ValueError(f"path must end in .npz, got {str(path)!r}")
        if not path.parent.is_dir():
            raise FileNotFoundError(f"directory {str(path.parent)!r} does not exist")
        self.path = path
        self.compress = bool(compress)
        self._names: tuple[str, ...] | None = None
        self._attributes: dict[str, tuple[str, ...]] = {}
        # One record per frame, appended in one step (an interruption cannot leave a
        # frame half-recorded): (time, {system: {attribute: array}}).
        self._frames: list[tuple[float, dict[str, dict[str, np.ndarray]]]] = []
        self._closed = False

    @property
    def frame_count(self) -> int:
        """Number of frames added so far."""
        return len(self._frames)

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` has been called."""
        return self._closed

    def add_frame(self, time: float, systems: Mapping[str, object]) -> None:
        """Record the live particles of each system at simulation time ``time``.

        Parameters
        ----------
        time : float
            Simulation time of the frame [s].
        systems : Mapping[str, ParticleSystem or ParticleStore]
            The systems by name. The first frame fixes the names and, per system, the
            recorded attributes; every later frame must give the same names.
        """
        if self._closed:
            raise ValueError(f"add_frame on a closed cache writer ({self.path})")
        time = check.real("time", time)
        if not isinstance(systems, Mapping) or not systems:
            raise TypeError("systems must be a non-empty mapping of name -> ParticleSystem")
        stores = {_check_name(name): _store_of(name, system) for name, system in systems.items()}
        if self._names is None:
            names = tuple(stores)
            attributes = {
                name: tuple(a for a in ATTRIBUTES if store.has(a)) for name, store in stores.items()
            }
        else:
            names, attributes = self._names, self._attributes
            if set(stores) != set(names):
                raise ValueError(
                    f"frame {len(self._frames)} gives systems {sorted(stores)}, but the first "
                    f"frame gave {sorted(names)}; every frame must give the same systems"
                )
        record = {
            name: {
                a: np.array(stores[name][a], dtype=ATTRIBUTES[a][0], order="C")
                for a in attributes[name]
            }
            for name in names
        }
        if self._names is None:
            self._names, self._attributes = names, attributes
        self._frames.append((time, record))

    def close(self) -> None:
        """Write the file with the frames added so far; calling it again does nothing.

        With no frame added, nothing is written (an existing file is kept).
        """
        if self._closed:
            return
        self._closed = True
        frames, self._frames = self._frames, []
        if not frames:
            return
        compression = zipfile.ZIP_DEFLATED if self.compress else zipfile.ZIP_STORED
        with replacing(self.path) as tmp, zipfile.ZipFile(tmp, "w", compression) as archive:
            _put(archive, "format", np.array(FORMAT))
            _put(archive, "version", np.array(VERSION, dtype=np.int64))
            _put(archive, "times", np.array([t for t, _ in frames], dtype=np.float64))
            _put(archive, "systems", np.array(self._names, dtype=str))
            for name in self._names:
                chunks = [record[name] for _, record in frames]
                counts = [len(chunk["position"]) for chunk in chunks]
                offsets = np.zeros(len(frames) + 1, dtype=np.int64)
                np.cumsum(counts, out=offsets[1:])
                _put(archive, f"{name}/attributes", np.array(self._attributes[name], dtype=str))
                _put(archive, f"{name}/offsets", offsets)
                for attribute in self._attributes[name]:
                    dtype, components = ATTRIBUTES[attribute]
                    shape = (int(offsets[-1]),) + ((components,) if components > 1 else ())
                    _put_chunks(
                        archive, f"{name}/{attribute}", dtype, shape, (c[attribute] for c in chunks)
                    )

    def __enter__(self) -> CacheWriter:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"CacheWriter({str(self.path)!r}, frame_count={self.frame_count})"


def _put(archive: zipfile.ZipFile, key: str, array: np.ndarray) -> None:
    with archive.open(f"{key}.npy", "w", force_zip64=True) as member:
        np.lib.format.write_array(member, np.asanyarray(array), allow_pickle=False)


def _put_chunks(archive: zipfile.ZipFile, key: str, dtype: np.dtype, shape: tuple, chunks) -> None:
    """Write the concatenation of ``chunks`` as one ``.npy`` member, chunk by chunk."""
    header = {"descr": np.lib.format.dtype_to_descr(dtype), "fortran_order": False, "shape": shape}
    with archive.open(f"{key}.npy", "w", force_zip64=True) as member:
        np.lib.format.write_array_header_1_0(member, header)
        for chunk in chunks:
            if chunk.size:
                # flat bytes of the C-ordered chunk, without a copy
                member.write(memoryview(chunk.reshape(-1).view(np.uint8)))


class Cache:
    """A particle cache read back by :func:`load_cache`. Arrays are read-only.

    Attributes
    ----------
    times : numpy.ndarray
        Simulation time of each frame [s], shape ``(frame_count,)``.
    systems : tuple of str
        System names.
    """

    def __init__(
        self,
        times: np.ndarray,
        offsets: dict[str, np.ndarray],
        arrays: dict[str, dict[str, np.ndarray]],
    ):
        self.times = times
        self.systems = tuple(offsets)
        self._offsets = offsets
        self._arrays = arrays

    @property
    def frame_count(self) -> int:
        """Number of frames."""
        return len(self.times)

    def __len__(self) -> int:
        return self.frame_count

    def _system(self, system: str | None) -> str:
        if system is None:
            if len(self.systems) != 1:
                raise ValueError(
                    f"the cache holds systems {list(self.systems)}; name the one you want"
                )
            return self.systems[0]
        if system not in self._offsets:
            raise KeyError(f"no system {system!r} in the cache; it holds {list(self.systems)}")
        return system

    def _index(self, index: int) -> int:
        index = check.integer("index", index)
        if not -self.frame_count <= index < self.frame_count:
            raise IndexError(f"frame {index} out of range for a cache of {self.frame_count}")
        return index % self.frame_count

    def attributes(self, system: str | None = None) -> tuple[str, ...]:
        """Attributes recorded for ``system`` (may be omitted if there is only one)."""
        return tuple(self._arrays[self._system(system)])

    def offsets(self, system: str | None = None) -> np.ndarray:
        """Row offsets of ``system``, shape ``(frame_count + 1,)`` (see the file layout)."""
        return self._offsets[self._system(system)]

    def counts(self, system: str | None = None) -> np.ndarray:
        """Number of particles of ``system`` in each frame, shape ``(frame_count,)``."""
        return np.diff(self.offsets(system))

    def array(self, attribute: str, system: str | None = None) -> np.ndarray:
        """Every frame's values of ``attribute``, concatenated (rows per :meth:`offsets`)."""
        arrays = self._arrays[self._system(system)]
        if attribute not in arrays:
            raise KeyError(
                f"attribute {attribute!r} was not recorded; the cache has {list(arrays)}"
            )
        return arrays[attribute]

    def frame(self, index: int, system: str | None = None) -> dict[str, np.ndarray]:
        """One frame's particles of ``system``.

        Parameters
        ----------
        index : int
            Frame number; negative counts from the end.
        system : str, optional
            System name; may be omitted when the cache holds a single system.

        Returns
        -------
        dict of str to numpy.ndarray
            Read-only views, e.g. ``"position"`` of shape ``(n, 3)``.
        """
        name = self._system(system)
        f = self._index(index)
        start, stop = self._offsets[name][f : f + 2]
        return {a: values[start:stop] for a, values in self._arrays[name].items()}

    def __repr__(self) -> str:
        return f"Cache(frame_count={self.frame_count}, systems={list(self.systems)})"


def load_cache(path) -> Cache:
    """Read a particle cache written by :class:`CacheWriter`.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.npz`` cache file.

    Returns
    -------
    Cache

    Raises
    ------
    ValueError
        If the file is not a motes cache, is damaged, or was written in a newer format
        version than this motes reads.
    """
    shown = os.fspath(path)
    try:
        data = np.load(path, allow_pickle=False)
    except FileNotFoundError:
        raise
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as err:
        raise ValueError(f"{shown} is not a motes cache: not a NumPy .npz file ({err})") from None
    if not isinstance(data, np.lib.npyio.NpzFile):
        raise ValueError(f"{shown} is not a motes cache: a single NumPy array, not an .npz file")
    with data:
        keys = set(data.files)

        def get(key: str) -> np.ndarray:
            if key not in keys:
                raise ValueError(f"{shown} is a damaged motes cache: entry {key!r} is missing")
            try:
                array = data[key]
            except (ValueError, OSError, EOFError, zipfile.BadZipFile, zlib.error) as err:
                raise ValueError(f"{shown} is a damaged motes cache: {key!r}: {err}") from None
            array.setflags(write=False)
            return array

        if "format" not in keys:
            raise ValueError(f"{shown} is not a motes cache: it has no 'format' entry")
        kind = get("format")
        if kind.shape != () or kind.dtype.kind != "U" or str(kind) != FORMAT:
            raise ValueError(f"{shown} is not a motes cache: its format is not {FORMAT!r}")
        version = get("version")
        if version.shape != () or not np.issubdtype(version.dtype, np.integer) or version < 1:
            raise ValueError(f"{shown} is a damaged motes cache: bad version entry {version!r}")
        if int(version) > VERSION:
            raise ValueError(
                f"{shown} is a motes cache of format version {int(version)}, newer than this "
                f"motes reads (version {VERSION}); upgrade motes to read it"
            )
        times = get("times")
        names = get("systems")
        if times.ndim != 1 or names.ndim != 1:
            raise ValueError(f"{shown} is a damaged motes cache: times or systems not 1-D")
        offsets: dict[str, np.ndarray] = {}
        arrays: dict[str, dict[str, np.ndarray]] = {}
        for name in map(str, names):
            offs = get(f"{name}/offsets")
            if offs.shape != (len(times) + 1,) or offs[0] != 0 or np.any(np.diff(offs) < 0):
                raise ValueError(f"{shown} is a damaged motes cache: bad {name}/offsets")
            offsets[name] = offs
            arrays[name] = {}
            for attribute in map(str, get(f"{name}/attributes")):
                values = get(f"{name}/{attribute}")
                components = ATTRIBUTES.get(attribute, (None, None))[1]
                expected = (int(offs[-1]),) + (() if components in (1, None) else (components,))
                if values.shape[:1] != expected[:1] or (
                    components is not None and values.shape != expected
                ):
                    raise ValueError(
                        f"{shown} is a damaged motes cache: {name}/{attribute} has shape "
                        f"{values.shape}, expected {expected}"
                    )
                arrays[name][attribute] = values
    return Cache(times, offsets, arrays)
