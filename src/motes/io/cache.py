"""Particle cache: per-frame particle states of named systems and bodies, in one file.

This is what ``motes run ... --export CACHE.h5`` (or ``CACHE.npz``) writes, for
``motes render`` and ``motes export`` and for other tools (renderers, DCC importers,
analysis notebooks) to read back, with :func:`load_cache`, h5py or NumPy alone. Anything
with a :class:`~motes.state.ParticleState` is recorded through it: emitter systems,
liquids, cloth, hair, rigid worlds and flocks alike.

Two containers hold the same keys, chosen by the extension: ``.h5`` (format version 3,
HDF5: each frame appended to chunked datasets, shuffled and deflated, optionally rounded
to ``significant_digits``; :mod:`motes.io.cache_h5`) and ``.npz`` (format version 2, a
ZIP of ``.npy`` arrays that NumPy alone reads; :mod:`motes.io.cache_npz`). Both write
frame by frame with flat memory. ``docs/cache-format.md`` has sizes and speeds.

File layout
-----------
An ``.npz`` is a ZIP archive of ``.npy`` arrays, readable with ``numpy.load(path)`` (no
pickles: ``allow_pickle=False`` works); in an ``.h5`` file ``S/NAME`` is the dataset
``NAME`` of the group ``S``, strings are UTF-8, and the key ``significant_digits``
(int64, ``-1`` for none) is added. ``F`` is the number of frames; for each entry ``S`` (a
system or a body), ``N_S`` is its total number of particle records over all frames.

=====================  ============  ==========  ============================================
key                    shape         dtype       meaning
=====================  ============  ==========  ============================================
``format``             ()            str         always ``"motes-cache"``
``version``            ()            int64       ``3`` (``.h5``) or ``2`` (``.npz``)
``motes_version``      ()            str         version of motes that wrote the file
``scene``              ()            str         scene name; ``""`` when not from a scene
``seed``               ()            int64       the scene's seed; ``-1`` when not given
``fps``                ()            float64     the scene's frame rate [1/s]; ``0`` when
                                                 not given (absent in older files)
``overrides``          ()            str         the values set over the scene file's
                                                 (``motes run --set``), as a JSON object
                                                 of key path to value; ``"{}"`` for none
                                                 (absent in older files)
``times``              (F,)          float64     simulation time of each frame [s]
``names``              (S,)          str         entry names, in the order first given
``S/attributes``       (A,)          str         attributes recorded for ``S``: ``ids``,
                                                 ``positions``, ``velocities``, ``radius``,
                                                 then the state's fields
``S/units``            (A,)          str         SI unit of each (``"1"``: dimensionless,
                                                 ``""``: not a quantity)
``S/docs``             (A,)          str         meaning of each
``S/offsets``          (F+1,)        int64       frame ``f``'s particles of ``S`` are rows
                                                 ``offsets[f]:offsets[f+1]`` of every
                                                 attribute array; ``offsets[0] = 0``,
                                                 ``offsets[F] = N_S``
``S/ids``              (N_S,)        int64       stable particle identity: follows a
                                                 particle across frames
``S/positions``        (N_S, 3)      float       position [m]
``S/velocities``       (N_S, 3)      float       velocity [m/s]
``S/radius``           (N_S,)        float       particle radius [m]
``S/NAME``             (N_S[, c])    any         every other attribute of the state (a
                                                 vector one with ``c`` components)
``S/faces``            (m, 3)        int64       only for an entry with a mesh (a cloth):
                                                 triangles over its particles
``S/curves``           (s,)          int64       only for an entry with curves (hair):
                                                 particles per strand, root first
``S/body_centers``     (F, b, 3)     float64     only for a rigid world with bodies: each
                                                 body's centre of mass per frame [m]
``S/body_rotations``   (F, b, 3, 3)  float64     with the centres: each body's rotation
                                                 per frame (its axes as columns)
=====================  ============  ==========  ============================================

The last four keys come from :class:`~motes.io.entry.Entry` items (a scene's bodies give
them); faces and curves are the first frame's (the topology does not change). They and
``fps`` are absent in files written before them: readers that do not know them ignore
them, so the format version stays 2.

Values keep the kind's own dtype (float32 for systems and liquids, float64 for cloth,
hair and rigid worlds), so a frame read back equals the live state. Arrays are record
major (one row per particle, as other tools expect); the state's ``(c, n)`` rows are
:meth:`Cache.state`'s transposed views of them. ``S`` stands for the name as given
(``"fire/positions"`` for an entry named ``fire``); names must be non-empty and contain
no ``/``. The first frame fixes each entry's attributes, dtypes and components; every
later frame must have them (further ones are ignored). Within a frame, particles are in
the kind's own order (a liquid reorders its particles: follow ``ids``). A reader should
ignore keys it does not know; a file whose ``version`` is greater than the one it knows
needs a newer reader. Files of format version 1 (systems only: ``systems``,
``S/position``, ``S/velocity``, ``S/color``, ``S/size``, ``S/id``) are read with the
attributes renamed to version 2's.

Writing is atomic: the file is built under a temporary name and moved into place when
complete, also when :class:`CacheWriter` is closed by an exception or Ctrl-C, with the
frames added so far (a frame is whole in the file or cut from it). A writer closed with
no frame writes nothing and leaves an existing file as it was.

Examples
--------
>>> with CacheWriter("run.h5", scene="fire", seed=1) as cache:  # doctest: +SKIP
...     for _ in range(100):
...         fire.step(1 / 60)
...         water.step(1 / 60)
...         cache.add_frame(fire.time, {"fire": fire, "water": water})
>>> cache = load_cache("run.h5")  # doctest: +SKIP
>>> cache.frame(10, "fire")["positions"].shape  # doctest: +SKIP
(1234, 3)
>>> cache.state(10, "water").positions.shape  # doctest: +SKIP
(3, 4096)
"""

