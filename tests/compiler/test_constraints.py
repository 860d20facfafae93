"""Loop-closure constraints of cut joints: every kind against the tree joint of the same kind (a motion the joint
allows satisfies its rows), the rows' null space against the kind's motion subspace, the derivatives against
finite differences, and the generated C against the tape."""

import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

sys.path.insert(0, str(Path(__file__).parent))
import treekit  # noqa: E402

from mbs.compiler.ccode import generate_loop_c  # noqa: E402
from mbs.compiler.ccode_loops import loop_work_size  # noqa: E402
from mbs.compiler.constraints import ROWS, CutJoint, derive_constraints  # noqa: E402
from mbs.compiler.equations import derive_equations  # noqa: E402
from mbs.compiler.kinematics import Kinematics  # noqa: E402
from mbs.compiler.tree import JointSpec, Tree, TreeBody, TreeError, t  # noqa: E402

KINDS = tuple(ROWS)
#: Degrees of freedom each kind leaves between its frames.
DOF = {"fixed": 0, "revolute": 1, "prismatic": 1, "cylindrical": 2, "universal": 2, "planar": 3, "spherical": 3,
       "free": 6}
LOOPS_C = Path(__file__).parents[2] / "runtime" / "c" / "loops.c"


def _unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def _axes(kind, rng):
    """Random unit axes of a kind; the two of universal and planar joints perpendicular."""
    n = _unit(rng.normal(size=3))
    if kind in ("revolute", "prismatic", "cylindrical"):
        return (tuple(n),)
    if kind in ("universal", "planar"):
        return (tuple(n), tuple(_unit(np.cross(n, rng.normal(size=3)))))
    return ()


def _pose(rng):
    return sp.Matrix(treekit.random_rotation(rng).tolist()), tuple(rng.normal(size=3) * 0.3)


def _body(name, parent, spec, X_parent, X_child, prescribed=()):
    return TreeBody(name, parent, spec, X_parent, X_child, 1.0, (0.1, 0.0, 0.0), sp.eye(3) * 0.1, prescribed)


def _pair(kind, rng, *, joined_by=None, rotation="quaternion"):
    """(tree, cut): body A on a free joint from the ground, body B on a joint of kind `joined_by` (default: kind)
    from A with frames a, b, and a cut joint of `kind` between the same frames."""
    axes = _axes(kind, rng)
    Xa, Xb = _pose(rng), _pose(rng)
    between = JointSpec(joined_by or kind, axes if joined_by is None else (), rotation)
    tree = Tree((_body("A", -1, JointSpec("free", (), rotation), _pose(rng), _pose(rng)),
                 _body("B", 0, between, Xa, Xb)), (0, 0, -9.81))
    return tree, CutJoint("cut", JointSpec(kind, axes), 0, Xa, 1, Xb)


def _evaluator(tree, cuts):
    kin = Kinematics(tree)
    cons = derive_constraints(kin, cuts)
    f = treekit.numeric_function(cons, [], cons.outputs())
    nc = cons.nc

    def evaluate(t_value, x):
        values = np.array(f(t_value, list(x), []))
        return values[:nc], values[nc:2 * nc], values[2 * nc:]
    return cons, evaluate


@pytest.mark.parametrize("kind", KINDS)
def test_a_motion_the_joint_allows_satisfies_its_rows(kind):
    """B moved by a tree joint of the cut's own kind: g, gdot and gddot (vdot = 0) vanish at any state."""
    rng = np.random.default_rng(KINDS.index(kind))
    tree, cut = _pair(kind, rng)
    cons, evaluate = _evaluator(tree, [cut])
    assert cons.nc == len(ROWS[kind]) == 6 - DOF[kind]
    assert cons.names == tuple(f"cut.{label}" for label in ROWS[kind])
    for _ in range(5):
        g, gd, gdd = evaluate(0.0, treekit.random_state(rng, tree))
        assert np.max(np.abs(np.concatenate([g, gd, gdd])), initial=0.0) < 1e-12


