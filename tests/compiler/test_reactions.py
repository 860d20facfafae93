"""Reaction loads and acceleration sensors against analytic mechanics and statics worked out by hand.

The references are written here from first principles (Newton's law for a physical pendulum, the statics of a
slider-crank), evaluated at the simulated states: they share nothing with the compiler's Newton-Euler passes.
Tolerances: the quantities are O(1..1000) N out of a few hundred floating-point operations; 1e-9 relative is far
below any modelling error (a wrong sign, frame or lever arm shows at the percent level).
"""

from pathlib import Path

import numpy as np
import pytest

import mbs
from mbs.runtime.workspace import Workspace

MODELS = Path(__file__).parent / "models"
G = 9.81
REL = 1e-9


@pytest.fixture(scope="module")
def pendulum():
    system = mbs.load(MODELS / "physical_pendulum.mbs")
    return system, system.simulate("swing").check()


def pendulum_reference(res, m=2.0, d=0.5, Ic=0.2):
    """Pivot load on the body from Newton's law for its centre of mass, in radial and tangential parts:
    radial (towards the pivot) m (g cos phi + d phidot^2); tangential m g sin phi Ic / (Ic + m d^2)."""
    phi, w = res["hinge.phi"], res["der(hinge.phi)"]
    radial = m * (G * np.cos(phi) + d * w**2)
    tangential = m * G * np.sin(phi) * Ic / (Ic + m * d**2)
    e_r = np.stack([np.sin(phi), np.zeros_like(phi), np.cos(phi)])      # centre of mass -> pivot
    e_t = np.stack([-np.cos(phi), np.zeros_like(phi), np.sin(phi)])     # direction of increasing phi
    return radial, tangential, e_r, e_t


def loads(res, name):
    return np.stack([res[f"{name}.load.{c}"] for c in ("fx", "fy", "fz")]), \
        np.stack([res[f"{name}.load.{c}"] for c in ("mx", "my", "mz")])


def test_pivot_reaction_of_a_physical_pendulum(pendulum):
    _, res = pendulum
    radial, tangential, e_r, e_t = pendulum_reference(res)
    force, moment = loads(res, "hinge")
    scale = 2 * G
    assert np.ptp(res["hinge.phi"]) > 3.0  # a large swing, through the bottom with speed
    np.testing.assert_allclose(np.sum(force * e_r, axis=0), radial, rtol=0, atol=REL * scale)
    np.testing.assert_allclose(np.sum(force * e_t, axis=0), tangential, rtol=0, atol=REL * scale)
    np.testing.assert_allclose(force[1], 0.0, atol=REL * scale)
    np.testing.assert_allclose(moment, 0.0, atol=REL * scale)  # a frictionless hinge, moment about its axis


def test_reaction_of_a_joint_written_child_to_parent_is_the_load_on_its_frame_b(pendulum):
    _, res = pendulum
    np.testing.assert_allclose(res["twin_hinge.phi"], res["hinge.phi"], rtol=0, atol=1e-9)
    force, moment = loads(res, "twin_hinge")
    radial, tangential, e_r, e_t = pendulum_reference(res)
    # frame b is the ground: it takes the opposite of the load on the body
    np.testing.assert_allclose(np.sum(force * e_r, axis=0), -radial, rtol=0, atol=REL * 2 * G)
    np.testing.assert_allclose(np.sum(force * e_t, axis=0), -tangential, rtol=0, atol=REL * 2 * G)
    np.testing.assert_allclose(moment, 0.0, atol=REL * 2 * G)


def test_acceleration_sensor_of_the_centre_of_mass(pendulum):
    _, res = pendulum
    phi, w = res["hinge.phi"], res["der(hinge.phi)"]
    m, d, Ic = 2.0, 0.5, 0.2
    phidd = -m * G * d * np.sin(phi) / (Ic + m * d**2)
    _, _, e_r, e_t = pendulum_reference(res)
    expected = d * phidd * e_t + d * w**2 * e_r
    acc = np.stack([res[f"bob_motion.acc.{c}"] for c in "xyz"])
    np.testing.assert_allclose(acc, expected, rtol=0, atol=REL * G)


