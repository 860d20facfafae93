"""`mbs sweep`: values with units, a Latin hypercube, an existing cluster by address, the table as CSV and HDF5."""

from __future__ import annotations

import numpy as np
import pytest

from mbs.cli import main

pytest.importorskip("distributed")


def test_sweep_on_an_existing_cluster_writes_csv_hdf5_and_plot(dask_client, tmp_path, capsys):
    h5py = pytest.importorskip("h5py")
    csv, h5, png = tmp_path / "t.csv", tmp_path / "t.h5", tmp_path / "t.png"
    status = main(["sweep", "library/examples/pendulum.mbs", "--scene", "swing", "--param", "l=50cm,1m,2m",
                   "--param", "m=2kg", "--metric", "period(hinge.phi)", "--scheduler", dask_client.scheduler.address,
                   "--out", str(csv), "--out", str(h5), "--plot", str(png), "--sample", "0.001"])
    assert status == 0, capsys.readouterr().err
    lines = [line for line in csv.read_text().splitlines() if not line.startswith("#")]
    assert lines[0] == "l,period(hinge.phi),status,message"
    assert [float(line.split(",")[0]) for line in lines[1:]] == [0.5, 1.0, 2.0]
    with h5py.File(h5) as f:
        periods = f["metrics/period(hinge.phi)"][()]
        assert f["parameters/l"].attrs["unit"] == "m" and f["metrics/period(hinge.phi)"].attrs["unit"] == "s"
        assert list(f["status"].asstr()[()]) == ["finished"] * 3
    csv_periods = [float(line.split(",")[1]) for line in lines[1:]]
    np.testing.assert_array_equal(periods, csv_periods)
    assert periods[2] / periods[0] == pytest.approx(2.0, rel=1e-5)  # T ~ sqrt(l): same amplitude, same K
    assert png.stat().st_size > 0


def test_latin_hypercube_covers_each_stratum_once(dask_client, tmp_path, capsys):
    csv = tmp_path / "lhs.csv"
    status = main(["sweep", "library/examples/pendulum.mbs", "--param", "l=1,2", "--design", "lhs", "4",
                   "--metric", "final(hinge.phi)", "--t-end", "0.1", "--scheduler", dask_client.scheduler.address,
                   "--out", str(csv)])
    assert status == 0, capsys.readouterr().err
    rows = [line.split(",") for line in csv.read_text().splitlines() if not line.startswith("#")][1:]
    lengths = sorted(float(r[0]) for r in rows)
    assert [int((l - 1.0) / 0.25) for l in lengths] == [0, 1, 2, 3]


@pytest.mark.parametrize("args, message", [
    (["--param", "l=1,x"], "expected a number with an optional unit"),
    (["--param", "l=1s,2s"], "expected length"),
    (["--param", "l=1,2", "--design", "lhs"], "expected 'grid' or 'lhs N'"),
    (["--param", "l=1,2", "--metric", "peak(nothing)"], "no output or coordinate 'nothing'"),
    (["--param", "l=1,2", "--out", "t.xlsx"], "written as .csv or .h5"),
    (["--param", "q=1,2"], "no parameter 'q'"),
])
def test_bad_sweep_arguments_are_errors_before_any_run(args, message, capsys):
    assert main(["sweep", "library/examples/pendulum.mbs", *args]) == 1
    assert message in capsys.readouterr().err
