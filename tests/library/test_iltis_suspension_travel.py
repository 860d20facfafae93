"""The Iltis front suspension corner of the library moves through its whole travel and steers without losing its
closed loops. The oracle is the data sheet's geometry, recomputed here with numpy: the hardpoints, the derived
link lengths (leaf arm, lower arm, carrier between its ball joints, steering rod) and the strut's force law,
whose stiffness marks the bump and rebound stops. The model's side is read through position sensors only
(tests/library/models/iltis_corner_probe.mbs: the library corner on a chassis of prescribed height)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

import mbs
from mbs.runtime import build, comfort
from mbs.runtime.assembly import assemble
from mbs.runtime.workspace import Workspace

pytestmark = pytest.mark.skipif(not build.have_c_compiler(), reason="closed loops need the C back end")

PROBE = Path(__file__).parent / "models" / "iltis_corner_probe.mbs"
QUARTER_CAR = Path(__file__).parents[2] / "library" / "iltis" / "quarter_car.mbs"

# ---- the data sheet (front-left corner, nominal configuration, vehicle frame: x forward, y left, z up) ----------
LEAF_PIVOT = np.array([0.970, 0.1585, 0.600])
LEAF_TIP = np.array([0.970, 0.488, 0.531])        # = the carrier's upper ball joint
ARM_PIVOT = np.array([0.970, 0.259, 0.302])
ARM_BALL = np.array([0.970, 0.572, 0.229])        # = the carrier's lower ball joint
WHEEL_CENTRE = np.array([0.970, 0.615, 0.356])
STRUT_TOP = np.array([1.045, 0.297, 0.632])
STRUT_BOTTOM = np.array([1.045, 0.500, 0.241])
RACK_CENTRE = np.array([0.830, 0.0, 0.600])
RACK_PICKUP = 0.07                                # from the rack centre, along y
ROD_LENGTH = 0.38424601
SHEET_LENGTHS = {"leaf arm": 0.33665, "lower arm": 0.32140, "carrier": 0.31346}


def strut_stiffness(Z):
    """dF/dZ of the data sheet's strut spring F = -4.0092e6 + 2.8397e7 Z - 6.7061e7 Z^2 + 5.2796e7 Z^3."""
    return 2.8397e7 - 2 * 6.7061e7 * Z + 3 * 5.2796e7 * Z**2


SOFT_STIFFNESS = strut_stiffness(6.7061e7 / (3 * 5.2796e7))  # its minimum: the free travel between the stops
STOP_FACTOR = 25  # a length where the strut is this many times stiffer than at its softest is in a stop
BUMP_STOP_Z, REBOUND_STOP_Z = 0.38, 0.48  # strut lengths the static sweep reaches: deep in the bump / rebound stop

TOL = 1e-9


def rotate_x(point, pivot, phi):
    """point turned by phi about the x axis through pivot (right-handed: y towards z)."""
    d = point - pivot
    c, s = math.cos(phi), math.sin(phi)
    return pivot + np.array([d[0], c * d[1] - s * d[2], s * d[1] + c * d[2]])


def arm_angle_for_strut_length(Z):
    """The control-arm angle at which the strut (chassis at its nominal height) has length Z."""
    return brentq(lambda phi: np.linalg.norm(rotate_x(STRUT_BOTTOM, ARM_PIVOT, phi) - STRUT_TOP) - Z, -1.0, 1.0)


def kabsch(nominal, current):
    """The rotation R with current - c ≈ R (nominal - c0) (least squares over the points)."""
    a = nominal - nominal.mean(axis=0)
    b = current - current.mean(axis=0)
    u, _, vt = np.linalg.svd(a.T @ b)
    d = np.sign(np.linalg.det(vt.T @ u.T))
    return vt.T @ np.diag([1.0, 1.0, d]) @ u.T