@pytest.mark.parametrize("kind", KINDS)
def test_the_rows_leave_exactly_the_joints_motions(kind):
    """B on a free joint at the pose where the frames coincide: G on B's six velocities has full row rank and its
    null space is the kind's motion subspace (free-joint velocities: translation in a, rotation in b)."""
    rng = np.random.default_rng(10 + KINDS.index(kind))
    tree, cut = _pair(kind, rng, joined_by="free")
    cons, evaluate = _evaluator(tree, [cut])
    x = treekit.random_state(rng, tree)
    x[7:14] = [0, 0, 0, 1, 0, 0, 0]  # B: no translation, identity quaternion
    nq = tree.nq
    g0, base, _ = evaluate(0.0, np.concatenate([x[:nq], np.zeros(tree.nv)]))
    assert np.max(np.abs(g0), initial=0.0) < 1e-12
    G = np.column_stack([evaluate(0.0, np.concatenate([x[:nq], e]))[1] - base for e in np.eye(tree.nv)])
    GB = G[:, 6:]
    assert np.linalg.matrix_rank(GB, tol=1e-9) == cons.nc
    zero = np.zeros(3)
    axes = [np.array(a, dtype=float) for a in cut.joint.axes] + [zero, zero]
    motions = {
        "fixed": [], "spherical": [np.r_[zero, e] for e in np.eye(3)], "free": [],
        "revolute": [np.r_[zero, axes[0]]], "prismatic": [np.r_[axes[0], zero]],
        "cylindrical": [np.r_[axes[0], zero], np.r_[zero, axes[0]]],
        "universal": [np.r_[zero, axes[0]], np.r_[zero, axes[1]]],
        "planar": [np.r_[axes[1], zero], np.r_[np.cross(axes[0], axes[1]), zero], np.r_[zero, axes[0]]],
    }[kind]
    for m in motions:
        assert np.max(np.abs(GB @ m), initial=0.0) < 1e-12


def test_derivatives_are_the_time_derivatives_of_the_rows():
    """Along q(t) = q0 + v t (cardan rotations: qdot = v) with a prescribed coordinate moving with t: gdot is
    dg/dt and gddot (vdot = 0) is d(gdot)/dt, by central differences."""
    rng = np.random.default_rng(7)
    cuts, bodies = [], [_body("A", -1, JointSpec("free", (), "cardan"), _pose(rng), _pose(rng))]
    bodies.append(_body("B", 0, JointSpec("free", (), "cardan"), _pose(rng), _pose(rng),
                        (0.1 * sp.sin(3 * t), None, None, None, None, None)))
    for kind in KINDS:
        cuts.append(CutJoint(kind, JointSpec(kind, _axes(kind, rng)), 0, _pose(rng), 1, _pose(rng)))
    cuts.append(CutJoint("to_ground", JointSpec("revolute", _axes("revolute", rng)), -1, _pose(rng), 1, _pose(rng)))
    tree = Tree(tuple(bodies), (0, 0, -9.81))
    cons, evaluate = _evaluator(tree, cuts)
    assert cons.nc == sum(len(ROWS[k]) for k in KINDS) + 5
    x = treekit.random_state(rng, tree)
    nq = tree.nq
    q0, v = x[:nq], x[nq:]
    h = 1e-5

    def at(time):
        return evaluate(time, np.concatenate([q0 + v * time, v]))
    t0 = 0.4
    (g_p, gd_p, _), (g_m, gd_m, _), (_, gd, gdd) = at(t0 + h), at(t0 - h), at(t0)
    assert np.allclose(gd, (g_p - g_m) / (2 * h), rtol=1e-7, atol=1e-8)
    assert np.allclose(gdd, (gd_p - gd_m) / (2 * h), rtol=1e-6, atol=1e-7)


