"""Results as HDF5: an exact round trip of the table, units and descriptions on the datasets, scene settings and
the event log as attributes; a pandas DataFrame indexed by time."""

from __future__ import annotations

import numpy as np
import pytest

from mbs.cli import main
from mbs.runtime.results import Results

h5py = pytest.importorskip("h5py")


def sample_results() -> Results:
    t = np.linspace(0.0, 1.0, 11)
    meta = {"model": "m", "integrator": "dopri5", "rtol": 1e-8, "status": "finished", "message": "",
            "stats": {"nfev": 12}, "units": {"hinge.phi": "rad", "l": "m"},
            "events": [{"t": 0.5, "name": "contact", "mode": "stick"}]}
    return Results(["time", "hinge.phi", "der(hinge.phi)", "a/b"], np.column_stack([t, np.sin(t), np.cos(t), t * t]),
                   meta)


def test_round_trip_is_exact_and_keeps_metadata_and_events(tmp_path):
    res = sample_results()
    back = Results.from_hdf5(res.to_hdf5(tmp_path / "r.h5"))
    assert back.names == res.names
    np.testing.assert_array_equal(back.data, res.data)
    assert back.metadata["stats"] == {"nfev": 12} and back.metadata["rtol"] == 1e-8
    assert back.metadata["units"]["hinge.phi"] == "rad" and back.metadata["units"]["l"] == "m"
    assert back.metadata["events"] == res.metadata["events"]
    with h5py.File(tmp_path / "r.h5") as f:
        assert f["columns/hinge.phi"].attrs["unit"] == "rad" and f["columns/time"].attrs["unit"] == "s"
        assert f.attrs["integrator"] == "dopri5"


def test_simulate_writes_hdf5_with_scene_and_descriptions(tmp_path, capsys):
    out = tmp_path / "swing.h5"
    assert main(["simulate", "library/examples/pendulum.mbs", "--scene", "swing", "--out", str(out),
                 "--param", "l=2m"]) == 0, capsys.readouterr().err
    with h5py.File(out) as f:
        assert f.attrs["scene"] == "swing" and f.attrs["scene_description"] == "ten seconds of swinging"
        assert f.attrs["t_end"] == 10.0 and f.attrs["integrator"] == "dopri5"
        assert f["columns/hinge.phi"].attrs["unit"] == "rad"
        phi = f["columns/hinge.phi"][()]
    res = Results.from_hdf5(out)
    assert res.metadata["parameters"]["l"]["description"] == "rod length"
    np.testing.assert_array_equal(res["hinge.phi"], phi)


def test_not_a_results_file_is_an_error(tmp_path):
    with h5py.File(tmp_path / "other.h5", "w") as f:
        f["x"] = [1.0]
    from mbs import MbsError
    with pytest.raises(MbsError, match="not an mbs results file"):
        Results.from_hdf5(tmp_path / "other.h5")


def test_to_pandas_is_indexed_by_time():
    pd = pytest.importorskip("pandas")
    res = sample_results()
    frame = res.to_pandas()
    assert isinstance(frame, pd.DataFrame) and frame.index.name == "time"
    assert list(frame.columns) == ["hinge.phi", "der(hinge.phi)", "a/b"]
    np.testing.assert_array_equal(frame["hinge.phi"].to_numpy(), res["hinge.phi"])
