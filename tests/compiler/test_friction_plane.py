"""A point contact sliding in a plane with isotropic dry friction (coulomb(..., surface_normal = z):
compiler/friction_plane.py) against what no one here wrote: a block launched obliquely on a level plane (a
straight line at mu_k g, the closed-form stopping time and distance), a block pushed sideways on an incline (the
classic curve: with psi the angle between the velocity and the downhill direction and k = mu_k / tan(theta),
v = v0 tan(psi/2)^k / sin(psi), so the stopping time and the final position are quadratures in psi), and a block on
a spring whose slide turns (scipy on the hand-written equations)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp

import mbs

MODELS = Path(__file__).parent / "models" / "friction_plane.mbs"
G = 9.81


def simulate(model, t_end, samples=101):
    system = mbs.load(MODELS, model)
    return system.simulate(t_end=t_end, t_eval=np.linspace(0.0, t_end, samples), rtol=1e-10, atol=1e-12)


def test_a_block_launched_obliquely_stops_on_a_straight_line_at_the_closed_form_time():
    res = simulate("plane", 1.0)
    assert res.success, res.message
    v0 = math.hypot(1.2, 0.5)
    t_stop, distance = v0 / (0.3 * G), v0 ** 2 / (2 * 0.3 * G)
    assert [e["event"] for e in res.events] == ["rub.friction.slip", "rub.friction.grip"]
    assert res.events[1]["time"] == pytest.approx(t_stop, abs=1e-9)
    assert "mode: 1 -> 0" in res.events[1]["changes"]  # it sticks: no force is left to hold
    moving, resting = res.t < t_stop - 1e-6, res.t > t_stop + 1e-6  # (the event's rows are both at t_stop)
    s = np.hypot(res["table.x"], res["table.y"])
    np.testing.assert_allclose(s[moving], v0 * res.t[moving] - 0.5 * 0.3 * G * res.t[moving] ** 2, atol=1e-10)
    np.testing.assert_allclose(res["table.y"] * 1.2, res["table.x"] * 0.5, atol=1e-12)  # the line of launch
    np.testing.assert_allclose(s[resting], distance, atol=1e-9)
    np.testing.assert_allclose(res["friction_force"][moving], 0.3 * 2 * G, rtol=1e-12)
    np.testing.assert_allclose(res["friction_force"][resting], 0.0, atol=1e-9)


def test_a_block_pushed_sideways_on_an_incline_curves_downhill_and_sticks():
    theta, mu_k, v0 = math.radians(15), 0.6, 1.0
    k = mu_k / math.tan(theta)
    speed = lambda psi: v0 * math.tan(psi / 2) ** k / math.sin(psi)
    dt = lambda psi: speed(psi) / (G * math.sin(theta) * math.sin(psi))
    integral = lambda f: quad(f, 0.0, math.pi / 2, epsabs=1e-14, epsrel=1e-13, limit=200)[0]
    t_stop = integral(dt)
    downhill = integral(lambda p: speed(p) * math.cos(p) * dt(p))
    across = integral(lambda p: speed(p) * math.sin(p) * dt(p))
    res = simulate("incline", 0.5)
    assert res.success, res.message
    grips = [e for e in res.events if e["event"] == "rub.friction.grip"]
    assert len(grips) == 1 and "mode: 1 -> 0" in grips[0]["changes"]
    assert grips[0]["time"] == pytest.approx(t_stop, abs=1e-9)
    assert res["slope_motion.x"][-1] == pytest.approx(-downhill, abs=1e-9)  # x of the slope frame points uphill
    assert res["slope_motion.y"][-1] == pytest.approx(across, abs=1e-9)
    # at rest the friction holds the block's weight along the slope, within the cone mu_s N
    assert res["friction_force"][-1] == pytest.approx(2 * G * math.sin(theta), rel=1e-9)


def test_a_slide_that_turns_without_stopping_follows_the_hand_written_equations():
    def rhs(_, y):
        x, yy, vx, vy = y
        v = math.hypot(vx, vy)
        return [vx, vy, -20 * x - 0.1 * G * vx / v, -20 * yy - 0.1 * G * vy / v]

    ref = solve_ivp(rhs, (0.0, 1.0), [0.3, 0.0, 0.0, 1.0], dense_output=True, rtol=1e-12, atol=1e-14,
                    method="DOP853")
    res = simulate("orbit", 1.0, samples=21)
    expected = ref.sol(res.t)  # (the results have a row before and after each event as well)
    assert res.success, res.message
    turns = [e for e in res.events if e["event"] == "rub.friction.grip"]
    assert len(turns) == 2 and all("mode: 1 -> 1" in e["changes"] for e in turns)  # re-armed, still sliding
    np.testing.assert_allclose(res["table.x"], expected[0], atol=1e-9)
    np.testing.assert_allclose(res["table.y"], expected[1], atol=1e-9)
