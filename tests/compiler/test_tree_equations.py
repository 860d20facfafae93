"""The equations against sympy.physics.mechanics (Kane's method), and the written-out display form.

Kane's equations and ours are both exact symbolic forms of the same mechanics; evaluated in double precision
they agree to ~1e-14 on this O(1) example, TOL = 1e-9 as in the other oracle tests."""

import sys
from pathlib import Path

import numpy as np
import sympy as sp
import sympy.physics.mechanics as me

sys.path.insert(0, str(Path(__file__).parent))
import treekit  # noqa: E402

from mbs.compiler.equations import derive_equations, display_equations  # noqa: E402
from mbs.compiler.kinematics import Kinematics  # noqa: E402
from mbs.compiler.tree import JointSpec, Tree, TreeBody  # noqa: E402

TOL = 1e-9
EYE, ZERO = sp.eye(3), (0, 0, 0)
R = sp.Rational

# Three links: joint axes in their frame a, joint positions in the parent, frame-a rotations about the parent's z.
AXES = ((0, 0, 1), (1, 0, 0), (0, R(3, 5), R(4, 5)))
JOINT_AT = ((0, 0, 0), (R(1, 2), 0, -R(1, 10)), (0, R(3, 10), -R(3, 5)))
FRAME_A_ANGLE = (0, 0, R(3, 10))
COM = ((R(3, 10), R(1, 10), -R(1, 5)), (R(1, 10), R(1, 5), -R(2, 5)), (-R(1, 10), 0, -R(3, 10)))
INERTIA = ((R(1, 10), R(1, 5), R(3, 10), R(1, 100), R(-1, 50), R(1, 40)),
           (R(1, 5), R(1, 10), R(1, 4), R(-1, 100), R(1, 50), 0),
           (R(1, 20), R(1, 10), R(1, 8), 0, R(1, 60), R(-1, 70)))  # ixx, iyy, izz, ixy, iyz, izx


def _inertia_matrix(ixx, iyy, izz, ixy, iyz, izx):
    return sp.Matrix([[ixx, ixy, izx], [ixy, iyy, iyz], [izx, iyz, izz]])


def _our_chain(m, g):
    bodies = []
    for i in range(3):
        a = FRAME_A_ANGLE[i]
        Rz = sp.Matrix([[sp.cos(a), -sp.sin(a), 0], [sp.sin(a), sp.cos(a), 0], [0, 0, 1]])
        bodies.append(TreeBody(f"link{i + 1}", i - 1, JointSpec("revolute", (AXES[i],)), (Rz, JOINT_AT[i]),
                               (EYE, ZERO), m[i], COM[i], _inertia_matrix(*INERTIA[i])))
    return Tree(tuple(bodies), (0, 0, -g))


def _kane_chain(m, g):
    """(mass matrix, forcing, q, u) by KanesMethod, with M(q) u' = forcing(q, u)."""
    q, u = me.dynamicsymbols("q1:4"), me.dynamicsymbols("u1:4")
    N = me.ReferenceFrame("N")
    origin = me.Point("O")
    origin.set_vel(N, 0)
    parent, joint_point, bodies, loads = N, origin, [], []
    for i in range(3):
        A = me.ReferenceFrame(f"A{i + 1}")
        A.orient_axis(parent, parent.z, FRAME_A_ANGLE[i])
        A.set_ang_vel(parent, 0)
        B = me.ReferenceFrame(f"B{i + 1}")
        axis = sum((c * e for c, e in zip(AXES[i], (A.x, A.y, A.z))), me.Vector(0))
        B.orient_axis(A, axis, q[i])
        B.set_ang_vel(A, u[i] * axis)
        offset = sum((c * e for c, e in zip(JOINT_AT[i], (parent.x, parent.y, parent.z))), me.Vector(0))
        P = joint_point.locatenew(f"P{i + 1}", offset)
        if parent is N:
            P.set_vel(N, 0)
        else:
            P.v2pt_theory(joint_point, N, parent)
        G = P.locatenew(f"G{i + 1}", sum((c * e for c, e in zip(COM[i], (B.x, B.y, B.z))), me.Vector(0)))
        G.v2pt_theory(P, N, B)
        bodies.append(me.RigidBody(f"b{i + 1}", G, B, m[i], (me.inertia(B, *INERTIA[i]), G)))
        loads.append((G, -m[i] * g * N.z))
        parent, joint_point = B, P
    kane = me.KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=[qi.diff() - ui for qi, ui in zip(q, u)])
    kane.kanes_equations(bodies, loads)
    return kane.mass_matrix, kane.forcing, q, u


