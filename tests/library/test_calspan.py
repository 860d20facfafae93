"""The benchmark's Calspan tyre (library/tyres/calspan.mbs) against the data sheet's formulas evaluated by hand
here, at a point in the light-load branch with camber (the numbers also worked by hand), in the heavy-load branch, and the data sheet's own
figure: a cornering stiffness of about 41.6 kN/rad at the static front load."""

import math
import sys
from pathlib import Path

import pytest

import mbs

sys.path.insert(0, str(Path(__file__).resolve().parent))
from tyrekit import fade as library_fade  # noqa: E402
from tyrekit import tyre_forces as forces  # noqa: E402

MODEL = Path(__file__).parent / "models" / "calspan_probe.mbs"
R0, K, V_LOW = 0.364325, 460000.0, 0.3
A0, A1, A2, A3, A4, AW = 2625.0, 14.47, 12930.0, 2.29, 18175.0, 1.0
B1, B3, B4, SN = -0.464e-4, 1.216, 2.18e-11, 1.0274
AF1, AF2 = -0.171e-4, 0.171e-4


def calspan(fz, alpha, gamma):
    """(Fy, Mz) of the data sheet, written out independently of the model file."""
    f = (B1 * fz + B3 + B4 * fz ** 2) * SN
    if fz <= AW * A2:
        term = A1 * fz * (fz - A2) - A0 * A2
        a = term / (A2 * f * fz) * (alpha - A2 * A3 * (A4 - fz) * fz / (A4 * term) * gamma)
    else:
        a = -A0 / (f * fz) * (alpha - A2 * A3 * AW * (A4 - AW * A2) / (-A0 * A4) * gamma)
    g = a - a * abs(a) / 3 + a ** 3 / 27 if abs(a) < 3 else math.copysign(1.0, a)
    fy = f * fz * g
    return fy, (AF1 * fz + AF2 * abs(fy)) * fy


def fade(vx):
    return library_fade(vx, V_LOW)


@pytest.fixture(scope="module")
def probe():
    return mbs.load(MODEL)


def test_light_load_point_with_camber(probe):
    out = forces(probe, z0=0.355, vy=0.2, tilt=0.01)
    assert out["fz"] == pytest.approx(K * (R0 - 0.355 / math.cos(0.01)), rel=1e-12)
    fy, _ = calspan(out["fz"], out["alpha"], out["gamma"])
    fy *= fade(10.0)
    assert (out["fy"], out["mz"]) == pytest.approx((fy, (AF1 * out["fz"] + AF2 * abs(fy)) * fy), rel=1e-10)
    # by hand: Fz = 4281.33 N, alpha = 0.0199910, gamma = 0.01 -> f = 1.0312, Fy = -889.30 N
    assert out["fy"] / fade(10.0) == pytest.approx(-889.30, abs=0.01)


def test_heavy_load_branch_saturates(probe):
    out = forces(probe, z0=0.33, vy=3.0)   # Fz = 15.8 kN > A2, a large slip angle
    assert out["fz"] > A2
    fy = calspan(out["fz"], out["alpha"], out["gamma"])[0] * fade(10.0)
    assert out["fy"] == pytest.approx(fy, rel=1e-10)


def test_cornering_stiffness_at_the_static_front_load():
    fz = 1513.4 * 9.81 * 1.047 / 2.017 / 2     # a quarter of the weight on the front axle's share
    # the data sheet: "about 41.6 kN/rad"; d Fy / d alpha at alpha = 0 is A0 + A1 Fz (1 - Fz / A2)
    stiffness = -(calspan(fz, 1e-6, 0.0)[0] - calspan(fz, -1e-6, 0.0)[0]) / 2e-6
    assert stiffness == pytest.approx(41.6e3, rel=0.01)


def test_the_model_file_has_the_same_cornering_stiffness(probe):
    z0 = R0 - 3853.0 / K
    lo, hi = (forces(probe, z0=z0, vx=10.0, vy=s) for s in (-0.0005, 0.0005))
    stiffness = -(hi["fy"] - lo["fy"]) / (hi["alpha"] - lo["alpha"]) / fade(10.0)
    # the shaping g(a) = a - a|a|/3 + ... bends the secant by |a|/3 ~ 2e-4 at this slip
    assert stiffness == pytest.approx(A0 + A1 * 3853.0 * (1 - 3853.0 / A2), rel=1e-3)
