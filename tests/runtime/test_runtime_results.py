"""Results: access by name, CSV/NPZ round trips, atomic files, plots."""

from __future__ import annotations

import numpy as np
import pytest

from mbs.runtime import results as results_module
from mbs.runtime.errors import UsageError
from mbs.runtime.results import Results
from mbs.runtime.simulate import simulate
from mbs.runtime.workspace import Workspace


@pytest.fixture(scope="module")
def res(pendulum):
    return simulate(pendulum, Workspace(pendulum), 2.0, sample=0.01, rtol=1e-9, atol=1e-11)


def test_columns_by_name(res, pendulum):
    assert res.names == ("time", "hinge.phi", "hinge.phi_dot", "angle", "energy")
    np.testing.assert_array_equal(res["angle"], res["hinge.phi"])
    assert res["hinge.phi"][0] == pytest.approx(np.radians(30))
    assert res.t[-1] == 2.0 and len(res) == 201
    assert res.columns(["time", "energy"]).shape == (201, 2)
    with pytest.raises(KeyError, match="no column 'nope'"):
        res["nope"]
    with pytest.raises(ValueError):
        res["angle"][0] = 1.0  # read-only
    meta = res.metadata
    assert (meta["model"], meta["integrator"], meta["rtol"], meta["status"]) == ("pendulum", "dopri5", 1e-9, "finished")


@pytest.mark.parametrize("suffix", ["csv", "npz"])
def test_round_trip_is_exact(res, tmp_path, suffix):
    path = tmp_path / f"run.{suffix}"
    getattr(res, f"to_{suffix}")(path)
    back = getattr(Results, f"from_{suffix}")(path)
    assert back.names == res.names
    np.testing.assert_array_equal(back.data, res.data)  # %.17g is exact for float64
    assert back.metadata == res.metadata
    assert [p.name for p in tmp_path.iterdir()] == [path.name]  # no temporary files left


def test_round_trip_of_a_failed_empty_run(tmp_path):
    empty = Results(["time", "x"], np.empty((0, 2)), {"status": "failed", "message": "integration failed at t = 0 s"})
    for suffix in ("csv", "npz"):
        back = getattr(Results, f"from_{suffix}")(getattr(empty, f"to_{suffix}")(tmp_path / f"e.{suffix}"))
        assert len(back) == 0 and back.names == ("time", "x") and not back.success


def test_npz_name_is_kept_exactly(res, tmp_path):
    path = tmp_path / "run.data"  # np.savez would append .npz to a path
    res.to_npz(path)
    assert path.exists() and Results.from_npz(path).names == res.names


@pytest.mark.parametrize("suffix", ["csv", "npz"])
def test_failed_write_leaves_no_partial_file(res, tmp_path, monkeypatch, suffix):
    path = tmp_path / f"run.{suffix}"
    path.write_text("previous contents")

    def broken(f, *args, **kwargs):
        f.write(b"partial" if "b" in getattr(f, "mode", "b") else "partial")
        raise OSError("disk full (simulated)")

    monkeypatch.setattr(results_module.np, "savetxt" if suffix == "csv" else "savez", broken)
    with pytest.raises(OSError, match="disk full"):
        getattr(res, f"to_{suffix}")(path)
    assert path.read_text() == "previous contents"
    assert [p.name for p in tmp_path.iterdir()] == [path.name]
    monkeypatch.undo()
    new = tmp_path / f"new.{suffix}"
    monkeypatch.setattr(results_module.np, "savetxt" if suffix == "csv" else "savez", broken)
    with pytest.raises(OSError):
        getattr(res, f"to_{suffix}")(new)
    assert not new.exists()


def test_plot_writes_an_image_atomically(res, tmp_path):
    fig = res.plot(["hinge.phi", "energy"], tmp_path / "plot.png")
    path = tmp_path / "plot.png"
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert len(fig.axes) == 2  # two units (or none): two panels
    assert [p.name for p in tmp_path.iterdir()] == ["plot.png"]
    with pytest.raises(KeyError):
        res.plot(["missing"], tmp_path / "bad.png")
    assert not (tmp_path / "bad.png").exists()
    res.plot("angle", tmp_path / "plot.svg", title="swing")
    assert b"<svg" in (tmp_path / "plot.svg").read_bytes()[:500]


def test_bad_tables_are_rejected():
    with pytest.raises(UsageError):
        Results(["time", "a"], np.zeros((3, 3)))
    with pytest.raises(UsageError):
        Results(["time", "a,b"], np.zeros((3, 2)))
    with pytest.raises(UsageError):
        Results(["time", "time"], np.zeros((3, 2)))


