"""The root finder of c/ode.c shares the trial points of a step's searches among the indicators that cross in it
(the second of two twin contacts starts from the bracket the first one's trial points give), takes the departure
probe only after a restart and hands the indicators at the event to the restart: none of it may move an event.
The reference is the same model built with -DMBS_ODE_EVENTS_FORMER=1 (each crossing located from its step's ends
alone): where an indicator changes sign once at the scale of doubles (two free falls onto contacts, quadratic in
time), both must end on the same two adjacent doubles, so the runs agree to the bit."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import mbs
from former_builds import flagged_build, simulate_with

TWIN_DROPS = Path(__file__).parent / "models" / "twin_drops.mbs"
G, H = 9.81, 1.0


def former_build(system, scene: str):
    """The scene's compiled model with the former root finding."""
    return flagged_build(system, scene, ("-DMBS_ODE_EVENTS_FORMER=1",))


@pytest.fixture(scope="module")
def twins():
    system = mbs.load(TWIN_DROPS)
    return system, former_build(system, "drops")


#: c/ode.c MBS_ODE_TWIN_WINDOW: crossings of one step at most this far apart (t < 1 s) are one event
TWIN_WINDOW = 1e-10


@pytest.mark.parametrize("apart", [4e-10, 1e-11, 1e-14])
def test_twin_contacts_are_located_as_the_former_root_finder_did_to_the_bit(twins, apart):
    """Two contacts `apart` seconds apart, found in one step: beyond the twin window (c/ode.c MBS_ODE_TWIN_WINDOW)
    they are two events (the second located from the first one's trial points), each at its free-fall time
    sqrt(2 h / g); within it one, at the later crossing, where both have crossed; either way at the times and with
    the samples of the former search."""
    system, former = twins
    dh = apart * np.sqrt(2 * G * H)
    now = system.simulate("drops", params={"dh": dh})
    before = simulate_with(system, "drops", former, params={"dh": dh})
    assert now.success and before.success
    assert [(e["event"], e["direction"], e["time"]) for e in now.events] == \
        [(e["event"], e["direction"], e["time"]) for e in before.events]
    for name in now.names:
        assert np.array_equal(now[name], before[name]), name
    closing = {e["event"].split(" ")[-1]: e["time"] for e in now.events if e["direction"] == "rising"}
    assert closing["drop_right.contact)"] == pytest.approx(np.sqrt(2 * (H + dh) / G), abs=1e-12)
    if apart > TWIN_WINDOW:
        assert closing["drop_left.contact)"] == pytest.approx(np.sqrt(2 * H / G), abs=1e-12)
        assert closing["drop_right.contact)"] - closing["drop_left.contact)"] == pytest.approx(apart, abs=2e-12)
    else:
        assert closing["drop_left.contact)"] == closing["drop_right.contact)"]


#: c/ode.c's former test for a crossing at a step's end, and its former search evaluating every indicator at its
#: trial points
SCAN_FORMER, SINGLE_FORMER = "-DMBS_ODE_SCAN_FORMER=1", "-DMBS_ODE_SINGLE_FORMER=1"
ILTIS_QUARTER_CAR = Path(__file__).resolve().parents[2] / "library" / "iltis" / "quarter_car.mbs"


@pytest.mark.parametrize("flag", [SCAN_FORMER, SINGLE_FORMER])
@pytest.mark.parametrize("model, scene, integrator", [("handback_stop.mbs", "swings", "dopri5"),
                                                       ("handback_stop.mbs", "swings", "adams"),
                                                       ("adams_switches.mbs", "run", None),
                                                       ("twin_drops.mbs", "drops", None),
                                                       (ILTIS_QUARTER_CAR, "bump_10", None)])
def test_the_crossing_test_and_the_search_run_as_the_former_to_the_bit(model, scene, integrator, flag):
    """The indicators at a step's end tested for a crossing all at once (c/ode.c mbs_ode_any_crossed), the root
    finding set up only after one; its trial points evaluating the indicators that crossed alone
    (mbs_event_indicator, each printed as mbs_events prints it), the ones at the event evaluated afresh: the run of
    the former build (-DMBS_ODE_SCAN_FORMER=1, -DMBS_ODE_SINGLE_FORMER=1) to the bit, its events and counters the
    same."""
    system = mbs.load(Path(__file__).parent / "models" / model)
    options = {"integrator": integrator} if integrator else {}
    now = system.simulate(scene, **options)
    was = simulate_with(system, scene, flagged_build(system, scene, (flag,)), **options)
    assert now.success and len(now.events) > 1
    assert now.events == was.events
    assert now.metadata["stats"] == was.metadata["stats"]
    assert np.array_equal(np.asarray(now.data), np.asarray(was.data))