def test_spatial_chain_matches_kanes_method():
    m = sp.symbols("m1:4")
    g = sp.Symbol("g")
    params = list(m) + [g]
    p = [1.3, 0.8, 0.6, 9.81]
    M_kane, F_kane, q, u = _kane_chain(m, g)
    tree = _our_chain(m, g)
    eqs = derive_equations(Kinematics(tree))
    rng = np.random.default_rng(11)
    for _ in range(3):
        x = rng.uniform(-2, 2, size=6)
        subs = dict(zip(list(q) + list(u) + params, list(x) + p))
        M_ref = np.array(M_kane.xreplace(subs).evalf(), dtype=float)
        F_ref = np.array(F_kane.xreplace(subs).evalf(), dtype=float).ravel()
        out = treekit.evaluate(eqs, params, 0.0, x, p)
        np.testing.assert_allclose(out["M"], M_ref, rtol=0, atol=TOL)
        np.testing.assert_allclose(out["f"], F_ref, rtol=0, atol=TOL)
        np.testing.assert_allclose(out["vdot"], np.linalg.solve(M_ref, F_ref), rtol=0, atol=TOL)


def test_display_form_of_the_chain_matches_kane():
    # The written-out M, k, q (substituting the tape back) are the same equations: M vdot + k = q.
    m = sp.symbols("m1:4")
    g = sp.Symbol("g")
    M_kane, F_kane, q, u = _kane_chain(m, g)
    tree = _our_chain(m, g)
    M, k, qe = display_equations(Kinematics(tree), simplify=False)
    subs = dict(zip(list(q) + list(u) + list(m) + [g], [0.3, -1.1, 0.7, 0.5, 1.2, -0.4, 1.3, 0.8, 0.6, 9.81]))
    ours = dict(zip(tree.q_symbols + tree.v_symbols, [subs[s] for s in list(q) + list(u)]))
    ours.update({s: subs[s] for s in list(m) + [g]})
    num = lambda e, s: np.array(e.xreplace(s).evalf(), dtype=float)  # noqa: E731
    np.testing.assert_allclose(num(M, ours), num(M_kane, subs), atol=TOL)
    np.testing.assert_allclose(num(qe - k, ours), num(F_kane, subs), atol=TOL)
    # k holds the velocity terms only, q the weights only.
    at_rest = {**ours, **{s: 0 for s in tree.v_symbols}}
    np.testing.assert_allclose(num(k, at_rest), 0, atol=1e-15)
    assert not (qe.free_symbols & set(tree.v_symbols))


def test_simple_pendulum_display():
    m, l, g = sp.symbols("m l g", positive=True)
    arm = TreeBody("arm", -1, JointSpec("revolute", ((0, 1, 0),)), (EYE, ZERO), (EYE, ZERO), m, (0, 0, -l),
                   sp.zeros(3))
    tree = Tree((arm,), (0, 0, -g))
    M, k, q = display_equations(Kinematics(tree))
    phi, dd = tree.q_symbols[0], sp.Symbol("phi''")
    assert M == sp.Matrix([[m * l**2]])
    assert k == sp.Matrix([[0]])
    assert q == sp.Matrix([[-m * g * l * sp.sin(phi)]])
    assert sp.simplify(M[0] * dd + k[0] - q[0] - (m * l**2 * dd + m * g * l * sp.sin(phi))) == 0


def test_double_pendulum_display_is_the_textbook_form():
    # Planar double pendulum of point masses (rotations about y): the classical equations.
    m1, m2, l1, l2, g = sp.symbols("m1 m2 l1 l2 g", positive=True)
    y = ((0, 1, 0),)
    link1 = TreeBody("a", -1, JointSpec("revolute", y), (EYE, ZERO), (EYE, ZERO), m1, (0, 0, -l1), sp.zeros(3))
    link2 = TreeBody("b", 0, JointSpec("revolute", y), (EYE, (0, 0, -l1)), (EYE, ZERO), m2, (0, 0, -l2),
                     sp.zeros(3))
    tree = Tree((link1, link2), (0, 0, -g))
    M, k, q = display_equations(Kinematics(tree))
    t1, t2 = tree.q_symbols
    w1, w2 = tree.v_symbols
    expected_M = sp.Matrix([[(m1 + m2) * l1**2 + m2 * l2**2 + 2 * m2 * l1 * l2 * sp.cos(t2),
                             m2 * l2**2 + m2 * l1 * l2 * sp.cos(t2)],
                            [m2 * l2**2 + m2 * l1 * l2 * sp.cos(t2), m2 * l2**2]])
    expected_k = sp.Matrix([-m2 * l1 * l2 * sp.sin(t2) * (2 * w1 * w2 + w2**2), m2 * l1 * l2 * sp.sin(t2) * w1**2])
    expected_q = sp.Matrix([-(m1 + m2) * g * l1 * sp.sin(t1) - m2 * g * l2 * sp.sin(t1 + t2),
                            -m2 * g * l2 * sp.sin(t1 + t2)])
    for ours, ref in ((M, expected_M), (k, expected_k), (q, expected_q)):
        assert (ours - ref).applyfunc(lambda e: sp.simplify(sp.expand_trig(e))) == sp.zeros(*ref.shape)