from __future__ import annotations

import json
import os
import weakref
import zipfile
import zlib
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .. import _validate as check
from ..particles import BUILTIN
from ..state import CORE, Field, ParticleState
from ._atomic import DeferredInterrupt
from .entry import Entry, as_entry

#: Value of the ``format`` entry.
FORMAT = "motes-cache"
#: Format version of the ``.h5`` container, and the newest this module reads (``.npz``
#: files are version 2: the same keys in a ZIP of ``.npy`` arrays).
VERSION = 3
#: Cache file extensions (``.h5`` and ``.hdf5``: version 3; ``.npz``: version 2).
SUFFIXES = (".h5", ".hdf5", ".npz")


class DamagedCacheError(ValueError):
    """A cache whose data cannot be read back (an ``.h5`` read lazily finds the damage
    when a frame is asked for): the message names the file and the entry."""


#: Format version 1's attribute names, in version 2's names.
V1_NAMES = {
    "position": "positions",
    "velocity": "velocities",
    "color": "color",
    "size": "radius",
    "id": "ids",
}
#: Format version 1's attributes' units and meanings (by version 2 name).
_V1_FIELDS = {**CORE, "color": ("1", "linear RGBA in [0, 1]")}


def _check_name(name) -> str:
    if not isinstance(name, str) or not name or "/" in name:
        raise ValueError(f"entry names must be non-empty strings without '/', got {name!r}")
    return name


def _entry_of(name: str, item) -> Entry:
    try:
        return as_entry(item)
    except TypeError as error:
        raise TypeError(f"items[{name!r}]: {error}") from None


