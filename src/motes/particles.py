"""The particle store: one flat NumPy array per attribute (structure of arrays).

Layout
------
A vector attribute with ``c`` components is stored as one array of shape
``(c, capacity)``: each component is a contiguous row, which is the layout compiled
kernels vectorise over (a kernel over ``(N, 3)`` rows ran 4.6x slower here). Scalar
attributes are ``(capacity,)``. Live particles are packed in ``[0, count)``.

``store["position"]`` returns the convenient ``(count, 3)`` view of the live particles
(a transposed view: writes go straight into the store); ``store.raw("position")`` the
``(3, capacity)`` buffer that kernels take.

Overflow policy
---------------
The capacity is fixed at construction. A spawn that does not fit is truncated: the
particles past capacity are dropped and counted in :attr:`ParticleStore.dropped`, and
:meth:`ParticleStore.spawn` returns how many were actually created. Nothing grows
behind the caller's back, so memory use is known in advance.

Killing
-------
:meth:`ParticleStore.compact` removes dead particles with a stable compaction: survivors
keep their relative order and every attribute moves together. Ids are never reused.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import prange

from . import _memory
from . import _validate as check
from ._jit import SERIAL_BELOW, device, parallel_kernel, serial_kernel
from .state import Field, ParticleState

#: Placeholder dtype meaning "the store's floating-point precision" (float32 or float64).
REAL = "real"


@dataclass(frozen=True)
class Attribute:
    """Declaration of a per-particle attribute.

    Parameters
    ----------
    name : str
        Attribute name, e.g. ``"temperature"``.
    components : int
        1 for a scalar, 3 for a vector, 4 for RGBA.
    dtype : str or numpy dtype
        ``REAL`` (the store's float precision) or any NumPy dtype.
    default : float or tuple of float
        Value given to newly spawned particles (per component for vectors).
    doc : str
        Meaning and unit, shown in :meth:`ParticleStore.describe`.
    unit : str
        SI unit of the values (``"m"``, ``"1/kg"``; ``"1"`` for dimensionless ones), as
        :meth:`ParticleStore.particle_state` reports it; ``""`` when none applies or none
        is given.
    """

    name: str
    components: int = 1
    dtype: object = REAL
    default: float | tuple[float, ...] = 0.0
    doc: str = ""
    unit: str = ""

    def __post_init__(self):
        if not self.name.isidentifier():
            raise ValueError(f"attribute name must be an identifier, got {self.name!r}")
        check.integer("components", self.components, low=1)
        if isinstance(self.default, tuple) and len(self.default) != self.components:
            raise ValueError(
                f"default of attribute {self.name!r} has {len(self.default)} values, "
                f"expected {self.components}"
            )


#: Attributes motes knows by name; modules request them with ``store.require(name)``.
BUILTIN = {
    a.name: a
    for a in (
        Attribute("position", 3, doc="position [m]", unit="m"),
        Attribute("velocity", 3, doc="velocity [m/s]", unit="m/s"),
        Attribute("age", 1, doc="time since birth [s]", unit="s"),
        Attribute("lifetime", 1, default=float("inf"), doc="age at which it dies [s]", unit="s"),
        Attribute("id", 1, np.int64, default=-1, doc="unique id, never reused"),
        Attribute("mass", 1, default=1.0, doc="mass [kg]", unit="kg"),
        Attribute(
            "inv_mass", 1, default=1.0, doc="1/mass [1/kg]; 0 pins the particle", unit="1/kg"
        ),
        Attribute("charge", 1, doc="electric charge [C]", unit="C"),
        Attribute("color", 4, default=(1.0, 1.0, 1.0, 1.0), doc="linear RGBA in [0, 1]", unit="1"),
        Attribute("size", 1, default=0.05, doc="radius [m]", unit="m"),
        Attribute("rotation", 1, doc="sprite rotation about the view axis [rad]", unit="rad"),
        Attribute("birth_color", 4, default=(1.0, 1.0, 1.0, 1.0), doc="colour at birth", unit="1"),
        Attribute("birth_size", 1, default=0.05, doc="size at birth [m]", unit="m"),
        Attribute("birth_speed", 1, doc="speed at birth [m/s]", unit="m/s"),
    )
}

#: Ways to remove dead particles (see :class:`ParticleStore`).
COMPACTIONS = ("stable", "swap")

#: Always allocated: the minimum a moving, ageing particle needs.
CORE = ("position", "velocity", "age", "lifetime", "id")

#: Store attributes that are a :class:`~motes.state.ParticleState`'s core, by state name.
STATE_CORE = {"ids": "id", "positions": "position", "velocities": "velocity", "radius": "size"}


class ParticleStore:
    """Fixed-capacity structure-of-arrays storage for particles.

    Parameters
    ----------
    capacity : int
        Maximum number of live particles (> 0).
    attributes : iterable of str or Attribute
        Attributes to allocate in addition to :data:`CORE`.
    dtype : {numpy.float32, numpy.float64}
        Precision of ``REAL`` attributes. float32 halves memory traffic; float64 is for
        verification and long-running simulations.
    compaction : {"stable", "swap"}
        How the dead are removed. ``"stable"`` keeps the survivors' order and moves every
        survivor after the first death; ``"swap"`` fills each hole with the last live
        particle, moving only about twice as many particles as died (much faster when
        few die per step, as in a fire), at the cost of order. Both are deterministic.
    """

    def __init__(
        self, capacity: int, attributes=(), *, dtype=np.float32, compaction: str = "stable"
    ):
        self.capacity = check.integer("capacity", capacity, low=1)
        self.compaction = check.choice("compaction", compaction, COMPACTIONS)
        self.dtype = np.dtype(dtype)
        if self.dtype not in (np.float32, np.float64):
            raise ValueError(f"dtype must be float32 or float64, got {self.dtype}")
        self.count = 0
        #: Particles requested past capacity and not created, since construction.
        self.dropped = 0
        self._next_id = 0
        self._specs: dict[str, Attribute] = {}
        self._arrays: dict[str, np.ndarray] = {}
        self._defaults: dict[str, np.ndarray] = {}
        self.require(*CORE, *attributes)
        self._keep = np.ones(self.capacity, dtype=np.bool_)

    # -- attributes -------------------------------------------------------------------
    def require(self, *attributes: str | Attribute) -> None:
        """Allocate attributes (names of :data:`BUILTIN` ones, or :class:`Attribute`).

        Already allocated attributes are left as they are; live particles get the default
        value of a newly allocated one.
        """
        new: dict[str, Attribute] = {}
        for item in attributes:
            spec = item if isinstance(item, Attribute) else self._builtin(item)
            known = self._specs.get(spec.name, new.get(spec.name))
            if known is not None:
                if known != spec:
                    raise ValueError(f"attribute {spec.name!r} is already declared differently")
                continue
            new[spec.name] = spec
        if not new:
            return
        self._check_memory([*self._specs.values(), *new.values()])
        for spec in new.values():
            dtype = self._dtype_of(spec)
            shape = (self.capacity,) if spec.components == 1 else (spec.components, self.capacity)
            array = np.empty(shape, dtype=dtype)
            self._specs[spec.name] = spec
            self._arrays[spec.name] = array
            self._defaults[spec.name] = np.asarray(spec.default, dtype=dtype).reshape(
                (-1, 1) if spec.components > 1 else ()
            )
            self._fill_default(spec.name, 0, self.count)
        # Compaction moves every attribute in one kernel call per dtype: 2D row views.
        groups: dict[np.dtype, list[np.ndarray]] = {}
        for array in self._arrays.values():
            groups.setdefault(array.dtype, []).append(array.reshape(-1, self.capacity))
        self._groups = [tuple(views) for views in groups.values()]

    def _dtype_of(self, spec: Attribute) -> np.dtype:
        return self.dtype if spec.dtype == REAL else np.dtype(spec.dtype)

    def _check_memory(self, specs: list[Attribute]) -> None:
        """Refuse, before allocating, attributes that would not fit in memory."""
        per_particle = 1 + sum(s.components * self._dtype_of(s).itemsize for s in specs)
        _memory.check(
            f"capacity = {self.capacity}",
            per_particle * self.capacity,
            per=f"{per_particle} B per particle for {len(specs)} attributes and the kill mask",
        )

    @staticmethod
    def _builtin(name: str) -> Attribute:
        if name not in BUILTIN:
            raise KeyError(
                f"unknown attribute {name!r}; built-in attributes are {', '.join(BUILTIN)} "
                "(declare others with motes.Attribute)"
            )
        return BUILTIN[name]

    def has(self, name: str) -> bool:
        """Whether attribute ``name`` is allocated."""
        return name in self._arrays

    @property
    def names(self) -> tuple[str, ...]:
        """Names of the allocated attributes, in allocation order."""
        return tuple(self._arrays)

    def raw(self, name: str) -> np.ndarray:
        """The full buffer of ``name``: shape ``(components, capacity)`` or ``(capacity,)``."""
        try:
            return self._arrays[name]
        except KeyError:
            raise KeyError(self._missing(name)) from None

    def __getitem__(self, name: str) -> np.ndarray:
        """Live view: ``(count, components)`` for vectors, ``(count,)`` for scalars."""
        array = self.raw(name)
        return array[: self.count] if array.ndim == 1 else array[:, : self.count].T

    def __setitem__(self, name: str, value) -> None:
        self[name][...] = value

    def particle_state(self) -> ParticleState:
        """The live particles as a :class:`~motes.state.ParticleState`: views, no copy.

        ``id``, ``position``, ``velocity`` and ``size`` are the state's ``ids``,
        ``positions``, ``velocities`` and ``radius`` (without a ``size`` attribute each
        particle has the attribute's default radius, 0.05 m, in a fresh array); every
        other attribute is a field of its own name, ``(components, count)`` or
        ``(count,)``, with its :attr:`Attribute.unit`.
        """
        n = self.count
        live = {name: array[..., :n] for name, array in self._arrays.items()}
        radius = live.get("size")
        if radius is None:  # the size every particle would have had
            radius = np.full(n, BUILTIN["size"].default, dtype=self.dtype)
        core = set(STATE_CORE.values())
        fields = {
            name: Field(live[name], spec.unit, spec.doc)
            for name, spec in self._specs.items()
            if name not in core
        }
        return ParticleState(live["id"], live["position"], live["velocity"], radius, fields)

    def _missing(self, name: str) -> str:
        return (
            f"attribute {name!r} is not allocated in this store "
            f"(allocated: {', '.join(self._arrays)})"
        )

    @property
    def bytes_per_particle(self) -> int:
        """Bytes of storage per unit of capacity, over all attributes and scratch."""
        per = sum(a.itemsize * (1 if a.ndim == 1 else a.shape[0]) for a in self._arrays.values())
        return per + self._keep.itemsize

    @property
    def nbytes(self) -> int:
        """Total bytes allocated for the store's arrays."""
        return sum(a.nbytes for a in self._arrays.values()) + self._keep.nbytes

    def describe(self) -> str:
        """A table of attributes: name, dtype, components, bytes per particle, meaning."""
        rows = [f"{'attribute':<14} {'dtype':<8} {'comp':>4} {'bytes':>5}  meaning"]
        for name, spec in self._specs.items():
            a = self._arrays[name]
            rows.append(
                f"{name:<14} {a.dtype.name:<8} {spec.components:>4} "
                f"{a.itemsize * spec.components:>5}  {spec.doc}"
            )
        rows.append(f"total {self.bytes_per_particle} bytes per particle (with the kill mask)")
        return "\n".join(rows)

    # -- life and death ---------------------------------------------------------------
    def spawn(self, count: int, *, initialised: frozenset[str] = frozenset()) -> slice:
        """Append up to ``count`` particles with default attributes and fresh ids.

        Returns the slice of the new particles (shorter than ``count`` when the store is
        full: the rest are dropped and added to :attr:`dropped`). Attributes named in
        ``initialised`` are left for the caller to write (an emitter sets them anyway).
        """
        count = check.integer("count", count, low=0)
        made = min(count, self.capacity - self.count)
        self.dropped += count - made
        start = self.count
        self.count += made
        for name in self._arrays:
            if name not in initialised:
                self._fill_default(name, start, self.count)
        ids = self._arrays["id"]
        ids[start : self.count] = np.arange(self._next_id, self._next_id + made, dtype=np.int64)
        self._next_id += made
        return slice(start, self.count)

    def _fill_default(self, name: str, start: int, stop: int) -> None:
        if stop > start:
            self._arrays[name][..., start:stop] = self._defaults[name]

    @property
    def keep(self) -> np.ndarray:
        """Scratch mask of shape ``(capacity,)``: kernels write False for particles to kill."""
        return self._keep

    def compact(self, keep: np.ndarray | None = None, *, index: bool = True) -> np.ndarray | None:
        """Remove particles whose ``keep`` flag is False (see ``compaction`` for the order).

        Parameters
        ----------
        keep : bool array, shape (count,) or (capacity,), optional
            Defaults to the store's own :attr:`keep` mask.
        index : bool, optional
            Build and return ``new_index``; False skips that pass over every particle
            when nobody holds particle indices.

        Returns
        -------
        new_index : int64 array of shape (old count,), or None when nobody died or
            ``index`` is False
            New index of each old particle, -1 for the dead; modules holding particle
            indices (springs) remap with it.
        """
        n = self.count
        mask = self._keep if keep is None else np.asarray(keep, dtype=np.bool_)
        if mask.shape[0] < n:
            raise ValueError(f"keep must have at least {n} entries, got {mask.shape[0]}")
        live = mask[:n]
        survivors = int(np.count_nonzero(live))
        if survivors == n:
            return None
        if self.compaction == "swap":
            # Holes below the new count, lowest first, take the survivors above it,
            # highest first: only about twice as many particles as died are touched.
            holes = np.flatnonzero(~live[:survivors])
            sources = np.flatnonzero(live[survivors:])[::-1] + survivors
            move_rows = _move_rows_parallel if holes.size >= SERIAL_BELOW else _move_rows_serial
            for group in self._groups:
                move_rows(group, sources, holes)
            new_index = None
            if index:
                new_index = np.arange(n, dtype=np.int64)
                new_index[~live] = -1
                new_index[sources] = holes
        else:
            new_index = None
            if index:
                new_index = np.empty(n, dtype=np.int64)
                _stable_index(mask, n, new_index)
            compact_rows = _compact_rows_parallel if n >= SERIAL_BELOW else _compact_rows_serial
            for group in self._groups:
                compact_rows(group, mask, n)
        self.count = survivors
        self._keep[:n] = True
        return new_index

    def kill(self, indices) -> np.ndarray | None:
        """Kill the particles at ``indices`` (array of live indices) and compact."""
        idx = np.asarray(indices, dtype=np.int64)
        if idx.size and (idx.min() < 0 or idx.max() >= self.count):
            raise IndexError(f"indices must be in [0, {self.count}), got {idx.min()}..{idx.max()}")
        self._keep[idx] = False
        return self.compact()

    def clear(self) -> None:
        """Remove every particle (ids keep counting up)."""
        self.count = 0


@serial_kernel
def _stable_index(keep, n, new_index):
    j = 0
    for i in range(n):
        if keep[i]:
            new_index[i] = j
            j += 1
        else:
            new_index[i] = -1
    return j


@device
def _compact_row(row, keep, n):
    # In place is safe: the write index j never passes the read index i. Branch-free:
    # always copy, advance only past survivors (a dead slot is overwritten next).
    j = 0
    for i in range(n):
        row[j] = row[i]
        j += keep[i]


@parallel_kernel
def _compact_rows_parallel(arrays, keep, n):
    # Rows are independent: whole rows go to threads.
    for array in arrays:
        for c in prange(array.shape[0]):
            _compact_row(array[c], keep, n)


@serial_kernel
def _compact_rows_serial(arrays, keep, n):
    # Small stores: one pass without the cost of a parallel region per array.
    for array in arrays:
        for c in range(array.shape[0]):
            _compact_row(array[c], keep, n)


@device
def _move_row(row, sources, destinations):
    for k in range(sources.shape[0]):
        row[destinations[k]] = row[sources[k]]


@parallel_kernel
def _move_rows_parallel(arrays, sources, destinations):
    # Sources all lie above the destinations: no move reads a slot another has written.
    for array in arrays:
        for c in prange(array.shape[0]):
            _move_row(array[c], sources, destinations)


@serial_kernel
def _move_rows_serial(arrays, sources, destinations):
    for array in arrays:
        for c in range(array.shape[0]):
            _move_row(array[c], sources, destinations)
