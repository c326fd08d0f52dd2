"""The one place that sets Numba's compilation flags.

Every compiled kernel in motes is decorated with one of the decorators below,
so the flags are chosen once:

- ``fastmath=FASTMATH``: every fast-math flag but ``reassoc`` and ``contract`` (see
  :data:`FASTMATH`), so that a kernel computes the same bits whether it was just compiled
  or loaded from the disk cache.
- ``error_model="numpy"``: the default ``"python"`` model inserts a zero-division check
  into every division, and that branch blocks SIMD in the whole loop.
- ``cache=True`` keeps compiled machine code on disk between processes (a first call
  costs ~0.3 s instead of ~1-2 s).
- ``parallel=True`` only on kernels whose ``prange`` iterations are independent. That
  alone does not make results independent of the thread count: with ``fastmath`` the
  vectorised body and the scalar remainder of a loop may round differently, and the
  thread count moves which particles fall in the remainder. So parallel kernels run
  ``prange`` over fixed blocks of :data:`BLOCK` particles (:func:`block_count`,
  :func:`block_bounds`) with a serial loop inside: the split is fixed by ``BLOCK``.
"""

from __future__ import annotations

import math
import os
from contextlib import contextmanager

import numba
import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.core import cgutils
from numba.core.errors import TypingError
from numba.extending import intrinsic, overload

#: LLVM fast-math flags of every kernel: ``fastmath=True`` less ``reassoc`` and ``contract``.
#:
#: Numba compiles what a kernel calls (the body of a ``prange`` loop, which becomes a
#: function of its own, and every compiled function it calls) twice: once on its own, and
#: once as a copy linked into the kernel's module and optimised again with it. A process
#: that compiles the kernel runs the first (the kernel's call resolves to the definition
#: loaded first); a process that loads it from the disk cache has only the second. LLVM's
#: passes keep every value exact unless a flag allows otherwise, and two flags let the
#: second optimisation round differently from the first: ``reassoc`` (regroup sums and
#: products, e.g. to vectorise a reduction) and ``contract`` (fuse a multiply and an add
#: into one FMA, rounded once, where both land in one basic block). With them the curl
#: noise's cached kernel differed from the fresh one in the last bits. Without them loops
#: still vectorise, but a float sum in a loop keeps its source order, so that loop no
#: longer vectorises (a hot sum is written as a loop of terms and :func:`ordered_sum`),
#: and no multiply-add is fused (a hot one is written with :func:`fma`). The flags kept:
#: ``nnan``, ``ninf`` (no NaN or infinity checks), ``nsz`` (the sign of a zero may be
#: ignored), ``arcp`` (divide by multiplying by a reciprocal), ``afn`` (approximate math
#: functions).
FASTMATH = frozenset({"nnan", "ninf", "nsz", "arcp", "afn"})

# Threading layer: OpenMP first. A parallel launch costs 5-10 µs with OpenMP on the
# 2-core reference machine against 50-120 µs with TBB, Numba's first choice where TBB is
# installed, and motes launches many short kernels (a 512² grid-fluid step about 100).
# Results do not depend on the layer (kernels split work in fixed blocks, see above).
# GNU OpenMP is not safe across fork() once its threads run: motes forks no process
# (Dask workers are spawned). NUMBA_THREADING_LAYER, when set, still decides.
if "NUMBA_THREADING_LAYER" not in os.environ:
    numba.config.THREADING_LAYER_PRIORITY = ["omp", "tbb", "workqueue"]

_COMMON = {"fastmath": set(FASTMATH), "error_model": "numpy"}

#: Parallel kernel over particles: iterations must be independent.
parallel_kernel = njit(parallel=True, cache=True, **_COMMON)

#: Parallel kernel built at run time around a user's compiled function (a pair force):
#: Numba cannot cache a kernel that closes over another compiled function, so it compiles
#: once per process.
parallel_factory = njit(parallel=True, **_COMMON)

#: Serial kernel: order-dependent loops (compaction, scans) and small systems.
serial_kernel = njit(cache=True, **_COMMON)

#: Device function inlined into the kernels that call it.
device = njit(inline="always", **_COMMON)

