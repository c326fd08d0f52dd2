r"""Inverse-square pair forces between particles: Newtonian gravity and Coulomb's law.

Every particle pulls (or pushes) every other. With ``p`` the particle's mass or charge,
the force on particle ``i`` is

.. math:: F_i = c \, p_i \sum_{j \ne i} p_j \, (x_j - x_i) / (|x_j - x_i|^2 + ε^2)^{3/2}

with ``c = G`` for gravity (attraction) and ``c = -k_e`` for Coulomb's law (like charges
repel). ``ε`` is the Plummer softening length (Plummer 1911; Aarseth 2003,
*Gravitational N-Body Simulations*): the force of a pair is that of two Plummer spheres of
radius ``ε``, finite at any distance, so close encounters need no tiny steps.

Two summations compute it (:func:`inverse_square`):

- ``"direct"``: every pair, O(n²), in tiles that vectorise (see ``nbody_kernels``). The
  pair terms are antisymmetric (``x_j - x_i`` and ``x_i - x_j`` round to exact negatives
  and share one distance), so linear momentum is conserved to round-off.
- ``"barnes_hut"``: an :class:`~motes.spatial.octree.Octree` and the Barnes & Hut (1986)
  walk with opening angle ``θ``, O(n log n); monopoles and optional quadrupoles. Its
  errors are measured in ``docs/nbody.md``. It needs weights of one sign (masses, or
  charges all positive or all negative): a centre of charge of mixed signs is undefined.

``"auto"`` chooses direct summation below :data:`AUTO_BARNES_HUT` particles.
"""

from __future__ import annotations

import numpy as np

from .. import _validate as check
from .._jit import threads_for
from ..spatial.octree import Octree
from . import nbody_kernels as kernels
from .base import Force, check_buffers, particle_mass

#: Gravitational constant [m^3 kg^-1 s^-2] (CODATA 2018).
G_SI = 6.67430e-11
#: Coulomb constant ``1 / (4π ε0)`` [N m^2 C^-2] (CODATA 2018).
K_COULOMB = 8.9875517923e9
#: ``method="auto"`` uses Barnes–Hut from this many particles up.
AUTO_BARNES_HUT = 16384
METHODS = ("auto", "direct", "barnes_hut")
#: Below this many particles the octree is built and its moments summed on one thread:
#: those passes are short (a radix-sort pass over 100,000 keys takes 0.3 ms), and the tree
#: takes some forty parallel launches, each of which waits for a time slice on a busy
#: machine (measured: 24 ms per launch with the 2 cores shared by 7 runnable processes).
TREE_SERIAL_BELOW = 1 << 18


def inverse_square(
    position: np.ndarray,
    weight: np.ndarray,
    out: np.ndarray,
    *,
    coupling: float = 1.0,
    scale: np.ndarray | None = None,
    softening: float = 0.0,
    method: str = "auto",
    theta: float = 0.7,
    quadrupole: bool = False,
    leaf_size: int = 32,
) -> np.ndarray:
    r"""Add ``coupling · scale_i · Σ_j w_j (x_j - x_i) / (r² + ε²)^{3/2}`` to ``out``.

    Parameters
    ----------
    position : float32 or float64 array of shape (3, n)
        Particle positions [m]; the sums run in this precision.
    weight : array of shape (n,)
        Source weights ``w`` (masses [kg], charges [C]).
    out : array of shape (3, n), the dtype of ``position``
        Accumulator, added to.
    coupling : float
        ``c`` (``G``, ``-k_e``; 1 gives the field per unit weight).
    scale : array of shape (n,), optional
        Per-target factor (the target's own mass or charge); 1 by default.
    softening : float
        Plummer softening length ``ε`` >= 0 [m].
    method : {"auto", "direct", "barnes_hut"}
    theta : float
        Barnes–Hut opening angle in (0, 1].
    quadrupole : bool
        Barnes–Hut: add the nodes' quadrupole moments.
    leaf_size : int
        Barnes–Hut: points per leaf (and group of targets walked together).

    Returns
    -------
    out
    """
    check_buffers(position, out)
    dtype = position.dtype
    if dtype not in (np.float32, np.float64) or out.dtype != dtype:
        raise ValueError(
            f"position and out must be float32 or float64 of one dtype, got {dtype}, {out.dtype}"
        )
    n = position.shape[1]
    method = check.choice("method", method, METHODS)
    theta = check.real("theta", theta, low=0.0, high=1.0, low_open=True)
    softening = check.non_negative("softening", softening)
    leaf_size = check.integer("leaf_size", leaf_size, low=1)
    if n == 0:
        return out
    weight = np.ascontiguousarray(weight, dtype=dtype)
    if weight.shape != (n,):
        raise ValueError(f"weight must have shape ({n},), got {weight.shape}")
    scale = np.ones(n, dtype) if scale is None else np.ascontiguousarray(scale, dtype=dtype)
    if scale.shape != (n,):
        raise ValueError(f"scale must have shape ({n},), got {scale.shape}")
    if method == "auto":
        method = "barnes_hut" if n >= AUTO_BARNES_HUT else "direct"
    rows = [np.ascontiguousarray(r) for r in position]
    real = dtype.type
    eps2 = real(softening * softening)
    with threads_for(n):
        if method == "direct":
            kernels.direct_kernel(*rows, weight, scale, real(coupling), eps2, *out)
        else:
            if weight.min() < 0 < weight.max():
                raise ValueError(
                    "barnes_hut needs weights of one sign (a centre of mixed charges is "
                    "undefined); use method='direct'"
                )
            options = (theta, quadrupole, leaf_size)
            _barnes_hut(rows, weight, scale, real(coupling), eps2, *options, out)
    return out


