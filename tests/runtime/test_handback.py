"""A run handed back to Python at an event without a jump of the state (a friction law's event, after which Python
checks the held forces; on a model with loops a prescribed motion's switch, before C projected after it itself:
tests/runtime/test_prescribed_restart.py) goes on in a new C solver that takes over what the old one learned, as a
restart in C keeps it (c/mbs_python.c mbs_ode_take_over): the first-step fractions per indicator and direction, the
indicators' last events, the step a restart in C goes on with, DOPRI5's controller memory.  The fixture: a slider
crank whose slider hits a stiff stop (a switch restarted in C) on every swing, before, between and after the two
switches of its base's ramp, built with -DMBS_ODE_PRESCRIBED_FORMER=1 so that those go back to Python; the baseline
is the same model built with -DMBS_ODE_HANDBACK_FORMER=1 as well (the new solver learned nothing), run in the same
test; the reference the same scene at rtol 1e-11."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import mbs
from mbs.runtime import event_loop
from mbs.runtime.integrators import native
from mbs.runtime.workspace import Workspace
from former_builds import flagged_build, simulate_with

MODELS = Path(__file__).parent / "models"
#: the ramp's switches handed back to Python (c/ode.c MBS_ODE_PRESCRIBED_FORMER), as before C projected after them
HANDING_BACK = ("-DMBS_ODE_PRESCRIBED_FORMER=1",)
HANDBACK_FORMER = ("-DMBS_ODE_HANDBACK_FORMER=1",)
FORMER = HANDING_BACK + HANDBACK_FORMER
#: a sample of stops (stiffness N/m, where it engages m): the learned fractions differ with each
STOPS = [(1e5, 0.46), (1e5, 0.47), (1e6, 0.46), (1e6, 0.47), (1e7, 0.46), (1e7, 0.47)]


@pytest.fixture(scope="module")
def stop():
    system = mbs.load(MODELS / "handback_stop.mbs")
    return system, flagged_build(system, "swings", HANDING_BACK), flagged_build(system, "swings", FORMER)


def samples(res, name: str) -> np.ndarray:
    """The column at the scene's sample times (every 5 ms; the row after an event where one falls on it)."""
    grid = np.linspace(0.0, 1.0, 201)
    rows = np.searchsorted(res.t, grid + 1e-12, side="right") - 1
    assert np.allclose(res.t[rows], grid, rtol=0, atol=1e-12)
    return res[name][rows]


def event_times(res, name: str) -> np.ndarray:
    return np.array([e["time"] for e in res.events if name in e["event"]])


def test_the_fixture_hands_back_at_the_ramp_and_restarts_the_stop_in_c(stop, monkeypatch):
    system, now, _ = stop
    taken = []
    take_over = native.NativeSolver.take_over
    monkeypatch.setattr(native.NativeSolver, "take_over",
                        lambda self, old, *rest: (taken.append(old.t), take_over(self, old, *rest))[1])
    res = simulate_with(system, "swings", now)
    assert res.success, res.message
    assert taken == [pytest.approx(0.2), pytest.approx(0.5)]  # the ramp's ends
    assert len(event_times(res, "guide.stop")) >= 10  # the stop, on every swing, restarted in C


def test_a_run_handed_back_goes_on_with_fewer_rejections_and_rhs_calls(stop):
    """Over the sample of stops: fewer rejected steps and fewer evaluations of f than the new solver that learned
    nothing (the trace of k_stop 1e6, x_stop 0.465: after each hand-back that one rejected the first step of the
    stop's first restart twice, at 2e6 and 3e2 times the tolerance; the carried fraction's first step passed)."""
    system, handing_back, former = stop
    now, was = np.zeros(2), np.zeros(2)
    for k_stop, x_stop in STOPS:
        params = {"k_stop": k_stop, "x_stop": x_stop}
        a = simulate_with(system, "swings", handing_back, params=params)
        b = simulate_with(system, "swings", former, params=params)
        assert a.success and b.success
        assert len(a.events) == len(b.events)
        now += [a.metadata["stats"]["nreject"], a.metadata["stats"]["nfev"]]
        was += [b.metadata["stats"]["nreject"], b.metadata["stats"]["nfev"]]
    assert now[0] < was[0]
    assert now[1] < was[1]