#: Compiled function that kernels call rather than inline at Numba's level: compiled
#: once per signature and linked into each kernel, where LLVM may still inline it. For
#: long bodies and for helpers of kernels that are not vectorised loops, since inlining
#: copies the body's IR into every call site before typing (the fluid's wall passes:
#: 13.6 s inlined against 4.4 s called; the sprite passes, projection and drawing: 41 s
#: against 23 s, at the same speed). Hot helpers stay :data:`device`: those of vectorised
#: loops (a call in a loop blocks its vectorisation: the curl noise ran 4.7x slower with
#: its helpers called) and those whose constant arguments unroll or fold code (the
#: sprites' per-fragment weights and fixed windows: all called, 1M sprites drew 5 %
#: slower on one thread).
called = njit(**_COMMON)


def called_copy(function):
    """A :data:`called` compilation of a :data:`device` function's body, for kernels that
    should call it rather than inline it (with ``NUMBA_DISABLE_JIT`` the plain function)."""
    return called(getattr(function, "py_func", function))


#: Particles per parallel work item (see the module docstring).
BLOCK = 1024


@device
def block_count(n):
    """Number of ``BLOCK``-sized work items covering ``n`` iterations."""
    return (n + BLOCK - 1) // BLOCK


@device
def block_bounds(block, n):
    """Iterations ``[start, stop)`` of work item ``block``, as unsigned integers.

    Kernels run ``prange`` over fixed blocks and a serial ``range`` inside each, so which
    iterations take the vectorised path and which the scalar remainder is fixed by
    ``BLOCK``, not by the thread count. With ``fastmath`` the two paths may round
    differently (float32 division by a reciprocal estimate), which made results depend
    on the thread count when ``prange`` split the loop itself. The bounds are unsigned
    because Numba then skips its negative-index wraparound, which blocks vectorisation
    (the signed version ran 5-8x slower).
    """
    start = block * BLOCK
    return np.uint64(start), np.uint64(min(n, start + BLOCK))


def ordered_sum(values, count):
    """``values[0] + ... + values[count - 1]`` in a fixed order, eight running sums at once.

    A float sum in a compiled loop keeps its source order (:data:`FASTMATH` has no
    ``reassoc``), so the loop does not vectorise and each addition waits for the last.
    A kernel that needs a fast sum computes its terms in a loop of their own (which can
    vectorise: nothing is summed there) and adds them here: value ``v`` goes to running
    sum ``v mod 8``, the eight are added pairwise, then the last ``count mod 8`` values in
    order. The order, and so the bits, do not depend on how the kernel around it was
    compiled.

    In compiled code a C-contiguous array (a kernel's buffer, or a row of one) is summed
    with the eight running sums as the lanes of one SIMD vector (:func:`_vector_sum`):
    one vector add per eight values. Numba leaves LLVM's SLP vectoriser off, so eight
    scalar running sums stay eight scalar adds: 1.5-3.4x slower (32 to 256 float32 or
    float64 values). Other arrays, and calls from Python, run :func:`_lane_sum`, the same
    order in scalar code.
    """
    return _lane_sum(values, count)


def _lane_sum(values, count):
    """:func:`ordered_sum` with eight scalar running sums."""
    zero = values.dtype.type(0)
    s0 = s1 = s2 = s3 = s4 = s5 = s6 = s7 = zero
    whole = np.uint64(count) // np.uint64(8) * np.uint64(8)
    for base in range(np.uint64(0), whole, np.uint64(8)):
        s0 += values[base]
        s1 += values[base + 1]
        s2 += values[base + 2]
        s3 += values[base + 3]
        s4 += values[base + 4]
        s5 += values[base + 5]
        s6 += values[base + 6]
        s7 += values[base + 7]
    total = ((s0 + s1) + (s2 + s3)) + ((s4 + s5) + (s6 + s7))
    for v in range(whole, np.uint64(count)):
        total += values[v]
    return total


def _contiguous_floats(values) -> bool:
    return (
        isinstance(values, types.Array)
        and values.ndim == 1
        and values.layout == "C"
        and isinstance(values.dtype, types.Float)
    )


