"""The full Iltis over the benchmark bump with its tyre contact switched by events (library/iltis/vehicle.mbs).

With switches on, each Calspan tyre's contact law ``if(rho > 0 m, max(0 N, k rho + d rho_dot), 0 N)`` becomes a
contact mode per wheel: lift-off where the deflection (and with it the force, d = 0) reaches zero from above,
touch-down where it rises through zero again, each located on the dense output and logged with the wheel's
name.  Checked against the smooth form of the same model integrated far below the tolerance (the error control
then steps over the kinks by itself): the event form agrees to the integration tolerance, with every integrator.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import mbs

VEHICLE = Path(__file__).resolve().parents[2] / "library" / "iltis" / "vehicle.mbs"
HEADER = 'model vehicle "Iltis on four suspensions" {'
WHEELS = ("tyre_fl", "tyre_fr", "tyre_rl", "tyre_rr")
TYRE_K = 460000.0  # N/m, the Calspan tyre's radial stiffness (library/tyres/calspan.mbs)


def vehicle(switches: bool):
    text = VEHICLE.read_text()
    assert HEADER in text
    return mbs.loads(text.replace(HEADER, f"{HEADER}\n    switches = {str(switches).lower()}"), path=str(VEHICLE))


@pytest.fixture(scope="module")
def switched():
    """The library's file as it stands: its switches are on (the default, which the file does not turn off), so
    this is the model the other Iltis tests build, and the fresh run compiles the vehicle's equations once (a copy
    with `switches = true` written in had other line numbers, so another derivation and another full compile)."""
    system = mbs.load(VEHICLE)
    assert system.model.switches and "switches" not in VEHICLE.read_text()
    return system


@pytest.fixture(scope="module")
def smooth():
    return vehicle(False)


def contact_events(res, wheel: str) -> tuple[list[float], list[float]]:
    """(lift-off times, touch-down times) of one wheel: its deflection condition rho > 0 falling / rising."""
    mine = [e for e in res.events if e["event"].endswith(f"(> in {wheel}.radial.contact)")]
    return ([e["time"] for e in mine if e["direction"] == "falling"],
            [e["time"] for e in mine if e["direction"] == "rising"])


@pytest.fixture(scope="module")
def reference(smooth):
    return smooth.simulate("bump_10", rtol=1e-10, atol=1e-12)


@pytest.mark.slow
@pytest.mark.parametrize("integrator", ["dopri5", "rodasp", "rodas5p", "Radau", "BDF", "cvode_bdf", "ida"])
def test_every_integrator_takes_the_iltis_over_the_bump_at_10_m_s_with_contact_events(switched, reference,
                                                                                       integrator):
    res = switched.simulate("bump_10", integrator=integrator)
    assert res.success, res.message
    for wheel in WHEELS:  # every wheel leaves the road and comes back (a graze may log a touch-down twice)
        lift_offs, touch_downs = contact_events(res, wheel)
        assert lift_offs and touch_downs and lift_offs[0] < touch_downs[0], wheel
        assert touch_downs[-1] > lift_offs[-1], wheel  # on the road at the end
        loads = res[f"{wheel}.radial.load"]
        assert np.any(loads == 0.0)  # held at zero in the air
        # never pulling: near an event the deflection is zero to the integrator's resolution (k times the scene's
        # atol of 1e-9 m; the multistep methods' interpolants reach a few 1e-12 m)
        assert loads.min() > -TYRE_K * 1e-9
    # the front wheels leave the road first, on the bump's crest
    assert contact_events(res, "tyre_fl")[0][0] < contact_events(res, "tyre_rl")[0][0]
    unique = np.r_[True, np.diff(res.t) > 0]
    heave = np.interp(reference.t, res.t[unique], res["heave"][unique])
    assert np.max(np.abs(heave - reference["heave"])) < 1e-4  # 0.1 mm, the tolerance's order on a 0.2 m bump


def test_the_event_log_names_the_wheel_at_lift_off_and_touch_down(switched, tmp_path):
    """The fast check: dopri5 over the bump at 10 m/s, the log in res.events and run.events.csv."""
    res = switched.simulate("bump_10", t_end=0.3)
    assert res.success, res.message
    lift_offs, touch_downs = contact_events(res, "tyre_fl")
    assert 0.15 < lift_offs[0] < touch_downs[0] < 0.3
    rows = res.to_events_csv(tmp_path / "run.events.csv").read_text().splitlines()
    assert rows[0].startswith("time,event")
    assert any("tyre_fl.radial.contact" in r for r in rows[1:])


@pytest.mark.slow
def test_at_30_m_s_the_iltis_jumps_the_bump_and_lands_as_the_smooth_form_does(switched, smooth):
    """Issue 11's extreme case: at 30 m/s the bump throws the car into the air (all four wheels off the road at
    once, about 1 m of heave); the event form lands where the smooth form integrated far below the tolerance
    does."""
    res = switched.simulate("bump_10", params={"v": 30})
    assert res.success, res.message
    airborne = np.ones(res.t.size, dtype=bool)
    for wheel in WHEELS:
        lift_offs, touch_downs = contact_events(res, wheel)
        assert lift_offs and touch_downs, wheel
        airborne &= res[f"{wheel}.radial.load"] <= 0.0
    assert airborne.any()  # a flight phase with no wheel on the road
    assert np.ptp(res["heave"]) > 0.5
    reference = smooth.simulate("bump_10", params={"v": 30}, rtol=1e-10, atol=1e-12)
    assert reference.success, reference.message
    unique = np.r_[True, np.diff(res.t) > 0]
    heave = np.interp(reference.t, res.t[unique], res["heave"][unique])
    assert np.max(np.abs(heave - reference["heave"])) < 1e-4
