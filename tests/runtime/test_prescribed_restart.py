"""A prescribed motion's switch on a model with loops is applied and restarted in C (c/ode.c mbs_ode_restart,
MBS_ODE_HANDLED_PROJECT): the state after it projected onto the constraints with the new values, as the Python event
loop does after the event handed back to it (runtime/event_loop.py), which the same model built with
-DMBS_ODE_PRESCRIBED_FORMER=1 still does: the baseline, run in the same test.  The fixture: a slider crank whose
slider's guide rides on a base that a prescribed motion ramps (the base in the loop: the guide's speed steps by the
ramp's rate at both of its ends); and the Iltis over the bump at 10 m/s, whose steering rack has two such switches."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import mbs
from mbs.runtime import build, event_loop
from mbs.runtime.integrators import native
from mbs.runtime.workspace import Workspace
from former_builds import flagged_build, simulate_with

pytestmark = pytest.mark.skipif(not build.have_c_compiler(), reason="needs a C compiler")

MODELS = Path(__file__).parent / "models"
VEHICLE = Path(__file__).resolve().parents[2] / "library" / "iltis" / "vehicle.mbs"
HANDING_BACK = ("-DMBS_ODE_PRESCRIBED_FORMER=1",)
RATE = 0.2  # prescribed_loop.mbs: the base's speed on its ramp [m/s]


@pytest.fixture(scope="module")
def ramp():
    system = mbs.load(MODELS / "prescribed_loop.mbs")
    return system, flagged_build(system, "swings", HANDING_BACK)


def log(res) -> list[tuple]:
    return [(e["event"], e["direction"], e["changes"]) for e in res.events]


def event_times(res) -> np.ndarray:
    return np.array([e["time"] for e in res.events])


def states(res, names) -> np.ndarray:
    return np.column_stack([res[n] for n in names])


def test_the_tables_mark_the_prescribed_switches_for_a_projection(ramp):
    system, _ = ramp
    model = system.compile("swings")
    handled = event_loop.c_restart_tables(model)[0]
    assert [spec.prescribed for spec in model.events] == [True, True]
    assert handled.tolist() == [2, 2]


@pytest.mark.parametrize("integrator", ["dopri5", "adams", "rodas5p"])
def test_the_ramp_is_restarted_in_c_with_the_state_on_the_constraints_after_it(ramp, monkeypatch, integrator):
    """No event goes back to Python (no solver takes over from another); the row after each of the ramp's events
    satisfies the loop's position and velocity constraints with the branches it switched to, the row before it
    (the same positions) misses the velocity constraint by the step of the base's speed."""
    system, _ = ramp
    taken = []
    take_over = native.NativeSolver.take_over
    monkeypatch.setattr(native.NativeSolver, "take_over",
                        lambda self, old, *rest: (taken.append(old.t), take_over(self, old, *rest))[1])
    res = system.simulate("swings", integrator=integrator)
    assert res.success, res.message
    assert not taken
    assert np.allclose(event_times(res), [0.2, 0.5], rtol=0, atol=1e-12)
    model = system.compile("swings")
    data = Workspace(model)
    x = states(res, model.x_names)
    for event in res.events:  # the branches as each event leaves them
        spec = next(s for s in model.events if s.name == event["event"])
        data.p[spec.switch] = 1.0 if event["direction"] == "rising" else 0.0
        before, after = np.flatnonzero(res.t == event["time"])
        gdot = [np.max(np.abs(data.constraint_velocity(event["time"], x[row]))) for row in (before, after)]
        assert np.max(np.abs(data.constraints(event["time"], x[after]))) < 1e-10
        assert gdot[1] < 1e-10
        assert gdot[0] == pytest.approx(RATE, rel=1e-6)


@pytest.mark.parametrize("integrator", ["dopri5", "adams", "rodas5p"])
def test_the_run_is_the_one_the_hand_back_to_python_gives(ramp, integrator):
    """The same event log, the same rows to round-off (the same projection with the same values, the restart's
    departing indicators and step as the take-over's), within the tolerance of a tight reference."""
    system, handing_back = ramp
    now = system.simulate("swings", integrator=integrator)
    was = simulate_with(system, "swings", handing_back, integrator=integrator)
    names = system.compile("swings").x_names
    assert log(now) == log(was)
    assert np.max(np.abs(event_times(now) - event_times(was))) <= 1e-12
    assert now.t.shape == was.t.shape and np.array_equal(now.t, was.t)
    assert np.max(np.abs(states(now, names) - states(was, names))) < 1e-9
    reference = system.simulate("swings", integrator="dopri5", rtol=1e-11, atol=1e-13)
    grid = np.searchsorted(now.t, np.linspace(0.0, 1.0, 201) + 1e-12, side="right") - 1
    grid_ref = np.searchsorted(reference.t, np.linspace(0.0, 1.0, 201) + 1e-12, side="right") - 1
    assert np.max(np.abs(states(now, names)[grid] - states(reference, names)[grid_ref])) < 1e-4


def test_the_iltis_bump_run_is_the_one_the_hand_back_to_python_gives():
    """The steering rack's two switches (the ends of its ramp) restarted in C: the same 392 events as with the
    hand-back, the same rows to round-off."""
    system = mbs.load(VEHICLE)
    model = system.compile("bump_10")
    assert 2 in event_loop.c_restart_tables(model)[0].tolist()
    now = system.simulate("bump_10")
    was = simulate_with(system, "bump_10", flagged_build(system, "bump_10", HANDING_BACK))
    assert now.success and was.success
    assert log(now) == log(was) and len(log(now)) == 392
    assert np.max(np.abs(event_times(now) - event_times(was))) <= 1e-12
    assert now.t.shape == was.t.shape
    names = [n for n in now.names if n != "time"]
    for name in names:
        scale = max(1.0, float(np.max(np.abs(was[name]))))
        assert np.max(np.abs(now[name] - was[name])) <= 1e-9 * scale, name
