"""DOPRI5's retry after two rejections in a row from one t takes the order the two error estimates measure (c/dopri5.c
dp_retry_shrink): fewer rejections where f changes fast just after a switch's restart, the same error test, and
nothing changed where no two rejections come in a row.  The baseline is the same model built with
-DMBS_ODE_STEPS_FORMER=1 (every retry shrinks by the 5th-order model err^0.17), the reference scipy's DOP853 at
rtol 1e-13 on the hand-written equation m s'' = -k s + F tanh((t - t_on) / tau) after t_on."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import mbs
from former_builds import flagged_build, simulate_with

FAST_RAMP = Path(__file__).parent / "models" / "fast_ramp.mbs"
M, K, T_ON, TAU, S0 = 1.0, 1000.0, 0.3, 1e-4, 0.01


@pytest.fixture(scope="module")
def ramp():
    system = mbs.load(FAST_RAMP)
    return system, flagged_build(system, "ramp", ("-DMBS_ODE_STEPS_FORMER=1",))


def reference(t: np.ndarray, force: float) -> tuple[np.ndarray, np.ndarray]:
    """(s, s') at t from scipy, integrated in two pieces: to the switch, and on from it with the ramp."""
    def rhs(time, y, on):
        push = force * np.tanh((time - T_ON) / TAU) if on else 0.0
        return [y[1], (-K * y[0] + push) / M]
    before = solve_ivp(rhs, (0.0, T_ON), [S0, 0.0], args=(False,), method="DOP853", rtol=1e-13, atol=1e-15,
                       dense_output=True)
    after = solve_ivp(rhs, (T_ON, t[-1]), before.y[:, -1], args=(True,), method="DOP853", rtol=1e-13, atol=1e-15,
                      dense_output=True)
    y = np.where(t < T_ON, before.sol(np.minimum(t, T_ON)), after.sol(np.maximum(t, T_ON)))
    return y[0], y[1]


def test_the_retry_at_a_fast_ramp_after_a_restart_is_rejected_fewer_times_than_the_former(ramp):
    """The force ramps to 1 N over 0.1 ms from the switch at 0.3 s, where the steps are 3 ms: the first step after
    the restart is rejected with err 455, then 207, 31 -- an error falling like h^2, not h^5.  The former retry
    shrank by err^0.17 and took five rejections there; the measured order takes three (the Iltis over the bump: a
    dozen in a row at a tyre's touch-down before).  Fails when dp_retry_shrink is undone."""
    system, former = ramp
    now = system.simulate("ramp").metadata["stats"]
    before = simulate_with(system, "ramp", former).metadata["stats"]
    assert now["nevents"] == before["nevents"] == 1
    assert now["nreject"] < before["nreject"]
    assert now["nfev"] <= before["nfev"]


def test_the_results_stay_within_the_tolerance_of_a_tight_reference(ramp):
    """Both retries against scipy at rtol 1e-13: the error test is the same, so is the error -- within 1e-8 m of
    the 0.01 m swing (rtol 1e-7, atol 1e-9 per step over some 250 steps) and the current no larger than the former's
    by more than a quarter."""
    system, former = ramp
    runs = {"now": system.simulate("ramp"), "before": simulate_with(system, "ramp", former)}
    s_ref, v_ref = reference(runs["now"]["time"], 1.0)
    errors = {}
    for label, run in runs.items():
        errors[label] = (np.max(np.abs(run["push.s"] - s_ref)), np.max(np.abs(run["der(push.s)"] - v_ref)))
        assert errors[label][0] < 1e-8, label
        assert errors[label][1] < 1e-6, label  # the speed swings 0.3 m/s: the same relative error
    assert errors["now"][0] <= 1.25 * errors["before"][0]
    assert errors["now"][1] <= 1.25 * errors["before"][1]


def test_without_two_rejections_in_a_row_the_run_is_the_former_to_the_bit(ramp):
    """No ramp (F = 0): the spring alone, where no step is rejected twice from one t, runs as before to the bit."""
    system, former = ramp
    now = system.simulate("ramp", params={"F": 0.0})
    before = simulate_with(system, "ramp", former, params={"F": 0.0})
    assert now.metadata["stats"] == before.metadata["stats"]
    for name in now.names:
        assert np.array_equal(now[name], before[name]), name
