"""The Magic Formula tyre (library/tyres/magic_formula.mbs, its default coefficients) against properties of the
standard form that were published with it, evaluated on the compiled model rather than on a second copy of its
equations. No published table of curve values for a published coefficient set was found (see the vehicle
session's report); these are the closed-form properties instead:

- Pacejka, Tyre and Vehicle Dynamics (2006), section 4.3.1, the basic formula
  y = D sin[C arctan{B x - E (B x - arctan B x)}]: its peak value is D (C >= 1), its slope at the origin B C D,
  and its peak lies at x_m with E = (B x_m - tan(pi / 2C)) / (B x_m - arctan B x_m). The cosine version of the
  pneumatic trail, t = D_t cos[C_t arctan{B_t x - E_t (B_t x - arctan B_t x)}], therefore vanishes at the x_m of
  its own B_t, C_t, E_t.
- The MF 5.2 parameter map (same book, eqs. 4.E1-4.E78; with these coefficients every shift is zero at zero
  camber): D_x = (PDX1 + PDX2 dfz) Fz, K_x = Fz (PKX1 + PKX2 dfz) exp(PKX3 dfz), C_x = PCX1,
  E_x = PEX1 + PEX2 dfz; D_y = (PDY1 + PDY2 dfz) Fz, K_ya = PKY1 Fz0 sin(2 arctan(Fz / (PKY2 Fz0))),
  C_y = PCY1, E_y = PEY1; the camber thrust at zero slip S_Vy = PVY3 gamma Fz; the trail at zero slip
  D_t = Fz QDZ1 R0 / Fz0 with B_t = QBZ1, C_t = QCZ1, E_t = QEZ1, and no residual torque at zero camber.
- Combined slip (4.E51-4.E67): the weights G_xa = cos[RCX1 arctan(B_xa alpha)] with
  B_xa = RBX1 cos[arctan(RBX2 kappa)], and G_yk alike, are 1 / sqrt(1 + z^2) for RCX1 = RCY1 = 1;
  Mz = -t Fy' + Mzr + s Fx (4.E71) with s = R0 (SSZ1 + ...) (4.E76): the lever arm of Fx carries no cos(alpha)
  (the trail t and the residual torque Mzr do).
The probe's v_low is made negligible, so slip and forces are the textbook ones (no fade-in)."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

import mbs

sys.path.insert(0, str(Path(__file__).resolve().parent))
from tyrekit import TyreProbe  # noqa: E402

MODEL = Path(__file__).parent / "models" / "mf_probe.mbs"
R0, K, FZ0, VX = 0.3135, 200000.0, 4000.0, 10.0
P = dict(PCX1=1.65, PDX1=1.0, PDX2=-0.1, PEX1=-0.5, PEX2=0.3, PKX1=21.0, PKX2=13.0, PKX3=-0.4, RBX1=12.0,
         RBX2=-10.0, PCY1=1.3, PDY1=1.0, PDY2=-0.15, PEY1=-1.0, PKY1=-20.0, PKY2=1.5, PVY3=-0.15, RBY1=10.0,
         RBY2=10.0, QBZ1=10.0, QCZ1=1.25, QDZ1=0.1, QEZ1=-1.6)
LOADS = [3000.0, 4000.0, 6000.0]


def peak_position(B, C, E):
    """x_m > 0 of the book's relation E = (B x_m - tan(pi / 2C)) / (B x_m - arctan B x_m), solved for x_m."""
    B = abs(B)
    return brentq(lambda x: B * x - E * (B * x - math.atan(B * x)) - math.tan(math.pi / (2 * C)), 1e-9, 10.0,
                  xtol=1e-15, rtol=1e-14)


@pytest.fixture(scope="module")
def tyre():
    system = mbs.load(MODEL)
    return TyreProbe(system, **{"tyre.v_low": 1e-4})


def at(tyre, fz, *, kappa=0.0, alpha=0.0):
    """The tyre at a load, a longitudinal slip and a slip angle (set through the wheel's motion)."""
    rho = fz / K
    return tyre(vx=VX, vy=VX * math.tan(alpha), spin=VX * (1 + kappa) / (R0 - rho / 3), height=R0 - rho)


def dfz(fz):
    return (fz - FZ0) / FZ0


@pytest.mark.parametrize("fz", LOADS)
def test_lateral_peak_is_D_at_the_slip_angle_of_B_C_E(tyre, fz):
    D = (P["PDY1"] + P["PDY2"] * dfz(fz)) * fz
    Ky = P["PKY1"] * FZ0 * math.sin(2 * math.atan(fz / (P["PKY2"] * FZ0)))
    alpha_m = peak_position(Ky / (P["PCY1"] * D), P["PCY1"], P["PEY1"])
    peak = at(tyre, fz, alpha=alpha_m)
    assert peak["fz"] == pytest.approx(fz, rel=1e-9)
    assert abs(peak["fy"]) == pytest.approx(D, rel=1e-9)
    assert peak["fy"] < 0.0                                   # ISO: positive slip angle, force to the right
    sweep = [abs(at(tyre, fz, alpha=a)["fy"]) for a in np.linspace(0.0, 0.6, 301)]
    assert max(sweep) <= D * (1 + 1e-12)
    for side in (0.99, 1.01):                                  # a maximum, not any point of value D
        assert abs(at(tyre, fz, alpha=alpha_m * side)["fy"]) < D


