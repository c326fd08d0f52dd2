import os

import numpy as np
import pytest

# ``motes run`` in the tests compiles in its own process: a helper started on a first
# run (motes.cli.compile_ahead) would only race the other tests for the cores.
# tests/test_compile_ahead.py turns it on where it tests it.
os.environ.setdefault("MOTES_COMPILE_AHEAD", "0")


@pytest.fixture
def rng():
    return np.random.default_rng(20261122)
