"""library/examples/bearing_pendulum.mbs against hand-written equations integrated by scipy in this test.

The pendulum (mass m, centre of mass at distance l from the pin, inertia j_c about it, J = j_c + m l^2) turns
about a pin of radius r whose friction torque is T = -mu r |R| sign(phi'), R the force the pin exerts on the
arm.  Newton for the centre of mass gives R from the accelerations, |R|^2 = m^2 ((l phi'^2 + g cos phi)^2 +
(l phi'' + g sin phi)^2), so J phi'' = -m g l sin phi + T(phi'') is implicit: here it is solved by bracketing
(scipy's brentq) in every right-hand side, not by the quadratic the compiler uses, and the turning points
(where sign(phi') flips) end each solve_ivp piece.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import mbs

EXAMPLE = Path(__file__).resolve().parents[2] / "library" / "examples" / "bearing_pendulum.mbs"
M, L, J_C, R_PIN, MU_K, MU_S, G = 1.0, 0.5, 0.02, 0.02, 0.3, 0.35, 9.81
J = J_C + M * L ** 2
PHI0 = math.radians(60)


def pin_load(phi, w, acc):
    return M * math.hypot(L * w ** 2 + G * math.cos(phi), L * acc + G * math.sin(phi))


def acceleration(phi, w, direction):
    """phi'' with the kinetic friction torque against the slip direction (+1 or -1)."""
    def residual(acc):
        return J * acc + M * G * L * math.sin(phi) + direction * MU_K * R_PIN * pin_load(phi, w, acc)
    bound = 10 * (M * G * L + MU_K * R_PIN * M * (L * w ** 2 + G)) / J + 1
    return brentq(residual, -bound, bound, xtol=1e-15, rtol=1e-15)


def reference(t_end, t_eval):
    """phi(t_eval) by solve_ivp, one piece per swing; the pin never holds within t_end (checked)."""
    t0, y0, direction = 0.0, [PHI0, 0.0], -1.0  # released at rest, it swings towards negative phi
    out = np.empty_like(t_eval)
    while t0 < t_end:
        def turn(t, y, t0=t0, direction=direction):
            return y[1] if t > t0 else direction
        turn.terminal, turn.direction = True, -direction
        piece = solve_ivp(lambda t, y, d=direction: [y[1], acceleration(y[0], y[1], d)], (t0, t_end), y0,
                          method="DOP853", rtol=1e-12, atol=1e-13, dense_output=True, events=turn)
        inside = (t_eval >= t0) & (t_eval <= piece.t[-1])
        out[inside] = piece.sol(t_eval[inside])[0]
        t0, y0 = piece.t[-1], [piece.y[0, -1], 0.0]
        # at the turning point the pin must not hold: the weight's moment exceeds mu_s r |R| at rest
        assert M * G * L * abs(math.sin(y0[0])) > MU_S * R_PIN * pin_load(y0[0], 0.0, 0.0) or t0 >= t_end
        direction = -direction
    return out


@pytest.fixture(scope="module")
def run():
    return mbs.load(EXAMPLE).simulate("decay")


def test_the_decay_matches_an_independent_integration(run):
    assert run.success, run.message
    expected = reference(10.0, run.t)
    np.testing.assert_allclose(run["angle"], expected, atol=1e-8)  # measured: 6e-10 rad
    # the amplitude decays by a load-dependent amount per swing (it is not a constant-torque decay)
    # released at 60 deg the pin cannot hold it: it slips from the start, towards negative phi
    assert run.events[0] == {"time": 0.0, "event": "pin.bearing.slip", "direction": "start",
                             "changes": "pin.bearing.mode: 0 -> -1"}
    turns = [e["time"] for e in run.events if e["event"] == "pin.bearing.grip"]
    assert len(turns) >= 10
    amplitudes = np.abs(np.interp(turns, run.t, run["angle"]))
    assert np.all(np.diff(amplitudes) < 0)


def test_the_friction_torque_is_mu_r_times_the_pin_load(run):
    moving = np.abs(run["der(pin.phi)"]) > 1e-6
    np.testing.assert_allclose(np.abs(run["friction_torque"][moving]), MU_K * R_PIN * run["pin_load"][moving],
                               rtol=1e-9)
    assert np.all(run["friction_torque"][moving] * run["der(pin.phi)"][moving] < 0)  # it opposes the motion
    assert run.unit("friction_torque") == "N*m"  # the element acts on the pin's angle: a torque


def test_the_pin_holds_the_pendulum_once_the_static_limit_can():
    res = mbs.load(EXAMPLE).simulate("rest")
    assert res.success, res.message
    last = res.events[-1]
    assert last["event"] == "pin.bearing.grip" and "pin.bearing.mode" in last["changes"]
    assert last["changes"].endswith("-> 0")
    at_rest = res.t > last["time"]
    assert np.all(res["der(pin.phi)"][at_rest] == 0)
    phi = res["angle"][-1]
    # held: the weight's moment is within mu_s r m g (the pin load at rest is the weight)
    assert M * G * L * abs(math.sin(phi)) <= MU_S * R_PIN * M * G
    assert abs(phi) > 0  # and it stopped off the vertical, as dry friction does
