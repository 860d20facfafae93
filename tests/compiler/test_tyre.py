"""The tyre force element's contact kinematics (compiler/tyre.py) against hand geometry: deflection, slip angle,
longitudinal slip and camber of a wheel set at chosen states, the normal force along the normal of a sloped
road, and finite slip quantities at standstill, where the textbook definitions divide by zero."""

import math
from pathlib import Path

import pytest

import mbs

MODEL = Path(__file__).parent / "models" / "tyre_probe.mbs"
R0, K, V_LOW = 0.36, 460000.0, 0.5


@pytest.fixture(scope="module")
def probe():
    return mbs.load(MODEL)


def at_start(system, **params):
    res = system.simulate("probe", params=params)
    return {name: res[name][0] for name in res.names if name.startswith(("tyre.", "point_contact."))}


def test_flat_road_deflection_slip_angle_and_load(probe):
    out = at_start(probe, vx=10.0, vy=0.2, z0=0.355)
    assert out["tyre.t.rho"] == pytest.approx(R0 - 0.355, rel=1e-12)
    assert out["tyre.t.fz"] == pytest.approx(K * (R0 - 0.355), rel=1e-12)
    assert out["tyre.t.alpha"] == pytest.approx(math.atan(0.2 / math.hypot(10.0, V_LOW)), rel=1e-12)
    assert out["tyre.t.fy"] == pytest.approx(-40000.0 * out["tyre.t.alpha"], rel=1e-12)
    assert out["tyre.t.mz"] == pytest.approx(-0.05 * out["tyre.t.fy"], rel=1e-12)


def test_camber_lengthens_the_loaded_radius_by_its_cosine(probe):
    out = at_start(probe, tilt=0.05, z0=0.355)
    assert out["tyre.t.gamma"] == pytest.approx(0.05, rel=1e-12)   # the top leans to -y
    assert out["tyre.t.rho"] == pytest.approx(R0 - 0.355 / math.cos(0.05), rel=1e-12)


def test_longitudinal_slip_from_the_spin_and_the_effective_rolling_radius(probe):
    out = at_start(probe, vx=10.0, vy=0.0, spin=30.0, z0=0.355)
    rho = R0 - 0.355
    vsx = 10.0 - 30.0 * (R0 - rho / 3)
    assert out["tyre.t.kappa"] == pytest.approx(-vsx / math.hypot(10.0, V_LOW), rel=1e-12)
    assert out["tyre.t.vx"] == pytest.approx(10.0, rel=1e-12)


def test_standstill_slip_is_finite(probe):
    out = at_start(probe, vx=0.0, vy=0.1, z0=0.355)
    assert out["tyre.t.alpha"] == pytest.approx(math.atan(0.1 / V_LOW), rel=1e-12)
    assert out["tyre.t.kappa"] == 0.0


def test_normal_force_along_the_normal_of_a_sloped_road_or_vertical(probe):
    slope, z0 = 0.2, 0.355
    out = at_start(probe, vx=0.0, vy=0.0, slope=slope, z0=z0)
    height = z0 / math.sqrt(1 + slope ** 2)          # the centre above the tangent plane through the origin
    assert out["tyre.t.rho"] == pytest.approx(R0 - height, rel=1e-12)
    # at rest and without gravity: one tyre pushes along the road normal (-slope, 0, 1), the other up
    assert out["tyre.acc.y"] == pytest.approx(0.0, abs=1e-9)
    assert out["tyre.acc.x"] == pytest.approx(-slope / math.sqrt(1 + slope ** 2) * out["tyre.t.fz"] / 400.0, rel=1e-9)
    assert out["point_contact.t.rho"] == pytest.approx(R0 - z0, rel=1e-12)   # the height above the road below
    assert out["tyre.acc.z"] == pytest.approx((out["tyre.t.fz"] / math.sqrt(1 + slope ** 2)
                                               + out["point_contact.t.fz"]) / 400.0, rel=1e-9)
