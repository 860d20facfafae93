"""The Magic Formula tyre (library/tyres/magic_formula.mbs) against the book's equations written out here
(Pacejka, Tyre and Vehicle Dynamics, 2006, eqs. 4.E1-4.E78, MF 5.2 coefficients, scaling factors 1), and
against the standard form's defining properties: the slope B C D at zero slip is the slip stiffness Kx
(longitudinal) and K_ya (lateral) of their own formulas, the peak of a pure-slip curve is D = mu Fz."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest

import mbs

sys.path.insert(0, str(Path(__file__).resolve().parent))
from tyrekit import fade as library_fade  # noqa: E402
from tyrekit import tyre_forces as forces  # noqa: E402

MODEL = Path(__file__).parent / "models" / "mf_probe.mbs"
R0, K, FNOMIN, V_LOW = 0.3135, 200000.0, 4000.0, 0.5
P = dict(PCX1=1.65, PDX1=1.0, PDX2=-0.1, PEX1=-0.5, PEX2=0.3, PKX1=21.0, PKX2=13.0, PKX3=-0.4, RBX1=12.0,
         RBX2=-10.0, RCX1=1.0, PCY1=1.3, PDY1=1.0, PDY2=-0.15, PEY1=-1.0, PKY1=-20.0, PKY2=1.5, PVY3=-0.15,
         RBY1=10.0, RBY2=10.0, RCY1=1.0)


def magic(B, C, D, E, x):
    return D * math.sin(C * math.atan(B * x - E * (B * x - math.atan(B * x))))


def book(fz, kappa, alpha, gamma):
    """(Fx, Fy) of the MF 5.2 equations for the coefficients above (the others zero)."""
    dfz = (fz - FNOMIN) / FNOMIN
    kx = fz * (P["PKX1"] + P["PKX2"] * dfz) * math.exp(P["PKX3"] * dfz)
    dx = (P["PDX1"] + P["PDX2"] * dfz) * fz
    ex = P["PEX1"] + P["PEX2"] * dfz
    fx0 = magic(kx / (P["PCX1"] * dx), P["PCX1"], dx, ex, kappa)
    ky = P["PKY1"] * FNOMIN * math.sin(2 * math.atan(fz / (P["PKY2"] * FNOMIN)))
    dy = (P["PDY1"] + P["PDY2"] * dfz) * fz
    fy0 = magic(ky / (P["PCY1"] * dy), P["PCY1"], dy, P["PEY1"], alpha) + fz * P["PVY3"] * gamma
    gx = math.cos(P["RCX1"] * math.atan(P["RBX1"] * math.cos(math.atan(P["RBX2"] * kappa)) * alpha))
    gy = math.cos(P["RCY1"] * math.atan(P["RBY1"] * math.cos(math.atan(P["RBY2"] * alpha)) * kappa))
    return gx * fx0, gy * fy0, kx, ky, dy


def fade(vx):
    return library_fade(vx, V_LOW)


@pytest.fixture(scope="module")
def probe(tmp_path_factory):
    return mbs.load(MODEL, cache_dir=str(tmp_path_factory.mktemp("cache")))


@pytest.mark.parametrize("vy", [0.1, 1.0, 4.0])        # small, near the peak, beyond it
def test_pure_lateral_slip(probe, vy):
    out = forces(probe, vx=10.0, vy=vy, spin=10.0 / (R0 - 0.02 / 3))
    fx, fy, _, ky, dy = book(out["fz"], out["kappa"], out["alpha"], out["gamma"])
    assert out["fy"] == pytest.approx(fy * fade(10.0), rel=1e-9)
    assert out["fx"] == pytest.approx(fx * fade(10.0), rel=1e-9, abs=1e-6)
    assert abs(out["fy"]) <= dy * 1.000001                # never beyond the peak D = mu Fz


def test_slopes_at_zero_slip_are_the_slip_stiffnesses(probe):
    spin0 = 10.0 / (R0 - 0.02 / 3)                           # free rolling at the 2 cm deflection
    a, b = (forces(probe, vx=10.0, vy=s, spin=spin0) for s in (-1e-4, 1e-4))
    ky = book(a["fz"], 0, 0, 0)[3]
    assert (b["fy"] - a["fy"]) / (b["alpha"] - a["alpha"]) / fade(10.0) == pytest.approx(ky, rel=1e-4)
    c, d = (forces(probe, vx=10.0, vy=0.0, spin=spin0 * (1 + s)) for s in (-1e-5, 1e-5))
    kx = book(c["fz"], 0, 0, 0)[2]
    assert (d["fx"] - c["fx"]) / (d["kappa"] - c["kappa"]) / fade(10.0) == pytest.approx(kx, rel=1e-4)


def test_combined_slip_reduces_both_forces(probe):
    spin0 = 10.0 / (R0 - 0.02 / 3)
    out = forces(probe, vx=10.0, vy=0.5, spin=spin0 * 1.05, tilt=0.02)
    fx, fy, *_ = book(out["fz"], out["kappa"], out["alpha"], out["gamma"])
    assert (out["fx"], out["fy"]) == pytest.approx((fx * fade(10.0), fy * fade(10.0)), rel=1e-9)
    pure_x = book(out["fz"], out["kappa"], 0.0, 0.0)[0]
    assert abs(out["fx"]) < abs(pure_x) * fade(10.0)


def test_peak_of_the_lateral_curve_is_mu_fz():
    alphas = np.linspace(0.0, 0.6, 6001)
    fz = 4500.0
    curve = [abs(book(fz, 0.0, a, 0.0)[1]) for a in alphas]
    assert max(curve) == pytest.approx(book(fz, 0, 0, 0)[4], rel=1e-6)
