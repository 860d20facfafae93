"""The symbolic O(n) algorithms against Pinocchio, on seeded random spatial trees.

Tolerance: the compared quantities are O(1..100) and come out of ~1e3 floating-point operations on either side,
so both codes agree to ~1e-12 (observed: below 1e-12); a wrong term in any recursion shows up at O(1e-2) or more.
TOL = 1e-9 sits safely between the two.
"""

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
from mbs.compiler.tree import JointSpec, Tree, TreeBody  # noqa: E402

pin = pytest.importorskip("pinocchio")

TOL = 1e-9
SEEDS = list(range(8)) + [pytest.param(seed, marks=pytest.mark.slow) for seed in range(8, 40)]


def _case(seed, **kwargs):
    rng = np.random.default_rng(seed)
    tree, params, values = treekit.random_tree(rng, int(rng.integers(2, 7)), **kwargs)
    eqs = derive_equations(Kinematics(tree))
    return rng, tree, params, values, eqs


def _assert_dynamics(out, M, vdot):
    np.testing.assert_allclose(out["M"], M, rtol=0, atol=TOL)
    np.testing.assert_allclose(out["vdot"], vdot, rtol=0, atol=TOL)
    # The forces of the RNEA and the mass matrix of the CRBA give the same accelerations as the ABA.
    np.testing.assert_allclose(np.linalg.solve(out["M"], out["f"]), vdot, rtol=0, atol=TOL)


@pytest.mark.parametrize("seed", SEEDS)
def test_tape_matches_pinocchio_crba_and_aba(seed):
    rng, tree, params, values, eqs = _case(seed)
    model = treekit.pinocchio_model(tree, dict(zip(params, values)))
    numeric = treekit.NumericModel(eqs, params)
    for _ in range(3):
        x = treekit.random_state(rng, tree)
        M, vdot = treekit.pinocchio_dynamics(model, tree, x)
        _assert_dynamics(numeric(0.0, x, values), M, vdot)


@pytest.mark.parametrize("seed", [1] + [pytest.param(s, marks=pytest.mark.slow) for s in (0, 2, 3, 4, 5, 6)])
def test_compiled_c_matches_pinocchio(seed, tmp_path):
    rng, tree, params, values, eqs = _case(seed)
    model = treekit.pinocchio_model(tree, dict(zip(params, values)))
    c = treekit.CModel(generate_c(eqs, params, f"random{seed}"), tmp_path)
    assert c.warnings == ""
    for _ in range(3):
        x = treekit.random_state(rng, tree)
        M, vdot = treekit.pinocchio_dynamics(model, tree, x)
        out = c.evaluate(0.0, x, values)
        _assert_dynamics(out, M, vdot)
        np.testing.assert_allclose(out["xdot"][:tree.nq], out["qdot"], rtol=0, atol=0)


@pytest.mark.parametrize("seed", [0] + [pytest.param(s, marks=pytest.mark.slow) for s in (1, 2)])
def test_any_topological_order(seed):
    # Our trees need not be depth-first (Pinocchio's crba needs it; its rnea columns do not).
    rng, tree, params, values, eqs = _case(50 + seed, depth_first=False)
    model = treekit.pinocchio_model(tree, dict(zip(params, values)))
    x = treekit.random_state(rng, tree)
    M, vdot = treekit.pinocchio_dynamics(model, tree, x)
    _assert_dynamics(treekit.evaluate(eqs, params, 0.0, x, values), M, vdot)


def _unit(rng):
    a = rng.normal(size=3)
    return tuple(float(x) for x in a / np.linalg.norm(a))


def _composite_tree(rng):
    """A random tree with cylindrical, universal, planar and cardan spherical/free joints."""
    base, params, values = treekit.random_tree(rng, int(rng.integers(2, 5)), ("revolute",))
    bodies = []
    for b in base.bodies:
        kind = ["cylindrical", "universal", "planar", "spherical", "free"][rng.integers(5)]
        axes = {"cylindrical": lambda: (_unit(rng),), "universal": lambda: (_unit(rng), _unit(rng)),
                "spherical": lambda: (), "free": lambda: ()}.get(kind)
        if kind == "planar":
            n = np.array(_unit(rng))
            u = np.cross(n, rng.normal(size=3))
            axes = (tuple(map(float, n)), tuple(map(float, u / np.linalg.norm(u))))
        else:
            axes = axes()
        bodies.append(TreeBody(b.name, b.parent, JointSpec(kind, axes, "cardan"), b.X_parent_joint,
                               b.X_child_joint, b.mass, b.com, b.inertia))
    return Tree(tuple(bodies), base.gravity), params, values