class _Layout:
    """What the first frame fixed for one entry: attributes, units, docs, dtypes, and
    its shapes (faces and curves as given then; whether it has body transforms)."""

    def __init__(self, entry: Entry):
        state = entry.state
        self.faces = entry.faces
        self.curves = entry.curves
        self.bodies = None if entry.transforms is None else len(entry.transforms[0])
        self.surface = entry.surface is not None
        self.attributes = state.names()
        fields = [state.field(a) for a in self.attributes]
        self.units = tuple(f.unit for f in fields)
        self.docs = tuple(f.doc for f in fields)
        self.dtypes = tuple(np.asarray(f.data).dtype for f in fields)
        # components: () for a scalar attribute, (c,) for a vector one
        self.components = tuple(np.shape(f.data)[:-1] for f in fields)

    def record(self, name: str, frame: int, entry: Entry) -> dict[str, np.ndarray]:
        """Record-major copies of the state's attributes, in the fixed dtypes, of the
        body transforms (``body_centers``, ``body_rotations``) and of the surface
        (``surface_vertices``, ``surface_faces``) if the first frame had them."""
        state = entry.state
        out = {}
        if self.bodies is not None:
            given = None if entry.transforms is None else len(entry.transforms[0])
            if given != self.bodies:
                raise ValueError(
                    f"frame {frame}: {name!r} gives transforms of {given} bodies, but "
                    f"{self.bodies} at the first frame"
                )
            out["body_centers"] = np.array(entry.transforms[0], dtype=np.float64)
            out["body_rotations"] = np.array(entry.transforms[1], dtype=np.float64)
        if self.surface:  # a frame without one has an empty mesh
            vertices, faces = entry.surface if entry.surface is not None else ((), ())
            out["surface_vertices"] = np.array(vertices, np.float32).reshape(-1, 3)
            out["surface_faces"] = np.array(faces, np.int64).reshape(-1, 3)
        for attribute, dtype, components in zip(
            self.attributes, self.dtypes, self.components, strict=True
        ):
            if attribute not in state:
                raise ValueError(
                    f"frame {frame}: {name!r} has no attribute {attribute!r}, recorded "
                    "since the first frame"
                )
            values = state[attribute]
            if values.shape[:-1] != components:
                raise ValueError(
                    f"frame {frame}: {name}/{attribute} has shape {values.shape}, but "
                    f"{(*components, 'n')} at the first frame"
                )
            out[attribute] = np.array(values.T, dtype=dtype, order="C")
        return out


