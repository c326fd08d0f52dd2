import os
from pathlib import Path

# Kernels compile at LLVM -O1 in the default run, into a cache of their own: compiling is
# most of the suite's time, and -O1 compiles about 40 % faster than the release -O3
# while computing the same values (fastmath's reassociation aside, which the tests'
# tolerances and the thread-count checks at either level allow). The release level is
# checked where it matters: test_determinism compiles its runs at -O3, and the
# benchmarks always run at -O3. NUMBA_OPT=3 on the command line tests the release
# build (in .numba_cache/O3). The cache is kept apart because Numba's cache key does not
# hold the level: an -O1 kernel would otherwise be loaded by a benchmark.
os.environ.setdefault("NUMBA_OPT", "1")
os.environ.setdefault(
    "NUMBA_CACHE_DIR",
    str(Path(__file__).resolve().parents[1] / ".numba_cache" / f"O{os.environ['NUMBA_OPT']}"),
)

import numpy as np
import pytest


@pytest.fixture
def rng():
    return np.random.default_rng(20261122)
