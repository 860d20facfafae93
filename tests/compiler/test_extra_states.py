"""Extra differential states (language/states.py) through the compiler, both back ends and every integrator.

Checked against what no one here wrote: the closed form of a first-order lag's step response
(y = c (1 - exp(-t / T))) and of its reset times (T ln 2 apart), scipy's solve_ivp on the hand-written
equations of a mass under PI control, and the eigenvalues of the hand-derived characteristic polynomials
(m s^3 + d s^2 + kp s + ki for the PI loop; -1/T and m s^2 + d s + k for the lag driving a mass).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import mbs
from mbs.runtime.linearize import jacobian as finite_differences
from mbs.runtime.workspace import Workspace

MODELS = Path(__file__).parent / "models"
LAG, PI, RESET = MODELS / "actuator_lag.mbs", MODELS / "pi_mass.mbs", MODELS / "lag_reset.mbs"
T, C = 0.2, 0.1  # actuator_lag.mbs: time constant, command


@pytest.fixture(scope="module")
def lag():
    return mbs.load(LAG)


@pytest.mark.parametrize("integrator", ["dopri5", "rodasp", "RK45", "Radau", "BDF", "LSODA", "cvode_bdf", "cvode_adams", "ida"])
def test_a_lag_follows_its_closed_form_with_every_integrator(lag, integrator):
    if integrator.startswith("cvode") or integrator == "ida":
        pytest.importorskip("sksundae")
    res = lag.simulate("step", integrator=integrator, rtol=1e-9, atol=1e-12)
    assert res.success, res.metadata.get("message")
    exact = C * (1 - np.exp(-res.t / T))
    assert np.max(np.abs(res["y"] - exact)) < 1e-8
    assert res.unit("y") == "m"


def test_the_numpy_back_end_gives_the_same_lag():
    res = mbs.load(LAG, backend="numpy").simulate("step", rtol=1e-9, atol=1e-12)
    assert np.max(np.abs(res["y"] - C * (1 - np.exp(-res.t / T)))) < 1e-8


def test_der_of_a_state_in_a_force_and_an_output_is_its_equation(lag):
    res = lag.simulate("step", rtol=1e-9, atol=1e-12)
    assert np.allclose(res["actuator_rate"], (C - res["y"]) / T, rtol=0, atol=1e-12)
    assert np.allclose(res["position"], res["y"], rtol=0, atol=0)


def pi_reference(t_eval):
    """The PI loop written by hand: x' = v, m v' = kp (r - x) + ki z - d v - load, z' = r - x."""
    m, kp, ki, d, r, load = 2.0, 800.0, 2000.0, 40.0, 0.05, 30.0

    def f(_t, y):
        x, v, z = y
        return [v, (kp * (r - x) + ki * z - d * v - load) / m, r - x]
    return solve_ivp(f, (0, t_eval[-1]), [0, 0, 0], t_eval=t_eval, method="DOP853", rtol=1e-12, atol=1e-14).y


@pytest.mark.parametrize("integrator", ["dopri5", "rodasp", "Radau"])
def test_a_pi_controller_state_against_scipy_on_hand_written_equations(integrator):
    res = mbs.load(PI).simulate("settle", integrator=integrator)
    x, v, z = pi_reference(res.t)
    assert np.max(np.abs(res["rail.s"] - x)) < 1e-7
    assert np.max(np.abs(res["z"] - z)) < 1e-8
    assert abs(res["rail.s"][-1] - 0.05) < 1e-3  # the integrator removes the load's offset
    assert np.max(np.abs(res["integrator_input"] - (0.05 - res["rail.s"]))) < 1e-12


def test_the_generated_jacobian_has_the_extra_state_columns():
    system = mbs.load(PI)
    compiled = system.compile("settle", jacobian=True)
    assert "jacobian" in compiled.functions
    data = Workspace(compiled)
    data.p = compiled.p_default
    x = np.array([0.01, 0.2, 0.003])
    J = data.jacobian(0.0, x)[:, :3]
    assert np.allclose(J, finite_differences(data, 0.0, x), rtol=1e-6, atol=1e-6)
    assert np.allclose(J[:, 2], [0.0, 1000.0, 0.0])  # d v'/d z = ki / m; nothing else depends on z


def test_linearised_eigenvalues_are_the_hand_derived_ones():
    lin = mbs.load(PI).linearize("settle", at="initial")
    m, kp, ki, d = 2.0, 800.0, 2000.0, 40.0
    expected = np.roots([m, d, kp, ki])
    assert lin.A_reduced.shape == (3, 3)
    assert np.allclose(np.sort_complex(lin.eigenvalues), np.sort_complex(expected), rtol=1e-6)


def test_a_lag_mode_is_linearised_with_the_mechanical_ones(lag):
    lin = lag.linearize("step", at="initial")
    expected = np.concatenate([[-1 / T], np.roots([1.0, 80.0, 4000.0])])
    assert np.allclose(np.sort_complex(lin.eigenvalues), np.sort_complex(expected), rtol=1e-6)
    lag_mode = next(mode for mode in lin.modes if abs(mode.eigenvalue + 1 / T) < 1e-6)
    assert abs(lag_mode.shape["y"]) > 0  # the shape has the extra state's amplitude
    assert "y" in lin.state_space.states


def test_an_event_reinitialises_a_state():
    res = mbs.load(RESET).simulate("saw")
    times = [e["time"] for e in res.events if e["event"] == "reset"]
    assert len(times) == 7
    assert np.allclose(times, T * math.log(2) * np.arange(1, 8), rtol=0, atol=1e-9)


def test_a_model_without_states_has_no_trace_of_them():
    gen = mbs.load(MODELS.parent.parent / "runtime" / "models" / "stiff_arm.mbs").generate(None)
    assert "MBS_NZ" not in gen.c_source and "MBS_NZ" not in gen.numpy_source
    assert "#define MBS_NX (MBS_NQ+MBS_NV)\n" in gen.c_source


def test_the_equilibrium_holds_the_extra_states_at_rest_too():
    """About the static equilibrium the integrator state carries the load: x = r, ki z = load."""
    lin = mbs.load(PI).linearize("settle")
    assert lin.x[0] == pytest.approx(0.05, abs=1e-10)
    assert lin.x[2] == pytest.approx(30.0 / 2000.0, abs=1e-10)
    assert np.allclose(np.sort_complex(lin.eigenvalues), np.sort_complex(np.roots([2.0, 40.0, 800.0, 2000.0])))


def test_mbs_eom_shows_the_state_equations_and_evaluates_with_the_states():
    from mbs.eom import equations_of_motion
    eq = equations_of_motion(mbs.load(PI))
    assert "der(z) = r - rail.s" in eq.text()
    _, _, q = eq.at({"rail.s": 0.01, "z": 0.002})
    assert q[0, 0] == pytest.approx(800 * 0.04 + 2000 * 0.002 - 30)