def toe(points):
    """Steer angle of the wheel [rad] about z (positive: wheel turned left), from the carrier's rotation out of
    its nominal pose (the wheel's spin axis is y there), found from three data-sheet points of the carrier."""
    nominal = np.array([LEAF_TIP, ARM_BALL, WHEEL_CENTRE])
    current = np.array([points["upper"], points["lower"], points["hub"]])
    axis = kabsch(nominal, current) @ np.array([0.0, 1.0, 0.0])
    return math.atan2(-axis[0], axis[1])


# ---- the model ---------------------------------------------------------------------------------------------------

class Probe:
    """The probe model compiled for its sweep scene; `at` assembles it at an arm angle, rack and time."""

    def __init__(self):
        self.system = mbs.load(PROBE)
        self.generated = self.system.generate("sweep")
        self.model = self.system.compile("sweep")
        self.data = Workspace(self.model)
        self.x = self.model.x0.copy()

    def at(self, arm_angle, rack=0.0, rack_rate=0.0, t=0.0):
        """(points {name: world position}, outputs, state) assembled with the arm angle held."""
        self.data.set_param("rack", rack)
        self.data.set_param("rack_rate", rack_rate)
        self.data.t = t
        self.x[self.model.x_names.index("fl.arm_bearing.phi")] = arm_angle
        result = assemble(self.model, self.data, self.x, fixed=["fl.arm_bearing.phi"],
                          row_names=self.generated.constraints.names)
        self.x = result.x
        return self.read(t, self.x)

    def read(self, t, x):
        y = dict(zip(self.model.y_names, self.data.outputs(t, x)))
        points = {name: np.array([y[f"{name}_{c}"] for c in "xyz"])
                  for name in ("leaf_tip", "arm_ball", "upper", "lower", "rod_ball", "hub", "rod_inner",
                               "rod_outer", "chassis")}
        return points, y, x

    def report(self, t, x):
        """(max |g|, rank, DOF) from the loop solver at a state."""
        r = self.data.loop_report(t, x)
        return float(np.max(np.abs(self.data.constraints(t, x)))), int(r[5]), int(r[6])


@pytest.fixture(scope="module")
def probe():
    return Probe()


def check_geometry(points, rack):
    """The data sheet's link lengths and the loop closures, at one position; the chassis at its height."""
    lift = points["chassis"]
    assert np.all(np.abs(lift[:2]) < TOL)  # the guide is vertical
    leaf_pivot, arm_pivot = LEAF_PIVOT + lift, ARM_PIVOT + lift
    rack_end = RACK_CENTRE + lift + np.array([0.0, RACK_PICKUP + rack, 0.0])
    lengths = {"leaf arm": np.linalg.norm(points["leaf_tip"] - leaf_pivot),
               "lower arm": np.linalg.norm(points["arm_ball"] - arm_pivot),
               "carrier": np.linalg.norm(points["leaf_tip"] - points["arm_ball"])}
    for name, length in lengths.items():
        assert abs(length - NOMINAL[name]) < TOL, name
    assert abs(np.linalg.norm(points["rod_ball"] - rack_end) - ROD_LENGTH) < TOL
    # the cut joints are closed: the points on both sides coincide
    assert np.linalg.norm(points["leaf_tip"] - points["upper"]) < TOL
    assert np.linalg.norm(points["rod_outer"] - points["rod_ball"]) < TOL
    assert np.linalg.norm(points["arm_ball"] - points["lower"]) < TOL
    assert np.linalg.norm(points["rod_inner"] - rack_end) < TOL
    # the leaf and the arm turn about chassis x axes: their outer points stay in the plane x = x_axle
    assert abs(points["leaf_tip"][0] - LEAF_PIVOT[0]) < TOL and abs(points["arm_ball"][0] - ARM_PIVOT[0]) < TOL


NOMINAL = {"leaf arm": np.linalg.norm(LEAF_TIP - LEAF_PIVOT), "lower arm": np.linalg.norm(ARM_BALL - ARM_PIVOT),
           "carrier": np.linalg.norm(LEAF_TIP - ARM_BALL)}