@pytest.mark.parametrize("k_stop, x_stop", [(1e6, 0.47), (1e7, 0.47)])
def test_results_stay_within_the_tolerance_of_a_tight_reference(stop, k_stop, x_stop):
    """The same error control: the samples and the events' times against the scene at rtol 1e-11 as close as the
    former hand-back's (within twice its error, and 1e-5 at rtol 1e-7 over a second); the same events."""
    system, handing_back, former = stop
    params = {"k_stop": k_stop, "x_stop": x_stop}
    reference = system.simulate("swings", params=params, rtol=1e-11, atol=1e-13)
    runs = [simulate_with(system, "swings", handing_back, params=params),
            simulate_with(system, "swings", former, params=params)]
    gaps, shifts = [], []
    for res in runs:
        assert [e["event"] for e in res.events] == [e["event"] for e in reference.events]
        gaps.append(max(float(np.max(np.abs(samples(res, n) - samples(reference, n))))
                        for n in ("guide.s", "main_bearing.phi")))
        shifts.append(float(np.max(np.abs(event_times(res, "") - event_times(reference, "")))))
    assert gaps[0] < 1e-5 and gaps[0] <= 2 * gaps[1]
    assert shifts[0] < 1e-6 and shifts[0] <= 2 * shifts[1]


def test_a_run_that_never_hands_back_is_bit_identical():
    """fast_ramp's switch restarts in C and nothing goes back to Python: the take-over never runs."""
    system = mbs.load(MODELS / "fast_ramp.mbs")
    now = system.simulate("ramp")
    was = simulate_with(system, "ramp", flagged_build(system, "ramp", HANDBACK_FORMER))
    assert now.metadata["stats"] == was.metadata["stats"]
    assert np.array_equal(now["push.s"], was["push.s"]) and np.array_equal(now.t, was.t)


def test_a_new_solver_takes_over_only_before_its_first_step():
    """take_over is a set-up call: after a step, or from itself, it refuses (nothing half-carried)."""
    model = mbs.load(MODELS / "fast_ramp.mbs").compile("ramp")
    data = Workspace(model)
    rhs, g = data.function("rhs"), data.function("events")
    module = native.native_module(rhs)
    x0 = np.asarray(data.x, dtype=float)
    solvers = []
    for _ in range(2):
        solvers.append(module.Solver("dopri5", rhs, 0.0, x0, 1.0, 1e-7, 1e-9))
        solvers[-1].set_events(g, event_loop.event_tables(model).directions)
    one, two = solvers
    gs = np.asarray(g(0.0, x0), dtype=float)
    with pytest.raises(RuntimeError):
        one.take_over(one, gs, gs)
    two.step()
    assert two.stats["naccept"] == 1
    with pytest.raises(RuntimeError):
        two.take_over(one, gs, gs)
    one.take_over(two, gs, gs)  # (without restarts set: nothing to carry, and no error)


def test_the_python_event_loop_projects_only_where_something_jumps(stop, monkeypatch):
    """With an integrator that hands every event to Python (scipy's Radau), the loop's speeds are projected at the
    ramp's two events (the prescribed speed steps) and not at the stop's (a continuous switch: nothing jumps, and
    projecting the located state moved other indicators within round-off of zero across it, whose switches then
    changed without an event)."""
    system, _, _ = stop
    projected = []
    real = Workspace.project.fget  # (a property: the compiled function, bound to the workspace)
    monkeypatch.setattr(Workspace, "project", property(
        lambda self: lambda t, x: projected.append(t) or real(self)(t, x)))
    res = system.simulate("swings", integrator="Radau", rtol=1e-8, atol=1e-10)
    assert res.success, res.message
    continuous = {e["time"] for e in res.events if "stop" in e["event"]}
    ramp = {e["time"] for e in res.events if "prescribed" in e["event"]}
    assert continuous and len(ramp) == 2
    assert ramp <= set(projected) and not continuous & set(projected)