def _barnes_hut(rows, weight, scale, coupling, eps2, theta, quadrupole, leaf_size, out):
    dtype = weight.dtype
    n = weight.shape[0]
    with threads_for(n, below=TREE_SERIAL_BELOW):
        tree = Octree(leaf_size=leaf_size).build(np.stack(rows))
        sx, sy, sz, sw = (np.empty(n, dtype) for _ in range(4))
        kernels.gather_kernel(*rows, weight, tree.order, sx, sy, sz, sw)
        nodes = tree.node_start.shape[0]
        com = np.empty((3, nodes))
        mass = np.empty(nodes)
        quad = np.empty((6, nodes))
        levels = tree.level_start
        for level in range(levels.shape[0] - 2, -1, -1):
            kernels.moments_kernel(
                levels[level], levels[level + 1], tree.node_start, tree.node_count,
                tree.node_child, tree.node_children, sx, sy, sz, sw, tree.node_center,
                com, mass, quad,
            )  # fmt: skip
    offset = np.sqrt(((com - tree.node_center) ** 2).sum(axis=0))
    accept2 = (tree.node_size / theta + offset) ** 2
    leaves = tree.leaves()
    leaves = leaves[np.argsort(tree.node_start[leaves], kind="stable")]
    kernels.barnes_hut_kernel(
        sx, sy, sz, sw, tree.order, leaves, tree.node_start, tree.node_count,
        tree.node_child, tree.node_children, com.astype(dtype), mass.astype(dtype),
        quad.astype(dtype), accept2.astype(dtype), eps2, bool(quadrupole), scale,
        coupling, *out,
    )  # fmt: skip


class _InverseSquare(Force):
    """Shared parameters of :class:`NBodyGravity` and :class:`Coulomb`."""

    def __init__(self, softening, method, theta, quadrupole, leaf_size):
        self.softening = check.non_negative("softening", softening)
        self.method = check.choice("method", method, METHODS)
        self.theta = check.real("theta", theta, low=0.0, high=1.0, low_open=True)
        if not isinstance(quadrupole, bool):
            raise TypeError(f"quadrupole must be True or False, got {quadrupole!r}")
        self.quadrupole = quadrupole
        self.leaf_size = check.integer("leaf_size", leaf_size, low=1)

    def _options(self) -> dict:
        return {
            "softening": self.softening,
            "method": self.method,
            "theta": self.theta,
            "quadrupole": self.quadrupole,
            "leaf_size": self.leaf_size,
        }


class NBodyGravity(_InverseSquare):
    r"""Newtonian gravity between every pair of particles, Plummer-softened.

    ``F_i = G m_i Σ_j m_j (x_j - x_i) / (|x_j - x_i|² + ε²)^{3/2}`` [N].

    Parameters
    ----------
    G : float
        Gravitational constant > 0 [m^3 kg^-1 s^-2]; SI by default (:data:`G_SI`), 1 for
        N-body units.
    softening : float
        Plummer softening length ``ε`` >= 0 [m].
    method : {"auto", "direct", "barnes_hut"}
        Summation (see :mod:`motes.forces.nbody`).
    theta : float
        Barnes–Hut opening angle in (0, 1]: smaller is more accurate and slower
        (``docs/nbody.md`` tabulates both).
    quadrupole : bool
        Barnes–Hut: add quadrupole moments (smaller errors at the same ``θ``).
    leaf_size : int
        Barnes–Hut: points per leaf >= 1.

    Notes
    -----
    Masses are the ``mass`` attribute (1 kg each without one). The sum runs in the
    positions' precision.

    Examples
    --------
    >>> import numpy as np
    >>> from motes.forces.apply import add_forces
    >>> position = np.array([[0.0, 1.0], [0.0, 0.0], [0.0, 0.0]])
    >>> f = add_forces([NBodyGravity(G=1.0)], position, np.zeros((3, 2)), np.array([2.0, 3.0]), 0.0)
    >>> f[0].tolist()
    [6.0, -6.0]
    """

    reads = ("position",)

    def __init__(
        self,
        G: float = G_SI,
        *,
        softening: float = 0.0,
        method: str = "auto",
        theta: float = 0.7,
        quadrupole: bool = False,
        leaf_size: int = 32,
    ):
        self.G = check.positive("G", G)
        super().__init__(softening, method, theta, quadrupole, leaf_size)

    def __repr__(self) -> str:
        return f"NBodyGravity(G={self.G}, softening={self.softening}, method={self.method!r})"

    def accumulate(self, store, position, velocity, time, out) -> None:
        check_buffers(position, out)
        n = position.shape[1]
        mass = particle_mass(store, n, position.dtype)
        weight = np.ones(n, position.dtype) if mass.shape[0] == 0 else mass
        inverse_square(position, weight, out, coupling=self.G, scale=weight, **self._options())

    def potential_energy(self, position: np.ndarray, mass: np.ndarray) -> float:
        """``W = -G Σ_{i<j} m_i m_j / sqrt(r² + ε²)`` [J], by direct summation in float64.

        For validation and diagnostics (O(n²) memory-light loops in NumPy blocks).
        """
        return -self.G * pair_potential_sum(position, mass, self.softening)