class CacheWriter:
    """Writes frames of particle states into a cache file as they come.

    The container is chosen by the extension: ``.h5`` (format version 3, HDF5: each
    frame appended to chunked, compressed datasets) or ``.npz`` (format version 2, a ZIP
    of ``.npy`` arrays that NumPy alone reads: each frame spooled to disk, the archive
    written on :meth:`close`). Either way memory stays flat however many frames come.

    Parameters
    ----------
    path : str or os.PathLike
        Output file, ending in ``.h5`` (or ``.hdf5``) or ``.npz``.
    compress : bool, optional
        Compress the per-particle arrays: byte shuffle and deflate in ``.h5`` (on by
        default), deflate of the ZIP members in ``.npz`` (off by default, like
        :func:`numpy.savez`; it gains little on particle data).
    significant_digits : int, optional
        ``.h5`` only: significant decimal digits kept of every floating-point attribute,
        1 to 15 (``4``: within 0.5e-4 of each value, relative, so 0.15 mm at 3 m from the
        origin); lossy, and about twice smaller again. None (the default) keeps every bit.
    scene : str, optional
        Name of the scene the frames come from, recorded in the file.
    seed : int, optional
        The scene's seed (>= 0), recorded in the file.
    fps : float, optional
        The scene's frame rate [1/s], recorded in the file (exporters time their frames
        by it: :mod:`motes.io.export`).
    overrides : Mapping[str, object], optional
        Values set over the scene file's (key path -> value, as ``motes run --set``
        gives them), recorded as JSON; values JSON cannot hold are recorded as text.
    """

    def __init__(
        self,
        path,
        *,
        compress: bool | None = None,
        significant_digits: int | None = None,
        scene: str | None = None,
        seed: int | None = None,
        fps: float | None = None,
        overrides: Mapping[str, object] | None = None,
    ):
        path = Path(path)
        suffix = path.suffix.lower()
        if suffix not in SUFFIXES:
            raise ValueError(f"path must end in .h5, .hdf5 or .npz, got {str(path)!r}")
        if not path.parent.is_dir():
            raise FileNotFoundError(f"directory {str(path.parent)!r} does not exist")
        if scene is not None and not isinstance(scene, str):
            raise TypeError(f"scene must be a string, got {type(scene).__name__}")
        hdf5 = suffix != ".npz"
        digits = significant_digits
        if digits is not None:
            if not hdf5:
                raise ValueError("significant_digits (lossy) needs an .h5 cache, not .npz")
            digits = check.integer("significant_digits", digits, low=1)
            if digits > 15:
                raise ValueError(f"significant_digits must be in [1, 15], got {digits}")
        self.path = path
        self.compress = hdf5 if compress is None else bool(compress)
        self.significant_digits = digits
        self.scene = scene
        self.seed = None if seed is None else check.integer("seed", seed, low=0)
        self.fps = None if fps is None else check.positive("fps", fps)
        if overrides is not None and not isinstance(overrides, Mapping):
            raise TypeError(f"overrides must be a mapping, got {type(overrides).__name__}")
        self.overrides = json.dumps(dict(overrides or {}), default=str, sort_keys=True)
        self._layouts: dict[str, _Layout] | None = None
        self._sink = None
        self._frames = 0
        self._failed: BaseException | None = None
        self._closed = False

    @property
    def version(self) -> int:
        """Format version of the file: 3 (``.h5``) or 2 (``.npz``)."""
        return 2 if self.path.suffix.lower() == ".npz" else VERSION

    @property
    def frame_count(self) -> int:
        """Number of frames added so far."""
        return self._frames

    @property
    def closed(self) -> bool:
        """Whether :meth:`close` has been called."""
        return self._closed

    def _header(self) -> dict:
        from .._version import __version__

        header = {
            "format": FORMAT,
            "version": np.int64(self.version),
            "motes_version": __version__,
            "scene": self.scene or "",
            "seed": np.int64(-1 if self.seed is None else self.seed),
            "fps": np.float64(self.fps or 0.0),
            "overrides": self.overrides,
        }
        if self.version > 2:
            digits = self.significant_digits
            header["significant_digits"] = np.int64(-1 if digits is None else digits)
        return header

    def _open_sink(self, layouts: dict[str, _Layout]) -> None:
        if self.version == 2:
            from .cache_npz import NpzSink

            sink = NpzSink(self.path, self._header(), compress=self.compress)
        else:
            from .cache_h5 import H5Sink

            sink = H5Sink(
                self.path,
                self._header(),
                compress=self.compress,
                significant_digits=self.significant_digits,
            )
        sink.start(layouts)
        self._sink = sink
        # A writer dropped without close() leaves no temporary file behind.
        self._finalizer = weakref.finalize(self, sink.abort)

    def add_frame(self, time: float, items: Mapping[str, object]) -> None:
        """Record the particles of each item at simulation time ``time``.

        Parameters
        ----------
        time : float
            Simulation time of the frame [s].
        items : Mapping[str, HasParticles or ParticleState or Entry]
            Systems, stores, liquids, cloth, hair, rigid worlds, scene bodies (anything
            with ``particle_state()``), states or :class:`~motes.io.entry.Entry` items
            (a state with faces, curves or body transforms), by name. The first frame
            fixes the names and each one's attributes; every later frame must give the
            same names.
        """
        if self._closed:
            raise ValueError(f"add_frame on a closed cache writer ({self.path})")
        if self._failed is not None:
            raise ValueError(f"the cache writer failed at frame {self._frames}: {self._failed}")
        time = check.real("time", time)
        if not isinstance(items, Mapping) or not items:
            raise TypeError("items must be a non-empty mapping of name -> particles")
        entries = {_check_name(name): _entry_of(name, item) for name, item in items.items()}
        layouts = self._layouts
        if layouts is None:
            layouts = {name: _Layout(entry) for name, entry in entries.items()}
        elif set(entries) != set(layouts):
            raise ValueError(
                f"frame {self._frames} gives {sorted(entries)}, but the first frame "
                f"gave {sorted(layouts)}; every frame must give the same names"
            )
        frame = self._frames
        record = {name: layouts[name].record(name, frame, entries[name]) for name in layouts}
        if self._sink is None:
            self._open_sink(layouts)
            self._layouts = layouts
        # Ctrl-C waits until the frame is whole in the file; an error on the way (a full
        # disk) ends the writer, which still closes with the frames before it.
        with DeferredInterrupt():
            try:
                self._sink.add(time, record)
            except Exception as error:
                self._failed = error
                raise
            self._frames += 1

    def close(self) -> None:
        """Finish the file with the frames added so far; calling it again does nothing.

        With no frame added, nothing is written (an existing file is kept).
        """
        if self._closed:
            return
        self._closed = True
        if self._sink is not None:
            self._finalizer.detach()
            self._sink.finish()

    def __enter__(self) -> CacheWriter:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"CacheWriter({str(self.path)!r}, frame_count={self.frame_count})"


