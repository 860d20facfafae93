"""Extra differential states in models with closed kinematic loops (runtime/c/loops.c appends z' from the
generated mbs_state_rates to the loop solver's [qdot; vdot]; the projection and the assembly leave z alone).

Checked against what no one here wrote: the slider-crank's one-coordinate Lagrange equation (its kinematics
s(theta) = r cos theta + sqrt(L^2 - r^2 sin^2 theta) in closed form), written here by hand with sympy and
integrated by scipy's solve_ivp together with the extra state's own equation: a motor torque that lags its
command (T tau' + tau = tau_cmd, and an event that resets it), and LuGre's bristle deflection
(Canudas de Wit et al. 1995) in the slider's guide, a joint of the spanning tree.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from scipy.integrate import solve_ivp

import mbs

MODELS = Path(__file__).parent / "models"
SC = dict(r=0.1, L=0.4, mc=1.0, mr=0.5, ms=2.0, k=200.0, l0=0.45)   # both fixtures
T, TAU = 0.05, 0.5                                                   # slider_crank_lag.mbs
TAU_LUGRE = 2.0                                                      # slider_crank_lugre.mbs
LUGRE = dict(sigma0=1e4, sigma1=100.0, sigma2=0.4, fc=2.0, fs=3.0, vs=0.01)   # slider_crank_lugre.mbs
THETA0 = math.radians(30)


def slider_crank_terms(r, L, mc, mr, ms, k, l0):
    """(m, dm/dtheta, dV/dtheta, s, ds/dtheta) of the slider-crank as functions of the crank angle theta, from
    its kinetic and potential energy written by hand: m(theta) theta'' + m'(theta) theta'^2 / 2 + V'(theta) = Q."""
    th, w = sp.symbols("theta omega")
    beta = -sp.asin(r * sp.sin(th) / L)                        # rod angle
    cc = r / 2 * sp.Matrix([sp.cos(th), sp.sin(th)])            # crank centre of mass
    rc = r * sp.Matrix([sp.cos(th), sp.sin(th)]) + L / 2 * sp.Matrix([sp.cos(beta), sp.sin(beta)])
    s = r * sp.cos(th) + L * sp.cos(beta)                       # slider position
    d = lambda e: sp.diff(e, th) * w  # noqa: E731
    kinetic = (sp.Rational(1, 2) * (mc * r**2 / 12) * w**2 + sp.Rational(1, 2) * mc * d(cc).dot(d(cc))
               + sp.Rational(1, 2) * mr * d(rc).dot(d(rc)) + sp.Rational(1, 2) * (mr * L**2 / 12) * d(beta)**2
               + sp.Rational(1, 2) * ms * d(s)**2)
    m = sp.simplify(2 * kinetic / w**2)
    V = k / 2 * (s - l0)**2
    return tuple(sp.lambdify(th, e) for e in (m, sp.diff(m, th), sp.diff(V, th), s, sp.diff(s, th)))


@pytest.fixture(scope="module")
def lag():
    return mbs.load(MODELS / "slider_crank_lag.mbs")


def lag_reference(times, t_off=None):
    """[theta, omega, tau] at `times` by scipy (DOP853) on the hand-written equations; at t_off tau jumps to 0."""
    m, dm, dV, _, _ = slider_crank_terms(**SC)

    def rhs(_, y):
        th, w, tau = y
        return [w, (tau - 0.5 * dm(th) * w**2 - dV(th)) / m(th), (TAU - tau) / T]
    cuts = [times[0]] + ([t_off] if t_off is not None else []) + [times[-1]]
    y0, out = [THETA0, 0.0, 0.0], []
    for k, (start, end) in enumerate(zip(cuts, cuts[1:])):
        last = k == len(cuts) - 2
        part = times[(times >= start) & ((times <= end) if last else (times < end))]
        sol = solve_ivp(rhs, (start, end), y0, method="DOP853", rtol=1e-12, atol=1e-12, dense_output=True)
        out.append(sol.sol(part).T)
        y0 = [*sol.sol(end)[:2], 0.0]
    return np.vstack(out)


@pytest.mark.parametrize("integrator", ["dopri5", "rodasp", "Radau"])
def test_slider_crank_with_a_lagging_motor_follows_the_hand_written_equations(lag, integrator):
    res = lag.simulate("spin_up", integrator=integrator, rtol=1e-10, atol=1e-12)
    assert res.success, res.metadata.get("message")
    assert res.unit("tau") == "N*m"
    ref = lag_reference(res.t)
    np.testing.assert_allclose(res["tau"], TAU * (1 - np.exp(-res.t / T)), rtol=0, atol=1e-8)
    omega = res["der(main_bearing.phi)"]
    assert np.max(np.abs(res["main_bearing.phi"] - ref[:, 0])) < 1e-9   # 6e-11 measured (dopri5)
    assert np.max(np.abs(omega - ref[:, 1])) < 2e-9 * np.max(np.abs(omega))
    assert res["main_bearing.phi"][-1] > THETA0 + 0.5  # the motor has turned the crank
    # the loop stays closed: the slider where the crank and the rod put it
    r, L, th = SC["r"], SC["L"], res["main_bearing.phi"]
    assert np.max(np.abs(res["guide.s"] - (r * np.cos(th) + np.sqrt(L**2 - r**2 * np.sin(th)**2)))) < 1e-10


