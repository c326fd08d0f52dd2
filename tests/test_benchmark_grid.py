"""The grid benchmark's NumPy twin computes the step motes does, and the benchmark runs."""

from __future__ import annotations

import numpy as np
from benchmarks import grid
from benchmarks.grid_numpy import NumpySmoke


def test_the_numpy_twin_steps_as_motes_does():
    """From the same developed state, four steps of each agree: the same algorithm in
    float64 with a direct pressure solve against float32 and a solve to 1e-4, so within
    a few thousandths of the velocity scale (~1 m/s) and of the density's."""
    fluid = grid.developed(grid.smoke(32, 2), 10)
    twin = NumpySmoke(fluid)
    for _ in range(4):
        fluid.step(grid.DT)
        twin.step(grid.DT)
    scale_v = np.abs(fluid.v).max()
    assert scale_v > 0.2
    np.testing.assert_allclose(twin.v, fluid.v[0], atol=5e-3 * scale_v)
    np.testing.assert_allclose(twin.u, fluid.u[0], atol=5e-3 * scale_v)
    np.testing.assert_allclose(twin.density, fluid.density[0], atol=5e-3 * fluid.density.max())
