"""One particle-state contract: what every kind of particle simulation shows of itself.

Emitter-driven systems, liquids, cloth, hair and rigid worlds keep their particles in
storage of their own (a store with a capacity, float32 rows that the solver permutes,
float64 rows for an implicit solve or position Verlet). :class:`ParticleState` is the
one view every kind hands out through ``particle_state()`` (the :class:`HasParticles`
protocol), and the only thing the renderer and the particle cache read:

- ``ids`` (n,) int64: a particle's identity, stable across steps (a kind that reorders
  its arrays carries its ids along);
- ``positions`` (3, n) [m] and ``velocities`` (3, n) [m/s]: one contiguous row per
  component, the layout the kernels use (``positions.T`` is the ``(n, 3)`` view);
- ``radius`` (n,) [m]: each kind's natural particle radius;
- any further attribute by name, with its unit: colour (4, n) linear RGBA, mass [kg],
  age [s], density [kg/m³], phase...

The arrays are the kind's own where its storage allows (no copy), so a state reflects
the simulation at the moment it was taken; take a new one after a step (a liquid
reallocates its arrays every step, a system's count changes). Arrays a kind computes on
request (a rigid world's velocities, a constant radius) are fresh. Treat a state as
read-only: each kind has its own way to change its particles.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["CORE", "Field", "HasParticles", "ParticleState", "as_state"]


@dataclass(frozen=True)
class Field:
    """One per-particle attribute of a :class:`ParticleState`.

    Parameters
    ----------
    data : ndarray, shape (components, n) or (n,)
        The values, one column per particle.
    unit : str
        SI unit, e.g. ``"m"``, ``"m/s"``, ``"kg/m³"``; ``"1"`` for a dimensionless
        quantity (colour, a ratio), ``""`` for what is not a quantity (an id, an index,
        a flag).
    doc : str
        What it is, in a few words.
    """

    data: np.ndarray
    unit: str = "1"
    doc: str = ""


#: The attributes every state has: name -> (unit, meaning).
CORE: dict[str, tuple[str, str]] = {
    "ids": ("", "stable particle identity, int64"),
    "positions": ("m", "position"),
    "velocities": ("m/s", "velocity"),
    "radius": ("m", "particle radius"),
}


class ParticleState:
    """A read view of ``n`` particles: ids, positions, velocities, radius and named fields.

    Parameters
    ----------
    ids : (n,) int64 array
        Stable identity of each particle.
    positions : (3, n) float array
        Positions [m].
    velocities : (3, n) float array
        Velocities [m/s].
    radius : (n,) float array
        Particle radius [m].
    fields : mapping of str to Field, optional
        Further attributes, each ``(components, n)`` or ``(n,)``, in the order given.

    Examples
    --------
    >>> import numpy as np
    >>> state = ParticleState(
    ...     np.arange(2), np.zeros((3, 2)), np.ones((3, 2)), np.full(2, 0.1),
    ...     {"mass": Field(np.array([1.0, 2.0]), "kg", "mass")},
    ... )
    >>> state.count, state.names()
    (2, ('ids', 'positions', 'velocities', 'radius', 'mass'))
    >>> state.unit("mass"), state["mass"].tolist()
    ('kg', [1.0, 2.0])
    """

    __slots__ = ("_core", "_fields")

    def __init__(self, ids, positions, velocities, radius, fields: Mapping | None = None):
        ids = np.asarray(ids)
        if ids.ndim != 1 or ids.dtype != np.int64:
            raise ValueError(f"ids must be a 1-D int64 array, got {ids.dtype} {ids.shape}")
        n = ids.shape[0]
        core = {"ids": ids}
        for name, value, shape in (
            ("positions", positions, (3, n)),
            ("velocities", velocities, (3, n)),
            ("radius", radius, (n,)),
        ):
            array = np.asarray(value)
            if array.shape != shape or array.dtype.kind != "f":
                raise ValueError(
                    f"{name} must be a float array of shape {shape}, got {array.dtype} "
                    f"{array.shape}"
                )
            core[name] = array
        self._core = core
        self._fields: dict[str, Field] = {}
        for name, field in (fields or {}).items():
            if not isinstance(field, Field):
                raise TypeError(f"fields[{name!r}] must be a Field, got {type(field).__name__}")
            if not isinstance(name, str) or not name.isidentifier() or name in CORE:
                raise ValueError(f"field names must be identifiers other than {list(CORE)}")
            data = np.asarray(field.data)
            if data.ndim not in (1, 2) or data.shape[-1] != n:
                raise ValueError(
                    f"field {name!r} must have shape ({n},) or (components, {n}), got {data.shape}"
                )
            self._fields[name] = field if data is field.data else Field(data, field.unit, field.doc)

    # -- the core ---------------------------------------------------------------------
    @property
    def count(self) -> int:
        """Number of particles ``n``."""
        return self._core["ids"].shape[0]

    def __len__(self) -> int:
        return self.count

    @property
    def ids(self) -> np.ndarray:
        """Stable identity of each particle, int64, shape (n,)."""
        return self._core["ids"]

    @property
    def positions(self) -> np.ndarray:
        """Positions [m], shape (3, n)."""
        return self._core["positions"]

    @property
    def velocities(self) -> np.ndarray:
        """Velocities [m/s], shape (3, n)."""
        return self._core["velocities"]

    @property
    def radius(self) -> np.ndarray:
        """Particle radius [m], shape (n,)."""
        return self._core["radius"]

    # -- by name ----------------------------------------------------------------------
    def names(self) -> tuple[str, ...]:
        """Every attribute: the core four (:data:`CORE`), then the fields in order."""
        return (*CORE, *self._fields)

    def __contains__(self, name) -> bool:
        return name in self._core or name in self._fields

    def field(self, name: str) -> Field:
        """Attribute ``name`` with its unit and meaning (the core ones too)."""
        if name in self._core:
            unit, doc = CORE[name]
            return Field(self._core[name], unit, doc)
        try:
            return self._fields[name]
        except KeyError:
            raise KeyError(
                f"no attribute {name!r} in this state (it has {', '.join(self.names())})"
            ) from None

    def __getitem__(self, name: str) -> np.ndarray:
        """Values of attribute ``name``: ``(components, n)`` or ``(n,)``."""
        core = self._core.get(name)
        return core if core is not None else self.field(name).data

    def unit(self, name: str) -> str:
        """SI unit of attribute ``name`` (``"1"`` dimensionless, ``""`` not a quantity)."""
        return self.field(name).unit

    # -- what forces read ---------------------------------------------------------------
    # Forces take "a store" for attributes other than position and velocity (the mass);
    # these two methods are the part of ParticleStore's interface they use, so any
    # kind's state can stand in for a store (motes.forces.apply).
    def has(self, name: str) -> bool:
        """Whether attribute ``name`` exists (as ``ParticleStore.has``)."""
        return name in self

    def raw(self, name: str) -> np.ndarray:
        """Values of attribute ``name``, ``(components, n)`` or ``(n,)`` (as
        ``ParticleStore.raw``, without spare capacity: the state holds exactly ``n``)."""
        return self[name]

    # -- derived states ---------------------------------------------------------------
    def take(self, index) -> ParticleState:
        """The particles chosen by ``index`` (a bool mask or int indices): copies."""
        fields = {n: Field(f.data[..., index], f.unit, f.doc) for n, f in self._fields.items()}
        core = self._core
        return ParticleState(
            core["ids"][index],
            core["positions"][:, index],
            core["velocities"][:, index],
            core["radius"][index],
            fields,
        )

    def replace(self, *, radius=None, **fields: Field) -> ParticleState:
        """The same particles with ``radius`` and/or fields replaced or added (no copy)."""
        core = self._core
        return ParticleState(
            core["ids"],
            core["positions"],
            core["velocities"],
            core["radius"] if radius is None else radius,
            {**self._fields, **fields},
        )

    def __repr__(self) -> str:
        extra = f", fields={list(self._fields)}" if self._fields else ""
        return f"ParticleState({self.count} particles{extra})"


@runtime_checkable
class HasParticles(Protocol):
    """Anything that shows its particles as a :class:`ParticleState`."""

    def particle_state(self) -> ParticleState:
        """The particles now (see :mod:`motes.state` for what is a view)."""
        ...


def as_state(item) -> ParticleState:
    """``item`` itself if it is a :class:`ParticleState`, else ``item.particle_state()``."""
    if isinstance(item, ParticleState):
        return item
    method = getattr(item, "particle_state", None)
    if method is None:
        raise TypeError(
            f"expected a ParticleState or an object with particle_state(), got "
            f"{type(item).__name__}"
        )
    state = method()
    if not isinstance(state, ParticleState):
        raise TypeError(
            f"{type(item).__name__}.particle_state() returned {type(state).__name__}, "
            "not a ParticleState"
        )
    return state
