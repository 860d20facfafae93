"""FMI 2.0 export of events that jump the state (`reinit`), end the run (`terminate`) and switch modes, run by an
independent FMI client (FMPy): its Model Exchange (its own CVODE, locating the indicators' roots and calling
fmi2NewDiscreteStates) and our Co-Simulation (DOPRI5 inside fmi2DoStep).

Checked against what no one here wrote: the closed form of the bouncing ball (first impact at t1 = sqrt(2h/g), every
flight e times the previous one, accumulation at t1 (1 + e) / (1 - e)), the loop-closure constraints (the speeds
after an impact in a closed loop satisfy G v = 0), and against `mbs simulate` of the same model (itself checked
against the closed forms in tests/runtime/test_events.py).

Tolerances.  Co-Simulation integrates the ball's parabolas with DOPRI5, exact on polynomials of degree 5, and
locates the impacts to adjacent doubles: the take-off times it implies agree with the closed form to round-off
(observed 7.5e-15 s; asserted 1e-9 s, the issue's figure).  Model Exchange's impacts are where FMPy's CVODE puts
them: its BDF (orders 1 to 5, restarted at order 1 after each event) with rtol = relative_tolerance and
atol = rtol * nominal (1 here) makes a global error in the ball's height and speed proportional to the tolerance,
and an impact time error of that error over the impact speed.  Observed over 20 impacts: 3.8e-8 s at rtol 1e-10,
5.2e-6 s at 1e-8, 5.3e-4 s at 1e-6 (about 400 rtol, linear in rtol); asserted: below 1e3 rtol at 1e-10 and at
least 30 times larger at 1e-8 (the error is CVODE's, converging with its tolerance, not the FMU's).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import mbs
from mbs.fmu import export_fmu

fmpy = pytest.importorskip("fmpy")
from fmpy import read_model_description, simulate_fmu  # noqa: E402
from fmpy.validation import validate_fmu  # noqa: E402

from test_fmu import on_grid  # noqa: E402

BALL = "library/examples/bouncing_ball.mbs"
G, H, E = 9.81, 1.0, 0.8
T1 = math.sqrt(2 * H / G)
T_INF = T1 * (1 + E) / (1 - E)
N = 20  # impacts checked


def impact_times(n: int) -> np.ndarray:
    """t_k = t1 + 2 t1 (e + e^2 + ... + e^k): the closed form of the k-th impact."""
    k = np.arange(n)
    return T1 + 2 * T1 * E * (1 - E ** k) / (1 - E)


@pytest.fixture(scope="module")
def ball(tmp_path_factory):
    system = mbs.load(BALL)
    return system, export_fmu(system, "drop", tmp_path_factory.mktemp("ball") / "ball.fmu")


def run(fmu, kind, stop_time, dt=0.01, rtol=1e-10, output=("height", "count", "der(fall.s)"), messages=None):
    """FMPy's run of the FMU; ``messages`` collects the FMU's log."""
    def logger(env, name, status, category, message):
        messages.append(message.decode())
    return simulate_fmu(str(fmu), fmi_type=kind, stop_time=stop_time, output_interval=dt,
                        relative_tolerance=rtol, output=list(output), logger=None if messages is None else logger)


def me_impacts(out) -> np.ndarray:
    """Model Exchange records each event twice (before and after): the times where the count goes up."""
    return out["time"][1:][np.diff(out["count"]) > 0]


def test_the_ball_exports_with_its_impact_as_an_event_indicator(ball):
    _, fmu = ball
    assert validate_fmu(str(fmu)) == []
    md = read_model_description(str(fmu))
    assert md.numberOfEventIndicators == 1


def test_model_exchange_impacts_against_the_closed_form_and_simulate(ball):
    system, fmu = ball
    out = run(fmu, "ModelExchange", impact_times(N)[-1] + 0.005)
    times = me_impacts(out)
    assert len(times) == N
    error = np.max(np.abs(times - impact_times(N)))
    assert error < 1e3 * 1e-10, error
    ours = np.array([e["time"] for e in system.simulate("drop").events[:N]])
    assert np.max(np.abs(times - ours)) < 1e3 * 1e-10
    # the reinit: the speed after each impact is -e times the speed before (the two rows at the event)
    at = np.flatnonzero(np.diff(out["count"]) > 0)
    np.testing.assert_allclose(out["der(fall.s)"][at + 1], -E * out["der(fall.s)"][at], rtol=1e-12)
    coarse = me_impacts(run(fmu, "ModelExchange", impact_times(N)[-1] + 0.005, rtol=1e-8))
    assert np.max(np.abs(coarse - impact_times(N))) > 30 * error  # CVODE's error, converging with rtol


def test_co_simulation_take_off_times_against_the_closed_form(ball):
    """The samples of each flight give back its take-off time exactly (a parabola): t - (v+ - v) / g with the
    take-off speed v+ = sqrt(v^2 + 2 g s)."""
    _, fmu = ball
    out = run(fmu, "CoSimulation", impact_times(N)[-1] + 0.001, dt=0.001)
    t, s, v, count = out["time"], out["height"], out["der(fall.s)"], out["count"].astype(int)
    np.testing.assert_allclose(s[count == 0], H - G * t[count == 0] ** 2 / 2, atol=1e-12)
    flying = count >= 1
    take_off = t[flying] - (np.sqrt(v[flying] ** 2 + 2 * G * s[flying]) - v[flying]) / G
    assert set(count[flying]) == set(range(1, N + 1))
    assert np.max(np.abs(take_off - impact_times(N)[count[flying] - 1])) < 1e-9


def test_the_accumulation_point_ends_the_run_with_its_results(ball):
    """Chattering ends the run as `mbs simulate` ends it (status zeno): Co-Simulation at the same event with the
    same state (the same DOPRI5 and the same rule: 10 impacts within 1e-9 s), Model Exchange where CVODE no longer
    resolves the flights (an impact located while the ball rises, runtime/events.against_motion), short of the
    accumulation point by CVODE's resolution.  FMPy keeps every row up to there."""
    system, fmu = ball
    res = system.simulate("drop")
    assert res.metadata["status"] == "zeno"
    messages = []
    cs = run(fmu, "CoSimulation", 6.0, messages=messages)
    assert cs["time"][-1] == pytest.approx(res.t[-1], abs=1e-12)
    assert cs["count"][-1] == len(res.events)
    assert cs["der(fall.s)"][-1] == pytest.approx(res["der(fall.s)"][-1], abs=1e-15)
    assert any("chattering (Zeno behaviour)" in m for m in messages)
    messages.clear()
    me = run(fmu, "ModelExchange", 6.0, messages=messages)
    assert T_INF - 1e-3 < me["time"][-1] < T_INF and me["count"][-1] >= 40
    assert any("crosses against the motion" in m for m in messages)
    assert np.all(me["height"] > -1e-12)  # the ball never sinks into the ground


