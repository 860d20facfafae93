"""`mbs accuracy`, `mbs numerics` and `mbs simulate --error-estimate` on the shipped pendulum."""

import csv

import numpy as np

import mbs
from mbs.cli import main


def test_accuracy_writes_table_csv_and_plot(tmp_path, capsys):
    out, plot = tmp_path / "wp.csv", tmp_path / "wp.png"
    assert main(["accuracy", "library/examples/pendulum.mbs", "--integrators", "dopri5,cvode_bdf", "--tolerances",
                 "1e-4..1e-6", "--repeats", "1", "--t-end", "2", "--out", str(out), "--plot", str(plot)]) == 0
    text = capsys.readouterr().out
    assert "reference: dopri5 at rtol 1e-09, confirmed by DOP853" in text
    rows = list(csv.DictReader(out.open()))
    assert {"integrator", "rtol", "error", "wall_time"} <= set(rows[0])
    assert [(r["integrator"], float(r["rtol"])) for r in rows] == [
        ("dopri5", 1e-4), ("dopri5", 1e-5), ("dopri5", 1e-6), ("cvode_bdf", 1e-4), ("cvode_bdf", 1e-5),
        ("cvode_bdf", 1e-6)]
    assert plot.stat().st_size > 0


def test_numerics_names_the_recommendation(capsys):
    assert main(["numerics", "tests/runtime/models/stiff_mount.mbs"]) == 0
    text = capsys.readouterr().out
    assert "recommended: integrator = rodas5p" in text and "mostly mount_guide.s" in text


def test_error_estimate_is_close_to_the_true_error(tmp_path, capsys):
    out = tmp_path / "run.csv"
    args = ["simulate", "library/examples/pendulum.mbs", "--t-end", "3", "--rtol", "1e-5", "--atol", "1e-7"]
    assert main([*args, "--error-estimate", "--out", str(out)]) == 0
    assert "estimated global error" in capsys.readouterr().out
    from mbs.runtime.results import Results as R
    res = R.from_csv(out)
    estimate = res.metadata["error_estimate"]["hinge.phi"]
    exact = mbs.load("library/examples/pendulum.mbs").simulate("swing", t_end=3, t_eval=res.t, rtol=1e-12,
                                                               atol=1e-14)
    true_error = np.max(np.abs(res["hinge.phi"] - exact["hinge.phi"]))
    assert true_error / 3 < estimate < true_error * 3