class Cache:
    """A particle cache read back by :func:`load_cache`. Arrays are read-only.

    Attributes
    ----------
    times : numpy.ndarray
        Simulation time of each frame [s], shape ``(frame_count,)``.
    names : tuple of str
        Entry names (systems and bodies).
    version : int
        Format version of the file.
    scene : str or None
        Name of the scene the frames come from (None when not recorded).
    seed : int or None
        The scene's seed (None when not recorded).
    fps : float or None
        The scene's frame rate [1/s] (None when not recorded).
    overrides : dict
        Values set over the scene file's (key path -> value; empty when none or not
        recorded).
    motes_version : str or None
        Version of motes that wrote the file (None before format version 2).
    significant_digits : int or None
        Significant decimal digits kept of floating-point attributes in a lossy ``.h5``
        cache; None when every bit was kept.

    An ``.h5`` cache is read lazily: a frame's rows are read from the file when asked
    for, and the file stays open until :meth:`close` (or the end of a ``with`` block).
    """

    def __init__(
        self,
        times: np.ndarray,
        offsets: dict[str, np.ndarray],
        arrays: dict[str, dict[str, np.ndarray]],
        fields: dict[str, dict[str, tuple[str, str]]],
        *,
        version: int = VERSION,
        scene: str | None = None,
        seed: int | None = None,
        fps: float | None = None,
        overrides: dict | None = None,
        motes_version: str | None = None,
        significant_digits: int | None = None,
        shapes: dict[str, dict[str, np.ndarray]] | None = None,
        close=None,
        path: str = "the cache",
    ):
        self.path = path
        self.times = times
        self.fps = fps
        self.overrides = dict(overrides or {})
        self.names = tuple(offsets)
        self.version = version
        self.scene = scene
        self.seed = seed
        self.motes_version = motes_version
        self.significant_digits = significant_digits
        self._offsets = offsets
        self._arrays = arrays
        self._fields = fields
        # per entry: faces, curves, body_centers (F, b, 3), body_rotations (F, b, 3, 3)
        self._shapes = shapes or {}
        self._close = close

    def close(self) -> None:
        """Close the file (an ``.h5`` cache reads frames from it when asked); arrays
        already read stay valid."""
        close, self._close = self._close, None
        if close is not None:
            close()

    def __enter__(self) -> Cache:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    @property
    def lossy(self) -> bool:
        """Whether floating-point attributes were stored to fewer digits than they had."""
        return self.significant_digits is not None

    @property
    def systems(self) -> tuple[str, ...]:
        """The entry names (:attr:`names`; format version 1 held systems only)."""
        return self.names

    @property
    def frame_count(self) -> int:
        """Number of frames."""
        return len(self.times)

    def __len__(self) -> int:
        return self.frame_count

    def _name(self, name: str | None) -> str:
        if name is None:
            if len(self.names) != 1:
                raise ValueError(f"the cache holds {list(self.names)}; name the one you want")
            return self.names[0]
        if name not in self._offsets:
            raise KeyError(f"no entry {name!r} in the cache; it holds {list(self.names)}")
        return name

    def _index(self, index: int) -> int:
        index = check.integer("index", index)
        if not -self.frame_count <= index < self.frame_count:
            raise IndexError(f"frame {index} out of range for a cache of {self.frame_count}")
        return index % self.frame_count

    def attributes(self, name: str | None = None) -> tuple[str, ...]:
        """Attributes recorded for entry ``name`` (may be omitted if there is only one)."""
        return tuple(self._arrays[self._name(name)])

    def unit(self, attribute: str, name: str | None = None) -> str:
        """SI unit of ``attribute`` of entry ``name`` (``"1"`` dimensionless, ``""`` none)."""
        fields = self._fields[self._name(name)]
        if attribute not in fields:
            raise KeyError(
                f"attribute {attribute!r} was not recorded; the cache has {list(fields)}"
            )
        return fields[attribute][0]

    def offsets(self, name: str | None = None) -> np.ndarray:
        """Row offsets of entry ``name``, shape ``(frame_count + 1,)`` (see the layout)."""
        return self._offsets[self._name(name)]

    def counts(self, name: str | None = None) -> np.ndarray:
        """Number of particles of entry ``name`` in each frame, shape ``(frame_count,)``."""
        return np.diff(self.offsets(name))

    def array(self, attribute: str, name: str | None = None) -> np.ndarray:
        """Every frame's values of ``attribute``, concatenated (rows per :meth:`offsets`)."""
        arrays = self._arrays[self._name(name)]
        if attribute not in arrays:
            raise KeyError(
                f"attribute {attribute!r} was not recorded; the cache has {list(arrays)}"
            )
        return self._rows(arrays[attribute], slice(None), f"{self._name(name)}/{attribute}")

    def frame(self, index: int, name: str | None = None) -> dict[str, np.ndarray]:
        """One frame's particles of entry ``name``, one row per particle.

        Parameters
        ----------
        index : int
            Frame number; negative counts from the end.
        name : str, optional
            Entry name; may be omitted when the cache holds a single entry.

        Returns
        -------
        dict of str to numpy.ndarray
            Read-only views, e.g. ``"positions"`` of shape ``(n, 3)``.
        """
        name = self._name(name)
        f = self._index(index)
        start, stop = self._offsets[name][f : f + 2]
        rows = slice(start, stop)
        return {
            a: self._rows(values, rows, f"{name}/{a}") for a, values in self._arrays[name].items()
        }

    def _rows(self, values, rows: slice, key: str) -> np.ndarray:
        """``values[rows]``, read-only; a lazily read ``.h5`` dataset that cannot be
        decoded there raises :class:`DamagedCacheError` naming the file and ``key``."""
        try:
            return _read_only(values[rows])
        except (OSError, ValueError) as error:
            raise DamagedCacheError(
                f"{self.path} is a damaged motes cache: {key}, rows {rows.start}:{rows.stop}: "
                f"{error}"
            ) from None

    def state(self, index: int, name: str | None = None) -> ParticleState:
        """One frame of entry ``name`` as the :class:`~motes.state.ParticleState` it was
        recorded from: ``(c, n)`` read-only views of the file's rows, units restored.

        A version 1 entry recorded without ``size`` has the attribute's default radius.
        """
        name = self._name(name)
        rows = self.frame(index, name)
        meaning = self._fields[name]
        radius = rows.get("radius")
        if radius is None:
            radius = np.full(len(rows["ids"]), BUILTIN["size"].default, np.float32)
        fields = {a: Field(values.T, *meaning[a]) for a, values in rows.items() if a not in CORE}
        return ParticleState(rows["ids"], rows["positions"].T, rows["velocities"].T, radius, fields)

    def entry(self, index: int, name: str | None = None) -> Entry:
        """One frame of entry ``name`` as an :class:`~motes.io.entry.Entry`: its
        :meth:`state` with the faces, curves, body transforms and surface recorded for
        it."""
        name = self._name(name)
        shapes = self._shapes.get(name, {})
        f = self._index(index)
        transforms = surface = None
        if "body_centers" in shapes:
            transforms = (shapes["body_centers"][f], shapes["body_rotations"][f])
        if "surface_offsets" in shapes:
            (v0, t0), (v1, t1) = shapes["surface_offsets"][f : f + 2]
            surface = (
                self._rows(shapes["surface_vertices"], slice(v0, v1), f"{name}/surface_vertices"),
                self._rows(shapes["surface_faces"], slice(t0, t1), f"{name}/surface_faces"),
            )
        return Entry(
            self.state(index, name),
            faces=shapes.get("faces"),
            curves=shapes.get("curves"),
            transforms=transforms,
            surface=surface,
        )

    def __repr__(self) -> str:
        return f"Cache(frame_count={self.frame_count}, names={list(self.names)})"


