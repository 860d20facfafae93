"""The driver's rows of a run with events (runtime/simulate.py): the rows just after an event where nothing jumps
(a continuous switch) are their predecessors' twins, given the predecessor's state and run-time values so that the
rows' one pass copies them (runtime/rows.py: a row that repeats the one before it takes its values) instead of
computing them, here on a closed loop, whose rows are projected in that pass."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import mbs
from mbs.runtime.simulate import _as_predecessors, simulate

#: The slider-crank held by a spring, with a stop on the slider whose force grows from zero past 0.46 m (a kink: a
#: continuous switch); the slider swings between about 0.42 and 0.48 m about the spring's free length 0.45 m.
SPRING_CRANK = Path(__file__).resolve().parent / "models" / "slider_crank_spring.mbs"
STOP = '''        joint prismatic(axis = x)
        force stop = joint(s = -if(guide.s > 0.46 m, 4000 * (guide.s / 1 m - 0.46), 0) * 1 N)
'''
#: How far the slider is past the stop's kink [m].
GAP = "    output gap = guide.s - 0.46 m\n}\n"


def test_each_twin_takes_the_state_and_values_of_the_last_row_before_it_that_is_no_twin():
    xs = np.arange(12.0).reshape(6, 2)
    which = np.array([0, 0, 1, 2, 2, 3])
    twin = np.array([False, False, True, True, False, True])
    _as_predecessors(xs, which, twin)
    assert xs.tolist() == [[0, 1], [2, 3], [2, 3], [2, 3], [8, 9], [8, 9]]
    assert which.tolist() == [0, 0, 0, 0, 2, 2]
    alone = np.arange(4.0).reshape(2, 2)
    _as_predecessors(alone, np.array([0, 1]), np.zeros(2, dtype=bool))  # no twins: nothing changes
    assert alone.tolist() == [[0, 1], [2, 3]]


def test_each_twin_takes_what_a_walk_back_to_its_predecessor_finds():
    """_as_predecessors' index arithmetic over all rows against a plain walk back from each twin to the last row
    before it that is no twin: the same states and values for random masks, with runs of twins."""
    rng = np.random.default_rng(11)
    for trial in range(300):
        rows = int(rng.integers(1, 40))
        twin = rng.random(rows) < rng.choice([0.05, 0.2, 0.5])
        twin[0] = False  # (as in a run: its first row is a sample or the row before an event)
        xs, which = rng.random((rows, 3)), rng.integers(0, 5, rows).astype(np.intp)
        expected_x, expected_w = xs.copy(), which.copy()
        for row in np.flatnonzero(twin):
            of = row - 1
            while twin[of]:
                of -= 1
            expected_x[row], expected_w[row] = xs[of], which[of]
        _as_predecessors(xs, which, twin)
        assert np.array_equal(xs, expected_x) and np.array_equal(which, expected_w), trial


def test_the_rows_at_a_continuous_event_of_a_closed_loop_are_computed_once():
    text = SPRING_CRANK.read_text()
    guide = text.index("joint prismatic(axis = x)")
    text = text[:guide - 8] + STOP + text[text.index("    }", guide):]
    system = mbs.loads(text[:text.rindex("}")] + GAP)
    compiled = system.compile()
    assert "project" in compiled.functions and all(e.continuous for e in compiled.events)
    data, _ = system.start()
    outputs = data.function("outputs")
    res = simulate(compiled, data, 0.5, sample=0.01)
    assert res.success, res.message
    times = [e["time"] for e in res.events]
    assert len(times) >= 2  # the stop is reached and left
    pairs = [np.flatnonzero(res.t == t) for t in times]
    assert all(len(rows) == 2 for rows in pairs)  # a row before and after each event (none on a sample time)
    for before, after in pairs:
        assert np.array_equal(res.data[before], res.data[after])
        assert abs(res["gap"][before]) < 1e-9  # the row is at the kink (the sensor reads its distance)
    assert outputs.calls == len(res.t) - len(pairs)  # each twin copied, every other row computed once


def test_each_run_s_results_carry_a_fresh_dict_of_the_model_s_units_in_its_order():
    """The units in the results' metadata (a copy of a dict made once per model, runtime/simulate.py units_of): the
    model's units in their order, a dict of the run's own that a caller may change without touching the next run's."""
    system = mbs.load(str(SPRING_CRANK))
    first, second = system.simulate(t_end=0.05), system.simulate(t_end=0.05)
    units = system.compile().units
    assert type(first.metadata["units"]) is dict and list(first.metadata["units"].items()) == list(units.items())
    first.metadata["units"]["guide.s"] = "furlong"
    assert second.metadata["units"]["guide.s"] == units["guide.s"] == "m"
    assert system.simulate(t_end=0.05).unit("guide.s") == "m"
