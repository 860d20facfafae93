"""Events applied and restarted inside the C sampling loop (c/ode.c, mbs_ode_restart) give the run the Python
loop gives: the same events in the same order at the same times, the same samples to the tolerance, the same
rows at both sides of each event.  The Python loop (runtime/event_loop.py) is the reference: it restarts a new
integrator after every event, which C replaces by a restart of the same one.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import mbs
from mbs.runtime import event_loop

STICK_SLIP = Path(__file__).resolve().parents[2] / "library" / "examples" / "stick_slip.mbs"


@pytest.fixture(scope="module")
def stick_slip():
    return mbs.load(STICK_SLIP)


def run_in_python(system, monkeypatch, **kwargs):
    with monkeypatch.context() as patch:
        patch.setattr(event_loop, "c_restart_tables", lambda model: None)
        return system.simulate(**kwargs)


@pytest.mark.parametrize("integrator", ["dopri5", "rodasp", "rodas5p"])
def test_events_restarted_in_c_match_the_python_loop(stick_slip, monkeypatch, integrator):
    handled = []
    replay = event_loop.replay
    monkeypatch.setattr(event_loop, "replay", lambda model, data, log, *rest: (handled.append(len(log)),
                                                                              replay(model, data, log, *rest))[1])
    in_c = stick_slip.simulate("cycles", integrator=integrator)
    assert sum(handled) > 5  # the slip events (a mode set by generated C) never went back to Python
    in_python = run_in_python(stick_slip, monkeypatch, scene="cycles", integrator=integrator)
    assert in_c.success and in_python.success
    assert [(e["event"], e["direction"], e["changes"]) for e in in_c.events] == \
        [(e["event"], e["direction"], e["changes"]) for e in in_python.events]
    times_c = np.array([e["time"] for e in in_c.events])
    times_py = np.array([e["time"] for e in in_python.events])
    assert np.max(np.abs(times_c - times_py)) < 1e-6  # restarts differ only in the step-size memory
    assert np.array_equal(np.diff(in_c.t) == 0, np.diff(in_python.t) == 0)  # two rows at each event
    for name in in_c.names:
        scale = 1e-6 * max(1.0, np.max(np.abs(in_python[name])))
        assert np.max(np.abs(in_c[name] - in_python[name])) < scale, name


def test_twin_contacts_4e_10_s_apart_are_both_restarted_in_c_at_their_free_fall_times(monkeypatch):
    """The chattering window (1e-9 s) is per indicator: another indicator firing within it (the left and right
    wheel of a symmetric car, here two drops 1.8 nm apart) is restarted in C, not handed to the Python loop
    (which restarts a whole new integrator); each contact closes at its free-fall time sqrt(2 h / g)."""
    system = mbs.load(Path(__file__).parent / "models" / "twin_drops.mbs")
    in_python = []
    apply_events = event_loop.apply_events
    monkeypatch.setattr(event_loop, "apply_events", lambda *a, **k: in_python.append(a) or apply_events(*a, **k))
    res = system.simulate("drops")
    assert res.success, res.message
    assert in_python == []
    h, dh, g = 1.0, 1.8e-9, 9.81
    first = [e["time"] for e in res.events[:2]]
    assert [e["event"].split(" ")[-1] for e in res.events[:2]] == ["drop_left.contact)", "drop_right.contact)"]
    assert first[1] - first[0] < 1e-9
    assert first == pytest.approx([np.sqrt(2 * h / g), np.sqrt(2 * (h + dh) / g)], abs=1e-12)


@pytest.mark.parametrize("apart", [1e-14, 1e-13])
def test_twin_contacts_closer_than_the_departure_step_are_one_event_with_both_in_it(monkeypatch, apart):
    """Mirror-image wheels of a symmetric car over one bump cross 1e-14 s apart by the round-off of their states:
    the two contacts are one event (both booked, neither handed to Python), within 1e-12 s (the departure step)
    of each one's free-fall time sqrt(2 h / g). Stopped at the first alone, the second was taken over silently
    at the restart: no event booked, and its branch missing from the rows' values (the Iltis' outputs showed a
    tyre pulling with 436 N)."""
    system = mbs.load(Path(__file__).parent / "models" / "twin_drops.mbs")
    h, g = 1.0, 9.81
    dh = apart * np.sqrt(2 * g * h)  # the right mass this much higher closes its contact `apart` later
    in_python = []
    apply_events = event_loop.apply_events
    monkeypatch.setattr(event_loop, "apply_events", lambda *a, **k: in_python.append(a) or apply_events(*a, **k))
    res = system.simulate("drops", params={"dh": dh})
    assert res.success, res.message
    assert in_python == []
    closing = [e for e in res.events if e["direction"] == "rising"][:2]
    assert sorted(e["event"].split(" ")[-1] for e in closing) == ["drop_left.contact)", "drop_right.contact)"]
    assert closing[0]["time"] == closing[1]["time"]
    for e, drop in zip(closing, (h, h + dh)):
        assert e["time"] == pytest.approx(np.sqrt(2 * drop / g), abs=1e-12)
    assert len(res.events) == 4  # and both open again together


@pytest.mark.parametrize("integrator", ["Radau", "RK45"])
def test_twin_contacts_closer_than_the_departure_step_are_one_event_in_the_python_loop(integrator):
    """The same twins with scipy's integrators, whose events the Python loop locates and restarts
    (runtime/event_loop.py): the later contact is booked with the first, not taken over by the restart's
    look-ahead without an event (the Iltis' contact log with Radau, BDF, cvode_bdf and ida missed a wheel)."""
    system = mbs.load(Path(__file__).parent / "models" / "twin_drops.mbs")
    h, g, apart = 1.0, 9.81, 1e-14
    dh = apart * np.sqrt(2 * g * h)
    res = system.simulate("drops", params={"dh": dh}, integrator=integrator)
    assert res.success, res.message
    closing = [e for e in res.events if e["direction"] == "rising"][:2]
    assert sorted(e["event"].split(" ")[-1] for e in closing) == ["drop_left.contact)", "drop_right.contact)"]
    assert closing[0]["time"] == closing[1]["time"]
    assert closing[0]["time"] == pytest.approx(np.sqrt(2 * h / g), abs=1e-6)  # scipy's event location, rtol 1e-10


@pytest.mark.parametrize("flags", [(0, 2, 1), (1, 2, 3), (0, 2, 0)],
                         ids=["a flag each", "flags side by side in p", "two switches share a flag"])
def test_a_log_of_switch_flips_is_booked_at_once_as_entry_by_entry(flags):
    """replay's numpy path for logs whose events only flip branches (event_loop._book_branches: filled forward per
    switch, or per flag where two switches share one) against its entry-by-entry loop (_book_each, which applies
    any action) on a log of random crossings of three switches: the same records in the same order, the same
    values in force after every entry, the same twins."""
    from types import SimpleNamespace

    from mbs.runtime.events import EventSpec
    rng = np.random.default_rng(7)
    specs = (EventSpec("a", 0, switch=flags[0], continuous=True), EventSpec("b", 1, switch=flags[1]),
             EventSpec("c", -1, switch=flags[2], continuous=True))
    model = SimpleNamespace(events=specs, nx=1)
    m, nev = 60, len(specs)
    g_old = rng.choice([-1.0, 1.0], size=(m, nev))
    g_event = np.where(rng.random((m, nev)) < 0.4, -0.5 * g_old, g_old)  # about 40 % of them cross
    log = np.column_stack([np.sort(rng.random(m)), rng.random((m, 2)), g_old, g_event])
    fired = event_loop.crossing_rows(g_old, g_event, np.array([s.direction for s in specs]))
    assert fired.sum() > 20 and np.any(fired.sum(axis=1) > 1) and not np.all(fired.any(axis=1))
    start = np.array([0.0, 1.0, 1.0, 7.5])
    assert (event_loop.event_tables(model).switch_span is not None) == (flags == (1, 2, 3))
    booked = []
    for book in (lambda p, r, f: event_loop._book_each(model, None, log, fired, p, r, f),
                 lambda p, r, f: event_loop._book_branches(model, fired, g_old, g_event, log[:, 0], p, r, f)):
        p, records, fired_times = start.copy(), event_loop.EventLog(), []
        copies, twin = book(p, records, fired_times)
        booked.append((copies, twin, p, records.rows(), fired_times))
    for each, at_once in zip(*booked):
        if isinstance(each, np.ndarray):
            assert np.array_equal(each, at_once)
        else:
            assert each == at_once


def test_one_pair_s_crossings_are_those_of_the_rows_mask():
    """events.crossings (plain Python over a model's indicators) against events.crossing_rows (numpy) on random
    indicator pairs with zeros of both signs, NaN and infinities in every direction."""
    from mbs.runtime.events import crossing_rows, crossings
    rng = np.random.default_rng(3)
    values = np.array([-2.0, -0.0, 0.0, 1.5, np.nan, np.inf, -np.inf, 1e-300])
    for _ in range(500):
        g_old, g_new = rng.choice(values, 30), rng.choice(values, 30)
        directions = rng.choice([-1, 0, 1], 30).astype(np.intc)
        expected = np.flatnonzero(crossing_rows(g_old, g_new, directions))
        found = crossings(g_old, g_new, directions)
        assert found.dtype == expected.dtype and np.array_equal(found, expected)


def test_the_tables_crossings_are_those_of_the_rows_mask():
    """EventTables.crossings (the directions' masks made once per model) against events.crossing_rows on rows of
    random indicators with zeros of both signs, NaN and infinities, in every direction."""
    from types import SimpleNamespace

    from mbs.runtime.events import EventSpec
    rng = np.random.default_rng(5)
    values = np.array([-2.0, -0.0, 0.0, 1.5, np.nan, np.inf, -np.inf, 1e-300])
    directions = rng.choice([-1, 0, 1], 30)
    model = SimpleNamespace(events=tuple(EventSpec(f"e{k}", int(d)) for k, d in enumerate(directions)))
    tables = event_loop.EventTables.of(model)
    g_old, g_new = rng.choice(values, (200, 30)), rng.choice(values, (200, 30))
    assert np.array_equal(tables.crossings(g_old, g_new), event_loop.crossing_rows(g_old, g_new, directions))


def test_the_event_log_s_rows_are_those_of_its_records_in_the_order_booked():
    """event_loop.EventLog keeps the entries replay books at once as columns (no EventRecord each): its rows and
    event names are those of the records the Python loop makes for the same entries, in the order booked, blocks of
    records and of columns interleaved."""
    from mbs.runtime.events import EventRecord
    first = [EventRecord(0.25, "start", "start", "mode 0 -> 1")]
    columns = ([0.5, 1.0], ["a", "b"], ["rising", "falling"], ["branch 0 -> 1", ""])
    last = [EventRecord(1.5, "c", "either", ""), EventRecord(2.0, "a", "falling", "branch 1 -> 0")]
    log = event_loop.EventLog(first)
    log.add_columns(*columns)
    log.add_columns([], [], [], [])
    log += last[:1]
    log.append(last[1])
    records = first + [EventRecord(*entry) for entry in zip(*columns)] + last
    assert len(log) == len(records) == 5
    assert log.rows() == [r.as_row() for r in records]
    assert [list(row) for row in log.rows()] == [list(r.as_row()) for r in records]  # the keys in the same order
    assert log.events() == [r.event for r in records]
    assert event_loop.event_rows(log) == event_loop.event_rows(records)


@pytest.mark.parametrize("on_samples", [False, True], ids=["every event its row after", "events on sample times"])
def test_a_long_log_s_rows_placed_at_once_are_those_placed_piece_by_piece(monkeypatch, on_samples):
    """replay's rows of a log of BOOK_AT_ONCE entries or more, placed as one block (event_loop._place_rows: index
    arithmetic, the log's columns taken as they are where every event has its row after it), against the pieces
    the short logs append one by one: the same times, states, p copies and twins in the joined arrays.  An event on a
    sample's time has no row after it (that sample, filled after the restart, is)."""
    rng = np.random.default_rng(13)
    nx, times = 2, np.arange(10) / 10  # (k / 10: the doubles nearest to 0.1, 0.3 as the event times below)
    states = rng.random((times.size, nx))
    t_event = np.array([0.05, 0.1, 0.15, 0.22, 0.3, 0.41, 0.55, 0.63, 0.77]) if on_samples else \
        np.array([0.05, 0.12, 0.15, 0.22, 0.33, 0.41, 0.55, 0.63, 0.77])
    m = t_event.size
    assert m >= event_loop.BOOK_AT_ONCE
    log = np.column_stack([t_event, rng.random((m, 2 * nx))])
    twin = rng.random(m) < 0.5
    joined = []
    for at_once in (True, False):
        monkeypatch.setattr(event_loop, "BOOK_AT_ONCE", event_loop.BOOK_AT_ONCE if at_once else m + 1)
        segments = event_loop.Segments()
        segments.add_values(np.zeros((m + 1, 3)))
        row = event_loop._place_rows(log, times, states, 1, segments, t_event, twin, 0, 1, nx, m)
        joined.append((row, *segments.arrays(nx)))
    assert joined[0][0] == joined[1][0]
    for placed, pieces in zip(joined[0][1:], joined[1][1:]):
        assert placed.dtype == pieces.dtype and np.array_equal(placed, pieces)
    # the samples from row 1 up to the last event, and two rows per event but the two on samples (0.1 s, 0.3 s)
    assert joined[0][1].size == (joined[0][0] - 1) + 2 * m - (2 if on_samples else 0)
