"""Linearisation about the static equilibrium against closed forms: the two-mass quarter car, the pendulum,
a ball-joint pendulum (quaternions: nq != nv) and a spring-held slider crank (a closed loop)."""

from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import mbs
from mbs.cli import main

MODELS = Path(__file__).parent / "models"
G = 9.81


def parameters(system) -> dict:
    return {p.name: p.value for p in system.model.parameters}


def two_mass_frequencies(m_s, m_u, k_s, k_t) -> np.ndarray:
    """Undamped natural frequencies [Hz] of a sprung mass on k_s over an unsprung mass on k_t: the roots of
    m_s m_u w^4 - (k_s m_u + (k_s + k_t) m_s) w^2 + k_s k_t = 0."""
    b = k_s / m_s + (k_s + k_t) / m_u
    c = k_s * k_t / (m_s * m_u)
    root = np.sqrt(b * b - 4 * c)
    return np.sqrt(np.array([(b - root) / 2, (b + root) / 2])) / (2 * np.pi)


def test_two_mass_quarter_car_has_the_closed_form_frequencies_and_eigenvalues():
    system = mbs.load("library/examples/two_mass_quarter_car.mbs")
    p = parameters(system)
    lin = system.linearize()
    assert lin.dof == 2
    m_s, m_u, k_s, k_t, d = p["m_body"], p["m_wheel"], p["k_susp"], p["k_tyre"], p["d_susp"]
    expected = two_mass_frequencies(m_s, m_u, k_s, k_t)
    assert lin.undamped_frequencies == pytest.approx(expected, rel=1e-6)
    # with the damper: the eigenvalues of the textbook state matrix in absolute heights (z_body, z_wheel)
    M = np.diag([m_s, m_u])
    K = np.array([[k_s, -k_s], [-k_s, k_s + k_t]])
    C = np.array([[d, -d], [-d, d]])
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    lam = np.linalg.eigvals(A)
    lam = lam[lam.imag > 0]
    lam = lam[np.argsort(np.abs(lam))]
    got = np.array([m.eigenvalue for m in lin.modes])
    assert got == pytest.approx(lam, rel=1e-6)
    assert lin.damping_ratios == pytest.approx(-lam.real / np.abs(lam), rel=1e-6)
    # the bounce mode moves the body most, the hop mode the wheel (relative coordinate wheel_guide.s)
    assert lin.modes[0].dominant(1)[0][0] == "body_guide.s"
    assert lin.modes[1].dominant(1)[0][0] == "wheel_guide.s"


@pytest.mark.parametrize("length", [1.0, 2.5])
def test_pendulum_small_oscillation_frequency(length):
    system = mbs.load("library/examples/pendulum.mbs")
    lin = system.linearize(params={"l": length})
    (mode,) = lin.modes
    # the model's bob has 1e-6 kg m^2 about its centre: sqrt(g/l) to 5e-7 relative
    assert mode.frequency == pytest.approx(np.sqrt(G / length) / (2 * np.pi), rel=2e-6)
    assert mode.damping_ratio == pytest.approx(0.0, abs=1e-9)
    assert list(mode.shape) == ["hinge.phi"]


def test_ball_joint_pendulum_quaternions_give_three_physical_degrees_of_freedom():
    system = mbs.load(MODELS / "spherical_pendulum.mbs")
    p = parameters(system)
    compiled = system.compile()
    assert compiled.nq == compiled.nv + 1
    lin = system.linearize()
    assert lin.dof == 3
    m, l = p["m"], p["l"]
    Ixx, Iyy = 0.01, 0.015  # the model's principal moments about the centre of mass
    swing = sorted(np.sqrt(m * G * l / (m * l * l + np.array([Ixx, Iyy]))) / (2 * np.pi))
    assert lin.undamped_frequencies == pytest.approx([0.0, *swing], rel=1e-6, abs=1e-6)
    oscillating = [mode for mode in lin.modes if mode.oscillatory]
    assert [mode.frequency for mode in oscillating] == pytest.approx(swing, rel=1e-6)
    # the spin about the rod: a rigid-body motion, no stiffness
    assert [mode.dominant(1)[0][0] for mode in lin.modes if not mode.oscillatory] == ["ball.wz", "ball.wz"]


