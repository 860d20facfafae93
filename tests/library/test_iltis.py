"""The Iltis quarter car of the library: it settles on its tyre carrying exactly its own weight."""

import pytest

import mbs

G = 9.81


def test_quarter_car_settles_with_the_tyre_carrying_the_whole_weight():
    system = mbs.load("library/iltis/quarter_car.mbs")
    res = system.simulate("settle", t_end=3.0)
    assert res.success, res.message
    p = {x.name: x.value for x in system.model.parameters}
    weight = G * (p["m_quarter"] + p["fl.m_leaf"] + p["fl.m_arm"] + p["fl.m_carrier"] + p["fl.m_rod"]
                  + p["fl.m_wheel"])
    # at rest the only vertical external forces are gravity and the tyre (the guide is vertical, frictionless)
    assert res["tyre.radial.load"][-1] == pytest.approx(weight, rel=1e-3)
    # and the suspension stays inside its travel: between the bump stop and the rebound stop of the strut
    assert 0.40 < res["fl.travel"][-1] < 0.46


def test_static_equilibrium_balances_the_weight_to_1e_6():
    """start = equilibrium: the bump scene starts at rest on the springs; the tyre carries the weight."""
    system = mbs.load("library/iltis/quarter_car.mbs")
    res = system.simulate("bump_5", t_end=0.01)
    assert res.success, res.message
    p = {x.name: x.value for x in system.model.parameters}
    weight = G * (p["m_quarter"] + p["fl.m_leaf"] + p["fl.m_arm"] + p["fl.m_carrier"] + p["fl.m_rod"]
                  + p["fl.m_wheel"])
    assert res["tyre.radial.load"][0] == pytest.approx(weight, rel=1e-6)
    assert res["der(lift.s)"][0] == 0.0