def test_a_terminal_event_ends_the_fmpy_run_there(tmp_path):
    text = open(BALL, encoding="utf-8").read().replace(
        "    output height = fall.s", "    event stop when t > 1.2 s { terminate }\n    output height = fall.s")
    system = mbs.loads(text)
    fmu = export_fmu(system, "drop", tmp_path / "stop.fmu")
    assert validate_fmu(str(fmu)) == []
    res = system.simulate("drop")
    assert res.t[-1] == 1.2
    for kind, tol in (("ModelExchange", 1e-9), ("CoSimulation", 1e-12)):
        out = run(fmu, kind, 3.0, dt=0.05)
        assert out["time"][-1] == pytest.approx(1.2, abs=tol), kind
        assert out["count"][-1] == 2
        assert out["height"][-1] == pytest.approx(res["height"][-1], abs=1e-7), kind


def slider_crank_with_brake() -> str:
    """The slider crank (a closed loop) whose independent speed, the crank pin's, is halved at t = 0.5 s: the
    velocity constraints are linear in the speeds, so every speed halves."""
    text = open("library/examples/slider_crank.mbs", encoding="utf-8").read()
    end = text.rindex("}")
    return (text[:end] + '    event brake when t > 0.5 s "halve the speeds" {\n'
            "        reinit der(crank_pin.phi) = 0.5 * der(crank_pin.phi)\n    }\n" + text[end:])


