"""The Iltis in steady cornering against an independent model: the linear single-track (bicycle) model,
built here from the vehicle's mass, its axle positions (the static axle loads place the centre of gravity
between them) and the Calspan tyre's cornering stiffness at the static axle loads; its yaw inertia enters
the transient, which a steady state does not see.

The multibody model has what the single-track model lacks: roll, load transfer, roll steer of the linkages,
camber thrust and aligning torques. At small lateral acceleration the load transfer is a second-order effect;
roll steer is measured (each wheel's toe in the body) and given to the single-track model as its steer
angles; camber thrust and the aligning torque are switched off in the tyres (A3 = 0, AF1 = AF2 = 0), which
leaves the tyre of the single-track model: a lateral force proportional to the slip angle.
"""

import numpy as np
import pytest

import mbs

G = 9.81
X_FRONT, X_REAR = 0.970, -1.047                  # axle positions (data sheet)
A0, A1, A2 = 2625.0, 14.47, 12930.0              # the Calspan coefficients of the cornering stiffness
TYRES = ("tyre_fl", "tyre_fr", "tyre_rl", "tyre_rr")


def cornering_stiffness(fz):
    """dFy/dalpha of the Calspan tyre at alpha = 0 (light-load branch): A0 + A1 Fz (1 - Fz / A2)."""
    return A0 + A1 * fz * (1.0 - fz / A2)


def single_track_steady_state(mass, a, b, c_front, c_rear, v, delta_front, delta_rear):
    """(yaw rate, side slip) of the linear single-track model in steady state, ISO signs (left positive):
    m v r = F_f + F_r, a F_f - b F_r = 0, F = C (delta - (v_y +- x r) / v)."""
    # unknowns (beta, r): lateral forces F_f = c_f (delta_f - beta - a r / v), F_r = c_r (delta_r - beta + b r / v)
    matrix = np.array([[c_front + c_rear, mass * v + (c_front * a - c_rear * b) / v],
                       [c_front * a - c_rear * b, (c_front * a * a + c_rear * b * b) / v]])
    rhs = np.array([c_front * delta_front + c_rear * delta_rear, c_front * a * delta_front - c_rear * b * delta_rear])
    beta, r = np.linalg.solve(matrix, rhs)
    return r, beta


@pytest.mark.slow
def test_steady_cornering_agrees_with_the_single_track_model():
    vehicle = mbs.load("library/iltis/vehicle.mbs")
    pure = {f"{t}.{p}": 0.0 for t in TYRES for p in ("A3", "AF1", "AF2")}
    res = vehicle.simulate("cornering", params=pure)
    assert res.success, res.message
    static = {t: res[f"{t}.radial.load"][0] for t in TYRES}
    front, rear = static["tyre_fl"] + static["tyre_fr"], static["tyre_rl"] + static["tyre_rr"]
    mass = (front + rear) / G
    wheelbase = X_FRONT - X_REAR
    a, b = wheelbase * rear / (front + rear), wheelbase * front / (front + rear)
    c_front = cornering_stiffness(static["tyre_fl"]) + cornering_stiffness(static["tyre_fr"])
    c_rear = cornering_stiffness(static["tyre_rl"]) + cornering_stiffness(static["tyre_rr"])
    end = -1                                       # 3.3 s after the ramp: steady (the yaw mode decays in ~0.5 s)
    assert abs(res["lateral_acc"][end]) < 1.0     # m/s^2: small
    assert abs(res["yaw_rate"][end] - res["yaw_rate"][end - 10]) < 0.01 * abs(res["yaw_rate"][end])
    delta_front = 0.5 * (res["steer_fl"][end] + res["steer_fr"][end]) - 0.5 * (res["steer_fl"][0] + res["steer_fr"][0])
    delta_rear = 0.5 * (res["steer_rl"][end] + res["steer_rr"][end]) - 0.5 * (res["steer_rl"][0] + res["steer_rr"][0])
    r, beta = single_track_steady_state(mass, a, b, c_front, c_rear, res["speed"][end], delta_front, delta_rear)
    assert res["yaw_rate"][end] == pytest.approx(r, rel=0.05)
    assert res["side_slip"][end] == pytest.approx(beta, rel=0.05)


def test_single_track_model_limits():
    """The reference itself: neutral steer (a c_f = b c_r) turns at the kinematic yaw rate v delta / L with the
    side slip b delta / L - m a v^2 / (c_r L^2 / ... ) reduced to its closed form; and no steer, no turn."""
    m, a, b, c, v, delta = 1500.0, 1.0, 1.0, 80000.0, 20.0, 0.01
    r, beta = single_track_steady_state(m, a, b, c, c, v, delta, 0.0)
    assert r == pytest.approx(v * delta / (a + b), rel=1e-12)
    # rear axle: c (beta - b r / v) = -m v r a / (a + b)  ->  beta = b r / v - m v r a / ((a + b) c)
    assert beta == pytest.approx(b * r / v - m * v * r * a / ((a + b) * c), rel=1e-12)
    assert single_track_steady_state(m, a, b, c, c, v, 0.0, 0.0) == (0.0, 0.0)
