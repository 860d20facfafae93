"""Rodas5P (runtime/c/rodas5p.c) against solutions it did not compute: closed forms for its classical, stiff and
dense-output orders (fixed steps), a Radau reference on stiff van der Pol, and RODASP's cost per step.

Fixed steps: loose tolerances with first_step = max_step = h make every step accepted with size h.  RODASP is
measured by the same code, as the contrast (order 4, Hermite dense output of order 3).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from mbs.runtime.integrators import get_integrator
from mbs.runtime.workspace import Workspace

LINEAR, PROTHERO_ROBINSON, VAN_DER_POL = 0.0, 1.0, 2.0


def workspace(model, p):
    data = Workspace(model)
    data.p = np.array(p, dtype=float)
    return data


def fixed_steps(data, method, x0, t_end, h):
    solver = get_integrator(method)(data.rhs, 0.0, x0, t_end, rtol=1e3, atol=1e3, first_step=h, max_step=h)
    while solver.status == "running":
        solver.step()
    assert solver.status == "finished" and solver.nsteps == round(t_end / h) and solver.nreject == 0
    return solver


def rates(errors):
    errors = np.array(errors)
    return np.log2(errors[:-1] / errors[1:])


@pytest.mark.parametrize("method, order", [("rodasp", 4), ("rodas5p", 5)])
def test_order_on_a_linear_system_with_its_closed_form(order_problems, method, order):
    """x' = [[-1, 10], [-10, -1]] x: x(1) = e^-1 (cos 10, -sin 10) from (1, 0)."""
    data = workspace(order_problems, [LINEAR, 1.0, 10.0])
    exact = np.exp(-1.0) * np.array([np.cos(10.0), -np.sin(10.0)])
    errors = [np.abs(fixed_steps(data, method, [1.0, 0.0], 1.0, h).y - exact).max() for h in (0.05, 0.025, 0.0125)]
    assert np.all(rates(errors) > order - 0.1), rates(errors)


@pytest.mark.parametrize("method, order", [("rodasp", 4), ("rodas5p", 5)])
def test_order_on_nonlinear_van_der_pol(order_problems, method, order):
    """mu = 1 (not stiff): every elementary differential of order <= 5 is there, unlike on a linear system."""
    data = workspace(order_problems, [VAN_DER_POL, 1.0, 0.0])
    ref = solve_ivp(data.rhs, (0.0, 2.0), [2.0, 0.0], method="DOP853", rtol=1e-13, atol=1e-15).y[:, -1]
    errors = [np.abs(fixed_steps(data, method, [2.0, 0.0], 2.0, h).y - ref).max() for h in (0.05, 0.025, 0.0125)]
    assert np.all(np.abs(rates(errors) - order) < 0.25), rates(errors)


@pytest.mark.parametrize("method, order", [("rodasp", 4), ("rodas5p", 5)])
def test_stiff_order_on_prothero_robinson(order_problems, method, order):
    """x0' = -1e6 (x0 - sin t) + cos t: h |lambda| from 1e5 to 2.5e4, the regime where Rosenbrock methods not
    built for it (RODAS) drop to order 2-3; both keep their order against the exact x = (sin t, cos t)."""
    data = workspace(order_problems, [PROTHERO_ROBINSON, -1e6, 0.0])
    exact = np.array([np.sin(1.0), np.cos(1.0)])
    errors = [np.abs(fixed_steps(data, method, [0.0, 1.0], 1.0, h).y - exact).max() for h in (0.1, 0.05, 0.025)]
    assert np.all(np.abs(rates(errors) - order) < 0.25), rates(errors)


@pytest.mark.parametrize("method, dense_order", [("rodasp", 3), ("rodas5p", 4)])
def test_dense_output_order_within_one_step(order_problems, method, dense_order):
    """One step from the exact start: the interpolant's largest error inside the step is O(h^(order + 1))."""
    data = workspace(order_problems, [VAN_DER_POL, 1.0, 0.0])
    errors = []
    for h in (0.05, 0.025, 0.0125):
        solver = get_integrator(method)(data.rhs, 0.0, [2.0, 0.0], 1.0, rtol=1e3, atol=1e3, first_step=h,
                                        max_step=h)
        solver.step()
        inside = np.linspace(0.0, h, 11)[1:-1]
        ref = solve_ivp(data.rhs, (0.0, h), [2.0, 0.0], method="DOP853", rtol=1e-13, atol=1e-16, t_eval=inside).y
        errors.append(np.abs(solver.dense_output()(inside) - ref).max())
    assert np.all(np.abs(rates(errors) - (dense_order + 1)) < 0.35), rates(errors)


def test_stiff_van_der_pol_against_radau(order_problems):
    """Hairer and Wanner's VDPOL with epsilon = 1/mu = 1e-3 over 2 s: a relaxation oscillation, slow drifts
    joined by jumps of about 1e-3 s.  The end state against scipy's Radau (an implicit Runge-Kutta method of
    order 5, other code) at rtol 1e-10; the tolerance-controlled runs at rtol 1e-7 end within 10 rtol of it
    (measured: 1e-7 for rodas5p, 1e-8 for rodasp, which overshoots its tolerance less), and rodas5p with far
    fewer steps than RODASP (at 1e-6: 386 against 601)."""
    data = workspace(order_problems, [VAN_DER_POL, 1e3, 0.0])
    t_end, x0, rtol = 2.0, [2.0, 0.0], 1e-7
    jacobian = data.function("jacobian")
    ref = solve_ivp(data.rhs, (0.0, t_end), x0, method="Radau", rtol=1e-10, atol=1e-10,
                    jac=lambda t, x: jacobian(t, x)[:, :2]).y[:, -1]
    runs = {}
    for method in ("rodasp", "rodas5p"):
        solver = get_integrator(method)(data.rhs, 0.0, x0, t_end, rtol=rtol, atol=rtol)
        while solver.status == "running":
            solver.step()
        assert solver.status == "finished", solver.message
        runs[method] = solver
        assert np.all(np.abs(solver.y - ref) < 10 * rtol * np.abs(ref)), (method, solver.y, ref)
    assert runs["rodas5p"].nsteps < 0.8 * runs["rodasp"].nsteps
    assert runs["rodas5p"].nfev <= 8 * runs["rodas5p"].nsteps + 2
    assert runs["rodasp"].nfev <= 6 * runs["rodasp"].nsteps + 2
