"""Velocity-only forces (gravity, drag, wind): values, combination and Jacobians."""

import numpy as np
import pytest
from numpy.testing import assert_allclose

import motes as mo
import naive
from motes.forces.base import FieldTerms


def test_linear_drags_toward_different_winds_combine_exactly():
    terms = FieldTerms()
    for force in (
        mo.Drag(0.5, wind=(1, 0, 0)),
        mo.Wind((0, 0, 2), coefficient=1.5),
        mo.Gravity((0, -1, 0)),
    ):
        terms.add(force.terms())
    v = np.random.default_rng(0).normal(size=(10, 3))
    w = np.full(10, 2.0)
    direct = (-0.5 * (v - [1, 0, 0]) - 1.5 * (v - [0, 0, 2])) * 2.0 + [0, -1, 0]
    assert_allclose(
        naive.field_acceleration(
            v, w, terms.gravity, terms.linear_drag, terms.linear_drag_wind, 0.0, np.zeros(3)
        ),
        direct,
    )


def test_quadratic_drags_toward_different_winds_are_refused():
    terms = FieldTerms()
    terms.add(mo.QuadraticDrag(0.1).terms())
    with pytest.raises(ValueError, match="different wind"):
        terms.add(mo.QuadraticDrag(0.1, wind=(1, 0, 0)).terms())


def test_terminal_velocity_of_linear_and_quadratic_drag():
    for drag, terminal in (
        (mo.Drag(2.0), 9.81 / 2.0),
        (mo.QuadraticDrag(0.5), np.sqrt(9.81 / 0.5)),
    ):
        system = mo.ParticleSystem(1, dtype=np.float64, integrator="rk4")
        system.add(mo.Gravity(), drag)
        system.store.spawn(1)
        system.run(2000, 0.01)
        assert system["velocity"][0, 1] == pytest.approx(-terminal, rel=1e-9)


@pytest.mark.parametrize(
    "force", [mo.Drag(0.7, wind=(1, 2, 3)), mo.QuadraticDrag(0.3, wind=(1, 0, 0))]
)
def test_drag_jacobian_matches_finite_differences(force):
    rng = np.random.default_rng(1)
    v = rng.normal(size=(5, 3))

    def f(vel):
        t = force.terms()
        wind = np.zeros(3) if t.quadratic_wind is None else t.quadratic_wind
        return naive.field_acceleration(
            vel,
            np.ones(len(vel)),
            np.zeros(3),
            t.linear_drag,
            t.linear_drag_wind,
            t.quadratic_drag,
            wind,
        )

    jac = force.jacobian(v)
    _, dense_dv = jac.dense(5)
    eps = 1e-6
    numeric = np.zeros((15, 15))
    for j in range(15):
        dv = np.zeros(15)
        dv[j] = eps
        numeric[:, j] = (f(v + dv.reshape(5, 3) / 1).ravel() - f(v - dv.reshape(5, 3)).ravel()) / (
            2 * eps
        )
    # Central differences: error O(eps²) ≈ 1e-12 relative to entries of order 1.
    assert_allclose(dense_dv, numeric, atol=1e-7)


def test_gravity_does_not_move_pinned_particles():
    system = mo.ParticleSystem(2, dtype=np.float64, attributes=("inv_mass",))
    system.add(mo.Gravity(), mo.Drag(1.0, wind=(5, 0, 0)))
    system.store.spawn(2)
    system["inv_mass"] = [0.0, 1.0]
    system.run(10, 0.01)
    assert_allclose(system["position"][0], 0)
    assert system["position"][1, 1] < 0
