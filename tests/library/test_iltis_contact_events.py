"""The Iltis quarter car over the benchmark bump at 10 m/s with its tyre contact switched by events.

With ``switches = true`` the tyre's contact condition and the max() of its unilateral spring become events: the
log names the wheel's contact element at every lift-off and touch-down, and every integrator finishes.  Checked
against the smooth form of the same model: the heave agrees to the integration tolerance.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import mbs

QUARTER_CAR = Path(__file__).resolve().parents[2] / "library" / "iltis" / "quarter_car.mbs"
HEADER = 'model quarter_car "Iltis quarter car" {'


def with_switches(flag: str):
    """The quarter car with its kinks as events (true, the default) or smooth (false)."""
    text = QUARTER_CAR.read_text()
    assert HEADER in text
    return mbs.loads(text.replace(HEADER, HEADER + f"\n    switches = {flag}"), path=str(QUARTER_CAR))


@pytest.fixture(scope="module")
def switched():
    return with_switches("true")


@pytest.fixture(scope="module")
def smooth():
    return with_switches("false")


@pytest.mark.slow
@pytest.mark.parametrize("integrator", ["dopri5", "rodasp", "rodas5p", "Radau", "BDF"])
def test_lift_off_and_touch_down_are_logged_and_every_integrator_finishes(switched, smooth, integrator):
    res = switched.simulate("bump_10", integrator=integrator)
    assert res.success, res.message
    contact = [e for e in res.events if e["event"].endswith("in tyre.radial.contact)") and "(>" in e["event"]]
    lift_offs = [e["time"] for e in contact if e["direction"] == "falling"]
    touch_downs = [e["time"] for e in contact if e["direction"] == "rising"]
    assert lift_offs and touch_downs and lift_offs[0] < touch_downs[0]
    reference = smooth.simulate("bump_10", t_eval=res.t[np.r_[True, np.diff(res.t) > 0]], integrator="dopri5",
                                rtol=1e-9, atol=1e-11)
    heave = res["lift.s"][np.r_[True, np.diff(res.t) > 0]]
    assert np.max(np.abs(heave - reference["lift.s"])) < 2e-4