def test_a_reinit_in_a_closed_loop_keeps_the_speeds_on_the_constraints(tmp_path):
    """After the reinit the state is projected onto the loop constraints (mbs_project, as `mbs simulate` does):
    every speed halves and G v = 0.  Model Exchange shows the two rows at the event; both runs agree with
    simulate on the grid (observed 8e-8 ME, 6e-9 CS, in rad/s)."""
    system = mbs.loads(slider_crank_with_brake())
    compiled = system.compile()
    fmu = export_fmu(system, None, tmp_path / "crank.fmu")
    assert validate_fmu(str(fmu)) == []
    res = system.simulate(t_end=1.0, sample=0.01, rtol=1e-11, atol=1e-12)
    data = system._workspace(compiled, system.generate(), {p.name: p.value for p in system.model.parameters})
    names = list(compiled.x_names)
    speeds = names[compiled.nq:]
    for kind, tol in (("ModelExchange", 1e-6), ("CoSimulation", 1e-7)):
        out = run(fmu, kind, 1.0, output=names)
        ours, theirs = on_grid(res.t, 0.01), on_grid(out["time"], 0.01)
        away = res.t[ours] != 0.5  # at the event's own time a sample may be either side of it
        for name in names:
            assert np.max(np.abs(out[name][theirs][away] - res[name][ours][away])) < tol, (kind, name)
        for i in np.flatnonzero(out["time"] > 0.5):
            x = np.array([out[n][i] for n in names])
            assert np.max(np.abs(data.constraint_jacobian(out["time"][i], x) @ x[compiled.nq:])) < 1e-7, kind
    me = run(fmu, "ModelExchange", 1.0, output=names)
    at = np.flatnonzero((np.diff(me["time"]) == 0) & (me["time"][:-1] >= 0.5))[0]  # before and after the event
    for name in speeds:  # to the drift of CVODE's state before it off the velocity constraints (observed 3e-8)
        assert me[name][at + 1] == pytest.approx(0.5 * me[name][at], rel=1e-6), name


def test_stick_slip_modes_and_reinit_agree_with_simulate(tmp_path):
    """library/examples/stick_slip.mbs: the stick/slip of a mode switched by events (slip: `set stick = 0`; grip:
    `reinit` the speed to the belt's and `set stick = 1`), checked against its closed form in
    tests/runtime/test_stick_slip.py.  Observed against `mbs simulate`: 0 (CS, the same DOPRI5 and events), 4.5e-8
    m/s (ME, FMPy's CVODE at rtol 1e-10)."""
    system = mbs.load("library/examples/stick_slip.mbs")
    fmu = export_fmu(system, "cycles", tmp_path / "stick_slip.fmu")
    assert validate_fmu(str(fmu)) == []
    res = system.simulate("cycles")
    switches = [e["time"] for e in res.events if e["event"] in ("slip", "grip")]
    names = ["slide.s", "der(slide.s)", "sticking"]
    for kind, tol in (("ModelExchange", 1e-6), ("CoSimulation", 1e-12)):
        out = run(fmu, kind, 5.0, dt=0.005, output=names)
        ours, theirs = on_grid(res.t, 0.005), on_grid(out["time"], 0.005)
        for name in names:
            assert np.max(np.abs(out[name][theirs] - res[name][ours])) < tol, (kind, name)
        if kind == "ModelExchange":  # its event rows: the mode changes where simulate's do
            changed = out["time"][1:][np.diff(out["sticking"]) != 0]
            assert len(changed) == len(switches) and np.max(np.abs(changed - switches)) < 1e-7


