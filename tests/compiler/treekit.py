"""Oracles and harnesses for the tree-dynamics tests: a numeric evaluator of the tape, a ctypes harness for the
generated C, seeded random trees, and the same trees built in Pinocchio."""

from __future__ import annotations

import ctypes
import math
import subprocess
from pathlib import Path

import numpy as np
import sympy as sp
from sympy.printing.str import StrPrinter

from mbs.compiler.equations import Equations
from mbs.compiler.tree import JointSpec, Tree, TreeBody, t

GCC_FLAGS = ["-O2", "-Wall", "-Wextra", "-std=c99", "-Werror", "-shared", "-fPIC"]


# ---- numeric evaluation of the tape ----------------------------------------------------------------------------

class _Printer(StrPrinter):
    """Python text of an expression (sympy's str printer, with our names and full-precision floats)."""

    def __init__(self, names):
        super().__init__()
        self.names = names

    def _print_Symbol(self, expr):
        return self.names[expr]

    _print_Dummy = _print_Symbol

    def _print_Float(self, expr):
        return repr(float(expr))


_SCOPE = {"sin": math.sin, "cos": math.cos, "tan": math.tan, "sqrt": math.sqrt, "exp": math.exp,
          "log": math.log, "Abs": abs, "atan2": math.atan2, "pi": math.pi}


def numeric_function(eqs: Equations, parameters, outputs):
    """f(t, x, p) -> list of floats, evaluating `outputs` (expressions on eqs.tape) in order, in plain Python.
    Independent of the C printer: sympy's own str printer writes the expressions."""
    tree, tape = eqs.tree, eqs.tape
    names = {t: "t"}
    names.update({s: f"x[{k}]" for k, s in enumerate(tree.q_symbols + tree.v_symbols)})
    names.update({s: f"p[{k}]" for k, s in enumerate(parameters)})
    entries = tape.entries_for(outputs)
    names.update({e.symbol: f"w{k}" for k, e in enumerate(entries)})
    printer = _Printer(names)
    lines = ["def f(t, x, p):"]
    lines += [f"    {names[e.symbol]} = {printer.doprint(e.expr)}" for e in entries]
    lines.append(f"    return [{', '.join(printer.doprint(sp.sympify(o)) for o in outputs)}]")
    scope = dict(_SCOPE)
    exec("\n".join(lines), scope)
    return scope["f"]


class NumericModel:
    """M, f, qdot, vdot of `eqs` evaluated from the tape in Python (built once, called per state)."""

    def __init__(self, eqs: Equations, parameters):
        self.nq, self.nv = eqs.tree.nq, eqs.tree.nv
        outs = [e for row in eqs.mass_matrix for e in row] + list(eqs.forces) + list(eqs.qdot) + list(eqs.vdot)
        self.function = numeric_function(eqs, parameters, outs)

    def __call__(self, t_value, x, p) -> dict:
        nq, nv = self.nq, self.nv
        values = np.array(self.function(float(t_value), [float(v) for v in x], [float(v) for v in p]))
        return {"M": values[:nv * nv].reshape(nv, nv), "f": values[nv * nv:nv * nv + nv],
                "qdot": values[nv * nv + nv:nv * nv + nv + nq], "vdot": values[nv * nv + nv + nq:]}


def evaluate(eqs: Equations, parameters, t_value, x, p) -> dict:
    """M, f, qdot, vdot of `eqs` at one point, as numpy arrays."""
    return NumericModel(eqs, parameters)(t_value, x, p)


# ---- ctypes harness for the generated C ------------------------------------------------------------------------

