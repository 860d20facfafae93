"""The Iltis manoeuvres of the data sheet: anti-phase bump, steering ramp and sines (vehicle), the dip
(quarter car). Signs checked physically: roll about +x (forward) is positive when the left side (+y) rises;
the tie rods sit 0.14 m behind the front axle, so a rack moved to the left (+y, positive input) pushes the
rear of the carriers left and the wheels steer right (negative angle about z)."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest

import mbs

sys.path.insert(0, str(Path(__file__).resolve().parent))
from tyrekit import assert_tyre_loads_never_pull  # noqa: E402

TYRES = ("tyre_fl", "tyre_fr", "tyre_rl", "tyre_rr")
ROD_LEVER = 0.14  # m: the tie rod's carrier point behind the wheel centre (data sheet)


@pytest.fixture(scope="module")
def vehicle():
    return mbs.load("library/iltis/vehicle.mbs")


def loads_never_pull(res):
    assert_tyre_loads_never_pull(res, TYRES)


def test_quarter_car_sinks_into_the_dip_first():
    system = mbs.load("library/iltis/quarter_car.mbs")
    res = system.simulate("dip_5", t_end=0.6)
    assert res.success, res.message
    start = res["heave"][0]
    moved = np.nonzero(np.abs(res["heave"] - start) > 0.01)[0]
    assert res["heave"][moved[0]] < start           # down first: the road falls away under the wheel
    assert res["heave"].min() < start - 0.1          # and it follows most of the 0.2 m dip
    assert res["tyre.radial.load"].min() >= 0.0


@pytest.mark.slow
@pytest.mark.parametrize("scene", ["anti_5", "anti_10"])
def test_anti_phase_bump_rolls_the_car_left_side_down_first(vehicle, scene):
    res = vehicle.simulate(scene)
    assert res.success, res.message
    roll = res["roll"]
    assert np.max(np.abs(roll)) > 0.05            # clearly rolls (rad); in phase it stays below 1e-9
    first = np.nonzero(np.abs(roll) > 1e-3)[0][0]
    assert roll[first] < 0.0                      # left (dip) side down, right (bump) side up
    assert res.t[first] < 0.3                     # as the front wheels enter the bump/dip at t = 0
    loads_never_pull(res)


@pytest.mark.slow
def test_steering_ramp_steers_both_front_wheels_right_and_the_car_turns_right(vehicle):
    res = vehicle.simulate("steer_ramp")
    assert res.success, res.message
    t = res.t
    before, held = t < 0.2, t > 0.8               # ramp from 0.2 s to 0.7 s, then held
    rack = 0.004 * 0.5                            # m
    for wheel in ("steer_fl", "steer_fr"):
        angle = res[wheel] - res[wheel][0]
        assert np.max(np.abs(angle[before])) < 1e-6
        # rack / lever is the kinematic toe change of a vertical kingpin and a lateral rod: the inclined
        # kingpin and rod of the Iltis change it by a few per cent, and the body's roll in the turn steers the
        # wheels a little more (roll steer), neither changes its sign
        assert np.all(angle[held] < 0.0)
        assert angle[held].mean() == pytest.approx(-rack / ROD_LEVER, rel=0.15)
    # the Calspan tyres turn the car to the right; the body rolls to the outside (left side down)
    late = t > 2.0
    assert np.all(res["yaw_rate"][late] < 0.0) and np.all(res["lateral_acc"][late] < 0.0)
    assert np.all(res["roll"][late] < 0.0)
    # steady turning: the lateral acceleration is the speed times the yaw rate
    assert res["lateral_acc"][-1] == pytest.approx(res["speed"][-1] * res["yaw_rate"][-1], rel=0.02)
    loads_never_pull(res)


@pytest.mark.slow
def test_steering_sines_steer_in_proportion_at_1_hz(vehicle):
    amplitudes = {}
    for mm in (1, 2, 4):
        res = vehicle.simulate(f"steer_sine_{mm}")
        assert res.success, res.message
        angle = res["steer_fl"] - res["steer_fl"][0]
        late = res.t > 0.2
        amplitudes[mm] = 0.5 * np.ptp(angle[late])
        # the wheel follows the rack at 1 Hz: a sine fitted at 1 Hz explains it
        basis = np.column_stack([np.sin(2 * math.pi * (res.t[late] - 0.2)), np.cos(2 * math.pi * (res.t[late] - 0.2)),
                                 np.ones(late.sum())])
        coef, *_ = np.linalg.lstsq(basis, angle[late], rcond=None)
        assert np.std(angle[late] - basis @ coef) < 0.05 * amplitudes[mm]
        assert coef[0] < 0.0                      # rack to the left first: wheels to the right first
        assert amplitudes[mm] == pytest.approx(mm * 1e-3 / ROD_LEVER, rel=0.10)
        loads_never_pull(res)
    assert amplitudes[2] / amplitudes[1] == pytest.approx(2.0, rel=0.03)
    assert amplitudes[4] / amplitudes[1] == pytest.approx(4.0, rel=0.03)