def load_cache(path) -> Cache:
    """Read a particle cache written by :class:`CacheWriter` (format version 1 to 3).

    Parameters
    ----------
    path : str or os.PathLike
        A cache file: ``.h5`` (read lazily, frame by frame: damage found then raises
        :class:`DamagedCacheError`) or ``.npz`` (read whole).

    Returns
    -------
    Cache
        Close it when done (or use it in a ``with`` block) to close an ``.h5`` file.

    Raises
    ------
    ValueError
        If the file is not a motes cache, is damaged, or was written in a newer format
        version than this motes reads.
    """
    from . import cache_h5, cache_npz

    shown = os.fspath(path)
    try:
        hdf5 = cache_h5.is_hdf5(path)
        keys, read, close = (cache_h5 if hdf5 else cache_npz).open_keys(path)
    except FileNotFoundError:
        raise
    except TypeError as err:
        raise ValueError(f"{shown} is not a motes cache: {err}") from None
    except (ValueError, OSError, EOFError, zipfile.BadZipFile) as err:
        raise ValueError(
            f"{shown} is not a motes cache: not an HDF5 or NumPy .npz file ({err})"
        ) from None
    try:
        # an .npz is read whole here: its file is closed at once
        cache = _read(shown, keys, read, close if hdf5 else None)
    except BaseException:
        close()
        raise
    if not hdf5:
        close()
    return cache