class CModel:
    """The four functions of a generated C file, compiled with warnings as errors and loaded with ctypes."""

    def __init__(self, source: str, directory: Path, name: str = "model"):
        c_file, so_file = directory / f"{name}.c", directory / f"{name}.so"
        c_file.write_text(source)
        result = subprocess.run(["gcc", *GCC_FLAGS, "-o", str(so_file), str(c_file), "-lm"],
                                capture_output=True, text=True)
        if result.returncode != 0:
            raise AssertionError(f"gcc failed:\n{result.stderr}")
        self.warnings = result.stderr
        self.lib = ctypes.CDLL(str(so_file))
        self.sizes = {k: _define(source, k) for k in ("MBS_NQ", "MBS_NV", "MBS_NP", "MBS_NWORK")}
        dp = ctypes.POINTER(ctypes.c_double)
        for fn in ("mbs_rhs", "mbs_mass_matrix", "mbs_forces", "mbs_qdot"):
            getattr(self.lib, fn).argtypes = [ctypes.c_double, dp, dp, dp, dp]
            getattr(self.lib, fn).restype = ctypes.c_int
        for fn in ("mbs_state_name", "mbs_parameter_name"):
            getattr(self.lib, fn).argtypes = [ctypes.c_int]
            getattr(self.lib, fn).restype = ctypes.c_char_p

    def call(self, fn: str, t_value, x, p, n_out):
        """(status, output array) of one function."""
        arr = lambda a: np.ascontiguousarray(a, dtype=float)  # noqa: E731
        x, p = arr(x), arr(p if len(p) else [0.0])
        out = np.full(n_out, np.nan)
        work = np.full(max(self.sizes["MBS_NWORK"], 1), np.nan)
        ptr = lambda a: a.ctypes.data_as(ctypes.POINTER(ctypes.c_double))  # noqa: E731
        status = getattr(self.lib, fn)(t_value, ptr(x), ptr(p), ptr(out), ptr(work))
        return status, out

    def evaluate(self, t_value, x, p) -> dict:
        nq, nv = self.sizes["MBS_NQ"], self.sizes["MBS_NV"]
        out = {}
        for key, fn, n in (("M", "mbs_mass_matrix", nv * nv), ("f", "mbs_forces", nv), ("qdot", "mbs_qdot", nq),
                           ("xdot", "mbs_rhs", nq + nv)):
            status, values = self.call(fn, t_value, x, p, n)
            assert status == 0, f"{fn} returned {status}"
            out[key] = values
        out["M"] = out["M"].reshape(nv, nv)
        out["vdot"] = out["xdot"][nq:]
        return out


def _define(source: str, name: str) -> int:
    for line in source.splitlines():
        if line.startswith(f"#define {name} "):
            return int(line.split()[2])
    raise AssertionError(f"{name} not defined")


# ---- random trees -----------------------------------------------------------------------------------------------

def random_rotation(rng) -> np.ndarray:
    q = rng.normal(size=4)
    return quaternion_matrix(q / np.linalg.norm(q))


def quaternion_matrix(q) -> np.ndarray:
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def random_tree(rng, n_bodies: int, kinds=("revolute", "prismatic", "spherical", "free"), depth_first=True):
    """(tree, parameter symbols, parameter values): random topology, placements, axes, inertias. Masses and the
    principal inertias are symbols (run-time parameters), everything else numeric. With `depth_first` the bodies
    are in depth-first order (each subtree contiguous), as Pinocchio's crba requires; otherwise any topological
    order."""
    bodies, params, values, parents = [], [], [], []
    for i in range(n_bodies):
        if depth_first:
            # The parent is the previous body or one of its ancestors (or the ground).
            path, j = [-1], i - 1
            while j >= 0:
                path.append(j)
                j = parents[j]
            parents.append(int(path[rng.integers(len(path))]))
        else:
            parents.append(int(rng.integers(-1, i)) if i else -1)
        kind = kinds[rng.integers(len(kinds))]
        axes = ()
        if kind in ("revolute", "prismatic"):
            # Half of the axes along a coordinate axis, as in most real models (exercises exact zeros).
            a = np.eye(3)[rng.integers(3)] if rng.random() < 0.5 else rng.normal(size=3)
            axes = (tuple(float(x) for x in a / np.linalg.norm(a)),)
        m = sp.Symbol(f"m{i + 1}")
        J = sp.symbols(f"J{i + 1}x J{i + 1}y J{i + 1}z")
        params += [m, *J]
        principal = rng.uniform(0.05, 0.3, size=3)
        values += [float(rng.uniform(0.5, 3.0)), *(float(x) for x in principal)]
        Q = random_rotation(rng)  # principal axes
        inertia = sp.Matrix(3, 3, lambda r, c: sum(float(Q[r, k] * Q[c, k]) * J[k] for k in range(3)))
        def pose():
            return sp.Matrix(random_rotation(rng).tolist()), tuple(float(x) for x in rng.normal(size=3) * 0.4)
        # Half of the bodies have their frame at the joint's frame b (the usual modelling choice).
        child = pose() if rng.random() < 0.5 else (sp.eye(3), (0, 0, 0))
        bodies.append(TreeBody(f"b{i + 1}", parents[i], JointSpec(kind, axes),
                               pose(), child, m, tuple(float(x) for x in rng.normal(size=3) * 0.3), inertia))
    gravity = (0.3, -0.5, -9.81)
    return Tree(tuple(bodies), gravity), params, values