def test_the_data_sheet_lengths_follow_from_its_hardpoints():
    """The sheet's derived lengths are the distances of its hardpoints, rounded to 0.01 mm."""
    for name, length in SHEET_LENGTHS.items():
        assert abs(NOMINAL[name] - length) <= 5e-6, name
    # and the travel swept below runs from inside the bump stop to inside the rebound stop
    assert strut_stiffness(BUMP_STOP_Z) > STOP_FACTOR * SOFT_STIFFNESS
    assert strut_stiffness(REBOUND_STOP_Z) > STOP_FACTOR * SOFT_STIFFNESS
    assert BUMP_STOP_Z < np.linalg.norm(STRUT_TOP - STRUT_BOTTOM) < REBOUND_STOP_Z


def test_quarter_car_has_the_chassis_lift_and_one_degree_of_freedom_in_the_corner():
    """Quarter car: tree velocities lift, leaf, arm, 3 of the lower ball joint, 2 of the rod's Cardan joint (rack and
    wheel spin are prescribed); the two spherical cut joints take 6 independent rows. 8 - 6 = 2: the body's lift
    and the suspension travel. The steering rod is held against spinning about its own axis by its Cardan joint,
    so no idle motion is left."""
    system = mbs.load(QUARTER_CAR)
    model = system.compile()
    res = system.simulate(t_end=0.0)  # assembled from the file's initial values
    assert res.success, res.message
    data = Workspace(model)
    x = np.array([res[name][0] for name in model.x_names])
    report = data.loop_report(0.0, x)
    assert (model.nv, len(system.generate().constraints.names)) == (8, 6)
    assert (int(report[5]), int(report[6])) == (6, 2)
    assert np.max(np.abs(data.constraints(0.0, x))) < TOL


def test_corner_with_chassis_and_steering_prescribed_has_one_degree_of_freedom(probe):
    points, _, x = probe.at(0.0)
    g, rank, dof = probe.report(0.0, x)
    assert (probe.model.nv, rank, dof) == (7, 6, 1)
    assert g < TOL
    check_geometry(points, 0.0)
    # nominal configuration: every point where the data sheet puts it, the wheel straight ahead
    for name, where in (("leaf_tip", LEAF_TIP), ("arm_ball", ARM_BALL), ("hub", WHEEL_CENTRE)):
        assert np.linalg.norm(points[name] - where) < TOL, name
    assert abs(toe(points)) < TOL


def test_full_travel_from_the_bump_stop_to_the_rebound_stop_keeps_the_loops_closed(probe):
    lengths = np.linspace(BUMP_STOP_Z, REBOUND_STOP_Z, 21)
    hub_z = []
    for Z in lengths:
        phi = arm_angle_for_strut_length(Z)
        points, y, x = probe.at(phi)
        g, rank, dof = probe.report(0.0, x)
        assert g < TOL and dof == 1, (Z, g, dof)  # no singular position inside the travel
        check_geometry(points, 0.0)
        assert np.linalg.norm(points["arm_ball"] - rotate_x(ARM_BALL, ARM_PIVOT, phi)) < TOL
        assert abs(y["travel"] - Z) < TOL
        hub_z.append(points["hub"][2])
    hub_z = np.array(hub_z)
    assert np.all(np.diff(hub_z) < 0)  # the wheel drops as the strut extends
    assert hub_z[0] - hub_z[-1] > 0.15  # through a wheel travel of more than 15 cm