def test_numpy_back_end_computes_the_same_reactions(pendulum):
    system, res = pendulum
    c_model = system.compile("swing")
    np_model = mbs.load(MODELS / "physical_pendulum.mbs", backend="numpy").compile("swing")
    x = np.array([res[n][37] for n in c_model.x_names])
    y_c, y_np = Workspace(c_model).outputs(0.3, x), Workspace(np_model).outputs(0.3, x)
    assert np_model.y_names == c_model.y_names
    np.testing.assert_allclose(y_np, y_c, rtol=1e-12, atol=1e-12)


def slider_crank_statics(r=0.1, L=0.4, theta=np.radians(60), P=1000.0):
    """Hand calculation: the rod is a two-force member (no gravity, at rest), compression C along e (from the
    crank pin to the slider): slider x: -P + C e_x = 0; guide: N = -C e_z; crank about y: the rod's -C e at A
    turns it by (A x -C e)_y, which the drive cancels: T = C (A x e)_y."""
    A = r * np.array([np.cos(theta), 0.0, -np.sin(theta)])           # crank pin
    s = r * np.cos(theta) + np.sqrt(L**2 - (r * np.sin(theta))**2)  # slider position
    e = (np.array([s, 0.0, 0.0]) - A) / L
    C = P / e[0]
    T = C * np.cross(A, e)[1]
    return C * e, -C * e[2], T


def test_reactions_of_a_slider_crank_in_static_balance():
    rod_force, N, T = slider_crank_statics()
    system = mbs.load(MODELS / "slider_crank_static.mbs")
    res = system.simulate("hold", params={"T": T}).check()
    first = {name: res[name][0] for name in res.names}
    # the balance holds: no acceleration (else the hand calculation would not apply)
    assert abs(first["slider_acc.acc.x"]) < 1e-9
    P = 1000.0

    def load(name):
        return np.array([first[f"{name}.load.{c}"] for c in ("fx", "fy", "fz", "mx", "my", "mz")])

    # the cut joint: the rod pushes the slider along the rod
    np.testing.assert_allclose(load("wrist_pin"), [*rod_force, 0, 0, 0], rtol=0, atol=REL * P)
    # the tree joints: the crank pushes the rod, the ground holds the crank (and carries the drive torque T
    # about the bearing's own axis, which the load includes), the guide holds the slider down
    np.testing.assert_allclose(load("crank_pin"), [*rod_force, 0, 0, 0], rtol=0, atol=REL * P)
    np.testing.assert_allclose(load("main_bearing"), [*rod_force, 0, T, 0], rtol=0, atol=REL * P)
    np.testing.assert_allclose(load("guide"), [0, 0, N, 0, 0, 0], rtol=0, atol=REL * P)
    assert N < 0 and rod_force[0] > 0  # the rod leans up to the crank pin: the guide must hold the slider down


def test_a_scene_without_reactions_does_not_evaluate_the_accelerations():
    """Reactions cost one right-hand-side evaluation per output sample, and only when asked for."""
    system = mbs.load(MODELS / "physical_pendulum.mbs")
    gen = system.generate(None)
    assert "mbs_acc" not in gen.c_source
    gen = system.generate("swing")
    assert "mbs_acc" in gen.c_source


def test_a_vector_sensor_of_a_component_instance_expands_into_its_components():
    text = '''
component arm {
    param m = 1 kg
    port base
    rigid link {
        body {
            mass = m
            com = (0, 0, -0.3) m
            inertia = diag(0.01, 0.01, 0.01) kg*m^2
        }
    }
    interact hinge {
        connect base -> link
        joint revolute(axis = y) {
            init phi = 0.4 rad
        }
        sensor load = reaction()
    }
}
model two_arms {
    use arm as left {
        base = inertial
    }
}
scene swing {
    t_end = 0.1 s
    output left.hinge.load
}
'''
    system = mbs.loads(text)
    compiled = system.compile("swing")
    assert compiled.y_names == tuple(f"left.hinge.load.{c}" for c in ("fx", "fy", "fz", "mx", "my", "mz"))
    y = Workspace(compiled).outputs(0.0, compiled.x0)
    # at rest the centre of mass accelerates only tangentially: the radial part of the pivot load (towards the
    # pivot, e_r = (sin phi, 0, cos phi)) is exactly m g cos phi, and nothing acts along the hinge axis
    phi = 0.4
    assert y[0] * np.sin(phi) + y[2] * np.cos(phi) == pytest.approx(G * np.cos(phi), rel=REL)
    assert y[1] == 0.0