def _read(shown: str, keys: set[str], read, close) -> Cache:
    """The :class:`Cache` of a file's ``keys``, read by ``read(key, lazy)`` and checked."""

    def get(key: str, lazy: bool = False) -> np.ndarray:
        if key not in keys:
            raise ValueError(f"{shown} is a damaged motes cache: entry {key!r} is missing")
        try:
            array = read(key, lazy)
        except (ValueError, OSError, EOFError, KeyError, zipfile.BadZipFile, zlib.error) as err:
            raise ValueError(f"{shown} is a damaged motes cache: {key!r}: {err}") from None
        if isinstance(array, np.ndarray):
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
    version = int(version)
    if version > VERSION:
        raise ValueError(
            f"{shown} is a motes cache of format version {version}, newer than this "
            f"motes reads (version {VERSION}); upgrade motes to read it"
        )
    times = get("times")
    names = get("names" if version >= 2 else "systems")
    if times.ndim != 1 or names.ndim != 1:
        raise ValueError(f"{shown} is a damaged motes cache: times or names not 1-D")
    offsets: dict[str, np.ndarray] = {}
    arrays: dict[str, dict[str, np.ndarray]] = {}
    fields: dict[str, dict[str, tuple[str, str]]] = {}
    shapes: dict[str, dict[str, np.ndarray]] = {}
    for name in map(str, names):
        offs = get(f"{name}/offsets")
        if offs.shape != (len(times) + 1,) or offs[0] != 0 or np.any(np.diff(offs) < 0):
            raise ValueError(f"{shown} is a damaged motes cache: bad {name}/offsets")
        offsets[name] = offs
        stored = list(map(str, get(f"{name}/attributes")))
        if version >= 2:
            attributes = stored
            units = list(map(str, get(f"{name}/units")))
            docs = list(map(str, get(f"{name}/docs")))
            if len(units) != len(stored) or len(docs) != len(stored):
                raise ValueError(f"{shown} is a damaged motes cache: bad {name}/units or docs")
        else:
            attributes = [V1_NAMES.get(a, a) for a in stored]
            units = [_V1_FIELDS.get(a, ("", ""))[0] for a in attributes]
            docs = [_V1_FIELDS.get(a, ("", ""))[1] for a in attributes]
        missing = {"ids", "positions", "velocities"} - set(attributes)
        if missing:
            raise ValueError(f"{shown} is a damaged motes cache: {name} lacks {sorted(missing)}")
        arrays[name] = {}
        fields[name] = {}
        rows = int(offs[-1])
        for key, attribute, unit, doc in zip(stored, attributes, units, docs, strict=True):
            values = get(f"{name}/{key}", lazy=True)
            core = {"positions": (rows, 3), "velocities": (rows, 3), "ids": (rows,)}
            shape = core.get(attribute, (rows,) if attribute == "radius" else values.shape)
            if values.shape[:1] != (rows,) or len(values.shape) > 2 or values.shape != shape:
                raise ValueError(
                    f"{shown} is a damaged motes cache: {name}/{key} has shape "
                    f"{values.shape}, expected ({rows}, ...)"
                )
            arrays[name][attribute] = values
            fields[name][attribute] = (unit, doc)
        shapes[name] = _shapes(name, get, keys, len(times), int(offs[min(1, len(times))]), shown)
    meta = {}
    if version >= 2:
        seed = int(get("seed"))
        meta = {
            "scene": str(get("scene")) or None,
            "seed": None if seed < 0 else seed,
            "motes_version": str(get("motes_version")),
        }
        if "overrides" in keys:
            meta["overrides"] = _overrides(get("overrides"), shown)
        if "fps" in keys:
            fps = float(get("fps"))
            meta["fps"] = fps if fps > 0 else None
        if "significant_digits" in keys:
            digits = int(get("significant_digits"))
            meta["significant_digits"] = digits if digits >= 0 else None
    return Cache(
        times, offsets, arrays, fields, version=version, shapes=shapes, close=close,
        path=shown, **meta,
    )  # fmt: skip