@pytest.mark.parametrize("fz", LOADS)
def test_cornering_stiffness_is_BCD(tyre, fz):
    a, b = at(tyre, fz, alpha=-1e-5), at(tyre, fz, alpha=1e-5)
    Ky = P["PKY1"] * FZ0 * math.sin(2 * math.atan(fz / (P["PKY2"] * FZ0)))
    assert (b["fy"] - a["fy"]) / (b["alpha"] - a["alpha"]) == pytest.approx(Ky, rel=1e-6)


@pytest.mark.parametrize("fz", LOADS)
@pytest.mark.parametrize("sign", [1.0, -1.0])                   # driving and braking
def test_longitudinal_peak_is_D_at_the_slip_of_B_C_E(tyre, fz, sign):
    D = (P["PDX1"] + P["PDX2"] * dfz(fz)) * fz
    Kx = fz * (P["PKX1"] + P["PKX2"] * dfz(fz)) * math.exp(P["PKX3"] * dfz(fz))
    E = P["PEX1"] + P["PEX2"] * dfz(fz)
    kappa_m = peak_position(Kx / (P["PCX1"] * D), P["PCX1"], E)
    peak = at(tyre, fz, kappa=sign * kappa_m)
    assert peak["kappa"] == pytest.approx(sign * kappa_m, rel=1e-8)
    assert peak["fx"] == pytest.approx(sign * D, rel=1e-9)
    for side in (0.99, 1.01):
        assert abs(at(tyre, fz, kappa=sign * kappa_m * side)["fx"]) < D


@pytest.mark.parametrize("fz", LOADS)
def test_longitudinal_slip_stiffness_is_BCD(tyre, fz):
    a, b = at(tyre, fz, kappa=-1e-6), at(tyre, fz, kappa=1e-6)
    Kx = fz * (P["PKX1"] + P["PKX2"] * dfz(fz)) * math.exp(P["PKX3"] * dfz(fz))
    assert (b["fx"] - a["fx"]) / (b["kappa"] - a["kappa"]) == pytest.approx(Kx, rel=1e-6)


@pytest.mark.parametrize("fz", LOADS)
def test_pneumatic_trail_is_D_t_at_zero_slip_and_vanishes_at_the_x_m_of_its_B_C_E(tyre, fz):
    small = at(tyre, fz, alpha=1e-5)
    Dt = fz * P["QDZ1"] * R0 / FZ0
    assert -small["mz"] / (small["fy"] * math.cos(small["alpha"])) == pytest.approx(Dt, rel=1e-6)
    assert small["mz"] > 0.0                                  # aligning: turns the wheel towards its motion
    alpha_0 = peak_position(P["QBZ1"], P["QCZ1"], P["QEZ1"])
    zero = at(tyre, fz, alpha=alpha_0)
    scale = Dt * abs(zero["fy"])
    assert abs(zero["mz"]) < 1e-9 * scale
    before, after = at(tyre, fz, alpha=alpha_0 * 0.99), at(tyre, fz, alpha=alpha_0 * 1.01)
    assert before["mz"] > 0.0 > after["mz"]


def test_camber_thrust_at_zero_slip():
    system = mbs.load(MODEL)
    tilted = TyreProbe(system, **{"tyre.v_low": 1e-4, "tilt": 0.05})
    rho = tilted(vx=VX)["rho"]
    out = tilted(vx=VX, spin=VX / (R0 - rho / 3))              # rolling freely: no longitudinal slip
    assert abs(out["kappa"]) < 1e-12
    assert out["gamma"] == pytest.approx(0.05, rel=1e-9)     # tilted about x: the top leans to the right (ISO)
    assert out["fy"] == pytest.approx(P["PVY3"] * out["gamma"] * out["fz"], rel=1e-9)


@pytest.mark.parametrize("kappa, alpha", [(0.05, 0.05), (-0.1, 0.02), (0.02, -0.15)])
def test_combined_slip_weights(tyre, kappa, alpha):
    fz = 4500.0
    both, pure_x, pure_y = at(tyre, fz, kappa=kappa, alpha=alpha), at(tyre, fz, kappa=kappa), at(tyre, fz, alpha=alpha)
    k, a = both["kappa"], both["alpha"]
    b_xa = P["RBX1"] / math.sqrt(1 + (P["RBX2"] * k) ** 2)
    b_yk = P["RBY1"] / math.sqrt(1 + (P["RBY2"] * a) ** 2)
    assert both["fx"] / pure_x["fx"] == pytest.approx(1 / math.sqrt(1 + (b_xa * a) ** 2), rel=1e-9)
    assert both["fy"] / pure_y["fy"] == pytest.approx(1 / math.sqrt(1 + (b_yk * k) ** 2), rel=1e-9)


def test_lever_arm_of_fx_in_the_aligning_torque(tyre):
    """4.E71: s Fx enters Mz as it is; an SSZ1 changes Mz by SSZ1 R0 Fx at any slip angle."""
    fz, kappa, alpha = 4500.0, 0.08, 0.3
    base = at(tyre, fz, kappa=kappa, alpha=alpha)
    tyre.set(**{"tyre.SSZ1": 0.05})
    try:
        shifted = at(tyre, fz, kappa=kappa, alpha=alpha)
    finally:
        tyre.set(**{"tyre.SSZ1": 0.0})
    assert shifted["fx"] == base["fx"]
    assert shifted["mz"] - base["mz"] == pytest.approx(0.05 * R0 * base["fx"], rel=1e-9)
