"""The coulomb friction element (compiler/friction.py, language/friction.py) against closed forms: a block on an
incline that sticks below the friction angle and slides above it with g (sin theta - mu_k cos theta), with the
normal force given or taken from the slider's reaction; a disc driven in a bearing with friction (revolute); two
stacked blocks whose friction forces are solved together; a block sliding to rest through a Stribeck curve (stopping
time by quadrature); the tanh-smoothed law, which creeps where the switch holds; point contacts; and the errors for
elements the compiler cannot lower."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from mbs.language.diagnostics import MbsError
from scipy.integrate import quad

import mbs

MODELS = Path(__file__).parent / "models" / "friction.mbs"
G = 9.81


def simulate(model, t_end=1.0, **params):
    system = mbs.load(MODELS, model)
    return system.simulate(t_end=t_end, t_eval=np.linspace(0.0, t_end, 101), params=params, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("model", ["incline", "incline_reaction"])
def test_a_block_sticks_below_the_friction_angle(model):
    theta = math.radians(20)  # tan 20 deg = 0.36 < mu_s = 0.5
    res = simulate(model, theta=theta)
    assert res.success, res.message
    assert np.max(np.abs(res["slide.s"])) <= 1e-12 and not res.events
    np.testing.assert_allclose(res["friction_force"], 2 * G * math.sin(theta), rtol=1e-12)  # holds it uphill


@pytest.mark.parametrize("model", ["incline", "incline_reaction"])
def test_a_block_slides_above_the_friction_angle_with_the_analytic_acceleration(model):
    theta = math.radians(30)  # tan 30 deg = 0.58 > mu_s = 0.5
    res = simulate(model, theta=theta)
    acceleration = G * (math.sin(theta) - 0.3 * math.cos(theta))
    np.testing.assert_allclose(res["slide.s"], -0.5 * acceleration * res.t ** 2, atol=1e-10)
    np.testing.assert_allclose(res["friction_force"][1:], 0.3 * 2 * G * math.cos(theta), rtol=1e-10)


def test_a_revolute_joint_sticks_until_the_torque_exceeds_mu_s_r_n():
    held = simulate("wheel", torque=3.0)  # limit mu_s r n = 4 N m
    assert np.max(np.abs(held["axle.phi"])) <= 1e-12
    np.testing.assert_allclose(held["friction_torque"], -3.0, rtol=1e-12)
    turning = simulate("wheel", torque=5.0)
    acceleration = (5.0 - 0.5 * 0.05 * 100) / 0.5  # (torque - mu_k r n) / J
    np.testing.assert_allclose(turning["axle.phi"], 0.5 * acceleration * turning.t ** 2, atol=1e-10)


def test_two_elements_stick_together_and_one_slides_on_the_other():
    both = simulate("stack", push=1.0)  # below 0.2 * 1 kg * g between the blocks
    assert np.max(np.abs(both["ground.s"])) <= 1e-12 and np.max(np.abs(both["layer.s"])) <= 1e-12
    np.testing.assert_allclose(both["layer_force"], -1.0, rtol=1e-12)
    np.testing.assert_allclose(both["ground_force"], -1.0, rtol=1e-12)
    top = simulate("stack", push=3.0)  # the top slides; the ground holds the bottom against the top's drag
    drag = 0.2 * 1.0 * G
    np.testing.assert_allclose(top["ground.s"], 0.0, atol=1e-12)
    np.testing.assert_allclose(top["layer.s"], 0.5 * (3.0 - drag) / 1.0 * top.t ** 2, atol=1e-10)
    np.testing.assert_allclose(top["ground_force"], -drag, rtol=1e-10)


def test_a_stribeck_curve_sets_the_stopping_time_and_distance():
    mu = lambda v: 0.3 + (0.6 - 0.3) * math.exp(-(v / 0.1) ** 2)
    t_stop = quad(lambda v: 1 / (G * mu(v)), 0, 0.5, epsabs=1e-14, epsrel=1e-13)[0]
    distance = quad(lambda v: v / (G * mu(v)), 0, 0.5, epsabs=1e-14, epsrel=1e-13)[0]
    res = simulate("stribeck", t_end=0.3)
    grips = [e for e in res.events if e["event"] == "slide.friction.grip"]
    assert len(grips) == 1 and grips[0]["changes"].endswith("-> 0")  # it stops and sticks
    assert grips[0]["time"] == pytest.approx(t_stop, abs=1e-9)
    assert res["slide.s"][-1] == pytest.approx(distance, abs=1e-9)
    assert np.all(res["der(slide.s)"][res.t > t_stop + 1e-6] == 0)  # after the event rows


def test_the_smoothed_law_creeps_where_the_switch_holds():
    theta = math.radians(10)  # tan 10 deg < mu_k: the exact element holds the block
    res = simulate("incline_tanh", theta=theta)
    creep = 1e-3 * math.atanh(math.tan(theta) / 0.3)  # tanh(v / v_eps) = tan theta / mu_k
    assert res["der(slide.s)"][-1] == pytest.approx(-creep, rel=1e-6)


def test_friction_needs_a_sliding_joint_and_a_revolute_joint_a_radius(tmp_path):
    bad = MODELS.read_text().replace("force bearing = coulomb(mu_s = mu_s, mu_k = mu_k, normal = n, radius = r)",
                                     "force bearing = coulomb(mu_s = mu_s, mu_k = mu_k, normal = n)")
    path = tmp_path / "bad.mbs"
    path.write_text(bad)
    with pytest.raises(MbsError, match="needs its radius"):
        mbs.load(path, "wheel")


def test_a_point_contact_sticks_and_slides_like_the_incline():
    for degrees, moves in ((20, False), (30, True)):
        theta = math.radians(degrees)
        res = simulate("tipping_contact", theta=theta)
        acceleration = G * (math.sin(theta) - 0.3 * math.cos(theta)) if moves else 0.0
        np.testing.assert_allclose(res["rail.s"], -0.5 * acceleration * res.t ** 2, atol=1e-10)
        held = 2 * G * math.sin(theta)
        expected = 0.3 * 2 * G * math.cos(theta) if moves else held
        np.testing.assert_allclose(res["friction_force"][1:], expected, rtol=1e-10)


def test_a_point_contact_that_starts_sliding_slides_until_it_stops_and_then_sticks():
    theta = math.radians(10)  # below the friction angle: the kinetic friction brakes the block to rest
    res = simulate("tipping_contact", theta=theta, v0=-0.5)
    deceleration = G * (0.3 * math.cos(theta) - math.sin(theta))
    assert res.events[0]["direction"] == "start" and res.events[0]["changes"].endswith("-> -1")
    grips = [e for e in res.events if e["event"] == "rub.friction.grip"]
    assert len(grips) == 1 and grips[0]["changes"].endswith("-> 0")
    assert grips[0]["time"] == pytest.approx(0.5 / deceleration, abs=1e-9)
    assert res["rail.s"][-1] == pytest.approx(-0.5 ** 2 / (2 * deceleration), abs=1e-9)


def test_a_point_contact_on_a_moving_body_is_solved_with_a_joint_element():
    both = simulate("stack_contact", push=1.0)
    np.testing.assert_allclose(both["guide.s"], 0.0, atol=1e-12)
    np.testing.assert_allclose(both["layer_force"], -1.0, rtol=1e-12)
    np.testing.assert_allclose(both["ground_force"], -1.0, rtol=1e-12)
    top = simulate("stack_contact", push=3.0)
    drag = 0.2 * 1.0 * G
    np.testing.assert_allclose(top["ground.s"], 0.0, atol=1e-12)
    np.testing.assert_allclose(top["guide.s"], 0.5 * (3.0 - drag) * top.t ** 2, atol=1e-10)
    np.testing.assert_allclose(top["ground_force"], -drag, rtol=1e-10)


def edited(tmp_path, old, new, source=MODELS):
    text = source.read_text()
    assert old in text
    path = tmp_path / "edited.mbs"
    path.write_text(text.replace(old, new))
    return path


@pytest.mark.parametrize("old, new, message", [
    ("joint revolute(axis = z)\n        force drive", "joint spherical\n        force drive",
     "acts in a prismatic or revolute joint"),
    ("normal = m * 9.81 m/s^2 * cos(theta), tangent = x)",
     "normal = reaction, tangent = x)", "a point contact"),
])
def test_an_element_where_it_cannot_act_is_an_error_at_its_line(tmp_path, old, new, message):
    with pytest.raises(MbsError, match=message) as caught:
        mbs.load(edited(tmp_path, old, new))
    assert "coulomb" in str(caught.value)  # the source line with the caret


@pytest.mark.parametrize("model, old, new, message", [
    ("incline_reaction", "normal = reaction)", "normal = reaction * reaction / (1 N))", "a constant times it"),
    ("incline_tanh", "normal = m * 9.81 m/s^2 * cos(theta), smoothing", "normal = reaction, smoothing",
     "smoothed"),
])
def test_a_normal_force_the_compiler_cannot_solve_is_an_error(tmp_path, model, old, new, message):
    system = mbs.load(edited(tmp_path, old, new), model)
    with pytest.raises(MbsError, match=message):
        system.simulate(t_end=0.1)


def test_bearing_friction_in_a_slider_of_a_closed_loop_is_mu_times_its_reaction(tmp_path):
    """The guide of library/examples/slider_crank.mbs (a tree joint of the loop) with normal = reaction: its load
    comes from the inverse dynamics with the loop's multipliers (compiler/friction_loops.py); the reaction sensor
    derives the same load on its own path (compiler/reactions.py) for the outputs."""
    example = Path(__file__).resolve().parents[2] / "library" / "examples" / "slider_crank.mbs"
    text = example.read_text()
    for old, new in (("init der(phi) = 10 rad/s", "init phi = 30 deg\n            init der(phi) = 10 rad/s"),
                     ("init phi = 0 deg", ""), ("init s = 0.5 m", ""),
                     ("interact guide {\n", "interact guide {\n        force friction = coulomb(mu_s = 0.3, "
                      "mu_k = 0.2, normal = reaction)\n        sensor f = force(element = friction)\n"
                      "        sensor R = reaction()\n"),
                     ("    }\n}", "    }\n    output f = guide.f\n    output fy = guide.R.fy\n"
                      "    output fz = guide.R.fz\n}")):
        assert old in text
        text = text.replace(old, new, 1)
    path = tmp_path / "slider_crank_bearing.mbs"
    path.write_text(text)
    res = mbs.load(path).simulate(t_end=0.25, t_eval=np.linspace(0.0, 0.25, 26), rtol=1e-10, atol=1e-12)
    assert res.success, res.message
    assert [(e["event"], e["direction"]) for e in res.events] == [("guide.friction.slip", "start")]
    assert "0 -> -1" in res.events[0]["changes"]  # the crank pulls the slider back at 30 deg
    np.testing.assert_allclose(res["f"], 0.2 * np.hypot(res["fy"], res["fz"]), rtol=1e-10)
    assert np.all(res["f"] * res["der(guide.s)"] < 0)  # against the motion
