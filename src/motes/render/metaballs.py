r"""Metaball surfaces of particles: Blinn's Gaussian field, meshed by marching cubes.

J. F. Blinn, "A generalization of algebraic surface drawing", ACM Transactions on
Graphics 1(3), 1982. Each particle ``i`` at ``p_i`` contributes a Gaussian bump, and the
surface is where their sum reaches the threshold ``T``:

.. math:: D(x) = \sum_i b_i\, e^{-a |x - p_i|^2}, \qquad D(x) = T.

A lone particle gives a sphere of radius :math:`r = \sqrt{\ln(b/T) / a}`; nearby
particles blend smoothly. The surface is extracted from ``D`` sampled on a grid by
:func:`~motes.render.marching_cubes.marching_cubes` (Lorensen & Cline 1987), and its
vertex normals are the analytic :math:`-\nabla D / |\nabla D|` with

.. math:: \nabla D(x) = -2a \sum_i b_i\, (x - p_i)\, e^{-a |x - p_i|^2}.

Cut-off and the spatial grid
----------------------------
A contribution below ``cutoff * T`` is dropped, so particle ``i`` reaches only the nodes
within :math:`r_{c,i} = \sqrt{\ln(b_i / (\text{cutoff}\, T)) / a}`: nodes further than
``r_c`` from every particle are exactly 0. Particles are binned by a counting sort into
bins of whole cells at least ``r_c / SPLIT`` wide, sorted z-fastest, so a column of bins
is one contiguous run of particles.

The field is a gather: each column of nodes (a few bins wide in x and y, the whole grid
in z) sums, node by node, the particles of the bins within ``SPLIT`` of its own, in
their sorted order. Columns write disjoint nodes, so there are no races, and every node
sums its particles in bin order whatever the columns and threads: the field does not
depend on the number of threads. The Gaussian is separable,
:math:`e^{-a|d|^2} = e^{-a d_x^2} e^{-a d_y^2} e^{-a d_z^2}`, so a particle costs three
short rows of exponentials per column it reaches and one multiply-add per node.

The normals are a gather too: mesh vertices are counting-sorted into cubes of
``GROUP_BINS`` bins; each cube collects the particles within reach of it once, and each
of its vertices sums over that list: the terms in one vectorised loop, then their sum in
a fixed order (compiled code may not reorder a sum, see ``motes._jit.FASTMATH``).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np
from numba.core import types
from numba.extending import intrinsic, overload

from .. import _validate
from .._jit import (
    block_bounds,
    block_count,
    device,
    fma,
    ordered_sum,
    parallel_kernel,
    serial_kernel,
    threads_for,
)
from ..geometry.mesh import TriangleMesh
from .marching_cubes import _marching_cubes, spread_order

#: Default largest grid [nodes] :meth:`Metaballs.field` and :meth:`Metaballs.mesh` build:
#: 256³. Meshing takes about 19 B per node (the float32 field, three int32 edge indices,
#: three bytes of signs, crossings and cases), 320 MB at this size.
MAX_NODES = 256**3


#: Bins are whole cells at least ``r_c / SPLIT`` wide, so a particle reaches ``SPLIT`` bins
#: each way. Finer bins test fewer particles that turn out too far (a cube of 3 bins of
#: width ``r_c`` holds 6.4 times the particles of the ball of radius ``r_c``; of width
#: ``r_c / 2``, about 3 times) for more, shorter runs of particles to start.
SPLIT = 2

#: Float32 SIMD lanes (AVX2): loops over few items are padded to a multiple of this.
LANES = 8

#: A squared distance [m²] beyond every reach, for padding (finite: ``fastmath`` assumes
#: no infinities).
FAR = np.float32(3e38)

#: Points whose gradient is evaluated together (one list of nearby particles) lie in a
#: cube of this many bins a side.
GROUP_BINS = 2

#: Point groups per parallel work item of the gradient; they share one scratch list.
GROUPS = 64

#: Width [nodes] in x and y of the node columns the field is gathered by, at most.
COLUMN_NODES = 32


def _float32_from_bits(bits):
    """The float32 whose bit pattern is the int32 ``bits`` (a bitcast, no conversion)."""
    return np.array(bits, dtype=np.int32).view(np.float32)[()]


@intrinsic
def _bitcast_float32(typingctx, bits):
    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], context.get_value_type(types.float32))

    return types.float32(types.int32), codegen


@overload(_float32_from_bits, inline="always")
def _float32_from_bits_compiled(bits):
    # Compiled code bitcasts in a register (vectorisable); the Python version above runs
    # when NUMBA_DISABLE_JIT=1 (coverage runs).
    return lambda bits: _bitcast_float32(bits)


@device
def _exp(x):
    """``e^x`` for float32 ``x <= 0``, relative error < 1.1e-6 for ``x > -15`` (the field's
    exponents stay above ``-ln(b_i / (cutoff T))``), < 4e-6 down to -87.

    The C library's ``expf`` is a function call, which stops LLVM vectorising a loop;
    this is branch-free arithmetic that it can. ``e^x = 2^n 2^f`` with ``n`` the nearest
    integer to ``x / ln 2`` and ``|f| <= 1/2``: ``2^f`` by its Taylor series to degree 6
    (truncation 1.2e-7), ``2^n`` by writing the exponent bits. Arguments below -87 give
    ``e^-87`` (not 0) instead of a subnormal.
    """
    t = max(x, np.float32(-87.0)) * np.float32(1.4426950408889634)
    n = np.floor(t + np.float32(0.5))
    f = (t - n) * np.float32(0.6931471805599453)
    # Horner's scheme in fused multiply-adds (motes._jit.fma).
    p = np.float32(1.0 / 720.0)
    p = fma(p, f, np.float32(1.0 / 120.0))
    p = fma(p, f, np.float32(1.0 / 24.0))
    p = fma(p, f, np.float32(1.0 / 6.0))
    p = fma(p, f, np.float32(0.5))
    p = fma(p, f, np.float32(1.0))
    p = fma(p, f, np.float32(1.0))
    return p * _float32_from_bits((np.int32(n) + np.int32(127)) << np.int32(23))


@serial_kernel
def _bin_kernel(positions, origin, bin_size, bin_shape, strength, radius2, offsets, sorted_):
    """Counting sort of particles into bins, stable (so deterministic).

    Bin ``(bx, by, bz)`` (flat index ``(bx * nby + by) * nbz + bz``) holds the particles
    with ``floor((p - origin) / bin_size) + SPLIT == (bx, by, bz)``: ``SPLIT`` layers of
    bins outside the grid on each side catch particles that reach in from outside.
    Particles further out, or with ``radius2 <= 0`` (too weak to reach ``cutoff * T``),
    are dropped. ``offsets`` (nbins + 1,) receives the start of each bin, ``sorted_``
    (5, n) the kept particles' position relative to ``origin`` [m], strength ``b_i`` and
    squared reach ``r_c,i²`` [m²] in bin order. Returns the number kept.
    """
    n = positions.shape[0]
    nbins = bin_shape[0] * bin_shape[1] * bin_shape[2]
    bins = np.empty(n, dtype=np.int64)
    offsets[:] = 0
    for p in range(n):
        flat = 0
        for axis in range(3):
            cell = np.floor((positions[p, axis] - origin[axis]) / bin_size[axis]) + SPLIT
            if not (0.0 <= cell < bin_shape[axis]) or radius2[p] <= 0.0:
                flat = -1
                break
            flat = flat * bin_shape[axis] + int(cell)
        bins[p] = flat
        if flat >= 0:
            offsets[flat + 1] += 1
    for b in range(nbins):
        offsets[b + 1] += offsets[b]
    fill = offsets[:-1].copy()
    for p in range(n):
        b = bins[p]
        if b < 0:
            continue
        q = fill[b]
        fill[b] += 1
        for axis in range(3):
            sorted_[axis, q] = positions[p, axis] - origin[axis]
        sorted_[3, q] = strength[p]
        sorted_[4, q] = radius2[p]
    return offsets[nbins]


@device
def _axis_factors(x, reach, h, lo, hi, a, factor, d2):
    """The nodes ``[start, start + count)`` within ``[lo, hi)`` whose coordinate ``node h``
    is within ``reach`` of ``x`` along one axis, with ``factor[q] = e^{-a d²}`` and
    ``d2[q] = d²`` for each (``d`` the node's offset [m]). Past ``count``, up to the
    length of the arrays, ``factor`` is 0 and ``d2`` is :data:`FAR`, so loops may run
    whole SIMD vectors without effect. Returns ``(start, count)``.
    """
    start = max(lo, math.ceil((x - reach) / h))
    count = max(min(hi, math.floor((x + reach) / h) + 1) - start, 0)
    for q in range(factor.size):
        d = np.float32((start + q) * h) - x
        inside = q < count
        d2[q] = d * d if inside else FAR
        factor[q] = _exp(-a * d * d) if inside else np.float32(0.0)
    return start, count


@parallel_kernel
def _field_kernel(
    particles, offsets, bin_shape, bin_nodes, column_bins, a, spacing, width, order, out
):
    """Blinn's field at every node (module docstring), gathered by columns of nodes.

    ``particles`` (5, n) and ``offsets`` come from :func:`_bin_kernel`. A column is
    ``column_bins`` bins in x and y (``bin_nodes`` nodes each) and the whole grid in z;
    it sums into a local buffer with ``width`` spare nodes at the end of each row, so the
    innermost loop can run a whole number of SIMD vectors (a particle reaches ~9 nodes
    along a row: 8 + 1 left the 9th to a scalar remainder, which cost more than the
    vector). That loop runs over unsigned indices, so Numba adds no negative-index
    wraparound that would stop it from vectorising (see ``_jit.block_bounds``).
    ``width`` (a multiple of :data:`LANES`) must exceed the nodes a particle reaches
    along an axis.
    """
    nx, ny, nz = out.shape
    nbx, nby, nbz = bin_shape[0], bin_shape[1], bin_shape[2]
    kx, ky = column_bins[0], column_bins[1]
    mx, my = kx * bin_nodes[0], ky * bin_nodes[1]
    ncy = (ny + my - 1) // my
    nzp = nz + width
    hx, hy, hz = spacing[0], spacing[1], spacing[2]
    for c in numba.prange(order.size):
        cx, cy = divmod(order[c], ncy)
        i0, i1 = cx * mx, min(nx, cx * mx + mx)
        j0, j1 = cy * my, min(ny, cy * my + my)
        acc = np.zeros(mx * my * nzp, dtype=np.float32)
        scratch = np.empty((6, width), dtype=np.float32)
        fx, dx2, fy, dy2, fz, dz2 = scratch
        # The column's bins start at bin (cx kx + SPLIT, cy ky + SPLIT); particles can
        # reach it from SPLIT bins further each way. For one bx, the bins (bx, by, all z)
        # over that range of by are one contiguous run.
        y_stop = min(nby, cy * ky + ky + 2 * SPLIT)
        for bx in range(cx * kx, min(nbx, cx * kx + kx + 2 * SPLIT)):
            start = offsets[(bx * nby + cy * ky) * nbz]
            stop = offsets[(bx * nby + y_stop) * nbz]
            for p in range(start, stop):
                px, py, pz = particles[0, p], particles[1, p], particles[2, p]
                s, r2 = particles[3, p], particles[4, p]
                r = math.sqrt(r2)
                # Cheap rejection first: most particles of the runs miss the column.
                if px + r < i0 * hx or px - r > (i1 - 1) * hx:
                    continue
                if py + r < j0 * hy or py - r > (j1 - 1) * hy:
                    continue
                ia, ni = _axis_factors(px, r, hx, i0, i1, a, fx, dx2)
                ja, nj = _axis_factors(py, r, hy, j0, j1, a, fy, dy2)
                ka, nk = _axis_factors(pz, r, hz, 0, nz, a, fz, dz2)
                nq = np.uint64(-(-nk // LANES) * LANES)
                for qi in range(ni):
                    for qj in range(nj):
                        rest = r2 - dx2[qi] - dy2[qj]
                        if rest <= 0.0:
                            continue  # the row is out of reach
                        w = s * fx[qi] * fy[qj]
                        row = np.uint64(((ia + qi - i0) * my + ja + qj - j0) * nzp + ka)
                        for q in range(nq):
                            acc[row + q] += w * fz[q] if dz2[q] < rest else np.float32(0.0)
        for i in range(i0, i1):
            for j in range(j0, j1):
                row = ((i - i0) * my + j - j0) * nzp
                out[i, j, :] = acc[row : row + nz]


@parallel_kernel
def _group_key_kernel(points, origin, group_size, group_shape, keys):
    """``keys[v]``: the flat index ``(gx * ngy + gy) * ngz + gz`` of the cube of
    ``group_size`` [m] from ``origin + group_size * (gx, gy, gz)`` holding point ``v``;
    points outside the grid go to the nearest cube."""
    m = points.shape[0]
    for block in numba.prange(block_count(m)):
        start, stop = block_bounds(block, m)
        for v in range(start, stop):
            key = 0
            for c in range(3):
                g = np.floor((points[v, c] - origin[c]) / group_size[c])
                key = key * group_shape[c] + int(min(max(g, 0.0), group_shape[c] - 1))
            keys[v] = key


@serial_kernel
def _group_kernel(keys, group_count, order, groups, group_keys):
    """Counting sort of points by group key (:func:`_group_key_kernel`), stable.

    ``order`` (m,) receives the point indices group by group; ``groups`` (m + 1,) the
    start of each occupied group in ``order`` and ``group_keys`` (m,) its key. Returns
    the number of occupied groups.
    """
    m = keys.size
    counts = np.zeros(group_count + 1, dtype=np.int64)
    for v in range(m):
        counts[keys[v] + 1] += 1
    occupied = 0
    for key in range(group_count):
        if counts[key + 1]:
            groups[occupied] = counts[key]
            group_keys[occupied] = key
            occupied += 1
        counts[key + 1] += counts[key]
    groups[occupied] = m
    for v in range(m):
        order[counts[keys[v]]] = v
        counts[keys[v]] += 1
    return occupied


@parallel_kernel
def _gradient_kernel(
    points, origin, order, groups, group_keys, group_shape, group_bins, particles, offsets,
    bin_shape, bin_size, a, reach2, unit, out,
):  # fmt: skip
    """∇D (module docstring) at ``points`` (m, 3) [m], or with ``unit`` the outward unit
    normal ``-∇D / |∇D|`` (0 where ``∇D = 0``).

    Points come grouped by cubes of ``group_bins`` bins a side (:func:`_group_kernel`;
    ``group_shape`` cubes along each axis).
    Each group first copies the particles within ``sqrt(reach2)`` (the largest ``r_c``)
    of its cube into a local list padded to whole SIMD vectors, then each of its points
    computes its terms over that list in one contiguous, vectorised loop, testing each
    particle's own ``r_c``, and adds them with :func:`motes._jit.ordered_sum`. Groups
    write disjoint points: no races, and each point's sum has a fixed order.
    """
    nbx, nby, nbz = bin_shape[0], bin_shape[1], bin_shape[2]
    ngy, ngz = group_shape[1], group_shape[2]
    gs = group_bins
    wx, wy, wz = bin_size[0], bin_size[1], bin_size[2]
    n_groups = group_keys.size
    for block in numba.prange((n_groups + GROUPS - 1) // GROUPS):
        near = np.empty((5, 0), dtype=np.float32)
        terms = np.empty((3, 0), dtype=np.float32)
        for g in range(block * GROUPS, min(n_groups, block * GROUPS + GROUPS)):
            gx, rest = divmod(group_keys[g], ngy * ngz)
            gy, gz = divmod(rest, ngz)
            # The group's cube spans [l, l + gs w) on each axis relative to the origin;
            # its bins are gs * (gx, gy, gz) + SPLIT + [0, gs), and particles can reach
            # it from SPLIT bins further each way.
            lx, ly, lz = gx * gs * wx, gy * gs * wy, gz * gs * wz
            x0, x1 = gx * gs, min(nbx, gx * gs + gs + 2 * SPLIT)
            y0, y1 = gy * gs, min(nby, gy * gs + gs + 2 * SPLIT)
            z0, z1 = gz * gs, min(nbz, gz * gs + gs + 2 * SPLIT)
            total = 0
            for cx in range(x0, x1):
                for cy in range(y0, y1):
                    col = (cx * nby + cy) * nbz
                    total += offsets[col + z1] - offsets[col + z0]
            if near.shape[1] < total + LANES:
                near = np.empty((5, 2 * total + LANES), dtype=np.float32)
                terms = np.empty((3, 2 * total + LANES), dtype=np.float32)
            # Copy the particles within reach of the cube, branch-free (always write, keep
            # by advancing the count): which ones are kept is unpredictable.
            count = 0
            for cx in range(x0, x1):
                for cy in range(y0, y1):
                    col = (cx * nby + cy) * nbz
                    for p in range(offsets[col + z0], offsets[col + z1]):
                        x, y, z = particles[0, p], particles[1, p], particles[2, p]
                        ex = max(lx - x, x - (lx + gs * wx), 0.0)
                        ey = max(ly - y, y - (ly + gs * wy), 0.0)
                        ez = max(lz - z, z - (lz + gs * wz), 0.0)
                        for c in range(5):
                            near[c, count] = particles[c, p]
                        count += ex * ex + ey * ey + ez * ez < reach2
            # Pad to whole SIMD vectors with particles of no strength and no reach.
            padded = -(-count // LANES) * LANES
            for p in range(count, padded):
                for c in range(4):
                    near[c, p] = 0.0
                near[4, p] = -1.0
            for slot in range(groups[g], groups[g + 1]):
                v = order[slot]
                x = np.float32(points[v, 0] - origin[0])
                y = np.float32(points[v, 1] - origin[1])
                z = np.float32(points[v, 2] - origin[2])
                # Two passes: the terms (vectorised: no sum in the loop), then their sums
                # in a fixed order (see _jit.ordered_sum).
                for p in range(np.uint64(padded)):
                    dx = x - near[0, p]
                    dy = y - near[1, p]
                    dz = z - near[2, p]
                    d2 = fma(dx, dx, fma(dy, dy, dz * dz))
                    e = near[3, p] * _exp(-a * d2)
                    e = e if d2 < near[4, p] else np.float32(0.0)
                    terms[0, p] = e * dx
                    terms[1, p] = e * dy
                    terms[2, p] = e * dz
                sx = ordered_sum(terms[0], padded)
                sy = ordered_sum(terms[1], padded)
                sz = ordered_sum(terms[2], padded)
                if unit:  # -∇D / |∇D| = s / |s|
                    length = math.sqrt(sx * sx + sy * sy + sz * sz)
                    scale = np.float32(1.0) / length if length > 0.0 else np.float32(0.0)
                else:  # ∇D = -2a s
                    scale = np.float32(-2.0) * a
                out[v, 0] = scale * sx
                out[v, 1] = scale * sy
                out[v, 2] = scale * sz


# -- launchers ----------------------------------------------------------------------------
class _Bins(NamedTuple):
    """Particles counting-sorted into bins aligned with a node grid."""

    particles: np.ndarray  # (5, kept) float32: x, y, z relative to origin [m], b, r_c² [m²]
    offsets: np.ndarray  # (nbins + 1,) int64
    shape: np.ndarray  # (3,) int64 bins per axis, SPLIT guard layers each side included
    nodes: np.ndarray  # (3,) int64 nodes per bin along each axis
    size: np.ndarray  # (3,) float64 bin width [m], >= the largest r_c / SPLIT
    origin: np.ndarray  # (3,) float64 grid origin [m]
    reach2: float  # the largest r_c² [m²]


class Metaballs:
    r"""Blinn (1982) metaballs: a smooth surface around particles.

    Each particle adds ``b * exp(-a |x - p|²)`` to a field ``D``; the surface is
    ``D = threshold`` (module docstring). :meth:`from_radius` sets ``a`` and ``b`` from the
    radius of a lone particle's sphere.

    Parameters
    ----------
    a : float
        Falloff ``a`` > 0 [1/m²].
    b : float
        Strength ``b`` > 0 of one particle [field units]. A lone particle has a surface
        only when ``b > threshold``; below that only clusters show.
    threshold : float
        Iso-value ``T`` > 0 [field units].
    cell_size : float
        Grid spacing ``h`` > 0 [m]. Marching cubes interpolates linearly along cell
        edges, so features smaller than a few cells are lost.
    cutoff : float, optional
        Contributions below ``cutoff * threshold`` are dropped, 0 < cutoff < min(1, b/T).
        Sets the reach of a particle, ``r_c = sqrt(ln(b / (cutoff T)) / a)`` [m], and the
        field's error: at most ``cutoff * T`` per particle whose reach ends short of a
        node.
    padding : int, optional
        Empty cells >= 0 added around ``r_c`` on each side of the automatic grid.
    max_nodes : int, optional
        Largest grid [nodes] built; a larger one raises ``ValueError`` (memory guard,
        see :data:`MAX_NODES`).
    """

    def __init__(
        self,
        *,
        a: float,
        b: float,
        threshold: float,
        cell_size: float,
        cutoff: float = 1e-3,
        padding: int = 1,
        max_nodes: int = MAX_NODES,
    ):
        self.a = _validate.positive("a", a)
        self.b = _validate.positive("b", b)
        self.threshold = _validate.positive("threshold", threshold)
        self.cell_size = _validate.positive("cell_size", cell_size)
        self.cutoff = _validate.real(
            "cutoff",
            cutoff,
            low=0.0,
            high=min(1.0, self.b / self.threshold),
            low_open=True,
            high_open=True,
        )
        self.padding = _validate.integer("padding", padding, low=0)
        self.max_nodes = _validate.integer("max_nodes", max_nodes, low=8)

    @classmethod
    def from_radius(
        cls,
        radius: float,
        *,
        sharpness: float = 2.0,
        threshold: float = 1.0,
        cell_size: float | None = None,
        cutoff: float = 1e-3,
        padding: int = 1,
        max_nodes: int = MAX_NODES,
    ) -> Metaballs:
        """Metaballs where a lone particle gives a sphere of ``radius`` [m].

        ``sharpness`` = ``ln(b/T)`` = ``a r²`` > 0 is minus Blinn's "blobbiness" ``B``:
        larger values blend less and reach less far (``r_c / r =
        sqrt(1 + ln(1/cutoff) / sharpness)``). ``cell_size`` defaults to ``radius / 3``.
        """
        radius = _validate.positive("radius", radius)
        sharpness = _validate.positive("sharpness", sharpness)
        threshold = _validate.positive("threshold", threshold)
        return cls(
            a=sharpness / radius**2,
            b=threshold * math.exp(sharpness),
            threshold=threshold,
            cell_size=radius / 3.0 if cell_size is None else cell_size,
            cutoff=cutoff,
            padding=padding,
            max_nodes=max_nodes,
        )

    def __repr__(self) -> str:
        return (
            f"Metaballs(a={self.a:g}, b={self.b:g}, threshold={self.threshold:g}, "
            f"cell_size={self.cell_size:g}, cutoff={self.cutoff:g})"
        )

    @property
    def radius(self) -> float:
        """Radius [m] of a lone particle's sphere, ``sqrt(ln(b/T)/a)``; 0 if ``b <= T``."""
        return math.sqrt(max(math.log(self.b / self.threshold), 0.0) / self.a)

    @property
    def cutoff_radius(self) -> float:
        """Reach ``r_c`` [m] of a particle of weight 1 (class docstring)."""
        return math.sqrt(math.log(self.b / (self.cutoff * self.threshold)) / self.a)

    # -- public operations ----------------------------------------------------------------
    def field(self, positions, origin, shape, spacing=None, *, weights=None) -> np.ndarray:
        """Blinn's field ``D`` on a grid, with the cut-off (class docstring).

        Parameters
        ----------
        positions : (n, 3) array_like
            Particle positions [m].
        origin : (3,) array_like
            Position [m] of node ``(0, 0, 0)``.
        shape : (3,) sequence of int
            Nodes ``(nx, ny, nz)`` along each axis, each >= 1.
        spacing : float or (3,) array_like, optional
            Node spacing [m], > 0; defaults to ``cell_size``.
        weights : (n,) array_like, optional
            Per-particle factors >= 0 on ``b``.

        Returns
        -------
        (nx, ny, nz) float32
            ``D`` at ``origin + spacing * (i, j, k)``; exactly 0 further than ``r_c`` from
            every particle.
        """
        positions = _positions(positions)
        origin = _validate.vector("origin", origin)
        shape = _shape(shape, self.max_nodes)
        spacing = self._spacing(spacing)
        strength, radius2 = self._strengths(weights, len(positions))
        bins = self._bin(positions, strength, radius2, origin, spacing, shape)
        return _field(bins, self.a, spacing, shape)

    def gradient(self, points, positions, *, weights=None) -> np.ndarray:
        """Analytic gradient ``∇D`` [field units/m] of the field (with the cut-off).

        Parameters
        ----------
        points : (m, 3) array_like
            Where to evaluate it [m].
        positions : (n, 3) array_like
            Particle positions [m].
        weights : (n,) array_like, optional
            Per-particle factors >= 0 on ``b``.

        Returns
        -------
        (m, 3) float32
        """
        return self._at_points(points, positions, weights, unit=False)

    def normals(self, points, positions, *, weights=None) -> np.ndarray:
        """Outward unit normals ``-∇D / |∇D|`` at ``points`` (m, 3) [m], (m, 3) float32.

        Zero where ``∇D = 0``. Arguments as for :meth:`gradient`.
        """
        return self._at_points(points, positions, weights, unit=True)

    def mesh(self, positions, *, weights=None, bounds=None) -> TriangleMesh:
        """The metaball surface of particles at ``positions`` (n, 3) [m].

        Parameters
        ----------
        positions : (n, 3) array_like
            Particle positions [m]; none gives an empty mesh.
        weights : (n,) array_like, optional
            Per-particle factors >= 0 on ``b`` (a particle's strength is ``weight * b``).
        bounds : ((3,), (3,)) array_like, optional
            Lower and upper corners [m] of the grid. By default the particles' bounding
            box grown by ``r_c`` and ``padding`` cells, snapped to multiples of
            ``cell_size`` (so the grid does not shift with the particles) and the mesh is
            closed. A surface that crosses given bounds is open there.

        Returns
        -------
        TriangleMesh
            Outward counter-clockwise faces, unit normals ``-∇D / |∇D|``.
        """
        positions = _positions(positions)
        strength, radius2 = self._strengths(weights, len(positions))
        reach = radius2 > 0.0
        if not reach.any():
            return _empty_mesh()
        spacing = np.full(3, self.cell_size)
        if bounds is None:
            reached = positions[reach]
            margin = math.sqrt(radius2.max()) + self.padding * self.cell_size
            origin = np.floor((reached.min(axis=0) - margin) / self.cell_size) * self.cell_size
            upper = reached.max(axis=0) + margin
        else:
            origin, upper = _bounds(bounds)
        with np.errstate(over="ignore"):
            cells = np.floor((upper - origin) / self.cell_size) + 1
        shape = _shape(cells, self.max_nodes)
        if min(shape) < 2 and bounds is None:
            raise GridError(
                f"the particles' coordinates (up to {np.abs(positions).max():.3g} m) are too "
                f"large for cell_size={self.cell_size:g}: no cell fits between them"
            )
        if min(shape) < 2:
            raise ValueError(
                f"bounds must span at least one cell_size along each axis, got {shape}"
            )
        with threads_for(int(np.prod(shape))):
            bins = self._bin(positions, strength, radius2, origin, spacing, shape)
            field = _field(bins, self.a, spacing, shape)
            vertices, faces = _marching_cubes(field, self.threshold, spacing, origin)
            normals = _gradient(bins, self.a, vertices, unit=True)
        return TriangleMesh(vertices, faces, normals)

    # -- helpers --------------------------------------------------------------------------
    def _at_points(self, points, positions, weights, *, unit: bool) -> np.ndarray:
        points = _validate.points("points", points, min_rows=0)
        positions = _positions(positions)
        strength, radius2 = self._strengths(weights, len(positions))
        if len(points) == 0 or not np.any(radius2 > 0.0):
            return np.zeros((len(points), 3), dtype=np.float32)
        # Bins covering the points (their nodes are never evaluated): one bin per cell of
        # r_c / SPLIT, so the memory grows with the points' extent over r_c only.
        spacing = np.full(3, math.sqrt(float(radius2.max())) / SPLIT)
        lo = points.min(axis=0)
        shape = np.ceil((points.max(axis=0) - lo) / spacing).astype(np.int64) + 2
        if np.prod(shape) > self.max_nodes:
            raise ValueError(
                f"points spread over {np.prod(shape):,} bins of r_c / {SPLIT}, more than "
                f"max_nodes={self.max_nodes:,}: evaluate them in smaller batches"
            )
        bins = self._bin(positions, strength, radius2, lo, spacing, tuple(shape))
        return _gradient(bins, self.a, points, unit=unit)

    def _spacing(self, spacing) -> np.ndarray:
        if spacing is None:
            return np.full(3, self.cell_size)
        if np.ndim(spacing) == 0:
            return np.full(3, _validate.positive("spacing", spacing))
        spacing = _validate.vector("spacing", spacing)
        if np.any(spacing <= 0):
            raise ValueError(f"spacing must be > 0 along every axis, got {spacing.tolist()}")
        return spacing

    def _strengths(self, weights, n: int) -> tuple[np.ndarray, np.ndarray]:
        """Per-particle ``b_i`` (n,) and ``r_c,i²`` (n,) [m²], float32; ``r_c² <= 0``: no reach."""
        if weights is None:
            w = np.ones(n)
        else:
            w = np.asarray(weights, dtype=np.float64)
            if w.shape != (n,):
                raise ValueError(f"weights must have shape ({n},), got {w.shape}")
            if not np.all(np.isfinite(w)) or np.any(w < 0):
                raise ValueError("weights must be finite and >= 0")
        strength = self.b * w
        with np.errstate(divide="ignore"):
            radius2 = np.log(strength / (self.cutoff * self.threshold)) / self.a
        return strength.astype(np.float32), np.maximum(radius2, 0.0).astype(np.float32)

    def _bin(self, positions, strength, radius2, origin, spacing, shape) -> _Bins:
        """Counting-sort the particles into bins of whole cells >= ``r_c / SPLIT`` wide."""
        reach2 = float(radius2.max()) if len(radius2) else 0.0
        nodes = np.maximum(np.ceil(math.sqrt(reach2) / (SPLIT * spacing)), 1).astype(np.int64)
        bin_shape = -(-np.asarray(shape, dtype=np.int64) // nodes) + 2 * SPLIT
        size = nodes * spacing
        offsets = np.empty(int(np.prod(bin_shape)) + 1, dtype=np.int64)
        particles = np.empty((5, len(positions)), dtype=np.float32)
        kept = _bin_kernel(
            positions, origin, size, bin_shape, strength, radius2, offsets, particles
        )
        return _Bins(particles[:, :kept], offsets, bin_shape, nodes, size, origin, reach2)


def _field(bins: _Bins, a: float, spacing: np.ndarray, shape: tuple[int, int, int]) -> np.ndarray:
    """Launch :func:`_field_kernel`: the field on ``shape``."""
    reach_nodes = 2 * math.ceil(math.sqrt(bins.reach2) / float(spacing.min())) + 2
    width = -(-reach_nodes // LANES) * LANES
    out = np.empty(shape, dtype=np.float32)
    column_bins, columns = _columns(shape, bins.nodes)
    _field_kernel(
        bins.particles, bins.offsets, bins.shape, bins.nodes, column_bins, np.float32(a),
        spacing.astype(np.float32), width, spread_order(columns), out,
    )  # fmt: skip
    return out


def _columns(shape, bin_nodes) -> tuple[np.ndarray, int]:
    """Bins per column along x and y for :func:`_field_kernel`, and the column count.

    Wide columns are faster: a particle then visits one or two columns instead of four,
    and each visit has a fixed cost (2.2x faster at 32 nodes than at 3 on the benchmark
    splash). Columns shrink until every thread gets several. The field does not depend
    on the choice: each node sums its particles in bin order whatever the columns.
    """
    want = 4 * numba.get_num_threads()
    k = max(1, -(-COLUMN_NODES // int(min(bin_nodes[:2]))))
    while True:
        nodes = k * bin_nodes[:2]
        count = int(np.prod(-(-np.asarray(shape[:2]) // nodes)))
        if count >= want or k == 1:
            return np.full(2, k, dtype=np.int64), count
        k -= 1


def _gradient(bins: _Bins, a: float, points: np.ndarray, *, unit: bool = False) -> np.ndarray:
    """Launch the grouping kernels and :func:`_gradient_kernel`: ∇D at ``points``, or
    with ``unit`` the outward unit normals ``-∇D / |∇D|``."""
    points = np.ascontiguousarray(points)
    m = len(points)
    group_size = GROUP_BINS * bins.size
    group_shape = -(-(bins.shape - 2 * SPLIT) // GROUP_BINS)
    keys = np.empty(m, dtype=np.int64)
    _group_key_kernel(points, bins.origin, group_size, group_shape, keys)
    order = np.empty(m, dtype=np.int64)
    groups = np.empty(m + 1, dtype=np.int64)
    group_keys = np.empty(m, dtype=np.int64)
    occupied = _group_kernel(keys, int(np.prod(group_shape)), order, groups, group_keys)
    out = np.empty((m, 3), dtype=np.float32)
    _gradient_kernel(
        points, bins.origin, order, groups[: occupied + 1], group_keys[:occupied],
        group_shape, GROUP_BINS, bins.particles, bins.offsets, bins.shape, bins.size,
        np.float32(a), bins.reach2, unit, out,
    )  # fmt: skip
    return out


def _positions(positions) -> np.ndarray:
    return _validate.points("positions", positions, min_rows=0)


class GridError(ValueError):
    """The field's grid cannot be laid: it would exceed ``max_nodes`` (the particles
    spread too far for the cell size, or the cell is too small for the bounds), or the
    particles sit so far out that the cell size vanishes beside their coordinates."""


def _shape(shape, max_nodes: int) -> tuple[int, int, int]:
    """Node counts along x, y, z, refused past ``max_nodes`` in all. Counts may come as
    floats (a wide spread over a small cell is counted without integer overflow)."""
    counts = np.asarray(shape, dtype=np.float64).reshape(-1)
    if len(counts) != 3 or not np.all(counts >= 1) or np.any(counts != np.floor(counts)):
        raise ValueError(f"shape must be 3 node counts >= 1, got {shape}")
    with np.errstate(over="ignore"):
        nodes = float(np.prod(counts))
    if nodes > max_nodes:
        grow = (nodes / max_nodes) ** (1.0 / 3.0)
        shown = tuple(int(c) if math.isfinite(c) else c for c in counts)
        raise GridError(
            f"the grid would have {nodes:,.0f} nodes {shown}, more than "
            f"max_nodes={max_nodes:,}: use a cell_size at least {grow:.3g}x larger, tighter "
            "bounds, or raise max_nodes"
        )
    return tuple(int(c) for c in counts)


def _bounds(bounds) -> tuple[np.ndarray, np.ndarray]:
    try:
        lower, upper = bounds
    except (TypeError, ValueError):
        raise ValueError("bounds must be a pair (lower, upper) of 3-vectors") from None
    lower = _validate.vector("bounds[0]", lower)
    upper = _validate.vector("bounds[1]", upper)
    if np.any(upper <= lower):
        raise ValueError(f"bounds must have lower < upper on every axis, got {lower}, {upper}")
    return lower, upper


def _empty_mesh() -> TriangleMesh:
    return TriangleMesh(np.zeros((0, 3), np.float32), np.zeros((0, 3), np.int32))
