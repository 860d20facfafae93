"""Kinematic queries, applied loads and prescribed (rheonomic) coordinates.

Oracles: hand calculations for the line force and the driven pendulums (exact formulas, so agreement to rounding:
1e-12 relative), Pinocchio's forward kinematics and its aba with external forces (TOL as in
test_tree_dynamics: both sides round at ~1e-13, a wrong term is O(1e-2))."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

sys.path.insert(0, str(Path(__file__).parent))
import treekit  # noqa: E402

from mbs.compiler.ccode import generate_c  # noqa: E402
from mbs.compiler.equations import derive_equations  # noqa: E402
from mbs.compiler.kinematics import Kinematics  # noqa: E402
from mbs.compiler.tree import JointSpec, Tree, TreeBody, t  # noqa: E402

TOL = 1e-9
EYE, ZERO = sp.eye(3), (0, 0, 0)


def _values(kin, exprs, params, p, x, t_value=0.0):
    """Numeric values of kinematic tape expressions (via the tape evaluator)."""
    eqs = derive_equations(kin, forward_dynamics=False)
    fn = treekit.numeric_function(eqs, params, list(exprs))
    return np.array(fn(t_value, list(x), list(p)))


# ---- kinematics against Pinocchio ------------------------------------------------------------------------------

@pytest.mark.parametrize("seed", range(3))
def test_frame_queries_match_pinocchio(seed):
    pin = pytest.importorskip("pinocchio")
    rng = np.random.default_rng(300 + seed)
    tree, params, values = treekit.random_tree(rng, 4)
    model = treekit.pinocchio_model(tree, dict(zip(params, values)))
    data = model.createData()
    x = treekit.random_state(rng, tree)
    qp, vp, _ = treekit.pinocchio_state(tree, x)
    pin.forwardKinematics(model, data, qp, vp)
    kin = Kinematics(tree)
    points = [tuple(float(c) for c in rng.normal(size=3)) for _ in tree.bodies]
    exprs = []
    for i, point in enumerate(points):
        exprs += (list(kin.frame_position(i, point)) + list(kin.frame_velocity(i, point))
                  + list(kin.body_angular_velocity(i)) + [e for row in kin.frame_rotation(i) for e in row])
    values_all = _values(kin, exprs, params, values, x).reshape(len(points), 18)
    for i, (body, point, ours) in enumerate(zip(tree.bodies, points, values_all)):
        # Pinocchio's joint frame is our frame b; the body frame sits at inv(X_child_joint) in it.
        oMb = data.oMi[i + 1]
        Rb, rb = (np.array(sp.Matrix(X).evalf(), dtype=float).reshape(s) for X, s in
                  zip(body.X_child_joint, ((3, 3), (3,))))
        p_b = Rb.T @ (np.array(point) - rb)  # the point in frame b
        v_b = data.v[i + 1]
        np.testing.assert_allclose(ours[:3], oMb.act(p_b), atol=TOL)
        np.testing.assert_allclose(ours[3:6], oMb.rotation @ (v_b.linear + np.cross(v_b.angular, p_b)), atol=TOL)
        np.testing.assert_allclose(ours[6:9], oMb.rotation @ v_b.angular, atol=TOL)
        np.testing.assert_allclose(ours[9:].reshape(3, 3), oMb.rotation @ Rb.T, atol=TOL)


@pytest.mark.parametrize("seed", range(3))
def test_applied_forces_and_torques_match_pinocchio_aba(seed):
    pin = pytest.importorskip("pinocchio")
    rng = np.random.default_rng(400 + seed)
    tree, params, values = treekit.random_tree(rng, 4)
    kin = Kinematics(tree)
    loads = []
    for i in range(len(tree.bodies)):
        point, force, torque = (tuple(float(c) for c in rng.normal(size=3)) for _ in range(3))
        kin.add_force(i, point, force)
        kin.add_torque(i, torque)
        loads.append((np.array(point), np.array(force), np.array(torque)))
    eqs = derive_equations(kin)
    x = treekit.random_state(rng, tree)
    model = treekit.pinocchio_model(tree, dict(zip(params, values)))
    data = model.createData()
    qp, vp, P = treekit.pinocchio_state(tree, x)
    pin.forwardKinematics(model, data, qp, vp)
    fext = [pin.Force.Zero()]
    for i, body in enumerate(tree.bodies):
        point, force, torque = loads[i]
        Rb, rb = (np.array(sp.Matrix(X).evalf(), dtype=float).reshape(s) for X, s in
                  zip(body.X_child_joint, ((3, 3), (3,))))
        R = data.oMi[i + 1].rotation  # frame b -> world
        f_b, p_b = R.T @ force, Rb.T @ (point - rb)
        fext.append(pin.Force(f_b, np.cross(p_b, f_b) + R.T @ torque))
    a_pin = pin.aba(model, data, qp, vp, np.zeros(tree.nv), fext)
    unloaded = pin.aba(model, model.createData(), qp, vp, np.zeros(tree.nv))
    _, vdot = treekit.pinocchio_dynamics(model, tree, x)  # Pinocchio without loads, in our coordinates
    # Our free-joint accelerations are R (a_pin + omega x v_pin): affine in a_pin, so the loads' share is
    # P^-1 (a_pin - a_pin without loads).
    ours = treekit.evaluate(eqs, params, 0.0, x, values)
    np.testing.assert_allclose(ours["vdot"] - vdot, np.linalg.solve(P, a_pin - unloaded), atol=TOL)
    np.testing.assert_allclose(np.linalg.solve(ours["M"], ours["f"]), ours["vdot"], atol=TOL)


# ---- the line force against a hand calculation ------------------------------------------------------------------

def test_line_force_spring_damper():
    # An arm turning about the world z axis and a slider moving along x, both on the ground (so M is diagonal and
    # k = 0: the arm's centre of mass is on its axis, and it turns about a principal axis). A spring-damper from
    # the arm tip (l, 0, 0) to the slider point (0, h, 0): f must be exactly the generalized spring force.
    l, h, d = 0.8, 0.3, 1.5
    k, c, L0 = sp.symbols("k c L0")
    arm = TreeBody("arm", -1, JointSpec("revolute", ((0, 0, 1),)), (EYE, ZERO), (EYE, ZERO), 1, ZERO,
                   sp.diag(0.1, 0.2, 0.3))
    slider = TreeBody("slider", -1, JointSpec("prismatic", ((1, 0, 0),)), (EYE, (d, 0, 0)), (EYE, ZERO), 2, ZERO,
                      sp.eye(3))
    kin = Kinematics(Tree((arm, slider), (0, 0, -9.81)))
    kin.add_line_force("arm", (l, 0, 0), "slider", (0, h, 0), lambda L, rate: k * (L - L0) + c * rate)
    eqs = derive_equations(kin)
    params = [k, c, L0]
    p = [120.0, 4.0, 0.5]
    phi, s, dphi, ds = 0.4, -0.2, 1.1, -0.7
    out = treekit.evaluate(eqs, params, 0.0, [phi, s, dphi, ds], p)

    pa = np.array([l * math.cos(phi), l * math.sin(phi), 0.0])
    pb = np.array([d + s, h, 0.0])
    va = l * dphi * np.array([-math.sin(phi), math.cos(phi), 0.0])
    vb = np.array([ds, 0.0, 0.0])
    L = np.linalg.norm(pb - pa)
    e = (pb - pa) / L
    T = p[0] * (L - p[2]) + p[1] * e @ (vb - va)
    expected = [np.cross(pa, T * e)[2], -T * e[0]]  # tension pulls the tip toward the slider and back
    np.testing.assert_allclose(out["f"], expected, rtol=1e-12)
    np.testing.assert_allclose(out["vdot"], np.array(expected) / np.diag(out["M"]), rtol=1e-12)


def test_generalized_force_and_prescribed_ones_dropped():
    Q = sp.Symbol("Q")
    body = TreeBody("wheel", -1, JointSpec("revolute", ((0, 0, 1),)), (EYE, ZERO), (EYE, ZERO), 1, ZERO,
                    sp.diag(1, 1, 2))
    driven = TreeBody("hub", -1, JointSpec("revolute", ((0, 0, 1),)), (EYE, ZERO), (EYE, ZERO), 1, ZERO,
                      sp.eye(3), (3 * t,))
    kin = Kinematics(Tree((body, driven), (0, 0, -9.81)))
    kin.add_generalized_force("wheel", 0, Q)
    kin.add_generalized_force("hub", 0, 100 * Q)  # on a prescribed coordinate: no effect on the states
    out = treekit.evaluate(derive_equations(kin), [Q], 0.0, [0.3, 0.5], [1.5])
    np.testing.assert_allclose(out["f"], [1.5], rtol=1e-15)
    np.testing.assert_allclose(out["vdot"], [0.75], rtol=1e-15)


# ---- prescribed coordinates against analytic driven pendulums ---------------------------------------------------

def _pendulum(axis, prescribed_kind, prescribed_axis, motion, mass_driver=3):
    m, l, g = sp.symbols("m l g")
    driver = TreeBody("driver", -1, JointSpec(prescribed_kind, (prescribed_axis,)), (EYE, ZERO), (EYE, ZERO),
                      mass_driver, (0.1, 0.2, 0.0), sp.diag(0.3, 0.4, 0.5), (motion,))
    bob = TreeBody("pendulum", 0, JointSpec("revolute", (axis,)), (EYE, ZERO), (EYE, ZERO), m, (0, 0, -l),
                   sp.zeros(3))
    return Tree((driver, bob), (0, 0, -g)), [g, l, m]


def test_pendulum_on_turntable(tmp_path):
    # Swinging in a plane that turns at W about the vertical: theta'' = sin(theta) (W^2 cos(theta) - g/l).
    W = sp.Symbol("W")
    tree, params = _pendulum((1, 0, 0), "revolute", (0, 0, 1), W * t)
    assert tree.nq == 1 and tree.nv == 1
    eqs = derive_equations(Kinematics(tree))
    params = [W] + params
    p = [2.5, 9.81, 0.7, 1.3]
    c = treekit.CModel(generate_c(eqs, params, "turntable"), tmp_path)
    for t_value, theta, dtheta in ((0.0, 0.4, -1.0), (1.7, 2.0, 0.3)):
        expected = math.sin(theta) * (p[0]**2 * math.cos(theta) - p[1] / p[2])
        x = [theta, dtheta]
        for out in (treekit.evaluate(eqs, params, t_value, x, p), c.evaluate(t_value, x, p)):
            np.testing.assert_allclose(out["vdot"], [expected], rtol=1e-12)
            np.testing.assert_allclose(out["f"] / out["M"][0], [expected], rtol=1e-12)


def test_pendulum_with_shaken_pivot():
    # The pivot slides along x with s = A sin(w t): theta'' = (s'' cos(theta) - g sin(theta)) / l, which needs the
    # prescribed acceleration (second time derivative).
    A, w = sp.symbols("A w")
    tree, params = _pendulum((0, 1, 0), "prismatic", (1, 0, 0), A * sp.sin(w * t))
    eqs = derive_equations(Kinematics(tree))
    params = [A, w] + params
    p = [0.2, 5.0, 9.81, 0.7, 1.3]
    for t_value, theta, dtheta in ((0.3, 0.4, -1.0), (1.1, -2.0, 0.6)):
        s_dd = -p[0] * p[1]**2 * math.sin(p[1] * t_value)
        expected = (s_dd * math.cos(theta) - p[2] * math.sin(theta)) / p[3]
        out = treekit.evaluate(eqs, params, t_value, [theta, dtheta], p)
        np.testing.assert_allclose(out["vdot"], [expected], rtol=1e-12)
        np.testing.assert_allclose(out["f"] / out["M"][0], [expected], rtol=1e-12)


def test_joint_coordinate_queries():
    W = sp.Symbol("W")
    tree, _ = _pendulum((1, 0, 0), "revolute", (0, 0, 1), W * t**2)
    kin = Kinematics(tree)
    assert kin.joint_coordinate("pendulum", 0) == tree.q_symbols[0]
    assert kin.joint_velocity("pendulum", 0) == tree.v_symbols[0]
    values = _values(kin, [kin.joint_coordinate("driver", 0), kin.joint_velocity("driver", 0)], [W], [1.5],
                      [0.0, 0.0], t_value=2.0)
    np.testing.assert_allclose(values, [6.0, 6.0], rtol=1e-15)
