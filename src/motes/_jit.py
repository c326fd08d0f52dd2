"""The one place that sets Numba's compilation flags.

Every compiled kernel in motes is decorated with one of the three decorators below,
so the flags are chosen once:

- ``fastmath=True`` lets LLVM reassociate and vectorise float arithmetic.
- ``error_model="numpy"``: the default ``"python"`` model inserts a zero-division check
  into every division, and that branch blocks SIMD in the whole loop.
- ``cache=True`` keeps compiled machine code on disk between processes (a first call
  costs ~0.3 s instead of ~1-2 s).
- ``parallel=True`` only on kernels whose ``prange`` iterations are independent, so
  results never depend on the number of threads.
"""

from __future__ import annotations

from numba import njit

_COMMON = {"fastmath": True, "error_model": "numpy"}

#: Parallel kernel over particles: iterations must be independent.
parallel_kernel = njit(parallel=True, cache=True, **_COMMON)

#: Serial kernel: order-dependent loops (compaction, scans) and small systems.
serial_kernel = njit(cache=True, **_COMMON)

#: Device function inlined into the kernels that call it.
device = njit(inline="always", **_COMMON)

