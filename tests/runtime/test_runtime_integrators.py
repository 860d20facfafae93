"""Integrators checked against each other and against closed-form pendulum periods."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq
from scipy.special import ellipk

from mbs.runtime.errors import UsageError
from mbs.runtime.integrators import (FINISHED, DenseOutput, Dopri5, OdeSolver, Rodasp, available, get_integrator,
                                     register)
from mbs.runtime.simulate import simulate
from mbs.runtime.workspace import Workspace

G = 9.81
SCIPY_METHODS = ["RK45", "DOP853", "Radau", "BDF", "LSODA"]


def zero_crossings(solver, count, component=0):
    """Times of the first `count` sign changes of y[component], located on each step's dense output."""
    times = []
    while len(times) < count and solver.status == "running":
        y_old = solver.y[component]
        solver.step()
        if np.sign(solver.y[component]) != np.sign(y_old) and y_old != 0:
            dense = solver.dense_output()
            times.append(brentq(lambda t: dense(t)[component], solver.t_old, solver.t, xtol=1e-14))
    return times


def pendulum_period(model, phi0, integrator, rtol):
    data = Workspace(model)
    solver = get_integrator(integrator)(data.rhs, 0.0, [phi0, 0.0], 100.0, rtol=rtol, atol=rtol * 1e-3)
    t1, t2 = zero_crossings(solver, 2)
    return 2 * (t2 - t1)


@pytest.mark.parametrize("integrator", ["dopri5", "rodasp", "rodas5p"])
def test_small_amplitude_period(pendulum, integrator):
    period = pendulum_period(pendulum, 1e-3, integrator, 1e-10)
    # exact T = 2 pi sqrt(l/g) (1 + phi0^2/16 + ...): the correction is 6e-8 relative
    assert period == pytest.approx(2 * math.pi * math.sqrt(1 / G), rel=2e-7)


@pytest.mark.parametrize("integrator", ["dopri5", "rodasp", "rodas5p", "DOP853"])
def test_large_amplitude_period_is_the_elliptic_integral(pendulum, integrator):
    phi0 = 2.5  # 143 degrees: 47 % longer than the small-amplitude period
    exact = 4 * math.sqrt(1 / G) * ellipk(math.sin(phi0 / 2) ** 2)
    assert pendulum_period(pendulum, phi0, integrator, 1e-11) == pytest.approx(exact, rel=1e-8)


def test_dopri5_in_c_matches_scipy_dop853(pendulum):
    data = Workspace(pendulum)
    data.x = [2.0, 0.0]
    t_eval = np.linspace(0.0, 10.0, 1001)
    ref = solve_ivp(data.rhs, (0.0, 10.0), data.x, method="DOP853", rtol=1e-13, atol=1e-13, t_eval=t_eval)
    res = simulate(pendulum, data, 10.0, t_eval=t_eval, integrator="dopri5", rtol=1e-10, atol=1e-12)
    assert res.success
    np.testing.assert_allclose(res.columns(pendulum.x_names), ref.y.T, rtol=0, atol=5e-8)
    np.testing.assert_array_equal(res.t, t_eval)


def test_python_dense_output_equals_c_sampling(pendulum, quarter_car):
    for model, cls in ((pendulum, Dopri5), (quarter_car, Rodasp)):
        data = Workspace(model)
        data.x = model.x0 + 0.01
        solver = cls(data.rhs, 0.0, data.x, 1.0, rtol=1e-6, atol=1e-9)
        for _ in range(5):
            solver.step()
        dense = solver.dense_output()
        times = np.linspace(solver.t_old, solver.t, 7)
        # a second solver reaching the same step samples these times in C
        twin = cls(data.rhs, 0.0, data.x, 1.0, rtol=1e-6, atol=1e-9)
        for _ in range(4):
            twin.step()
        out = np.empty((times.size, model.nx))
        assert twin.sample(times, out, 0) == times.size
        np.testing.assert_allclose(dense(times).T, out, rtol=1e-13, atol=1e-15)
        np.testing.assert_allclose(dense(solver.t), solver.y, rtol=1e-13, atol=1e-15)


@pytest.mark.parametrize("integrator", ["dopri5", "rodasp", *SCIPY_METHODS])
def test_every_integrator_runs_the_pendulum(pendulum, integrator):
    data = Workspace(pendulum)
    res = simulate(pendulum, data, 3.0, sample=0.1, integrator=integrator, rtol=1e-8, atol=1e-10)
    assert res.success and res.metadata["status"] == FINISHED and len(res) == 31
    energy = res["energy"]
    assert np.ptp(energy) < 1e-5 * abs(energy[0])  # conservative system
    assert data.t == 3.0 and data.stats["nfev"] > 0


