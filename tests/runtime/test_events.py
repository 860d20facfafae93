"""Events: root finding on the dense output, actions, the event log, chattering, and switches.

Checked against what no one here wrote: the closed form of a bouncing ball (first impact at sqrt(2h/g), every
flight e times the previous one, accumulation at t1 (1 + e) / (1 - e)), exact arithmetic for time events, and
the failure of the stiff integrators on a stepped set point without switches (the issue's report).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import mbs
from mbs.runtime.events import ZENO_WINDOW, locate_crossing

ROOT = Path(__file__).resolve().parents[2]
BALL = ROOT / "library" / "examples" / "bouncing_ball.mbs"
ARM = Path(__file__).parent / "models" / "stiff_arm.mbs"
G, H, E = 9.81, 1.0, 0.8
T1 = math.sqrt(2 * H / G)
T_INF = T1 * (1 + E) / (1 - E)


def impact_times(n: int) -> np.ndarray:
    """t_k = t1 + 2 t1 (e + e^2 + ... + e^k): the closed form of the k-th impact."""
    k = np.arange(n)
    return T1 + 2 * T1 * E * (1 - E ** k) / (1 - E)


# ------------------------------------------------------------------------------------------ root finding
def test_a_time_event_is_located_exactly_on_its_time():
    assert locate_crossing(lambda t: t - 0.5, 0.3, 0.7, -0.2, 0.2) == 0.5
    assert locate_crossing(lambda t: 0.5 - t, 0.49, 0.9, 0.01, -0.4) == 0.5


def test_a_nonlinear_crossing_is_located_to_round_off():
    t = locate_crossing(lambda s: math.cos(s) - s, 0.0, 1.0, 1.0, math.cos(1.0) - 1.0)
    assert math.cos(t) - t <= 0 < math.cos(np.nextafter(t, 0)) - np.nextafter(t, 0)
    assert abs(t - 0.7390851332151607) <= 2e-16


# ------------------------------------------------------------------------------------------ bouncing ball
@pytest.fixture(scope="module")
def ball():
    return mbs.load(BALL)


@pytest.mark.parametrize("integrator", ["dopri5", "rodasp", "rodas5p", "RK45", "Radau"])
def test_bounce_times_follow_the_closed_form_until_the_ball_comes_to_rest(ball, integrator):
    res = ball.simulate("drop", integrator=integrator)
    times = np.array([e["time"] for e in res.events])
    assert len(times) >= 20
    assert np.max(np.abs(times[:25] - impact_times(25))) < 1e-9
    # chattering at the accumulation point ends the run there, with its message and every result
    assert res.metadata["status"] == "zeno"
    assert "chattering" in res.message and "'impact'" in res.message and "fall.s = " in res.message
    assert abs(times[-1] - T_INF) < 10 * ZENO_WINDOW / (1 - E)
    assert res.t[-1] == times[-1] and res["count"][-1] == len(times)


@pytest.mark.parametrize("integrator", ["BDF", "LSODA"])
def test_multistep_methods_stop_cleanly_where_the_flights_fall_below_their_resolution(ball, integrator):
    """scipy's BDF and LSODA restart at order 1 after each impact: their flights stop being resolved long
    before the Zeno window (an impact then located while the ball rises would send it into the ground).  They
    stop there, as Zeno, with the message and every result; the bounces up to there follow the closed form to
    what a first-order start at rtol 1e-10 resolves (1e-8 s over 20 bounces)."""
    res = ball.simulate("drop", integrator=integrator)
    times = np.array([e["time"] for e in res.events])
    assert res.metadata["status"] == "zeno", res.message
    assert "chattering" in res.message and "'impact'" in res.message and "against the motion" in res.message
    assert len(times) >= 20 and np.max(np.abs(times[:20] - impact_times(20))) < 1e-8
    assert T_INF - 1e-4 < res.t[-1] < T_INF  # at the accumulation point, with the results up to it
    assert res["count"][-1] == len(times) and abs(res["height"][-1]) < 1e-12


def test_both_sides_of_an_impact_are_rows_and_the_log_says_what_changed(ball):
    res = ball.simulate("drop")
    first = res.events[0]
    assert first["event"] == "impact" and first["direction"] == "falling"
    rows = np.flatnonzero(res.t == first["time"])
    assert len(rows) == 2
    before, after = res["der(fall.s)"][rows]
    assert before == pytest.approx(-G * T1, rel=1e-10) and after == pytest.approx(-E * before, rel=1e-14)
    assert res["count"][rows[0]] == 0 and res["count"][rows[1]] == 1  # outputs see the mode in force
    assert first["changes"].startswith("der(fall.s): -4.42945 -> 3.54356; bounces: 0 -> 1")
    assert np.all(np.diff(res.t) >= 0)


def test_the_numpy_back_end_finds_the_same_impacts():
    res = mbs.load(BALL, backend="numpy").simulate("drop", t_end=3.0, integrator="RK45")
    times = np.array([e["time"] for e in res.events])
    assert res.success and len(times) == 6  # the 7th impact comes at 3.117 s
    assert np.max(np.abs(times - impact_times(6))) < 1e-9


def test_a_terminal_event_ends_the_run_there(tmp_path):
    text = BALL.read_text().replace('    output height = fall.s', '    event stop when t > 1.2 s { terminate }\n'
                                    '    output height = fall.s')
    res = mbs.loads(text).simulate("drop")
    assert res.success and res.message.startswith("terminated by event 'stop' at t = 1.2 s")
    assert res.t[-1] == 1.2 and [e["event"] for e in res.events] == ["impact", "impact", "stop"]


def test_simulate_writes_the_event_log_beside_the_samples(tmp_path, monkeypatch):
    from mbs.cli import main
    out = tmp_path / "run.csv"
    status = main(["simulate", str(BALL), "--t-end", "2", "--out", str(out)])
    assert status == 0
    lines = (tmp_path / "run.events.csv").read_text().splitlines()
    assert lines[0] == "time,event,direction,changes"
    assert len(lines) == 1 + 3 and lines[1].split(",")[1:3] == ["impact", "falling"]
    assert float(lines[1].split(",")[0]) == pytest.approx(T1, abs=1e-12)


# ------------------------------------------------------------------------------------------ switches
@pytest.fixture(scope="module")
def arm():
    return mbs.load(ARM)


@pytest.mark.parametrize("integrator", ["dopri5", "rodasp", "rodas5p", "BDF", "LSODA"])
def test_a_stepped_set_point_is_a_time_event_every_integrator_passes(arm, integrator):
    res = arm.simulate(t_end=1.0, sample=0.01, integrator=integrator)
    assert res.success, res.message
    assert res.events[0]["time"] == 0.5 and res.events[0]["direction"] == "rising"
    step = np.flatnonzero(res.t == 0.5)
    assert len(step) == 2  # the set point jumps between the two rows: the state does not
    np.testing.assert_array_equal(res.data[step[0]], res.data[step[1]])
    # the motor holds -45 deg against gravity (sag of about 1e-6 rad at kp = 5e6 N m/rad)
    assert abs(res["shoulder.phi"][-1] + math.pi / 4) < 1e-5


def test_without_switches_the_stiff_integrator_collapses_at_the_step():
    """`switches = false`, the documented opt-out: the comparison evaluated as written inside every step."""
    text = ARM.read_text().replace("    gravity =", "    switches = false\n    gravity =")
    system = mbs.loads(text)
    assert system.compile().events == ()
    res = system.simulate(t_end=1.0, sample=0.01, integrator="rodasp")
    assert not res.success and "t = 0.5 s" in res.message and "collapsed" in res.message


def test_switches_keep_direct_evaluation_live(arm):
    """Outside a run the comparison is evaluated as written (equilibrium, linearisation, direct calls)."""
    compiled = arm.compile()
    data = arm._workspace(compiled, arm.generate(), {p.name: p.value for p in arm.model.parameters})
    x = np.zeros(compiled.nx)
    before, after = data.rhs(0.4, x), data.rhs(0.6, x)
    assert after[compiled.nq] < before[compiled.nq] - 1e5  # the motor pulls towards -45 deg after the step


def test_an_event_changes_a_parameter_and_actions_read_the_values_before_it():
    text = BALL.read_text().replace("set bounces = bounces + 1", "set bounces = bounces + 1\n        set e = 0.5")
    res = mbs.loads(text).simulate("drop", t_end=3.0)
    times = np.array([e["time"] for e in res.events])
    # the first impact still rebounds with e = 0.8 (pre-value), every later one with 0.5
    expected = T1 + np.cumsum([0.0, 2 * T1 * E, 2 * T1 * E * 0.5, 2 * T1 * E * 0.25])
    np.testing.assert_allclose(times[:4], expected, atol=1e-9)
    assert "e: 0.8 -> 0.5" in res.events[0]["changes"]


def test_switch_events_name_the_element_they_come_from(arm):
    res = arm.simulate(t_end=0.6, sample=0.01)
    assert res.events[0]["event"] == "switch.1 (> in shoulder.motor)"


def test_the_event_log_survives_npz(ball, tmp_path):
    from mbs.runtime.results import Results
    res = ball.simulate("drop", t_end=1.5)
    back = Results.from_npz(res.to_npz(tmp_path / "run.npz"))
    assert back.events == res.events and len(back.events) == 2


def test_events_of_component_instances_are_named_per_instance_and_fire_together():
    res = mbs.load(Path(__file__).parent / "models" / "two_droppers.mbs", "two").simulate(t_end=1.5, sample=0.01)
    first = res.events[:2]
    assert [e["event"] for e in first] == ["a.impact", "b.impact"] and first[0]["time"] == first[1]["time"]
    assert first[0]["time"] == pytest.approx(T1, abs=1e-12)
    assert res.metadata["status"] == "zeno" and "'b.impact'" in res.message
    assert res.t[-1] == pytest.approx(3 * T1, abs=1e-8)  # b's accumulation point, t1 (1 + e) / (1 - e), e = 0.5


def _textbook_init_switches(model, data, t, x):
    """init_switches as it was written, one switch at a time (the reference of the table-driven one)."""
    switches = [(k, s) for k, s in enumerate(model.events) if s.switch >= 0]
    if not switches:
        return -1
    frozen = model.p_names.index("switch.frozen")
    data.p[frozen] = 0.0
    g = data.function("events")(t, x)
    for k, s in switches:
        data.p[s.switch] = 1.0 if (g[k] > 0 or (s.inclusive and g[k] == 0)) else 0.0
    data.p[frozen] = 1.0
    return frozen


@pytest.mark.parametrize("shared", [False, True])
def test_init_switches_reads_and_writes_the_flags_as_the_textbook_loop(shared):
    """Every branch of the comparison (above, at zero inclusive or not, below, NaN), other events between the
    switches, and two switches on one flag (the later one wins): the same flags and frozen index as one switch at a
    time, the indicators evaluated with the flags unfrozen."""
    from types import SimpleNamespace

    from mbs.runtime.events import init_switches

    def spec(switch, inclusive=False):
        return SimpleNamespace(switch=switch, inclusive=inclusive)

    g_values = np.array([1.0, 0.0, 0.0, -2.0, np.nan, 3.0, 0.0, -1.0])
    events = [spec(1), spec(2, True), spec(3), spec(-1), spec(4, True), spec(-1), spec(5, True),
              spec(5 if shared else 6)]
    p_names = ("a", "f1", "f2", "f3", "f4", "f5", "f6", "switch.frozen")

    def run(init):
        seen = []
        model = SimpleNamespace(events=events, p_names=p_names)
        data = SimpleNamespace(p=np.full(len(p_names), 0.5))

        def indicators(t, x):
            seen.append(data.p[-1])  # the frozen flag while the indicators are evaluated
            return g_values.copy()
        data.function = lambda name: indicators
        return init(model, data, 0.0, np.zeros(2)), data.p, seen

    frozen, p, seen = run(init_switches)
    frozen_ref, p_ref, seen_ref = run(_textbook_init_switches)
    assert frozen == frozen_ref == 7 and seen == seen_ref == [0.0]
    assert p.tolist() == p_ref.tolist()
    assert p.tolist()[:7] == [0.5, 1.0, 1.0, 0.0, 0.0, 0.0 if shared else 1.0, 0.5 if shared else 0.0]
