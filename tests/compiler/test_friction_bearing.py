"""Several load-dependent friction elements in one model (compiler/friction_bearing.py): a double pendulum with
bearing friction mu r |R| in both pins, where each pin's load depends on both friction torques.  Checked against
the reaction sensors (the compiler's separate inverse dynamics with the run-time accelerations: the friction law
|T| = mu r |R| must hold to round-off) and against the energy balance written here by hand: the mechanical energy
of the two links falls by exactly the work of the two friction torques."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import mbs

MODEL = Path(__file__).parent / "models" / "double_bearing.mbs"
M, L, J_C, R_PIN, MU_K, G = 1.0, 0.5, 0.02, 0.02, 0.3, 9.81


@pytest.fixture(scope="module")
def run():
    system = mbs.load(MODEL)
    return system.simulate(t_end=2.0, t_eval=np.linspace(0.0, 2.0, 20001), rtol=1e-11, atol=1e-12)


def test_both_pins_slip_with_mu_r_times_their_load(run):
    assert run.success, run.message
    grips = {e["event"] for e in run.events if e["event"].endswith(".grip")}
    assert grips == {"shoulder.bearing.grip", "elbow.bearing.grip"}  # both turn several times
    for pin in ("shoulder", "elbow"):
        moving = np.abs(run[f"der({pin}.phi)"]) > 1e-6
        np.testing.assert_allclose(np.abs(run[f"{pin}_torque"][moving]),
                                   MU_K * R_PIN * run[f"{pin}_load"][moving], rtol=1e-10)
        assert np.all(run[f"{pin}_torque"][moving] * run[f"der({pin}.phi)"][moving] < 0)  # against the motion


def energy(a, b, wa, wb):
    """Kinetic plus potential energy of the two links (upper about the shoulder at angle a, lower at a + b)."""
    x1, z1 = -L * np.sin(a), -L * np.cos(a)
    vx1, vz1 = -L * np.cos(a) * wa, L * np.sin(a) * wa
    vx2 = -2 * L * np.cos(a) * wa - L * np.cos(a + b) * (wa + wb)
    vz2 = 2 * L * np.sin(a) * wa + L * np.sin(a + b) * (wa + wb)
    z2 = -2 * L * np.cos(a) - L * np.cos(a + b)
    kinetic = 0.5 * M * (vx1 ** 2 + vz1 ** 2 + vx2 ** 2 + vz2 ** 2) + 0.5 * J_C * (wa ** 2 + (wa + wb) ** 2)
    return kinetic + M * G * (z1 + z2) + 0 * x1


def test_the_energy_falls_by_the_work_of_the_friction_torques(run):
    a, b = run["shoulder.phi"], run["elbow.phi"]
    wa, wb = run["der(shoulder.phi)"], run["der(elbow.phi)"]
    power = run["shoulder_torque"] * wa + run["elbow_torque"] * wb
    work = np.concatenate(([0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(run.t))))
    lost = energy(a, b, wa, wb) - energy(a[0], b[0], wa[0], wb[0])
    assert work[-1] < -0.5  # a real loss (J), which the balance must account for
    # the trapezoidal rule on a 1e-4 s grid is accurate to ~1e-8 J here (power is smooth between the rows of events)
    np.testing.assert_allclose(lost, work, atol=1e-6)