def test_stiff_quarter_car_rodasp_matches_radau(quarter_car):
    data = Workspace(quarter_car)
    t_eval = np.linspace(0.0, 0.3, 31)
    ref = simulate(quarter_car, data, 0.3, t_eval=t_eval, integrator="Radau", rtol=1e-10, atol=1e-12)
    data.reset()
    res = simulate(quarter_car, data, 0.3, t_eval=t_eval, integrator="rodasp", rtol=1e-8, atol=1e-10)
    assert ref.success and res.success
    scale = np.abs(ref.data).max(axis=0) + 1e-12
    assert np.max(np.abs(res.data - ref.data) / scale) < 1e-6
    # where explicit DOPRI5 is held to h < 3e-5 s by stability, the stiff method is not
    data.reset()
    explicit = simulate(quarter_car, data, 0.3, t_eval=t_eval, integrator="dopri5", rtol=1e-4, atol=1e-6)
    data.reset()
    stiff = simulate(quarter_car, data, 0.3, t_eval=t_eval, integrator="rodasp", rtol=1e-4, atol=1e-6)
    assert explicit.success and stiff.success
    assert stiff.metadata["stats"]["nsteps"] * 5 < explicit.metadata["stats"]["nsteps"]


def test_registry_accepts_user_subclasses_and_rejects_unknown_names(pendulum, monkeypatch):
    from mbs.runtime.integrators import registry
    monkeypatch.setattr(registry, "_METHODS", dict(registry._METHODS))  # the test's method gone after it

    class EulerDense(DenseOutput):
        def __init__(self, t_old, t, y_old, y):
            super().__init__(t_old, t)
            self.y_old, self.y = y_old, y

        def _call_impl(self, t):
            s = (t - self.t_old) / (self.t - self.t_old)
            return np.multiply.outer(self.y_old, 1 - s) + np.multiply.outer(self.y, s)

    @register
    class Euler(OdeSolver):
        name = "test-euler"

        def _step_impl(self):
            h = min(1e-4, self.t_bound - self.t)
            self._y_old = self.y
            self.y = self.y + h * self.fun(self.t, self.y)
            self.t_old, self.t = self.t, self.t + h
            self.nfev += 1
            return True, None

        def _dense_output_impl(self):
            return EulerDense(self.t_old, self.t, self._y_old, self.y)

    assert "test-euler" in available() and get_integrator("TEST-EULER") is Euler
    res = simulate(pendulum, Workspace(pendulum), 0.5, sample=0.1, integrator="test-euler")
    ref = simulate(pendulum, Workspace(pendulum), 0.5, sample=0.1)
    assert res.success and np.allclose(res["hinge.phi"], ref["hinge.phi"], atol=1e-3)
    with pytest.raises(UsageError, match="unknown integrator 'nonesuch'"):
        get_integrator("nonesuch")
    with pytest.raises(UsageError):
        register(int)


def test_native_integrators_need_the_c_back_end(pendulum_numpy):
    from mbs.runtime.integrators import Dopri5
    data = Workspace(pendulum_numpy)
    with pytest.raises(UsageError, match="needs the right-hand side of a model built with the C back end"):
        Dopri5(data.function("rhs"), 0.0, data.x.copy(), 1.0)
    # simulate() runs such a request on the nearest scipy method instead, with a note (runtime/fallback.py)
    res = simulate(pendulum_numpy, Workspace(pendulum_numpy), 1.0, sample=0.5, integrator="dopri5")
    assert res.success and res.metadata["integrator"] == "RK45" and "using scipy's 'RK45'" in res.metadata["notes"][0]
    res = simulate(pendulum_numpy, Workspace(pendulum_numpy), 1.0, sample=0.5)  # default: RK45
    assert res.success and res.metadata["integrator"] == "RK45"


def test_bad_arguments_are_usage_errors(pendulum):
    data = Workspace(pendulum)
    for kwargs in (dict(rtol=0.0), dict(atol=[1.0, 2.0, 3.0]), dict(max_step=-1.0), dict(t_eval=[0.0, 2.0, 1.0]),
                   dict(t_eval=[0.0, 5.0]), dict(sample=0.0), dict(sample=0.1, t_eval=[0.0])):
        with pytest.raises(UsageError):
            simulate(pendulum, data, 1.0, **kwargs)
    with pytest.raises(UsageError, match="lies before"):
        simulate(pendulum, data, -1.0)


def test_vector_atol_and_sample_grid(pendulum):
    data = Workspace(pendulum)
    res = simulate(pendulum, data, 1.05, sample=0.1, atol=[1e-9, 1e-8])
    assert res.success
    np.testing.assert_allclose(res.t, np.r_[np.arange(11) * 0.1, 1.05])


@pytest.mark.parametrize("integrator, order", [("dopri5", 5), ("rodasp", 4), ("rodas5p", 5)])
def test_order_of_convergence_with_fixed_steps(pendulum, integrator, order):
    """Loose tolerances and max_step = first_step = h make every step accepted with size h."""
    data = Workspace(pendulum)
    ref = solve_ivp(data.rhs, (0.0, 2.0), [2.0, 0.0], method="DOP853", rtol=1e-13, atol=1e-14).y[:, -1]
    errors = []
    for h in (0.05, 0.025, 0.0125):
        solver = get_integrator(integrator)(data.rhs, 0.0, [2.0, 0.0], 2.0, rtol=1e3, atol=1e3, first_step=h,
                                            max_step=h)
        while solver.status == "running":
            solver.step()
        assert solver.nsteps == round(2.0 / h) and solver.nreject == 0
        errors.append(np.max(np.abs(solver.y - ref)))
    rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(np.abs(rates - order) < 0.4), rates  # still slightly pre-asymptotic at h = 0.05
