"""Forward sensitivities against what no one here wrote: the closed-form period of the pendulum and its
derivatives, and central finite differences of full runs of a double pendulum and of the quarter car."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.special import ellipe, ellipk

import mbs
from mbs.cli import main
from mbs.language.diagnostics import MbsError
from mbs.sensitivity import evaluate_metric, parse_metric, sensitivities

sys.path.insert(0, str(Path(__file__).parents[1] / "physics"))
import physkit

G = 9.81
RTOL, ATOL = 1e-11, 1e-13


def closed_form_period(L: float, a: float) -> tuple[float, float, float]:
    """(T, dT/dL, dT/da) of a pendulum of reduced length L released at rest from angle a:
    T = 4 sqrt(L/g) K(k2), k2 = sin^2(a/2), dK/dk2 = (E - (1 - k2) K) / (2 k2 (1 - k2))."""
    k2 = math.sin(a / 2) ** 2
    K, E = ellipk(k2), ellipe(k2)
    T = 4 * math.sqrt(L / G) * K
    dK = (E - (1 - k2) * K) / (2 * k2 * (1 - k2))
    return T, T / (2 * L), 4 * math.sqrt(L / G) * dK * math.sin(a / 2) * math.cos(a / 2)


@pytest.fixture(scope="module")
def pendulum():
    return mbs.load(physkit.MODELS / "pendulum.mbs")


def test_period_sensitivity_to_length_and_amplitude_matches_the_elliptic_integral(pendulum):
    m, l, J, a = 1.5, 0.8, 0.2, 1.0  # an extended bob: L = l + J/(m l), dL/dl = 1 - J/(m l^2), dL/dJ = 1/(m l)
    table = sensitivities(pendulum, params=["l", "theta0", "J", "m"], values={"l": l, "J": J, "theta0": a},
                          metrics=["period(hinge.phi)"], t_end=6.0, rtol=RTOL, atol=ATOL)
    L = l + J / (m * l)
    T, dT_dL, dT_da = closed_form_period(L, a)
    metric = "period(hinge.phi)"
    assert table.row(metric, "l").value == pytest.approx(T, rel=1e-9)
    # each derivative is O(1); the integration at rtol 1e-11 leaves ~1e-9 of it, a wrong chain rule 1e-1
    assert table.derivative(metric, "l") == pytest.approx(dT_dL * (1 - J / (m * l * l)), rel=1e-7)
    assert table.derivative(metric, "J") == pytest.approx(dT_dL / (m * l), rel=1e-7)
    assert table.derivative(metric, "m") == pytest.approx(-dT_dL * J / (m * m * l), rel=1e-7)
    # theta0 enters through the initial state only: S(0) = d x0/d theta0 = e_phi
    assert table.derivative(metric, "theta0") == pytest.approx(dT_da, rel=1e-7)


def test_point_pendulum_period_scales_with_the_square_root_of_the_length(pendulum):
    table = sensitivities(pendulum, params=["l"], values={"theta0": 0.3}, metrics=["period(hinge.phi)"],
                          t_end=4.0, rtol=RTOL, atol=ATOL)
    assert table.normalised("period(hinge.phi)", "l") == pytest.approx(0.5, abs=1e-8)


DOUBLE = """
model double "double pendulum of point masses on massless rods; l2 follows l1 unless set" {
    param m1 = 1 kg
    param m2 = 0.7 kg
    param l1 = 1 m
    param l2 = 0.6 * l1
    param phi0 = 40 deg
    rigid upper {
        body {
            mass = m1
            com = (0, 0, -l1)
            inertia = diag(1e-3, 1e-3, 1e-3) kg*m^2
        }
        frame elbow at (0, 0, -l1)
    }
    rigid lower {
        body {
            mass = m2
            com = (0, 0, -l2)
            inertia = diag(1e-3, 1e-3, 1e-3) kg*m^2
        }
    }
    interact shoulder {
        connect inertial -> upper
        joint revolute(axis = y) {
            init phi = phi0
        }
    }
    interact elbow {
        connect upper.elbow -> lower
        joint revolute(axis = y) {
            init phi = -0.5 * phi0
        }
    }
    output spread = shoulder.phi - elbow.phi
}
"""
PARAMS = ["l1", "m2", "phi0"]
T_END = 1.5


@pytest.fixture(scope="module")
def double():
    return mbs.loads(DOUBLE, path="double.mbs")


def full_run_final(system, values):
    res = system.simulate(t_end=T_END, sample=0.01, params=values, rtol=RTOL, atol=ATOL)
    assert res.success, res.message
    final = np.array([res[n][-1] for n in ("shoulder.phi", "elbow.phi", "der(shoulder.phi)", "der(elbow.phi)",
                                           "spread")])
    return final, np.array([np.max(res["spread"]), final[0] * final[1] / (1 + final[2] ** 2)])


def test_final_state_and_metric_arithmetic_sensitivities_match_central_differences_of_full_runs(double):
    metrics = [f"final({n})" for n in ("shoulder.phi", "elbow.phi", "der(shoulder.phi)", "der(elbow.phi)",
                                      "spread")] + ["peak(spread)",
                                                    "final(shoulder.phi) * final(elbow.phi) / (1 + final(der(shoulder.phi))**2)"]
    table = sensitivities(double, params=PARAMS, metrics=metrics, t_end=T_END, rtol=RTOL, atol=ATOL)
    base = {"l1": 1.0, "m2": 0.7, "phi0": math.radians(40)}
    for name in PARAMS:
        h = 1e-4 * base[name]
        up_final, up_peak = full_run_final(double, {name: base[name] + h})
        down_final, down_peak = full_run_final(double, {name: base[name] - h})
        fd = np.append((up_final - down_final) / (2 * h), (up_peak - down_peak) / (2 * h))  # + the arithmetic
        ours = np.array([table.derivative(m, name) for m in metrics])
        # central differences: truncation ~h^2 ~1e-8, integration noise ~1e-11/h ~1e-7 of derivatives O(1..10);
        # l2 = 0.6 l1 must follow l1, phi0 moves both initial angles: missing either is an O(1) error
        np.testing.assert_allclose(ours, fd, rtol=2e-5, atol=2e-5 * np.max(np.abs(fd)), err_msg=name)


def test_generated_parameter_jacobian_matches_differences_of_the_right_hand_side(double):
    compiled = double.compile(jacobian=True, parameter_jacobian=True)
    data, _ = double.start(jacobian=True, parameter_jacobian=True)
    x = np.array([0.3, -0.8, 1.1, -0.4])
    Fp = data.param_jacobian(0.0, x)
    p0 = data.p.copy()
    for k in range(compiled.np):
        h = 1e-6 * max(1.0, abs(p0[k]))
        data.p = p0 + h * np.eye(compiled.np)[k]
        up = data.rhs(0.0, x)
        data.p = p0 - h * np.eye(compiled.np)[k]
        down = data.rhs(0.0, x)
        data.p = p0
        np.testing.assert_allclose(Fp[:, k], (up - down) / (2 * h), rtol=1e-7, atol=1e-8)


def test_numpy_back_end_has_the_same_parameter_jacobian(double):
    numpy_system = mbs.loads(DOUBLE, path="double.mbs", backend="numpy")
    x = np.array([0.3, -0.8, 1.1, -0.4])
    c_data, _ = double.start(jacobian=True, parameter_jacobian=True)
    py_data, _ = numpy_system.start(jacobian=True, parameter_jacobian=True)
    np.testing.assert_allclose(py_data.param_jacobian(0.0, x), c_data.param_jacobian(0.0, x), rtol=1e-13,
                               atol=1e-13)


def test_unknown_parameter_and_metric_are_clear_errors(pendulum):
    with pytest.raises(MbsError, match="has no parameter 'q'"):
        sensitivities(pendulum, params=["q"])
    with pytest.raises(MbsError, match="unknown function 'sum'"):
        sensitivities(pendulum, params=["l"], metrics=["sum(hinge.phi)"])
    with pytest.raises(MbsError, match="no output or coordinate 'hinge.psi'"):
        sensitivities(pendulum, params=["l"], metrics=["final(hinge.psi)"])


@pytest.mark.parametrize("text, message", [
    ("rms(hinge.phi - 1)", r"rms\(\) of one column as it is"),
    ("abs(hinge.phi)", "is a signal, not a number"),
    ("peak(hinge.phi) ** final(hinge.phi)", r"exponent of \*\* must be a number"),
    ("__import__('os')", "unknown function '__import__'"),
])
def test_metrics_without_a_derivative_are_refused_by_the_shared_grammar(text, message):
    """The sweep's grammar accepts these (or refuses them in its own words); a sensitivity also needs each
    reduction to be of one column, so the chain rule reaches a derivative of a reduction."""
    columns = ["hinge.phi", "der(hinge.phi)"]
    with pytest.raises(MbsError, match=message):
        parse_metric(text, columns)
    assert evaluate_metric(parse_metric("2 * peak(hinge.phi) ** 2 - abs(final(der(hinge.phi)))", columns),
                           lambda r, c: (3.0, np.array([1.0])))[1] == pytest.approx([12.0 - 1.0])


def test_cli_prints_derivative_and_normalised_value(capsys, tmp_path):
    out_csv = tmp_path / "s.csv"
    status = main(["sensitivity", "library/examples/pendulum.mbs", "--param", "l=2m", "--metric",
                   "period(hinge.phi)", "--t-end", "6", "--out", str(out_csv)])
    out = capsys.readouterr().out
    assert status == 0
    row = next(line for line in out.splitlines() if line.startswith("period(hinge.phi)"))
    assert float(row.split()[-1]) == pytest.approx(0.5, abs=1e-5)  # T ~ sqrt(l): (l/T) dT/dl = 1/2
    assert out_csv.read_text().startswith("metric,parameter,value,p,derivative,normalised")
    assert main(["sensitivity", "library/examples/pendulum.mbs", "--param", "nope"]) == 1


def test_output_metrics_of_the_quarter_car_over_the_bump_match_differences_of_full_runs():
    """Outputs (the tyre load reads the road, a function of t and v) get dy/dp by directional differences; the
    run crosses the contact's max() kink never (the tyre keeps contact), so the derivative exists. The bump's
    curvature jumps at its ends, so differences of runs converge only linearly in the step (observed: 9e-4, 3.6e-4,
    3.4e-5 relative off at steps 1e-3, 1e-4, 1e-5 of v, towards our value): step 1e-5."""
    system = mbs.load("library/examples/two_mass_quarter_car.mbs")
    metrics = ["final(body_z)", "rms(wheel_load)", "final(suspension.travel)"]
    table = sensitivities(system, "bump", params=["d_susp", "v"], metrics=metrics, t_end=1.5, rtol=1e-10,
                          atol=1e-12)
    grid = table.run.t  # the metrics reduce the samples; a run adds rows at its events (the bump's ends are
    # switches), which move with v: the differences are taken of the same metric, over the sample grid

    def on_grid(r):
        rows = np.searchsorted(r.t, grid)
        np.testing.assert_allclose(r.t[rows], grid, rtol=0, atol=1e-12)
        return rows
    for name, value in (("d_susp", 2500.0), ("v", 10 / 3.6)):
        h = 1e-5 * value
        runs = [system.simulate("bump", t_end=1.5, params={name: value + sign * h}, rtol=1e-11, atol=1e-13)
                for sign in (1, -1)]
        summary = [np.array([r["body_z"][-1], np.sqrt(np.mean(r["wheel_load"][on_grid(r)] ** 2)),
                             r["suspension.travel"][-1]]) for r in runs]
        fd = (summary[0] - summary[1]) / (2 * h)
        ours = np.array([table.derivative(m, name) for m in metrics])
        np.testing.assert_allclose(ours, fd, rtol=1e-4, err_msg=name)


def test_closed_loops_are_a_clear_error_not_a_wrong_answer():
    system = mbs.load("library/examples/slider_crank.mbs")
    name = system.model.parameters[0].name
    with pytest.raises(MbsError, match="closed kinematic loops"):
        sensitivities(system, params=[name], t_end=0.1)


@pytest.mark.slow
def test_spatial_chain_with_quaternion_joints_matches_differences_of_full_runs():
    """Ball joints (quaternion coordinates) and a Cardan joint in 3-D: every final coordinate's derivative
    with respect to masses and a length, against central differences (observed agreement 3e-10)."""
    system = mbs.load("library/examples/spatial_chain.mbs")
    compiled = system.compile()
    names = list(compiled.p_names)[:3]
    metrics = [f"final({n})" for n in compiled.q_names]
    table = sensitivities(system, params=names, metrics=metrics, t_end=1.0, rtol=1e-11, atol=1e-13)
    for name, value in zip(compiled.p_names, compiled.p_default):
        if name not in names:
            continue
        h = 1e-5 * max(abs(value), 1.0)
        runs = [system.simulate(t_end=1.0, params={name: value + sign * h}, rtol=1e-12, atol=1e-14)
                for sign in (1, -1)]
        fd = np.array([(runs[0][q][-1] - runs[1][q][-1]) / (2 * h) for q in compiled.q_names])
        ours = np.array([table.derivative(m, name) for m in metrics])
        np.testing.assert_allclose(ours, fd, rtol=0, atol=1e-7 * np.max(np.abs(fd)), err_msg=name)


PUSHED = """
model pushed "a block coasting at v0 that a force F pushes from the time T on, and again from the place d on" {
    param m = 2 kg
    param v0 = 0.5 m/s
    param F = 3 N
    param T = 0.4 s
    param d = 0.6 m
    gravity = (0, 0, 0) m/s^2
    rigid block {
        body {
            mass = m
            com = (0, 0, 0) m
            inertia = diag(0.01, 0.01, 0.01) kg*m^2
        }
    }
    interact slide {
        connect inertial.origin -> block.origin
        joint prismatic(axis = x) {
            init der(s) = v0
        }
        force push = joint(s = if(t > T, F, 0 N) + if(slide.s > d, F, 0 N))
    }
}
"""


def pushed_closed_form(m, v0, F, T, d, t_end):
    """(x, v) at t_end and their derivatives to T and d: coasting until the time push at T, then uniformly
    accelerated, the place push adding F from the crossing of d on (tau from x(tau) = d)."""
    import sympy as sp
    Ts, ds, t = sp.symbols("T d t", positive=True)
    a = F / m
    x1 = v0 * t + a / 2 * (t - Ts) ** 2                      # after the time push (T < tau)
    tau = sp.solve(sp.Eq(x1, ds), t)
    tau = [r for r in tau if r.subs({Ts: T, ds: d}).is_real and float(r.subs({Ts: T, ds: d})) > T][0]
    x_tau, v_tau = x1.subs(t, tau), sp.diff(x1, t).subs(t, tau)
    x_end = x_tau + v_tau * (t_end - tau) + a * (t_end - tau) ** 2     # 2 F after tau: (2a)/2 (t - tau)^2
    v_end = v_tau + 2 * a * (t_end - tau)
    at = {Ts: T, ds: d}
    return {name: float(e.subs(at)) for name, e in
            (("x", x_end), ("v", v_end), ("dx/dT", sp.diff(x_end, Ts)), ("dx/dd", sp.diff(x_end, ds)),
             ("dv/dT", sp.diff(v_end, Ts)), ("dv/dd", sp.diff(v_end, ds)))}


def test_sensitivities_jump_at_switches_whose_time_moves_with_the_parameters():
    """A time event at T and a state event at x = d, both moving with the parameters: S jumps by
    (f- - f+) dtau/dp at each (without the jump d(x)/dd would be 0).  Closed form by sympy."""
    system = mbs.loads(PUSHED, path="pushed.mbs")
    table = sensitivities(system, params=["T", "d"], metrics=["final(slide.s)", "final(der(slide.s))"],
                          t_end=2.0, rtol=RTOL, atol=ATOL)
    ref = pushed_closed_form(2.0, 0.5, 3.0, 0.4, 0.6, 2.0)
    assert table.row("final(slide.s)", "T").value == pytest.approx(ref["x"], rel=1e-9)
    for metric, key in (("final(slide.s)", "x"), ("final(der(slide.s))", "v")):
        for p in ("T", "d"):
            assert table.derivative(metric, p) == pytest.approx(ref[f"d{key}/d{p}"], rel=1e-7), (metric, p)


def test_an_event_that_makes_the_state_jump_is_a_clear_error_not_a_wrong_answer():
    from mbs.runtime.errors import UsageError
    ball = mbs.load("library/examples/bouncing_ball.mbs")
    with pytest.raises(UsageError, match="event 'impact' makes the state jump"):
        sensitivities(ball, "drop", params=["e"], metrics=["final(fall.s)"], t_end=1.0)
