"""Modes named from their energy: the two-mass quarter car's bounce lives in the body, its hop in the wheel,
with the energy fractions of the textbook equations (absolute heights, written by hand here)."""

import numpy as np
import pytest

import mbs


def textbook_fractions(p):
    """Kinetic and potential fractions of the coordinates (body_guide.s, wheel_guide.s) = (z_b, z_w - z_b)
    for both damped modes, from M, K, C of the textbook model transformed to the model's coordinates."""
    m_s, m_u, k_s, k_t, d = p["m_body"], p["m_wheel"], p["k_susp"], p["k_tyre"], p["d_susp"]
    M = np.diag([m_s, m_u])
    K = np.array([[k_s, -k_s], [-k_s, k_s + k_t]])
    C = np.array([[d, -d], [-d, d]])
    T = np.array([[1.0, 0.0], [1.0, 1.0]])  # z = T s
    M, K, C = (T.T @ X @ T for X in (M, K, C))
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    lam, vec = np.linalg.eig(A)
    out = []
    for k in np.argsort(np.abs(lam)):
        if lam[k].imag <= 0:
            continue
        phi = vec[:2, k]
        kin = np.real(np.conj(phi) * (M @ phi)) / np.real(np.conj(phi) @ M @ phi)
        pot = np.real(np.conj(phi) * (K @ phi)) / np.real(np.conj(phi) @ K @ phi)
        out.append((kin, pot))
    return out


def test_quarter_car_modes_are_named_after_the_part_that_holds_their_energy():
    system = mbs.load("library/examples/two_mass_quarter_car.mbs")
    p = {q.name: q.value for q in system.model.parameters}
    lin = system.linearize()
    bounce, hop = lin.modes
    assert bounce.name == "chassis body_guide.s" and hop.name == "wheel wheel_guide.s"
    for mode, (kin, pot) in zip(lin.modes, textbook_fractions(p)):
        assert [mode.kinetic["chassis"], mode.kinetic["wheel"]] == pytest.approx(kin, abs=1e-5)
        assert [mode.potential["chassis"], mode.potential["wheel"]] == pytest.approx(pot, abs=1e-5)
    assert sum(bounce.kinetic.values()) == pytest.approx(1.0) and sum(hop.potential.values()) == pytest.approx(1.0)
    assert "chassis body_guide.s: chassis" in lin.table()


def test_iltis_quarter_car_bounce_and_hop_are_told_apart():
    """The issue's case: both modes used to list the same suspension angles; now the body holds the bounce's
    kinetic energy and the corner 'fl' the hop's."""
    lin = mbs.load("library/iltis/quarter_car.mbs").linearize()
    bounce, hop = lin.modes
    assert bounce.name.startswith("body ") and bounce.kinetic["body"] > 0.9
    assert hop.name.startswith("fl ") and hop.kinetic["fl"] > 0.9


@pytest.mark.slow
def test_iltis_vehicle_bounce_pitch_roll_and_hop_are_named():
    names = [m.name for m in mbs.load("library/iltis/vehicle.mbs").linearize().modes]
    for expected in ("car bounce", "car pitch", "car roll", "fl+fr arm_bearing.phi", "rl+rr arm_bearing.phi"):
        assert expected in names
