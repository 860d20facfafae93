"""A tyre relaxation length that a scene switches on (compiler/tyre_relaxation.py `switched_off`): a length
that is 0 once the inputs are put in adds no state and generates the code of a tyre without one; a scene that
replaces the input adds the state, and the force then builds up as the closed form of
tests/compiler/test_tyre_relaxation.py says (fy_ss (1 - exp(-V t / sigma)))."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

import mbs

WHEEL = Path(__file__).parent / "models" / "relaxing_wheel.mbs"
V, DELTA, C, SIGMA, V_LOW = 10.0, math.radians(2.0), 50000.0, 0.6, 0.5   # relaxing_wheel.mbs
VX, VSY = V * math.cos(DELTA), -V * math.sin(DELTA)
V_E = math.hypot(VX, V_LOW)
FY_SS = -C * math.atan(VSY / V_E)   # -C alpha, alpha the kinematic slip angle

SWITCHED = (WHEEL.read_text()
            .replace('    param sigma = 0.6 m "lateral relaxation length"',
                     '    input relax = 0 m "lateral relaxation length (0: off)"')
            .replace("relax_y = sigma", "relax_y = relax")
            + '\nscene relaxed {\n    input relax = 0.6 m\n    t_end = 0.3 s\n    sample = 0.005 s\n    rtol = 1e-10\n    atol = 1e-12\n}\n')


def test_a_zero_length_generates_the_code_of_a_tyre_without_one():
    plain = mbs.loads(WHEEL.read_text().replace(", relax_y = sigma", "").replace(
        '    param sigma = 0.6 m "lateral relaxation length"', '    input relax = 0 m "lateral relaxation length (0: off)"'),
        path=str(WHEEL))
    switched = mbs.loads(SWITCHED, path=str(WHEEL))
    gen = switched.generate("roll")
    assert gen.z_names == ()
    assert gen.c_source == plain.generate("roll").c_source
    res = switched.simulate("roll")
    assert np.allclose(res["fy"], FY_SS, rtol=1e-12, atol=0)


def test_a_scene_that_sets_the_input_switches_the_relaxation_on():
    system = mbs.loads(SWITCHED, path=str(WHEEL))
    res = system.simulate("relaxed")
    assert res.success and system.generate("relaxed").z_names == ("contact.tyre.alpha_r",)
    assert res.unit("contact.tyre.alpha_r") == "rad"
    assert np.max(np.abs(res["fy"] - FY_SS * (1 - np.exp(-V_E * res.t / SIGMA)))) < 1e-9 * FY_SS


def test_a_relaxation_length_input_is_not_a_run_time_input():
    """The length decides the compiled code, so linearising leaves it as the scene sets it (it used to be
    driven like any input, and the driven length's 1/sigma met sigma = 0: a code generation error) and a
    run-time value for it is a clear error."""
    import pytest
    from mbs.language.diagnostics import MbsError
    switched = mbs.loads(SWITCHED, path=str(WHEEL))
    plain = mbs.loads(WHEEL.read_text().replace(", relax_y = sigma", ""), path=str(WHEEL))
    lin = switched.linearize("roll", at="initial")
    assert np.allclose(lin.A, plain.linearize("roll", at="initial").A, rtol=1e-9, atol=1e-9)
    with pytest.raises(MbsError, match="relaxation length"):
        switched.simulate("roll", inputs={"relax": 0.5})