def slider_crank_frequency(p) -> float:
    """Energy method on the crank angle th, independent of the compiler: slider at X(th) = r cos th +
    sqrt(L^2 - r^2 sin^2 th), spring energy k (X - l0)^2 / 2, kinetic energy J(th) th'^2 / 2 of crank (about
    its pivot), rod (centre of mass at its middle, angle beta) and slider. At rest X = l0, so
    w^2 = k X'^2 / J."""
    th = sp.Symbol("th")
    r, L, k, l0 = (sp.Float(p[n]) for n in ("r", "L", "k", "l0"))
    m_c, m_r, m_s = (sp.Float(p[n]) for n in ("m_crank", "m_rod", "m_slider"))
    X = r * sp.cos(th) + sp.sqrt(L**2 - r**2 * sp.sin(th) ** 2)
    pin = sp.Matrix([r * sp.cos(th), r * sp.sin(th)])
    rod_cm = (pin + sp.Matrix([X, 0])) / 2
    beta = sp.asin(-r * sp.sin(th) / L)
    J = (m_c * r**2 / 12 + m_c * (r / 2) ** 2
         + m_r * (rod_cm.diff(th).T * rod_cm.diff(th))[0] + m_r * L**2 / 12 * beta.diff(th) ** 2
         + m_s * X.diff(th) ** 2)
    th0 = sp.acos((l0**2 + r**2 - L**2) / (2 * l0 * r))  # law of cosines: X(th0) = l0
    assert abs(float(X.subs(th, th0) - l0)) < 1e-12
    w2 = float((k * X.diff(th) ** 2 / J).subs(th, th0))
    return np.sqrt(w2) / (2 * np.pi)


def test_slider_crank_on_a_spring_closed_loop_has_the_energy_method_frequency():
    system = mbs.load(MODELS / "slider_crank_spring.mbs")
    p = parameters(system)
    lin = system.linearize()
    # 3 tree coordinates, 2 loop-closure rows: the full Jacobian has 6 eigenvalues, 4 of them spurious zeros
    assert lin.A.shape == (6, 6)
    spurious = np.sum(np.abs(np.linalg.eigvals(lin.A)) < 1e-6 * np.max(np.abs(lin.A)))
    assert spurious == 4
    assert lin.dof == 1
    (mode,) = lin.modes
    assert mode.frequency == pytest.approx(slider_crank_frequency(p), rel=1e-6)
    assert mode.damping_ratio == pytest.approx(0.0, abs=1e-9)
    assert lin.undamped_frequencies == pytest.approx([mode.frequency], rel=1e-9)


def test_cli_prints_the_mode_table(capsys):
    assert main(["linearize", "library/examples/pendulum.mbs", "--scene", "swing", "--param", "l=2m"]) == 0
    out = capsys.readouterr().out
    assert "1 degree of freedom" in out
    row = next(line for line in out.splitlines() if line.strip().startswith("1 "))
    assert float(row.split()[1]) == pytest.approx(np.sqrt(G / 2) / (2 * np.pi), rel=1e-4)
    assert "hinge.phi" in row


def test_cli_bad_state_choice_and_unknown_parameter_are_clean_errors(capsys):
    assert main(["linearize", "library/examples/pendulum.mbs", "--param", "nope=1"]) == 2  # a usage error
    err = capsys.readouterr().err
    assert "no parameter 'nope'" in err and "Traceback" not in err


def test_api_rejects_a_state_of_the_wrong_size():
    system = mbs.load("library/examples/pendulum.mbs")
    with pytest.raises(mbs.MbsError, match="needs 2 values"):
        system.linearize(at=[0.1, 0.0, 0.0])
    with pytest.raises(mbs.MbsError, match="expected 'equilibrium'"):
        system.linearize(at="somewhere")
    # about a given state: the pendulum hanging at rest
    lin = system.linearize(at=[0.0, 0.0])
    assert lin.modes[0].frequency == pytest.approx(np.sqrt(G) / (2 * np.pi), rel=2e-6)