def _read_only(values) -> np.ndarray:
    """``values`` (read from a file, or a view of a read-only array) as read-only."""
    values = np.asarray(values)
    values.setflags(write=False)
    return values


def _shapes(name: str, get, keys: set, frames: int, first: int, shown: str) -> dict:
    """The optional ``S/faces``, ``S/curves``, ``S/body_centers``, ``S/body_rotations``
    and ``S/surface_*`` of entry ``name``, checked against the frame count and the first
    frame's particles (surface vertices and faces are read lazily from an ``.h5``)."""
    out = {}
    for key in ("faces", "curves", "body_centers", "body_rotations", "surface_offsets"):
        if f"{name}/{key}" in keys:
            out[key] = get(f"{name}/{key}")
    faces, curves = out.get("faces"), out.get("curves")
    bad = []
    if "surface_offsets" in out:
        out["surface_vertices"] = get(f"{name}/surface_vertices", lazy=True)
        out["surface_faces"] = get(f"{name}/surface_faces", lazy=True)
        ends = out["surface_offsets"]
        lengths = (len(out["surface_vertices"]), len(out["surface_faces"]))
        if (
            ends.shape != (frames + 1, 2)
            or np.any(ends[0] != 0)
            or np.any(np.diff(ends, axis=0) < 0)
            or tuple(ends[-1]) != lengths
            or out["surface_vertices"].shape[1:] != (3,)
            or out["surface_faces"].shape[1:] != (3,)
        ):
            bad.append("surface_offsets, surface_vertices or surface_faces")
    if faces is not None and (
        faces.ndim != 2
        or faces.shape[1] != 3
        or (faces.size and not 0 <= faces.min() <= faces.max() < first)
    ):
        bad.append("faces")
    if curves is not None and (curves.ndim != 1 or int(curves.sum()) != first):
        bad.append("curves")
    if ("body_centers" in out) != ("body_rotations" in out):
        bad.append("body_centers or body_rotations (one without the other)")
    elif "body_centers" in out:
        centers, rotations = out["body_centers"], out["body_rotations"]
        b = centers.shape[1] if centers.ndim == 3 else -1
        if centers.shape != (frames, b, 3) or rotations.shape != (frames, b, 3, 3):
            bad.append("body_centers or body_rotations")
    if bad:
        raise ValueError(f"{shown} is a damaged motes cache: bad {name}/{bad[0]}")
    return out


def _overrides(entry: np.ndarray, shown: str) -> dict:
    """The ``overrides`` entry: a JSON object in a 0-d string array."""
    try:
        value = json.loads(str(entry)) if entry.shape == () and entry.dtype.kind == "U" else None
    except json.JSONDecodeError:
        value = None
    if not isinstance(value, dict):
        raise ValueError(f"{shown} is a damaged motes cache: 'overrides' is not a JSON object")
    return value