@intrinsic
def _vector_sum(typingctx, values, count):
    """:func:`ordered_sum` of a C-contiguous 1-D float array: the eight running sums are
    the lanes of one ``<8 x float>`` vector, added to eight values at a time, then its
    lanes pairwise and the last ``count mod 8`` values in order. The adds carry no
    fast-math flag: LLVM may not regroup them."""
    if not (_contiguous_floats(values) and isinstance(count, types.Integer)):
        return None

    def codegen(context, builder, signature, args):
        array_type, count_type = signature.args
        real = context.get_value_type(array_type.dtype)
        lanes = ir.VectorType(real, 8)
        i64 = ir.IntType(64)
        data = context.make_array(array_type)(context, builder, args[0]).data
        n = context.cast(builder, args[1], count_type, types.int64)
        whole = builder.and_(n, ir.Constant(i64, -8))
        sums = cgutils.alloca_once_value(builder, ir.Constant(lanes, None))
        eight = ir.Constant(i64, 8)
        with cgutils.for_range_slice(builder, ir.Constant(i64, 0), whole, eight) as (index, _):
            align = context.get_abi_sizeof(real)
            chunk = builder.load(builder.gep(data, [index]), align=align, typ=lanes)
            builder.store(builder.fadd(builder.load(sums), chunk), sums)
        vector = builder.load(sums)
        s = [builder.extract_element(vector, ir.Constant(ir.IntType(32), k)) for k in range(8)]
        add = builder.fadd
        total = add(add(add(s[0], s[1]), add(s[2], s[3])), add(add(s[4], s[5]), add(s[6], s[7])))
        result = cgutils.alloca_once_value(builder, total)
        with cgutils.for_range_slice(builder, whole, n, ir.Constant(i64, 1)) as (index, _):
            value = builder.load(builder.gep(data, [index]), typ=real)
            builder.store(add(builder.load(result), value), result)
        return builder.load(result)

    return values.dtype(values, count), codegen


@overload(ordered_sum, inline="always")
def _ordered_sum_compiled(values, count):
    if _contiguous_floats(values):
        return lambda values, count: _vector_sum(values, count)
    return _lane_sum


def fma(a, b, c):
    """``a * b + c`` rounded once (a fused multiply-add), in compiled kernels.

    :data:`FASTMATH` has no ``contract``, so the compiler never fuses a multiply and an
    add by itself; a kernel that wants the fused instruction (one instruction instead of
    two, one rounding instead of two) asks for it here. Unlike ``contract``, which lets
    each optimisation of a kernel decide, this is fused wherever it is written, in a
    fresh compile and in a cached one alike, so the bits do not depend on how the kernel
    was compiled. The arguments must be floats of one type (a float32 kernel stays
    float32). Compiled to ``llvm.fma``: one instruction on every x86-64 CPU with FMA3
    (since 2013), a slow software routine on older ones.

    Called from Python (``NUMBA_DISABLE_JIT=1``) it is exact for float32 arguments but
    for a rare double rounding (the product and sum are taken in float64), and for
    float64 fused on Python 3.13+ (``math.fma``), rounded twice before.
    """
    if isinstance(a, np.float32):
        return np.float32(np.float64(a) * np.float64(b) + np.float64(c))
    fused = getattr(math, "fma", None)
    return fused(a, b, c) if fused is not None else a * b + c


@intrinsic
def _llvm_fma(typingctx, a, b, c):
    def codegen(context, builder, signature, args):
        real = context.get_value_type(signature.return_type)
        function = builder.module.declare_intrinsic(
            "llvm.fma", [real], ir.FunctionType(real, [real, real, real])
        )
        return builder.call(function, args)

    return a(a, b, c), codegen


@overload(fma, inline="always")
def _fma_compiled(a, b, c):
    if not all(isinstance(t, types.Float) for t in (a, b, c)) or not a == b == c:
        raise TypingError(f"fma takes three floats of one type, got {a}, {b}, {c}")
    return lambda a, b, c: _llvm_fma(a, b, c)


#: Below this many particles a step runs its parallel kernels on one thread: waking the
#: thread pool costs more than the work, and on a machine whose other cores are busy a
#: parallel launch can wait milliseconds for a time slice (measured: 4.5 µs on one
#: thread against a 1.5 ms mean on two, for a 1,000-particle step with one core busy).
SERIAL_BELOW = 8192


@contextmanager
def threads_for(count: int, below: int = SERIAL_BELOW):
    """Run the enclosed block on one thread when ``count`` < ``below``.

    Results do not depend on it (kernels are block-parallel), only the launch cost. The
    previous thread count is restored on leaving, exceptions included.
    """
    previous = numba.get_num_threads()
    if count >= below or previous == 1:
        yield
        return
    numba.set_num_threads(1)
    try:
        yield
    finally:
        numba.set_num_threads(previous)
