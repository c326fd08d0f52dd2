"""The grid-fluid benchmark: its JSON contract, and that its NumPy twin computes the step
motes computes (the baseline ``grid_speedup_vs_numpy`` is a ratio against).

No timing asserts: only that the figures exist and are positive and finite.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from benchmarks import grid
from benchmarks.grid_numpy import NumpySmoke

from benchmark_contract import quick_figures

REQUIRED = (
    "grid_2d_512_ms",
    "grid_2d_512_pressure_ms",
    "grid_2d_512_advection_ms",
    "grid_3d_128_ms",
    "grid_128_ms",
    "grid_128_numpy_ms",
    "grid_speedup_vs_numpy",
    "volume_128_render_ms",
    "volume_128_light_ms",
)


def test_quick_run_ends_with_one_json_line_of_positive_finite_figures(capsys):
    figures = quick_figures(grid, capsys, REQUIRED)
    assert figures["quick"] is True
    for key in ("pressure_iterations_2d_512", "pressure_iterations_3d_128"):
        assert isinstance(figures[key], int) and 0 < figures[key] < 100, key


def _twin_and_motes(change=None, steps=4):
    """Both from the state of the benchmark's smoke (32²) after 10 steps, ``steps`` more."""
    fluid = grid.developed(grid.smoke(32, 2), 10)
    twin = NumpySmoke(fluid)
    if change:
        change(twin)
    for _ in range(steps):
        fluid.step(grid.DT)
        twin.step(grid.DT)
    return fluid, twin


def _errors(fluid, twin) -> dict:
    """Largest differences relative to the velocity and density scales."""
    speed, density = np.abs(fluid.v).max(), fluid.density.max()
    return {
        "u": float(np.abs(twin.u - fluid.u[0]).max() / speed),
        "v": float(np.abs(twin.v - fluid.v[0]).max() / speed),
        "density": float(np.abs(twin.density - fluid.density[0]).max() / density),
        "temperature": float(np.abs(twin.temperature - fluid.temperature[0]).max()),
    }


def test_the_numpy_twin_steps_as_motes_does():
    """The same step in float64 (a direct pressure solve) against float32 (a solve to a
    residual of 1e-4): measured 1e-6 of the velocity and density scales, 3e-4 K; the
    bounds, 1e-4 and 1e-3 K, leave a hundredfold margin and still fail a twin that
    drops a term (the smallest tried: smoke's weight, 3e-4 of the density)."""
    fluid, twin = _twin_and_motes()
    assert np.abs(fluid.v).max() > 0.3 and fluid.density.max() > 0.5  # a developed plume
    errors = _errors(fluid, twin)
    assert max(errors["u"], errors["v"], errors["density"]) < 1e-4, errors
    assert errors["temperature"] < 1e-3, errors


@pytest.mark.parametrize(
    "change",
    [
        lambda twin: setattr(twin, "vorticity", 0.0),
        lambda twin: setattr(
            twin, "buoyancy", dataclasses.replace(twin.buoyancy, density_weight=0.0)
        ),
    ],
    ids=["no confinement", "weightless smoke"],
)
def test_the_agreement_test_tells_a_missing_term(change):
    errors = _errors(*_twin_and_motes(change))
    assert max(errors["u"], errors["v"], errors["density"]) > 3e-4, errors