def random_state(rng, tree: Tree) -> np.ndarray:
    """A random state x = [q; v] with unit quaternions."""
    q = []
    for b in tree.bodies:
        nq = len(b.free_coordinates)
        if b.joint.uses_quaternion:
            quat = rng.normal(size=4)
            q += list(rng.normal(size=nq - 4)) + list(quat / np.linalg.norm(quat))
        else:
            q += list(rng.uniform(-1.5, 1.5, size=nq))
    return np.concatenate([q, rng.normal(size=tree.nv)])


# ---- the same tree in Pinocchio ---------------------------------------------------------------------------------

def _se3(pin, R, r):
    return pin.SE3(np.array(R, dtype=float), np.array(r, dtype=float).reshape(3))


def _numeric(e, subs):
    return float(sp.sympify(e).xreplace(subs))


def pinocchio_model(tree: Tree, subs: dict):
    """A Pinocchio model whose joint i+1 carries body i. Pinocchio's joint frame is our frame b, so joint
    placements are inv(X_child_joint of the parent) * X_parent_joint and bodies sit at inv(X_child_joint)."""
    import pinocchio as pin
    model = pin.Model()
    model.gravity = pin.Motion(np.array([_numeric(g, subs) for g in tree.gravity]), np.zeros(3))
    num = lambda M: np.array(sp.Matrix(M).xreplace(subs).evalf(), dtype=float)  # noqa: E731
    for i, b in enumerate(tree.bodies):
        Ra, ra = (num(X) for X in b.X_parent_joint)
        Rb, rb = (num(X) for X in b.X_child_joint)
        placement = _se3(pin, Ra, ra)
        if b.parent >= 0:
            Rpb, rpb = (num(X) for X in tree.bodies[b.parent].X_child_joint)
            placement = _se3(pin, Rpb, rpb).inverse() * placement
        kind = b.joint.kind
        if kind == "revolute":
            joint = pin.JointModelRevoluteUnaligned(num(b.joint.axes[0]).reshape(3))
        elif kind == "prismatic":
            joint = pin.JointModelPrismaticUnaligned(num(b.joint.axes[0]).reshape(3))
        elif kind == "spherical" and b.joint.rotation == "quaternion":
            joint = pin.JointModelSpherical()
        elif kind == "free" and b.joint.rotation == "quaternion":
            joint = pin.JointModelFreeFlyer()
        else:
            raise ValueError(f"no Pinocchio counterpart for {kind}")
        jid = model.addJoint(b.parent + 1, joint, placement, b.name)
        inertia = pin.Inertia(_numeric(b.mass, subs), num(b.com).reshape(3), num(b.inertia))
        model.appendBodyToJoint(jid, inertia, _se3(pin, Rb, rb).inverse())
    return model


def pinocchio_state(tree: Tree, x):
    """(q_pin, v_pin, P) with v_pin = P v: Pinocchio orders quaternions (x, y, z, w), and its free-flyer linear
    velocity is R^T pdot (child frame) where ours is pdot (parent frame)."""
    nq = tree.nq
    q, v = x[:nq], x[nq:]
    qp, P = [], np.eye(tree.nv)
    iq = iv = 0
    for b in tree.bodies:
        if b.joint.uses_quaternion:
            nt = 3 if b.joint.kind == "free" else 0
            quat = q[iq + nt:iq + nt + 4]
            qp += list(q[iq:iq + nt]) + list(quat[1:]) + [quat[0]]
            if nt:
                P[iv:iv + 3, iv:iv + 3] = quaternion_matrix(quat / np.linalg.norm(quat)).T
        else:
            qp += list(q[iq:iq + b.joint.nq])
        iq += b.joint.nq
        iv += b.joint.nv
    return np.array(qp), P @ v, P


