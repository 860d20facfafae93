"""Prescribed (rheonomic) coordinates: pendulums whose support is driven by a given function of time, against
their equations of motion derived by hand (Lagrange) and integrated by scipy in the test.

Shaken pendulum (pivot at x_c = A sin(w t), hinge about y, bob of mass m at distance l, moment J about its
centre about the hinge axis); the position of the centre of mass is (x_c - l sin(phi), 0, -l cos(phi)), so

    (m l^2 + J) phi'' = m l (x_c'' cos(phi) - g sin(phi)).

Whirling pendulum (shaft turned about z at the constant rate Omega, hinge about the shaft's y axis through the
shaft axis, principal moments J1, J2, J3 of the bob about its centre): the body's angular velocity in its axes
is (-Omega sin(phi), phi', Omega cos(phi)), so

    (m l^2 + J2) phi'' = (m l^2 + J1 - J3) Omega^2 sin(phi) cos(phi) - m g l sin(phi).

Tolerance: our run at rtol 1e-11 and scipy's DOP853 at rtol 1e-13 agree to ~1e-10 rad over 5 s (observed
2e-10 for the whirling pendulum, which swings through 80 degrees); ATOL = 1e-8 rad allows for the growth of
errors in these nonlinear oscillators, while dropping or flipping a drive term moves phi by 1e-2 or more.
"""

import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

sys.path.insert(0, str(Path(__file__).parent))
import physkit  # noqa: E402

import mbs  # noqa: E402

G = 9.81
ATOL = 1e-8
T_END = 5.0


def simulate(system, params=None):
    res = system.simulate(t_end=T_END, sample=0.01, integrator="dopri5", rtol=1e-11, atol=1e-12, params=params)
    assert res.success, res.message
    return res


def reference(rhs, phi0, t):
    sol = solve_ivp(rhs, (0, t[-1]), [phi0, 0.0], method="DOP853", rtol=1e-13, atol=1e-14, t_eval=t)
    assert sol.success
    return sol.y


@pytest.fixture(scope="module")
def shaken():
    return mbs.load(physkit.MODELS / "shaken_pendulum.mbs")


@pytest.mark.parametrize("w", [3.0, 5.0])
def test_shaken_pendulum(shaken, w):
    m, l, J, A = 0.9, 0.5, 0.004, 0.05      # the fixture's values; the drive frequency is a run-time parameter

    def rhs(t, y):
        phi, rate = y
        x_cc = -A * w * w * math.sin(w * t)
        return [rate, m * l * (x_cc * math.cos(phi) - G * math.sin(phi)) / (m * l * l + J)]

    res = simulate(shaken, {"w": w})
    phi, rate = reference(rhs, math.radians(10), res.t)
    np.testing.assert_allclose(res["hinge.phi"], phi, rtol=0, atol=ATOL)
    np.testing.assert_allclose(res["der(hinge.phi)"], rate, rtol=0, atol=10 * ATOL)   # ~w times the angle error
    # The drive matters at this tolerance: the free pendulum differs by far more than ATOL.
    free = reference(lambda t, y: [y[1], -m * G * l * math.sin(y[0]) / (m * l * l + J)], math.radians(10), res.t)
    assert np.abs(free[0] - phi).max() > 1e3 * ATOL


def test_whirling_pendulum():
    m, l, Omega, J1, J2, J3 = 1.2, 0.4, 7.0, 0.01, 0.02, 0.025

    def rhs(t, y):
        phi, rate = y
        s, c = math.sin(phi), math.cos(phi)
        return [rate, ((m * l * l + J1 - J3) * Omega**2 * s * c - m * G * l * s) / (m * l * l + J2)]

    res = simulate(mbs.load(physkit.MODELS / "whirling_pendulum.mbs"))
    phi, rate = reference(rhs, math.radians(20), res.t)
    # Above the critical speed (5.2 rad/s here) the bob is flung out: it swings about the off-axis equilibrium
    # acos(m g l / ((m l^2 + J1 - J3) Omega^2)) = 57 deg (the governor's working point), not about 0.
    assert phi.max() > math.radians(60)
    np.testing.assert_allclose(res["hinge.phi"], phi, rtol=0, atol=ATOL)
    np.testing.assert_allclose(res["der(hinge.phi)"], rate, rtol=0, atol=10 * ATOL)