def test_a_friction_element_is_refused_with_its_reason(tmp_path):
    with pytest.raises(mbs.MbsError, match="stick/slip switch of a friction element") as info:
        export_fmu(mbs.load("library/examples/stick_slip_coulomb.mbs"), "cycles", tmp_path / "c.fmu")
    assert "library/examples/stick_slip.mbs" in str(info.value)
    assert not (tmp_path / "c.fmu").exists()


def test_co_simulation_terminates_by_the_status_functions_and_a_saved_state_goes_on(tmp_path):
    """FMI 2.0 co-simulation: a terminal event inside fmi2DoStep ends it with fmi2Discard; fmi2Terminated is then
    true and fmi2LastSuccessfulTime the event's time.  A state saved before it (fmi2GetFMUstate) restores an
    instance that steps on."""
    from fmpy import extract
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import FMU2Slave, fmi2Discard, fmi2LastSuccessfulTime, fmi2Terminated
    text = open(BALL, encoding="utf-8").read().replace(
        "    output height = fall.s", "    event stop when t > 1.2 s { terminate }\n    output height = fall.s")
    fmu = export_fmu(mbs.loads(text), "drop", tmp_path / "stop.fmu")
    md = read_model_description(str(fmu))
    slave = FMU2Slave(guid=md.guid, unzipDirectory=extract(str(fmu), str(tmp_path / "x")),
                      modelIdentifier=md.coSimulation.modelIdentifier, instanceName="ball")
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    slave.doStep(currentCommunicationPoint=0.0, communicationStepSize=1.0)
    saved = slave.getFMUstate()
    with pytest.raises(FMICallException) as info:
        slave.doStep(currentCommunicationPoint=1.0, communicationStepSize=0.5)
    assert info.value.status == fmi2Discard
    assert slave.getBooleanStatus(fmi2Terminated)
    assert slave.getRealStatus(fmi2LastSuccessfulTime) == pytest.approx(1.2, abs=1e-12)
    slave.setFMUstate(saved)
    assert not slave.getBooleanStatus(fmi2Terminated)
    slave.doStep(currentCommunicationPoint=1.0, communicationStepSize=0.1)
    assert slave.getRealStatus(fmi2LastSuccessfulTime) == pytest.approx(1.1)
    slave.freeFMUstate(saved)
    slave.terminate()
    slave.freeInstance()


def test_an_impact_with_c_hooks_agrees_with_simulate(tmp_path):
    """tests/runtime/models/hook_ball.mbs: the floor and the impact law are C hooks compiled into the FMU.  After
    its second impact the ball restarts 6e-14 m below the floor; FMPy's CVODE then stops at the indicator's own
    zero on the way up, which must not count as a falling crossing (it ended the run as chattering before the
    FMU read an indicator at zero by the side it leaves to).  Observed against `mbs simulate` after 4 impacts:
    1.4e-8 m/s (ME), 3e-14 m/s (CS)."""
    hooks = {name: "tests/runtime/hooks/ball_hooks.c" for name in ("floor_height", "impact_law", "energy")}
    system = mbs.load("tests/runtime/models/hook_ball.mbs")
    fmu = export_fmu(system, None, tmp_path / "hook_ball.fmu", hooks=hooks)
    res = system.simulate(hooks=hooks, t_end=2.0, sample=0.01)
    assert len(res.events) == 4
    for kind, tol in (("ModelExchange", 1e-6), ("CoSimulation", 1e-12)):
        out = run(fmu, kind, 2.0, output=["fall.s", "der(fall.s)"])
        assert out["time"][-1] == pytest.approx(2.0)
        for name in ("fall.s", "der(fall.s)"):
            assert abs(out[name][-1] - res[name][-1]) < tol, (kind, name)
