"""Switches by default: a comparison inside an expression is an event in every model, as Modelica makes it.

The issue's new-user case: a 2-link arm held by a stiff PD motor (kp = 5e6 N m/rad) whose set point steps with
``if(t > 0.5 s, -45 deg, 0 deg)``; the model declares no event, no mode and no ``switches`` line.  Every
integrator passes the step, and the shoulder and elbow angles match an independent integration of the arm's
hand-written Lagrange equations (scipy's DOP853, piecewise in time: one run up to the step, one after it).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import mbs

ARM = Path(__file__).parent / "models" / "stiff_arm.mbs"
INTEGRATORS = ["dopri5", "rodasp", "auto", "cvode_adams", "cvode_bdf", "ida", "RK45", "DOP853", "Radau", "BDF",
               "LSODA"]

# the arm's data, as written in stiff_arm.mbs
M1, A1, I1, L1 = 2.0, 0.25, 0.042, 0.5  # upper link: mass, centre of mass from the shoulder, inertia (y), length
M2, A2, I2 = 1.0, 0.2, 0.013            # lower link: mass, centre of mass from the elbow, inertia (y)
KP, KD, C_ELBOW, G, STEP = 5e6, 2e3, 0.5, 9.81, 0.5
T_END = 0.7  # 0.2 s past the step: the motor has long settled at -45 deg


def arm_rhs(set_point: float):
    """The double pendulum in the x-z plane, both joints about y (a positive angle turns x down, towards -z):
    M(phi) phi'' + c(phi, phi') = Q_gravity + tau, written out by hand (the 2 x 2 mass matrix inverted by
    Cramer's rule in plain floats: the reference takes ~80000 evaluations, and np.linalg.solve's call cost was
    most of their time)."""
    def rhs(t, x):
        p1, p2, w1, w2 = x
        c2 = math.cos(p2)
        h = M2 * L1 * A2 * math.sin(p2)
        m11 = I1 + M1 * A1 ** 2 + I2 + M2 * (L1 ** 2 + A2 ** 2 + 2 * L1 * A2 * c2)
        m12 = I2 + M2 * (A2 ** 2 + L1 * A2 * c2)
        m22 = I2 + M2 * A2 ** 2
        coriolis = (-h * (2 * w1 * w2 + w2 ** 2), h * w1 ** 2)
        gravity = (G * (M1 * A1 * math.cos(p1) + M2 * (L1 * math.cos(p1) + A2 * math.cos(p1 + p2))),
                   G * M2 * A2 * math.cos(p1 + p2))
        torque = (KP * (set_point - p1) - KD * w1, -C_ELBOW * w2)
        f1, f2 = (gravity[i] + torque[i] - coriolis[i] for i in range(2))
        det = m11 * m22 - m12 * m12
        return [w1, w2, (m22 * f1 - m12 * f2) / det, (m11 * f2 - m12 * f1) / det]
    return rhs


@pytest.fixture(scope="module")
def reference():
    """The angles [shoulder, elbow] at any t in [0, T_END], integrated piecewise: the set point is 0 before the step
    and -45 deg after it, each piece a smooth problem (dense output of each). DOP853, not Radau: the motor's mode
    (~4000 rad/s, damping ratio 0.8) is not stiff at this accuracy, where the step is set by the error, not by
    stability; Radau at the same tolerances took 11x the time (125000 evaluations, 19000 LU decompositions) and the
    two references differ by at most 1e-13 rad (shoulder) and 4e-10 rad (elbow) at the sample times, 1e6 and 2e5
    times below the tolerances the test asks of the integrators."""
    opts = dict(method="DOP853", rtol=1e-11, atol=1e-13, dense_output=True)
    first = solve_ivp(arm_rhs(0.0), (0.0, STEP), [0.0, 0.0, 0.0, 0.0], **opts)
    second = solve_ivp(arm_rhs(-math.pi / 4), (STEP, T_END), first.y[:, -1], **opts)
    assert first.success and second.success
    return lambda t: np.array([(first.sol if s <= STEP else second.sol)(s)[:2] for s in t])


@pytest.fixture(scope="module")
def arm():
    code = [line.split("#")[0] for line in ARM.read_text().splitlines()]
    assert not any("switches" in line or "event" in line for line in code), "a new user's model: no events"
    return mbs.load(ARM)


def test_the_new_user_model_has_the_step_as_a_switch(arm):
    events = arm.compile().events
    assert [e.name for e in events] == ["switch.1 (> in shoulder.motor)"]


@pytest.mark.parametrize("integrator", INTEGRATORS)
def test_every_integrator_passes_the_step_and_matches_the_hand_written_arm(arm, reference, integrator):
    res = arm.simulate(t_end=T_END, sample=0.01, integrator=integrator, rtol=1e-8, atol=1e-10)
    assert res.success, res.message
    assert [e["time"] for e in res.events] == [STEP] and res.events[0]["direction"] == "rising"
    step = np.flatnonzero(res.t == STEP)
    assert len(step) == 2  # a row just before and just after the step: the state does not jump
    assert len(res.t) == 72
    expected = reference(res.t)
    # the motor swings the shoulder 0.785 rad within milliseconds (peak speed ~1e3 rad/s, so a step misplaced by
    # 1e-10 s shows); observed worst 1.2e-8 rad (scipy's BDF)
    np.testing.assert_allclose(res["shoulder.phi"], expected[:, 0], rtol=0, atol=1e-7)
    # the free elbow, kicked by the step, whirls through 22 rad: 5e-6 of that (observed 4.9e-5 rad, BDF; the
    # one-step methods 1e-7 to 2e-6)
    np.testing.assert_allclose(res["elbow.phi"], expected[:, 1], rtol=0, atol=1e-4)
    assert abs(res["shoulder.phi"][-1] + math.pi / 4) < 1e-5  # held at -45 deg, sag ~1e-6 rad at this kp


@pytest.mark.parametrize("path", ["library/examples/pendulum.mbs", "library/examples/double_pendulum.mbs",
                                  "library/examples/slider_crank.mbs"])
def test_a_model_without_comparisons_or_kinks_generates_the_code_it_did_without_switches(path):
    import re
    text = (ARM.parents[3] / path).read_text()
    off = re.sub(r"^(model \w+.*\{)$", r"\1\n    switches = false", text, count=1, flags=re.M)
    assert off != text
    default, smooth = (mbs.loads(t, path=path).generate() for t in (text, off))
    assert default.c_source == smooth.c_source and default.numpy_source == smooth.numpy_source
    assert default.p_names == smooth.p_names and not default.events


def test_the_numpy_back_end_holds_the_same_switch(reference):
    """The NumPy module of the same model (no C compiler needed): the same event, the same motion."""
    res = mbs.load(ARM, backend="numpy").simulate(t_end=T_END, sample=0.01, integrator="DOP853", rtol=1e-8,
                                                  atol=1e-10)
    assert res.success and [e["time"] for e in res.events] == [STEP]
    expected = reference(res.t)
    np.testing.assert_allclose(res["shoulder.phi"], expected[:, 0], rtol=0, atol=1e-7)
    np.testing.assert_allclose(res["elbow.phi"], expected[:, 1], rtol=0, atol=1e-4)
