"""The ride-comfort scene: the Iltis at 15 m/s over a class C road (ISO 8608, both tracks). The vertical seat
acceleration, weighted by Wk, dominates the horizontal ones (the road excites heave and pitch; roll only
through the tracks' incoherence), and the tyre loads fluctuate by tens of per cent without pulling."""

import sys
from pathlib import Path

import numpy as np
import pytest

import mbs
from mbs.commands.comfort import ride_report

sys.path.insert(0, str(Path(__file__).parent))
from tyrekit import assert_tyre_loads_never_pull  # noqa: E402


@pytest.mark.slow
def test_ride_on_a_class_c_road():
    res = mbs.load("library/iltis/vehicle.mbs").simulate("ride_c_15")
    assert res.success, res.message
    report = {what.split()[0]: value for what, value, _ in ride_report(res)}
    assert report["seat_acc_z"] > 2 * max(report["seat_acc_x"], report["seat_acc_y"])
    for tyre in ("tyre_fl", "tyre_fr", "tyre_rl", "tyre_rr"):
        assert 0.05 < report[f"{tyre}.radial.load"] < 1.0
    assert_tyre_loads_never_pull(res, ("tyre_fl", "tyre_fr", "tyre_rl", "tyre_rr"))
    # the tracks differ: the body rolls
    assert np.std(res["roll"]) > 1e-3
