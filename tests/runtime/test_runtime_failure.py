"""A failing run keeps its results up to the failure and says what happened."""

from __future__ import annotations

import re

import numpy as np
import pytest

from mbs.runtime.errors import SimulationError
from mbs.runtime.integrators import get_integrator
from mbs.runtime.simulate import simulate
from mbs.runtime.workspace import Workspace

MESSAGE = re.compile(r"integration failed at t = (\S+) s: (.+)")
ALL = ["dopri5", "rodasp", "RK45", "DOP853", "Radau", "BDF", "LSODA"]


def run_failing(model, integrator, mode):
    data = Workspace(model)
    data.p[4] = mode
    return data, simulate(model, data, 2.0, sample=0.01, integrator=integrator, rtol=1e-8, atol=1e-10)


@pytest.mark.parametrize("integrator", ALL)
def test_nan_after_half_a_second_keeps_the_first_half(failing, integrator):
    data, res = run_failing(failing, integrator, mode=0.0)  # silent NaN from t = 0.5 s
    assert not res.success and res.metadata["status"] == "failed"
    match = MESSAGE.fullmatch(res.message)
    assert match, res.message
    t_fail = float(match.group(1))
    assert 0.45 < t_fail <= 0.5  # the end of the last good step (BDF's steps are long)
    if integrator in ("dopri5", "rodasp", "RK45", "DOP853"):
        assert match.group(2).startswith("step size collapsed to ")
    # every sample up to the failure time is kept, and they are correct
    assert t_fail - 0.0101 < res.t[-1] <= t_fail and len(res) == int(round(res.t[-1] / 0.01)) + 1
    assert np.all(np.isfinite(res.data))
    ok = simulate(failing, Workspace(failing), 0.45, sample=0.01, integrator="DOP853", rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(res.data[:len(ok)], ok.data, atol=1e-6)
    assert data.t == pytest.approx(t_fail, abs=1e-6)  # the workspace holds the last good state
    with pytest.raises(SimulationError, match="integration failed at t = "):
        res.check()


@pytest.mark.parametrize("integrator", ["dopri5", "rodasp", "RK45", "Radau"])
def test_status_from_the_model_is_named(failing, integrator):
    _, res = run_failing(failing, integrator, mode=1.0)  # status 2 from t = 0.5 s
    assert MESSAGE.fullmatch(res.message), res.message
    assert "status 2 (non-finite value)" in res.message
    assert 0.48 <= res.t[-1] <= 0.5


def test_exact_message_of_dopri5(failing):
    _, res = run_failing(failing, "dopri5", mode=2.0)
    # the message, then what the mass matrix in the failing state says (runtime/diagnose.py)
    t, h = re.fullmatch(r"integration failed at t = (\S+) s: step size collapsed to (\S+) s "
                        r"\(the model returned status 1 \(singular mass matrix\)\)(?:: .*, at t = \S+ s in the "
                        r"state phi = .*)?", res.message).groups()
    assert 0.4999 < float(t) <= 0.5 and float(h) < 1e-12


def test_failure_at_the_initial_state(failing):
    data = Workspace(failing)
    data.p[3] = 0.0  # failing from t = 0 on
    data.p[4] = 1.0
    for integrator in ("dopri5", "RK45"):
        res = simulate(failing, data, 1.0, sample=0.1, integrator=integrator)
        assert not res.success and len(res) == 1  # the given initial state is kept
        assert "status 2 (non-finite value)" in res.message and res.message.startswith("integration failed at t = 0 s")


def test_too_many_steps(pendulum):
    res = simulate(pendulum, Workspace(pendulum), 10.0, sample=1.0, rtol=1e-10, max_steps=50)
    assert res.message.endswith("too many steps (max_steps = 50)")
    assert 1 <= len(res) < 11


def test_step_interface_reports_instead_of_raising(failing):
    data = Workspace(failing)
    solver = get_integrator("dopri5")(data.rhs, 0.0, data.x, 2.0, rtol=1e-8, atol=1e-10)
    while solver.status == "running":
        solver.step()
    assert solver.status == "failed" and MESSAGE.fullmatch(solver.message)
    with pytest.raises(RuntimeError):
        solver.step()


def test_progress_callback_sees_time_and_can_stop(pendulum):
    seen = []

    def progress(t, t_end):
        seen.append(t)
        return t < 1.0

    res = simulate(pendulum, Workspace(pendulum), 5.0, sample=0.01, progress=progress)
    assert res.metadata["status"] == "stopped" and res.message.startswith("stopped by the progress callback")
    assert seen == sorted(seen) and 1.0 <= res.t[-1] < 1.2
    full = simulate(pendulum, Workspace(pendulum), 5.0, sample=0.01, progress=lambda t, t_end: None)
    assert full.success and len(full) == 501