@pytest.mark.parametrize("Z", [BUMP_STOP_Z, None, REBOUND_STOP_Z], ids=["bump", "nominal", "rebound"])
def test_rack_ramp_steers_the_wheel_about_its_kingpin_and_keeps_the_rod_length(probe, Z):
    """The steering input ramps the rack at 10 mm/s from -10 mm to +10 mm (the data sheet's manoeuvres use up to
    4 mm); at fixed travel the two ball joints stay put, so the carrier can only turn about the line through them:
    the wheel steers, monotonically with the rack."""
    phi = 0.0 if Z is None else arm_angle_for_strut_length(Z)
    rate, start = 0.01, -0.01
    angles, balls = [], []
    for t in np.linspace(0.0, 2.0, 11):
        rack = start + rate * t
        points, _, x = probe.at(phi, rack=start, rack_rate=rate, t=t)
        g, _, dof = probe.report(t, x)
        assert g < TOL and dof == 1
        check_geometry(points, rack)
        angles.append(toe(points))
        balls.append(np.concatenate([points["upper"], points["lower"]]))
    balls = np.array(balls)
    assert np.max(np.abs(balls - balls[0])) < TOL
    angles = np.array(angles)
    # the rack pushes the rod's carrier end (behind the axle) outwards: the left wheel turns right
    assert np.all(np.diff(angles) < 0)
    assert angles[0] - angles[-1] > 0.1  # more than 5.7 degrees for 20 mm of rack
    if Z is None:  # rack centred at the design height: straight ahead (where the data sheet puts the rod)
        assert abs(angles[5]) < TOL


def test_a_rack_that_starts_moving_is_located_and_the_run_converges_with_its_tolerance(probe):
    """The rack at rest, then ramped at 50 mm/s from 0.1 s (an input's if on time): its speed steps there, and the
    loops' speeds with it. The run locates the instant (a switch of the prescribed motion) and projects the speeds
    onto the constraints there, so its error follows its tolerance; stepped across, the travel was off by 8 % of
    its range at rtol 1e-6 and 42 % at 1e-5 against the rtol 1e-10 run."""
    runs = {rtol: probe.system.simulate("ramp_start", params={"rack_rate": 0.05}, t_end=0.3, sample=0.01,
                                        rtol=rtol, atol=rtol * 1e-2) for rtol in (1e-5, 1e-6, 1e-10)}
    for res in runs.values():
        assert res.success, res.message
        assert [e["time"] for e in res.events if "prescribed motion of fl.rack" in e["event"]] == [
            pytest.approx(0.1, abs=1e-12)]
    reference = runs[1e-10]
    for name in ("travel", "hub_y"):
        exact = reference[name][comfort.sample_rows(reference.t)]
        assert np.ptp(exact) > 1e-5  # the rack's ramp moves the wheel (m)
        for rtol in (1e-5, 1e-6):
            res = runs[rtol]
            error = np.max(np.abs(res[name][comfort.sample_rows(res.t)] - exact))
            assert error < 10 * rtol * np.ptp(exact), (name, rtol, error)


def test_driven_through_its_travel_by_the_chassis_while_steering(probe):
    """A dynamic run: the chassis moved up and down by 16 cm at 0.5 Hz with the wheel on its tyre, the rack
    ramping. Every stored (projected) sample satisfies the constraints and the data-sheet lengths, and the
    strut reaches into both stops."""
    params = {"lift_amp": 0.16, "lift_freq": 0.5, "rack": -0.02, "rack_rate": 0.01}
    res = probe.system.simulate("sweep", params=params, t_end=4.0, sample=0.01, rtol=1e-8, atol=1e-10)
    assert res.success, res.message
    data = Workspace(probe.model)
    for key, value in params.items():
        data.set_param(key, value)
    X = np.column_stack([res[name] for name in probe.model.x_names])
    for t, x in zip(res.t, X):
        assert np.max(np.abs(data.constraints(t, x))) < TOL
        y = dict(zip(probe.model.y_names, data.outputs(t, x)))
        points = {name: np.array([y[f"{name}_{c}"] for c in "xyz"])
                  for name in ("leaf_tip", "arm_ball", "upper", "lower", "rod_ball", "hub", "rod_inner",
                               "rod_outer", "chassis")}
        assert abs(points["chassis"][2] - 0.16 * math.sin(math.pi * t)) < TOL
        check_geometry(points, -0.02 + 0.01 * t)
    travel = res["travel"]
    assert strut_stiffness(travel.min()) > STOP_FACTOR * SOFT_STIFFNESS and travel.min() < 0.42
    assert strut_stiffness(travel.max()) > STOP_FACTOR * SOFT_STIFFNESS and travel.max() > 0.43
