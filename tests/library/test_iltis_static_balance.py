"""The full Iltis vehicle at its static equilibrium: the external forces balance as a rigid whole.

External forces: gravity on every body at its centre of mass, and the four tyre forces. The tyres push
vertically (the point contact has no horizontal force) on the wheel centre, which lies on the same vertical
as the contact point, so a tyre's moment needs only the centre's x and y (scene 'balance' of vehicle.mbs
outputs them with the loads). Then the sum of all moments about the overall centre of gravity must vanish:
pitch (about y, non-trivial: front and rear axles carry different loads on tyres of different radii at
different lever arms) and roll (about x).

Where the centre of gravity is. With massless links (corner parameters m_leaf, m_arm, m_carrier, m_rod = 0)
the bodies with mass are the car body (sensor attitude.cg) and the four wheels (their centre of mass is the
wheel centre: the tyre sensors), so the weights are summed body by body from sensors. With the links' masses
there are no sensors on the links, so the centre of gravity comes from the kinetic energy: for a rigid
rotation w of the whole vehicle about the free joint's origin r0 the momentum is m w x (r_cg - r0), so the
mass matrix block of base translation against base rotation (body axes) is -m [r_cg - r0]x R. That reading
is checked against the sensors in the massless case (to 1e-9 m), together with the free joint's conventions
(position r0 in the inertial frame, quaternion qw, qx, qy, qz rotating car axes into the inertial frame).

Tolerance: moment residual <= 1e-6 W b (W the weight, b = 1 m, about half the wheelbase). The equilibrium is
found to max |vdot| <= 1e-6 m/s^2 or rad/s^2 (runtime/equilibrium.py); a residual moment that large would
need |M row| * 1e-6 ~ (2400 + 835 + ...) kg m^2 * 1e-6 ~ 4e-3 N m of the pitch row, 3e-7 of W b (~15 kN m).
The sum of the tyre loads is checked to the same 1e-6 relative the force test uses.
"""

import numpy as np
import pytest

import mbs
from mbs.runtime.workspace import Workspace

G = 9.81
TYRES = ("fl", "fr", "rl", "rr")
LINKS = ("m_leaf", "m_arm", "m_carrier", "m_rod")
CAR_COM = np.array([0.0, 0.0, 0.570])  # the car body's centre of mass in its own frame (vehicle.mbs)
LEVER = 1.0  # m: the reference arm of the moment tolerance (half the wheelbase is 1.0085 m)


@pytest.fixture(scope="module")
def vehicle():
    return mbs.load("library/iltis/vehicle.mbs")


def rotation(qw, qx, qy, qz) -> np.ndarray:
    return np.array([[1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qw * qz), 2 * (qx * qz + qw * qy)],
                     [2 * (qx * qy + qw * qz), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qw * qx)],
                     [2 * (qx * qz - qw * qy), 2 * (qy * qz + qw * qx), 1 - 2 * (qx * qx + qy * qy)]])


def at_rest(vehicle, params):
    """(state, outputs, total mass, centre of gravity from the mass matrix, base position, base rotation)."""
    compiled = vehicle.compile("balance")
    assert compiled.q_names[:7] == ("floating.x", "floating.y", "floating.z", "floating.qw", "floating.qx",
                                    "floating.qy", "floating.qz")
    assert compiled.v_names[:6] == ("der(floating.x)", "der(floating.y)", "der(floating.z)", "floating.wx",
                                    "floating.wy", "floating.wz")
    result, outputs = vehicle.equilibrium("balance", params=params)
    data = Workspace(compiled)
    for name, value in params.items():
        data.set_param(name, value)
    x = result.x
    M = data.mass_matrix(0.0, x)
    m = M[0, 0]
    assert np.diag(M[:3, :3]) == pytest.approx([m, m, m], rel=1e-12)
    r0, R = x[:3], rotation(*x[3:7])
    skew = -M[:3, 3:6] @ R.T / m  # [r_cg - r0]x
    assert np.max(np.abs(skew + skew.T)) < 1e-9
    cg = r0 + np.array([skew[2, 1], skew[0, 2], skew[1, 0]])
    return x, outputs, m, cg, r0, R


def tyre_moment(outputs, about) -> np.ndarray:
    total = np.zeros(3)
    for t in TYRES:
        contact = np.array([outputs[f"tyre_{t}.radial.centre.x"], outputs[f"tyre_{t}.radial.centre.y"], 0.0])
        total += np.cross(contact - about, [0.0, 0.0, outputs[f"tyre_{t}.radial.load"]])
    return total


def test_massless_links_moments_of_tyre_forces_and_weights_about_the_cg_vanish(vehicle):
    params = {f"{c}.{name}": 0.0 for c in TYRES for name in LINKS}
    x, out, m, cg_kinetic, r0, R = at_rest(vehicle, params)
    p = {x.name: x.value for x in vehicle.model.parameters}
    # the free joint's conventions: the car's centre of mass placed by (r0, R) is where the sensor sees it
    car = np.array([out["attitude.cg.x"], out["attitude.cg.y"]])
    assert (r0 + R @ CAR_COM)[:2] == pytest.approx(car, abs=1e-12)
    bodies = [(p["m_body"], r0 + R @ CAR_COM)]
    bodies += [(p["fl.m_wheel"], np.array([out[f"tyre_{t}.radial.centre.x"], out[f"tyre_{t}.radial.centre.y"],
                                           0.0])) for t in TYRES]  # heights do not enter vertical forces
    mass = sum(mb for mb, _ in bodies)
    assert mass == pytest.approx(m, rel=1e-12)
    cg = sum(mb * r for mb, r in bodies) / mass
    assert cg[:2] == pytest.approx(cg_kinetic[:2], abs=1e-9)  # the mass matrix's centre of gravity agrees
    weight = mass * G
    loads = [out[f"tyre_{t}.radial.load"] for t in TYRES]
    assert sum(loads) == pytest.approx(weight, rel=1e-6)
    moment = tyre_moment(out, cg)
    moment += sum(np.cross(r - cg, [0.0, 0.0, -mb * G]) for mb, r in bodies)
    # pitch (y) and roll (x); no vertical moment arises from vertical forces
    assert abs(moment[1]) <= 1e-6 * weight * LEVER
    assert abs(moment[0]) <= 1e-6 * weight * LEVER
    # the pitch balance is not trivial: the axles carry different loads at different arms
    front, rear = out["tyre_fl.radial.load"], out["tyre_rl.radial.load"]
    assert abs(front - rear) > 100.0
    assert abs(front * (out["tyre_fl.radial.centre.x"] - cg[0])) > 3000.0


def test_with_link_masses_moments_about_the_cg_from_the_kinetic_energy_vanish(vehicle):
    x, out, m, cg, r0, R = at_rest(vehicle, {})
    p = {x.name: x.value for x in vehicle.model.parameters}
    corner = sum(p[f"fl.{name}"] for name in (*LINKS, "m_wheel"))
    assert m == pytest.approx(p["m_body"] + 4 * corner, rel=1e-12)
    weight = m * G
    loads = [out[f"tyre_{t}.radial.load"] for t in TYRES]
    assert sum(loads) == pytest.approx(weight, rel=1e-6)
    # the weights of all bodies about their common centre of gravity sum to nothing: only the tyres remain
    moment = tyre_moment(out, cg)
    assert abs(moment[1]) <= 1e-6 * weight * LEVER
    assert abs(moment[0]) <= 1e-6 * weight * LEVER
