"""A wheel whose spin is a state, driven by a torque, on the Magic Formula tyre (library/examples/
driven_wheel.mbs): the tyre's longitudinal force is the only horizontal force on the moving parts, so their
momentum changes by its impulse (Newton's second law, checked on the run), and the wheel's spin equation
balances the torque against the force's moment (I w' = T - Fx r, r the loaded radius)."""

import numpy as np
import pytest

import mbs

MOVING_MASS = 400.0 + 15.0   # body and wheel (the carrier is massless)


@pytest.fixture(scope="module")
def run():
    system = mbs.load("library/examples/driven_wheel.mbs")
    res = system.simulate("accelerate")
    assert res.success, res.message
    return res


def test_momentum_changes_by_the_impulse_of_the_tyre_force(run):
    t, fx, v = run.t, run["tyre.radial.forces.fx"], run["speed"]
    impulse = np.trapezoid(fx, t)
    assert MOVING_MASS * (v[-1] - v[0]) == pytest.approx(impulse, rel=2e-3)
    assert v[-1] > v[0] + 1.0                       # the drive accelerates it


def test_drive_torque_makes_the_tyre_slip_forwards(run):
    late = run.t > 1.0
    assert np.all(run["tyre.radial.forces.kappa"][late] > 0.0)
    # the spin equation: T = Fx r + I w', the force acting at the contact point, the loaded radius r = R0 - rho
    # below the centre (the rate w' by finite differences of the sampled spin)
    spin_rate = np.gradient(run["spin"], run.t)
    torque = run["tyre.radial.forces.fx"] * (0.3135 - run["tyre.radial.forces.rho"]) + 0.9 * spin_rate
    assert torque[late] == pytest.approx(np.full(late.sum(), 300.0), rel=5e-3)
