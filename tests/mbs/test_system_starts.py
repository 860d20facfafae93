"""The start states a System keeps (mbs/system.py System._kept_start): a scene started again with the same model,
parameters and initial state begins where the last start did, without closing its loops and solving its static
equilibrium again, and the run from it is the run from a fresh start to the bit."""

from pathlib import Path

import numpy as np
import pytest

import mbs
import mbs.system

#: A slider-crank held by a spring (no gravity): one degree of freedom in a closed loop, at rest where the spring is
#: unstretched, the slider at x = l0 from the crank pivot.
MODEL = Path(__file__).resolve().parents[1] / "runtime" / "models" / "slider_crank_spring.mbs"
SCENES = """
scene rest {
    start = equilibrium
    t_end = 0.05 s
    sample = 0.01 s
    output slider_x = guide.s
}
"""


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    """The same bytes: the loop solver's work memory holds ints in the room of doubles too (c/loops.c, its plan),
    whose pairs may read as a NaN, which no float comparison finds equal to itself."""
    return a.shape == b.shape and a.tobytes() == b.tobytes()


@pytest.fixture(scope="module")
def text() -> str:
    return MODEL.read_text() + SCENES


@pytest.fixture()
def solves(monkeypatch):
    """The static equilibria solved (their count), through mbs.system.static_equilibrium."""
    calls = []
    real = mbs.system.static_equilibrium

    def counted(*args, **kwargs):
        calls.append(args)
        return real(*args, **kwargs)
    monkeypatch.setattr(mbs.system, "static_equilibrium", counted)
    return calls


def test_a_scene_run_again_starts_from_the_kept_state_and_runs_the_same_to_the_bit(text, solves):
    system = mbs.loads(text)
    first = system.simulate("rest")
    again = system.simulate("rest")
    assert len(solves) == 1  # the second run found the first start's state
    fresh = mbs.loads(text).simulate("rest")  # a System of its own: assembles and solves afresh
    assert len(solves) == 2
    assert np.array_equal(again.data, first.data)
    assert np.array_equal(again.data, fresh.data)
    # the rest is the spring's free length (the model's own statics: no force on the slider)
    assert first["slider_x"][0] == pytest.approx(0.45, abs=1e-9)


def test_the_kept_start_gives_the_state_and_the_loop_solver_memory_of_a_fresh_one(text):
    system = mbs.loads(text)
    system.start("rest")
    kept, _ = system.start("rest")
    fresh, _ = mbs.loads(text).start("rest")
    assert np.array_equal(kept.x, fresh.x)
    assert np.array_equal(kept.p, fresh.p)
    assert same_bits(kept.work, fresh.work)  # the kept partition goes with the state
    kept.x[0] += 1.0  # the workspace is the caller's: changing it changes nothing kept
    kept.work[:] = 0.0  # (its work memory a copy too: runtime/workspace.py Workspace._resumed)
    again = system.start("rest")[0]
    assert np.array_equal(again.x, fresh.x) and same_bits(again.work, fresh.work)


def test_other_parameters_start_afresh_and_each_is_kept(text, solves):
    system = mbs.loads(text)
    near = system.simulate("rest", params={"l0": "0.42 m"})
    assert near["slider_x"][0] == pytest.approx(0.42, abs=1e-9)
    assert system.simulate("rest")["slider_x"][0] == pytest.approx(0.45, abs=1e-9)
    assert len(solves) == 2
    system.simulate("rest", params={"l0": "0.42 m"})
    system.simulate("rest")
    assert len(solves) == 2


def test_a_sweep_keeps_no_more_than_its_bound(text, solves):
    system = mbs.loads(text)
    values = [0.40 + 0.005 * i for i in range(mbs.system.KEPT_STARTS + 3)]
    for value in values:
        system.start("rest", params={"l0": f"{value} m"})
    assert len(system._starts) == mbs.system.KEPT_STARTS
    system.start("rest", params={"l0": f"{values[-1]} m"})  # the most recent ones are kept
    assert len(solves) == len(values)
    system.start("rest", params={"l0": f"{values[0]} m"})  # the oldest was let go
    assert len(solves) == len(values) + 1


def test_forgotten_starts_are_solved_again(text, solves):
    system = mbs.loads(text)
    system.start("rest")
    system.forget_starts()
    system.start("rest")
    assert len(solves) == 2


def test_a_given_initial_state_is_not_kept(text, solves):
    system = mbs.loads(text)
    start, _ = system.start("rest")
    system.start("rest", x0=start.x)
    assert len(system._starts) == 1 and len(solves) == 1


def test_the_start_vectors_are_worked_out_once_per_binding(text, monkeypatch):
    """System._start_vectors: p and the initial state of a parameter binding are kept with it (System._binding), also
    past forget_starts (which lets go of the solved starts only); other parameters work out their own."""
    system = mbs.loads(text)
    made = []
    real = mbs.system.pipeline.initial_state
    monkeypatch.setattr(mbs.system.pipeline, "initial_state", lambda *a: made.append(1) or real(*a))
    first, _ = system.start("rest")  # (its compile evaluates the default initial state too)
    made.clear()
    system.forget_starts()
    again, _ = system.start("rest")
    assert made == []
    assert np.array_equal(again.x, first.x) and np.array_equal(again.p, first.p)
    assert same_bits(again.work, first.work)  # solved afresh, to the bit
    other, _ = system.start("rest", params={"l0": "0.42 m"})
    assert len(made) == 1 and not np.array_equal(other.p, first.p)
    fresh, _ = mbs.loads(text).start("rest", params={"l0": "0.42 m"})
    assert np.array_equal(other.x, fresh.x) and np.array_equal(other.p, fresh.p)