def test_results_without_a_copy_keep_the_drivers_table_read_only_and_check_names_as_ever():
    """copy=False (the simulation driver's fresh table) keeps the array itself, made read-only; a user's array is
    copied and left writable; bad names are errors either way (checked once per set of names)."""
    table = np.arange(6.0).reshape(3, 2)
    kept = Results(["time", "x"], table, copy=False)
    assert kept.data is table and not table.flags.writeable
    mine = np.arange(6.0).reshape(3, 2)
    copied = Results(["time", "x"], mine)
    assert copied.data is not mine and mine.flags.writeable
    np.testing.assert_array_equal(kept["x"], copied["x"])
    for names in (["time", "time"], ["time", "a,b"]):
        with pytest.raises(UsageError):
            Results(names, np.zeros((3, 2)), copy=False)


def test_column_names_are_the_str_of_each_name_given_checked_once_per_tuple():
    """Results' names: a tuple of str names as given (worked out once per tuple: results._str_columns), any other
    name its str(); names equal to an earlier tuple's but not str (0.0 == 0) are named as their own str()."""
    from mbs.runtime.results import Results
    assert Results(("time", "x"), [[0.0, 1.0]]).names == ("time", "x")
    assert Results(["time", "x"], [[0.0, 1.0]]).names == ("time", "x")
    assert Results((0, "x"), [[0.0, 1.0]]).names == ("0", "x")
    assert Results((0.0, "x"), [[0.0, 1.0]]).names == ("0.0", "x")
    named = Results((np.str_("time"), "x"), [[0.0, 1.0]])
    assert named.names == ("time", "x") and all(type(n) is str for n in named.names)
    assert named["time"][0] == 0.0
    with pytest.raises(UsageError):
        Results(("time", "time"), [[0.0, 1.0]])


def test_an_event_log_given_as_an_object_is_made_into_its_rows_when_first_read(tmp_path):
    """The simulation driver hands its log (runtime/event_loop.py EventLog) as it is: res.events is its rows, made
    at the first read (once), written to files and pickled as a list, and assignable as before."""
    import pickle

    from mbs.runtime.event_loop import EventLog
    from mbs.runtime.events import EventRecord

    log = EventLog([EventRecord(0.5, "impact", "falling", "ball.v: -1 -> 0.8")])
    log.add_columns([0.75, 1.0], ["switch", "switch"], ["rising", "falling"], ["branch 0 -> 1", ""])
    made = []
    wrapper = type("Watched", (), {"rows": lambda self: made.append(1) or log.rows()})()  # (counts the calls)
    res = Results(["time"], np.zeros((1, 1)), {}, events=wrapper)
    assert not made
    expected = [{"time": 0.5, "event": "impact", "direction": "falling", "changes": "ball.v: -1 -> 0.8"},
                {"time": 0.75, "event": "switch", "direction": "rising", "changes": "branch 0 -> 1"},
                {"time": 1.0, "event": "switch", "direction": "falling", "changes": ""}]
    assert res.events == expected and res.events is res.events and made == [1]
    assert Results(["time"], np.zeros((1, 1)), {}, events=log).events == expected
    assert Results.from_npz(res.to_npz(tmp_path / "r.npz")).events == expected
    assert pickle.loads(pickle.dumps(res)).events == expected
    res.events = expected[:1]
    assert res.events == expected[:1]


def test_results_of_blocks_read_columns_from_their_blocks_and_join_the_table_when_it_is_read():
    """Results.of_blocks (the simulation driver's time, states and outputs) give the same columns, length, table,
    files and pickles as the joined table given to the constructor; the blocks and the table read-only."""
    import pickle
    t, x, y = np.arange(4.0), np.arange(8.0).reshape(4, 2) + 0.5, np.arange(4.0).reshape(4, 1) - 3.0
    names = ("time", "a", "b", "y")
    joined = Results(names, np.hstack([t[:, None], x, y]), {"status": "finished"})
    res = Results.of_blocks(names, (t[:, None], x, y), {"status": "finished"})
    assert len(res) == 4 and res._data is None
    for name in names:
        np.testing.assert_array_equal(res[name], joined[name])
        assert not res[name].flags.writeable
    again = pickle.loads(pickle.dumps(res))
    np.testing.assert_array_equal(again["b"], joined["b"])
    assert res.data is res.data and not res.data.flags.writeable and res._blocks is None
    np.testing.assert_array_equal(res.data, joined.data)
    np.testing.assert_array_equal(again.data, joined.data)
    assert not x.flags.writeable  # (kept without a copy)
    empty = Results.of_blocks(names, (t[:0, None], x[:0], y[:0]))
    assert len(empty) == 0 and empty.data.shape == (0, 4)
    with pytest.raises(UsageError):
        Results.of_blocks(names, (t[:, None], x[:3], y))
    with pytest.raises(UsageError):
        Results.of_blocks(("time", "a"), (t[:, None], x, y))