def is_depth_first(tree: Tree) -> bool:
    """True if every subtree occupies consecutive body indices."""
    path = [-1]
    for i, b in enumerate(tree.bodies):
        while path[-1] != b.parent:
            path.pop()
            if not path:
                return False
        path.append(i)
    return True


def pinocchio_dynamics(model, tree: Tree, x):
    """(M, vdot) of Pinocchio, converted to our velocity coordinates: M = P^T M_pin P, and for free joints
    pddot = R (a_pin + omega x v_pin). M comes from crba, which needs depth-first order; otherwise from the
    columns of rnea (Pinocchio's own unittest/crba.cpp oracle)."""
    import pinocchio as pin
    data = model.createData()
    qp, vp, P = pinocchio_state(tree, x)
    if is_depth_first(tree):
        M_pin = np.array(pin.crba(model, data, qp))
        M_pin = np.triu(M_pin) + np.triu(M_pin, 1).T
    else:
        zero = np.zeros(tree.nv)
        bias = np.array(pin.rnea(model, data, qp, zero, zero))
        M_pin = np.column_stack([np.array(pin.rnea(model, data, qp, zero, e)) - bias for e in np.eye(tree.nv)])
    a_pin = pin.aba(model, data, qp, vp, np.zeros(tree.nv))
    vdot = np.array(a_pin)
    iv = 0
    for b in tree.bodies:
        if b.joint.uses_quaternion and b.joint.kind == "free":
            R = P[iv:iv + 3, iv:iv + 3].T
            vdot[iv:iv + 3] = R @ (a_pin[iv:iv + 3] + np.cross(vp[iv + 3:iv + 6], vp[iv:iv + 3]))
        iv += b.joint.nv
    return P.T @ M_pin @ P, vdot


# ---- composite joints as chains of single-axis joints -----------------------------------------------------------

_E = ((1, 0, 0), (0, 1, 0), (0, 0, 1))


def _chain_of(joint: JointSpec) -> list:
    """The single-axis joints (kind, axis) whose sequence is `joint`, in coordinate order."""
    if joint.kind == "cylindrical":
        return [("prismatic", joint.axes[0]), ("revolute", joint.axes[0])]
    if joint.kind == "universal":
        return [("revolute", joint.axes[0]), ("revolute", joint.axes[1])]
    if joint.kind == "planar":
        n, u = (sp.Matrix(a) for a in joint.axes)
        return [("prismatic", tuple(u)), ("prismatic", tuple(n.cross(u))), ("revolute", tuple(n))]
    rotation = [("revolute", e) for e in _E]
    if joint.kind == "spherical" and joint.rotation == "cardan":
        return rotation
    if joint.kind == "free" and joint.rotation == "cardan":
        return [("prismatic", e) for e in _E] + rotation
    return []


def decompose(tree: Tree) -> Tree:
    """The same mechanism with every composite joint replaced by single-axis joints and massless bodies between
    them; the state layout is unchanged (coordinates keep their order)."""
    bodies, new_index = [], {-1: -1}
    eye, zero = sp.eye(3), (0, 0, 0)
    for i, b in enumerate(tree.bodies):
        chain = _chain_of(b.joint)
        parent = new_index[b.parent]
        if not chain:
            bodies.append(TreeBody(b.name, parent, b.joint, b.X_parent_joint, b.X_child_joint, b.mass, b.com,
                                   b.inertia, b.prescribed))
        for k, (kind, axis) in enumerate(chain):
            last = k == len(chain) - 1
            Xp = b.X_parent_joint if k == 0 else (eye, zero)
            Xc = b.X_child_joint if last else (eye, zero)
            mass, com, inertia = (b.mass, b.com, b.inertia) if last else (0, zero, sp.zeros(3))
            bodies.append(TreeBody(b.name if last else f"{b.name}_{k}", parent, JointSpec(kind, (axis,)), Xp, Xc,
                                   mass, com, inertia, (b.prescribed[k],)))
            parent = len(bodies) - 1
        new_index[i] = len(bodies) - 1
    return Tree(tuple(bodies), tree.gravity)
