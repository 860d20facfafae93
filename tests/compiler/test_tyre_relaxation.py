"""The tyre's first-order relaxation length (compiler/tyre_relaxation.py) against its closed form.

A wheel rolled at constant speed V with a fixed steering angle delta has a constant kinematic slip angle
alpha = atan(vsy / sqrt(vx^2 + v_low^2)) with vx = V cos(delta), vsy = -V sin(delta). With the relaxation
length sigma the relaxed angle obeys sigma alpha_r' + V_e alpha_r = V_e alpha (V_e = sqrt(vx^2 + v_low^2)),
so a linear law fy = -C alpha_r builds up as fy_ss (1 - exp(-V_e t / sigma)): the steady value approached
with the distance constant sigma. Without the argument the force is there at once, as before.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import mbs

WHEEL = Path(__file__).parent / "models" / "relaxing_wheel.mbs"
V, DELTA, C, SIGMA, V_LOW = 10.0, math.radians(2.0), 50000.0, 0.6, 0.5
VX, VSY = V * math.cos(DELTA), -V * math.sin(DELTA)
V_E = math.hypot(VX, V_LOW)
ALPHA = math.atan(VSY / V_E)
FY_SS = -C * ALPHA


def test_the_lateral_force_builds_up_over_the_relaxation_length():
    system = mbs.load(WHEEL)
    res = system.simulate("roll")
    assert res.success
    expected = FY_SS * (1 - np.exp(-V_E * res.t / SIGMA))
    assert np.max(np.abs(res["fy"] - expected)) < 1e-9 * FY_SS
    assert res["contact.tyre.alpha_r"][-1] == pytest.approx(ALPHA * (1 - math.exp(-V_E * 0.3 / SIGMA)), rel=1e-8)
    assert res.unit("contact.tyre.alpha_r") == "rad"
    # the distance constant: at the rolled distance sigma the force is 1 - 1/e of its steady value
    k = int(np.argmin(np.abs(res.t - SIGMA / V_E)))
    assert res["fy"][k] == pytest.approx(FY_SS * (1 - math.exp(-V_E * res.t[k] / SIGMA)), rel=1e-7)


def test_the_relaxed_tyre_is_integrated_by_a_stiff_method_with_its_jacobian():
    res = mbs.load(WHEEL).simulate("roll", integrator="rodasp")
    assert np.max(np.abs(res["fy"] - FY_SS * (1 - np.exp(-V_E * res.t / SIGMA)))) < 1e-9 * FY_SS


def test_without_the_relaxation_length_nothing_changes():
    text = WHEEL.read_text().replace(", relax_y = sigma", "")
    system = mbs.loads(text, path=str(WHEEL))
    gen = system.generate("roll")
    assert gen.z_names == () and "MBS_NZ" not in gen.c_source
    res = system.simulate("roll")
    assert np.allclose(res["fy"], FY_SS, rtol=1e-12, atol=0)