class Coulomb(_InverseSquare):
    r"""Coulomb's law between every pair of charged particles, optionally softened.

    ``F_i = -k q_i Σ_j q_j (x_j - x_i) / (|x_j - x_i|² + ε²)^{3/2}`` [N]: like charges
    repel, unlike attract.

    Parameters
    ----------
    charge : str
        Name of the attribute holding each particle's charge [C]; ``"charge"`` is a
        built-in attribute (0 C unless an emitter sets it).
    k : float
        Coulomb constant > 0 [N m^2 C^-2]; SI by default (:data:`K_COULOMB`).
    softening : float
        Softening length ``ε`` >= 0 [m] (0: the exact law; coincident particles then
        exert nothing on each other).
    method : {"auto", "direct", "barnes_hut"}
        Summation; Barnes–Hut only for charges of one sign.
    theta, quadrupole, leaf_size
        As for :class:`NBodyGravity`.
    """

    def __init__(
        self,
        charge: str = "charge",
        *,
        k: float = K_COULOMB,
        softening: float = 0.0,
        method: str = "auto",
        theta: float = 0.7,
        quadrupole: bool = False,
        leaf_size: int = 32,
    ):
        if not isinstance(charge, str) or not charge.isidentifier():
            raise ValueError(f"charge must be an attribute name, got {charge!r}")
        self.charge = charge
        self.reads = ("position", charge)
        self.k = check.positive("k", k)
        super().__init__(softening, method, theta, quadrupole, leaf_size)

    def __repr__(self) -> str:
        return f"Coulomb({self.charge!r}, k={self.k}, softening={self.softening})"

    def bind(self, store) -> None:
        from ..particles import BUILTIN

        store.require("position")
        if store.has(self.charge):
            return
        if self.charge in BUILTIN:
            store.require(self.charge)
        else:
            raise KeyError(
                f"Coulomb reads charges from attribute {self.charge!r}, which this store "
                "lacks: declare it with motes.Attribute"
            )

    def accumulate(self, store, position, velocity, time, out) -> None:
        check_buffers(position, out)
        n = position.shape[1]
        if not store.has(self.charge):
            raise KeyError(
                f"Coulomb reads charges from attribute {self.charge!r}, which these particles lack"
            )
        charge = np.asarray(store.raw(self.charge)[:n], dtype=position.dtype)
        inverse_square(position, charge, out, coupling=-self.k, scale=charge, **self._options())


def pair_potential_sum(position: np.ndarray, weight: np.ndarray, softening: float) -> float:
    """``Σ_{i<j} w_i w_j / sqrt(|x_i - x_j|² + ε²)`` in float64 (NumPy, row blocks).

    Parameters
    ----------
    position : array of shape (3, n) [m]
    weight : array of shape (n,)
    softening : float
        ``ε`` [m].
    """
    p = np.asarray(position, dtype=np.float64)
    w = np.asarray(weight, dtype=np.float64)
    n = p.shape[1]
    total = 0.0
    eps2 = float(softening) ** 2
    rows = max(1, 4_000_000 // max(n, 1))
    for lo in range(0, n, rows):
        hi = min(n, lo + rows)
        d = p[:, lo:hi, None] - p[:, None, :]
        r = np.sqrt((d * d).sum(axis=0) + eps2)
        idx = np.arange(lo, hi)[:, None]
        upper = np.arange(n)[None, :] > idx
        total += float((w[lo:hi, None] * w[None, :] / np.where(upper, r, np.inf)).sum())
    return total