@pytest.mark.parametrize("seed", range(6))
def test_composite_joints_match_single_axis_chains(seed):
    # Pinocchio runs the same mechanism with each composite joint split into revolute/prismatic joints joined by
    # massless bodies; the coordinates, and so the states, are the same.
    rng = np.random.default_rng(200 + seed)
    tree, params, values = _composite_tree(rng)
    flat = treekit.decompose(tree)
    assert flat.nq == tree.nq and flat.nv == tree.nv
    model = treekit.pinocchio_model(flat, dict(zip(params, values)))
    eqs = derive_equations(Kinematics(tree))
    x = treekit.random_state(rng, tree)
    M, vdot = treekit.pinocchio_dynamics(model, flat, x)
    _assert_dynamics(treekit.evaluate(eqs, params, 0.0, x, values), M, vdot)


def test_quaternion_kinematic_map():
    # qdot = G(q) v must make R(q)^T dR/dt = [omega]x with omega the child-frame angular velocity (the
    # convention of Pinocchio's spherical joint). dR/dt by central differences: error O(h^2) = 1e-12.
    body = TreeBody("ball", -1, JointSpec("spherical"), (sp.eye(3), (0, 0, 0)), (sp.eye(3), (0, 0, 0)), 1,
                    (0, 0, -1), sp.eye(3))
    tree = Tree((body,), (0, 0, -9.81))
    eqs = derive_equations(Kinematics(tree))
    rng = np.random.default_rng(7)
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    w = rng.normal(size=3)
    qdot = treekit.evaluate(eqs, [], 0.0, np.concatenate([q, w]), [])["qdot"]
    h = 1e-6
    dR = (treekit.quaternion_matrix(q + h * qdot) - treekit.quaternion_matrix(q - h * qdot)) / (2 * h)
    W = treekit.quaternion_matrix(q).T @ dR
    np.testing.assert_allclose([W[2, 1], W[0, 2], W[1, 0]], w, atol=1e-8)
    assert abs(q @ qdot) < 1e-15  # the unit length is kept


def test_fixed_joint_equals_merged_body():
    # A body welded to a pendulum adds its inertia, moved to the pendulum's frame (parallel axis theorem).
    m1, m2 = 2.0, 0.5
    c2 = np.array([0.2, -0.1, -1.0])  # centre of mass of the welded body in the pendulum frame
    J2 = np.diag([0.01, 0.02, 0.03])
    axis = ((0, 1, 0),)
    eye, zero = sp.eye(3), (0, 0, 0)
    arm = TreeBody("arm", -1, JointSpec("revolute", axis), (eye, zero), (eye, zero), m1, (0, 0, -0.5),
                   sp.diag(0.1, 0.1, 0.01))
    weight = TreeBody("weight", 0, JointSpec("fixed"), (eye, tuple(c2)), (eye, zero), m2, zero, sp.Matrix(J2))
    welded = derive_equations(Kinematics(Tree((arm, weight), (0, 0, -9.81))))
    com = (m1 * np.array([0, 0, -0.5]) + m2 * c2) / (m1 + m2)
    shift = lambda m, d: m * (d @ d * np.eye(3) - np.outer(d, d))  # noqa: E731
    J = (np.diag([0.1, 0.1, 0.01]) + shift(m1, np.array([0, 0, -0.5]) - com) + J2 + shift(m2, c2 - com))
    merged = TreeBody("arm", -1, JointSpec("revolute", axis), (eye, zero), (eye, zero), m1 + m2, tuple(com),
                      sp.Matrix(J))
    single = derive_equations(Kinematics(Tree((merged,), (0, 0, -9.81))))
    x = [0.7, -1.3]
    a, b = treekit.evaluate(welded, [], 0.0, x, []), treekit.evaluate(single, [], 0.0, x, [])
    for key in ("M", "f", "vdot"):
        np.testing.assert_allclose(a[key], b[key], rtol=1e-13, atol=1e-13)
