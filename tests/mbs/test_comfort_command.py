"""`mbs comfort`: a results file with a seat acceleration and a tyre load, assessed as ISO 2631-1 says
(weighted RMS: the weighting factor times the RMS of a sine) and as the load fluctuation is defined."""

import math

import numpy as np

from mbs.cli import main
from mbs.runtime import comfort
from mbs.runtime.results import Results


def test_comfort_of_a_results_file(tmp_path, capsys):
    t = np.arange(0.0, 21.0, 0.005)
    acc = 0.8 * np.sin(2 * math.pi * 4.0 * t)
    load = 4000 + 500 * np.sin(2 * math.pi * 12.0 * t)
    path = Results(["time", "seat_acc_z", "tyre.radial.load"], np.column_stack([t, acc, load])).to_csv(
        tmp_path / "ride.csv")
    assert main(["comfort", str(path)]) == 0
    out = capsys.readouterr().out
    lines = {line.split()[0]: float(line.split()[-2]) for line in out.strip().splitlines()}
    assert math.isclose(lines["seat_acc_z"], comfort.magnitude("Wk", 4.0) * 0.8 / math.sqrt(2), rel_tol=1e-3)
    assert math.isclose(lines["tyre.radial.load"], 500 / math.sqrt(2) / 4000, rel_tol=1e-3)
