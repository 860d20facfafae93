"""The free-hub Iltis (library/iltis/free_hub.mbs): wheel spins as states driven by brake torques, on Magic
Formula tyres. Checked against Newton's laws on the run and closed forms no one here wrote:

- coasting: with no torque on the hubs and no rolling resistance the tyres settle where they carry no
  longitudinal force, rolling freely at omega = v / r_e, and the car keeps its speed;
- braking below the grip limit: the car and its four wheels decelerate together. Each wheel's spin equation
  I omega' = -T - Fx r (Fx at the contact point, r the loaded radius) with omega' = -a / r_e, summed with the car's
  M a = -sum Fx, gives the steady deceleration a = sum(T / r_i) / (M + sum I / (r_i r_e,i)) (r_i and r_e,i from
  the run's tyre deflections);
- locking the wheels: the deceleration stays below the tyres' peak grip, sum of mu_x,peak(Fz_i) Fz_i / M
  (mu_x,peak = PDX1 + PDX2 dfz, the Magic Formula's D_x / Fz) and equals the sum of the standard form's forces
  at the tyres' loads and slips (about 0.6 g: beyond its peak the longitudinal curve falls to D sin(C ...) at
  kappa = -1) over the mass."""

import numpy as np
import pytest

import mbs

pytestmark = pytest.mark.slow   # one compile of the Iltis with four Magic Formula tyres and three runs: minutes

MASS = 1260.0 + 4 * (4.0 + 6.0 + 10.0 + 1.0 + 57.35 + 0.001)   # body, corners (leaf, arm, carrier, rod, wheel, flange)
I_SPIN = 1.908
R0 = {"fl": 0.364325, "fr": 0.364325, "rl": 0.363812, "rr": 0.363812}
TYRES = ("fl", "fr", "rl", "rr")


@pytest.fixture(scope="module")
def system():
    return mbs.load("library/iltis/free_hub.mbs")


def run(system, scene):
    res = system.simulate(scene)
    assert res.success, res.message
    return res


def tyre(res, corner, what):
    return res[f"tyre_{corner}.radial.forces.{what}"]


def test_coasting_wheels_roll_freely_and_the_car_keeps_its_momentum(system):
    res = run(system, "coast_20")
    late = res.t > 0.5
    for corner in ("fl", "rl"):
        r_e = R0[corner] - tyre(res, corner, "rho") / 3
        rolling = tyre(res, corner, "vx") / r_e
        # spin_* is relative to the carrier, which still pitches a little with the body's settling
        assert res[f"spin_{corner}"][late] == pytest.approx(rolling[late], rel=1e-5)
        assert np.all(np.abs(tyre(res, corner, "fx")[late]) < 0.05)        # N: no longitudinal force left
    assert res["speed"][-1] == pytest.approx(20.0, rel=1e-4)                   # nothing brakes it


def test_braking_below_the_grip_limit_decelerates_car_and_wheels_together(system):
    res = run(system, "brake_20")
    end = -1
    torque = 600.0
    r = {c: R0[c] - tyre(res, c, "rho")[end] for c in TYRES}
    r_e = {c: R0[c] - tyre(res, c, "rho")[end] / 3 for c in TYRES}
    expected = sum(torque / r[c] for c in TYRES) / (MASS + sum(I_SPIN / (r[c] * r_e[c]) for c in TYRES))
    assert -res["longitudinal_acc"][end] == pytest.approx(expected, rel=2e-3)
    assert MASS * -res["longitudinal_acc"][end] == pytest.approx(-sum(tyre(res, c, "fx")[end] for c in TYRES),
                                                                 rel=2e-3)
    assert np.all(tyre(res, "fl", "kappa")[res.t > 0.5] < 0.0)                # braking slip


def test_locked_wheels_slide_below_the_peak_grip(system):
    res = run(system, "lock_20")
    end = -1
    assert res["spin_fl"][end] < 1.0 and res["spin_rl"][end] < 1.0           # rad/s: locked, against 55 rolling
    loads = {c: tyre(res, c, "fz")[end] for c in TYRES}
    peak = sum((1.0 - 0.1 * (fz - 4000.0) / 4000.0) * fz for fz in loads.values())   # PDX1, PDX2, FNOMIN
    deceleration = -res["longitudinal_acc"][end]
    assert deceleration * MASS < peak
    assert deceleration * MASS == pytest.approx(-sum(tyre(res, c, "fx")[end] for c in TYRES), rel=2e-3)
    sliding = sum(standard_form_fx(loads[c], tyre(res, c, "kappa")[end]) for c in TYRES)   # about 0.6 g
    assert deceleration * MASS == pytest.approx(-sliding, rel=5e-3)


def standard_form_fx(fz, kappa):
    """Fx of the Magic Formula's standard form with the library's default MF 5.2 coefficients (Pacejka 2006,
    4.E9-4.E18: PCX1 1.65, PDX1 1, PDX2 -0.1, PEX1 -0.5, PEX2 0.3, PKX1 21, PKX2 13, PKX3 -0.4, FNOMIN 4000 N)."""
    dfz = (fz - 4000.0) / 4000.0
    D = (1.0 - 0.1 * dfz) * fz
    B = fz * (21.0 + 13.0 * dfz) * np.exp(-0.4 * dfz) / (1.65 * D)
    E = -0.5 + 0.3 * dfz
    return D * np.sin(1.65 * np.arctan(B * kappa - E * (B * kappa - np.arctan(B * kappa))))