def test_an_event_resets_the_state_of_a_loop_model(lag):
    res = lag.simulate("spin_up", params={"t_off": 0.4}, integrator="dopri5", rtol=1e-10, atol=1e-12)
    assert res.success, res.metadata.get("message")
    assert [(e["time"], e["event"]) for e in res.events] == [(pytest.approx(0.4, abs=1e-12), "release")]
    after = res.t > 0.4
    np.testing.assert_allclose(res["tau"][after], TAU * (1 - np.exp(-(res.t[after] - 0.4) / T)), atol=1e-8)
    keep = np.abs(res.t - 0.4) > 1e-9  # the samples at the event itself (one each side of the jump) left out
    ref = lag_reference(res.t[keep], t_off=0.4)
    assert np.max(np.abs(res["main_bearing.phi"][keep] - ref[:, 0])) < 1e-7
    assert np.max(np.abs(res["tau"][keep] - ref[:, 2])) < 1e-8


def test_projection_and_rhs_leave_the_extra_state_alone(lag):
    data, _ = lag.start("spin_up")
    x = data.x.copy()
    x[-1] = 1.25                       # tau
    x[1] += 1e-3                       # off the constraints
    projected = data.function("project")(0.0, x)
    assert projected[-1] == 1.25 and abs(projected[1] - x[1]) > 1e-4
    xdot = data.rhs(0.0, projected)
    assert xdot[-1] == pytest.approx((TAU - 1.25) / T, rel=1e-14)


def lugre_reference(times):
    """[theta, omega, z] by scipy's Radau on the hand-written slider-crank with LuGre friction on the slider:
    F = -(sigma0 z + sigma1 z' + sigma2 v) along the guide, z' = v - sigma0 |v| z / g(v), v = s'(theta) omega."""
    m, dm, dV, _, ds = slider_crank_terms(**SC)
    s0, s1, s2, fc, fs, vs = (LUGRE[n] for n in ("sigma0", "sigma1", "sigma2", "fc", "fs", "vs"))

    def rhs(_, y):
        th, w, z = y
        v = ds(th) * w
        g = fc + (fs - fc) * math.exp(-(v / vs)**2)
        zdot = v - s0 * abs(v) * z / g
        force = -(s0 * z + s1 * zdot + s2 * v)
        return [w, (TAU_LUGRE + force * ds(th) - 0.5 * dm(th) * w**2 - dV(th)) / m(th), zdot]
    # the run has two rows at each of its events (the kinks of |v| and sign(v) are switches): the state is the same
    once, row = np.unique(times, return_inverse=True)
    sol = solve_ivp(rhs, (times[0], times[-1]), [THETA0, 0.0, 0.0], method="Radau", rtol=1e-11, atol=1e-13,
                    t_eval=once)
    assert sol.success
    return sol.y.T[row]


@pytest.mark.slow  # its reference, scipy's Radau in Python at rtol 1e-11 across 16 kinks, takes about 40 s
def test_lugre_friction_in_a_tree_joint_of_a_loop_model():
    system = mbs.load(MODELS / "slider_crank_lugre.mbs")
    res = system.simulate("spin_up", integrator="rodasp", rtol=1e-9, atol=1e-12)
    assert res.success, res.metadata.get("message")
    ref = lugre_reference(res.t)
    assert res["main_bearing.phi"][-1] > 8 * 2 * math.pi  # eight turns against the friction in one second
    assert np.max(np.abs(res["main_bearing.phi"] - ref[:, 0])) < 1e-6   # 1.1e-7 measured
    assert np.max(np.abs(res["friction.z"] - ref[:, 2])) < 1e-9          # 1.1e-10 measured (z ~ 2e-4 m)
    # it slides: the bristles sit near their steady deflection g(v) / sigma0 most of the time
    assert np.max(np.abs(res["friction.z"])) > 0.9 * LUGRE["fc"] / LUGRE["sigma0"]


def test_linearisation_of_a_loop_model_with_a_state(lag):
    """About the rest position (no torque: the spring unstretched, s = l0) the eigenvalues are the lag's -1/T and
    the crank's +-i sqrt(k s'(theta)^2 / m(theta)) of the hand-written Lagrange equation."""
    lin = lag.linearize(params={"tau_cmd": 0.0})
    m, _, _, s, ds = slider_crank_terms(**SC)
    theta = lin.x[0]
    assert s(theta) == pytest.approx(SC["l0"], abs=1e-10)
    omega = math.sqrt(SC["k"] * ds(theta)**2 / m(theta))
    expected = sorted([-1 / T, 1j * omega, -1j * omega], key=lambda e: (e.real, e.imag))
    found = sorted(lin.eigenvalues, key=lambda e: (round(e.real, 6), e.imag))
    np.testing.assert_allclose(found, expected, atol=1e-6 * omega)