def test_planar_mechanisms_fold_the_out_of_plane_rows_to_zero():
    """A slider-crank in the x-z plane: the y row and both tilt rows of its revolute cut are exact zeros."""
    eye = sp.eye(3)
    axis = ((0, -1, 0),)
    crank = _body("crank", -1, JointSpec("revolute", axis), (eye, (0, 0, 0)), (eye, (0, 0, 0)))
    rod = _body("rod", 0, JointSpec("revolute", axis), (eye, (sp.Rational(1, 10), 0, 0)), (eye, (0, 0, 0)))
    slider = _body("slider", -1, JointSpec("prismatic", ((1, 0, 0),)), (eye, (0, 0, 0)), (eye, (0, 0, 0)))
    tree = Tree((crank, rod, slider), (0, 0, 0))
    cons = derive_constraints(Kinematics(tree), [CutJoint("wrist", JointSpec("revolute", axis), 1,
                                                          (eye, (sp.Rational(2, 5), 0, 0)), 2, (eye, (0, 0, 0)))])
    for rows in (cons.position, cons.velocity, cons.acceleration):
        assert [rows[k] for k in (1, 3, 4)] == [0, 0, 0]
        assert all(rows[k] != 0 for k in (0, 2))


def test_bad_cut_joints_are_refused():
    rng = np.random.default_rng(3)
    tree, _ = _pair("revolute", rng)
    kin = Kinematics(tree)
    with pytest.raises(TreeError, match="numeric"):
        derive_constraints(kin, [CutJoint("c", JointSpec("revolute", ((sp.Symbol("a"), 0, 0),)), 0, _pose(rng), 1,
                                          _pose(rng))])
    with pytest.raises(TreeError, match="itself"):
        derive_constraints(kin, [CutJoint("c", JointSpec("spherical"), 1, _pose(rng), 1, _pose(rng))])
    with pytest.raises(TreeError, match="not in the tree"):
        derive_constraints(kin, [CutJoint("c", JointSpec("spherical"), 0, _pose(rng), 5, _pose(rng))])


def test_generated_c_matches_the_tape_and_runs_standalone(tmp_path):
    """The generated file plus runtime/c/loops.c compiles with -Werror as one standalone library (no Python);
    its constraint functions equal the tape's values, and its mbs_rhs / mbs_project run."""
    import ctypes
    rng = np.random.default_rng(5)
    tree, cut = _pair("spherical", rng, joined_by="free")
    kin = Kinematics(tree)
    cons = derive_constraints(kin, [cut])
    eqs = derive_equations(kin, forward_dynamics=False)
    source = generate_loop_c(eqs, cons, [], "pair") + "\n" + LOOPS_C.read_text()
    work = loop_work_size(tree.nq, tree.nv, 3)
    for line in ("#define MBS_NC 3", "#define MBS_NQUAT 2", "static const int mbs_quaternion_slots[2] = {3, 10};",
                 f"#define MBS_NWORK {tree.nv ** 2 + work}", f"#define MBS_LOOP_NWORK {work}"):
        assert line in source
    lib = treekit.CModel(source, tmp_path, "pair")
    dp = ctypes.POINTER(ctypes.c_double)
    for fn in ("mbs_constraints", "mbs_constraint_velocity", "mbs_constraint_acceleration", "mbs_project"):
        getattr(lib.lib, fn).argtypes = [ctypes.c_double, dp, dp, dp, dp]
    lib.lib.mbs_constraint_name.restype = ctypes.c_char_p
    assert lib.lib.mbs_constraint_name(2) == b"cut.z" and lib.lib.mbs_constraint_name(3) is None
    f = treekit.numeric_function(cons, [], cons.outputs())
    for _ in range(3):
        x = treekit.random_state(rng, tree)
        expected = np.array(f(0.2, list(x), []))
        got = np.concatenate([lib.call(fn, 0.2, x, [], 3)[1] for fn in
                              ("mbs_constraints", "mbs_constraint_velocity", "mbs_constraint_acceleration")])
        assert np.allclose(got, expected, rtol=1e-13, atol=1e-13)
        status, projected = lib.call("mbs_project", 0.2, x, [], tree.nx)
        assert status == 0
        assert np.max(np.abs(f(0.2, list(projected), [])[:6])) < 1e-11  # g and gdot hold
        status, xdot = lib.call("mbs_rhs", 0.2, x, [], tree.nx)
        assert status == 0 and np.all(np.isfinite(xdot))
