"""Inputs driven from Python and the state-space model, on a forced mass-spring-damper whose transfer
function X/F = 1 / (m s^2 + d s + k) is known in closed form."""

from pathlib import Path

import numpy as np
import pytest

import mbs

MODEL = Path(__file__).parent / "models" / "oscillator.mbs"
M, K, D = 2.0, 800.0, 8.0


@pytest.fixture(scope="module")
def oscillator():
    return mbs.load(MODEL)


def test_state_space_matches_the_transfer_function(oscillator):
    lin = oscillator.linearize()
    ss = lin.state_space
    assert ss.inputs == ("force",) and ss.outputs == ("x", "a")
    assert ss.units["force"] == "N" and ss.units["x"] == "m" and ss.units["a"] == "m/s^2"
    num, den = ss.transfer_function("force", "x")
    np.testing.assert_allclose(den, [1.0, D / M, K / M], rtol=1e-6)
    np.testing.assert_allclose(num, [0.0, 0.0, 1.0 / M], atol=1e-9)
    # the acceleration output reads the input directly: D = 1/m, C = [-k/m, -d/m]
    np.testing.assert_allclose(lin.D, [[0.0], [1.0 / M]], atol=1e-9)
    np.testing.assert_allclose(lin.C[1], [-K / M, -D / M], rtol=1e-6)
    g = lin.to_scipy()
    for w in (1.0, 20.0, 100.0):
        s = 1j * w
        H = g.C[0] @ np.linalg.solve(s * np.eye(2) - g.A, g.B[:, 0]) + g.D[0, 0]
        assert H == pytest.approx(1.0 / (M * s**2 + D * s + K), rel=1e-6)


def test_python_control_gets_named_signals(oscillator):
    control = pytest.importorskip("control")
    g = oscillator.linearize().to_control()
    assert list(g.input_labels) == ["force"] and list(g.output_labels) == ["x", "a"]
    assert control.dcgain(g)[0] == pytest.approx(1.0 / K, rel=1e-6)


def test_constant_callable_and_table_inputs_agree(oscillator):
    runs = [oscillator.simulate("step", inputs={"force": given})
            for given in ("10 N", 10.0, lambda t: 10.0, ([0.0, 1.0], [10.0, 10.0]))]
    for res in runs[1:]:
        np.testing.assert_allclose(res["x"], runs[0]["x"], atol=1e-8)
    # the scene's own step (10 N from 0.1 s) is replaced, not added
    plain = oscillator.simulate("step")
    assert abs(plain["x"][5]) < 1e-12 and runs[0]["x"][5] > 1e-4


def test_state_feedback_closes_a_loop(oscillator):
    """A PD controller u = -kp x - kd v adds kp to the stiffness and kd to the damping: the closed loop is the
    open model with k + kp and d + kd (an independent run of the same equations)."""
    kp, kd = 1200.0, 30.0
    closed = oscillator.simulate("step", inputs={"force": lambda t, x: 10.0 - kp * x[0] - kd * x[1]})
    stiffer = oscillator.simulate("step", inputs={"force": "10 N"}, params={"k": K + kp, "d": D + kd})
    np.testing.assert_allclose(closed["x"], stiffer["x"], atol=1e-8)
    assert closed["x"][-1] == pytest.approx(10.0 / (K + kp), rel=1e-2)


def test_bad_inputs_are_model_errors(oscillator):
    with pytest.raises(mbs.MbsError, match="has no input 'forse'"):
        oscillator.simulate("step", inputs={"forse": 1.0})
    with pytest.raises(mbs.MbsError, match="expected force"):
        oscillator.simulate("step", inputs={"force": "2 m"})
    with pytest.raises(mbs.MbsError, match="runs in C"):
        oscillator.simulate("step", inputs={"force": lambda t: 0.0}, integrator="dopri5")
