"""Joint kinds: the relative kinematics of frame b (child side) with respect to frame a (parent side).

Each kind is a small subclass of `JointKind` that implements one hook, `motion(q, v) -> JointMotion`, on the tape;
all vectors are in frame-b components at frame b's origin (where the motion subspace of the common joints is
constant):

* R, p:  R rotates b components into a components, p is b's origin in a components.
* S:     one 6-vector (omega; v) per velocity coordinate: the joint's motion subspace.
* c:     the 6-vector c_J = (d/dt S) v, the derivative of S taken component-wise in frame b (zero for revolute,
         prismatic, cylindrical and quaternion joints).
* qdot:  the time derivatives of the position coordinates (equal to v except for quaternions).

`q` and `v` are tuples of expressions (coordinate symbols, or expressions of t for prescribed coordinates). The
relative spatial velocity of b is v_J = S v and its acceleration S vdot + c_J (Featherstone, RBDA sec. 4.4).
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from .spatial import IDENTITY, ONE, ZERO, ZERO3, add, cross, dot, matmul, mul, transpose
from .tape import Tape
from .tree import JointSpec

HALF = sp.Rational(1, 2)
E_X, E_Y, E_Z = IDENTITY


@dataclass(frozen=True)
class JointMotion:
    """Relative kinematics of one joint (see the module docstring); S has nv entries, qdot nq."""

    R: tuple
    p: tuple
    S: tuple
    c: tuple
    qdot: tuple


def angular(w) -> tuple:
    return tuple(w) + ZERO3


def linear(v) -> tuple:
    return ZERO3 + tuple(v)


def combine(S, v) -> tuple:
    """S v for a list of 6-vectors S (expression level)."""
    return tuple(add(*(mul(col[i], x) for col, x in zip(S, v))) for i in range(6))


class JointKind:
    """Template of a joint kind; `spec` holds the axes, `tape` receives the temporaries, `tag` names them."""

    def __init__(self, spec: JointSpec, tape: Tape, tag: str):
        self.spec, self.tape, self.tag = spec, tape, tag

    def motion(self, q, v) -> JointMotion:
        raise NotImplementedError

    # -- helpers for the subclasses --
    def cos_sin(self, angle, suffix: str = "") -> tuple:
        tape = self.tape
        return tape.temp(sp.cos(angle), f"c{self.tag}{suffix}"), tape.temp(sp.sin(angle), f"s{self.tag}{suffix}")

    def axis_rotation(self, axis, angle, suffix: str = "") -> tuple:
        """Rotation by `angle` about the unit `axis`: c 1 + s [a]x + (1 - c) a a^T (literal axes fold)."""
        c, s = self.cos_sin(angle, suffix)
        ax = ((ZERO, -axis[2], axis[1]), (axis[2], ZERO, -axis[0]), (-axis[1], axis[0], ZERO))
        one_c = add(ONE, -c)
        return tuple(tuple(self.tape.temp(add(c if i == j else ZERO, mul(s, ax[i][j]),
                                              mul(one_c, mul(axis[i], axis[j]))), f"R{self.tag}{suffix}_{i}{j}")
                           for j in range(3)) for i in range(3))


class Fixed(JointKind):
    def motion(self, q, v):
        return JointMotion(IDENTITY, ZERO3, (), ZERO3 + ZERO3, ())


class Revolute(JointKind):
    def motion(self, q, v):
        axis = self.spec.axes[0]
        return JointMotion(self.axis_rotation(axis, q[0]), ZERO3, (angular(axis),), ZERO3 + ZERO3, tuple(v))


class Prismatic(JointKind):
    def motion(self, q, v):
        axis = self.spec.axes[0]
        return JointMotion(IDENTITY, tuple(mul(x, q[0]) for x in axis), (linear(axis),), ZERO3 + ZERO3, tuple(v))


class Cylindrical(JointKind):
    """Coordinates (s, phi): slide along the axis, then turn about it (the axis is the same in a and b)."""

    def motion(self, q, v):
        axis = self.spec.axes[0]
        return JointMotion(self.axis_rotation(axis, q[1]), tuple(mul(x, q[0]) for x in axis),
                           (linear(axis), angular(axis)), ZERO3 + ZERO3, tuple(v))


class Universal(JointKind):
    """Rotation phi1 about axis1, then phi2 about axis2 of the once-rotated frame:
    omega_b = u phi1' + a2 phi2' with u = R2^T a1, and d/dt u = -phi2' a2 x u."""

    def motion(self, q, v):
        a1, a2 = self.spec.axes
        R2 = self.axis_rotation(a2, q[1], "b")
        R = matmul(self.tape, self.axis_rotation(a1, q[0], "a"), R2, f"R{self.tag}")
        u = self.tape.vector([dot(col, a1) for col in transpose(R2)], f"u{self.tag}")
        rate = mul(v[0], v[1])
        c = angular(mul(-rate, x) for x in cross(a2, u))
        return JointMotion(R, ZERO3, (angular(u), angular(a2)), c, tuple(v))


class Planar(JointKind):
    """Translation x along u and y along w = n x u (in frame a), then rotation phi about the normal n."""

    def motion(self, q, v):
        n, u = self.spec.axes
        w = self.tape.vector(cross(n, u), f"n{self.tag}")
        R = self.axis_rotation(n, q[2])
        Rt = transpose(R)
        S = (linear(self.tape.vector([dot(row, u) for row in Rt], f"u{self.tag}")),
             linear(self.tape.vector([dot(row, w) for row in Rt], f"w{self.tag}")),
             angular(n))
        p = tuple(add(mul(a, q[0]), mul(b, q[1])) for a, b in zip(u, w))
        return JointMotion(R, p, S, translation_bias(S, v), tuple(v))


def translation_bias(S, v) -> tuple:
    """c_J of a joint whose translation is given in frame a: d/dt (R^T) pdot = -omega_b x (R^T pdot), where
    omega_b and R^T pdot are the angular and linear parts of v_J (only the translation columns depend on R)."""
    vJ = combine(S, v)
    return ZERO3 + tuple(-x for x in cross(vJ[:3], vJ[3:]))


class QuaternionRotation:
    """Unit quaternion (w, x, y, z); angular velocity in frame b. R is scaled by 2/|q|^2 so that it stays a rotation
    even when the integrated quaternion drifts off unit length."""

    nq = 4

    @staticmethod
    def evaluate(joint: JointKind, q, w_b) -> tuple:
        """(R, angular subspace columns, angular bias, qdot)."""
        tape, tag = joint.tape, joint.tag
        w, x, y, z = q
        s = tape.temp(2 / add(w**2, x**2, y**2, z**2), f"qs{tag}")
        sx, sy, sz = (tape.temp(mul(s, e), f"q{tag}{n}") for e, n in ((x, "x"), (y, "y"), (z, "z")))
        xx, yy, zz = (tape.temp(mul(a, b), f"q{tag}{n}") for a, b, n in ((sx, x, "xx"), (sy, y, "yy"), (sz, z, "zz")))
        xy, xz, yz = (tape.temp(mul(a, b), f"q{tag}{n}") for a, b, n in ((sx, y, "xy"), (sx, z, "xz"), (sy, z, "yz")))
        wx, wy, wz = (tape.temp(mul(a, w), f"q{tag}{n}") for a, n in ((sx, "wx"), (sy, "wy"), (sz, "wz")))
        rows = ((1 - yy - zz, xy - wz, xz + wy), (xy + wz, 1 - xx - zz, yz - wx), (xz - wy, yz + wx, 1 - xx - yy))
        R = tuple(tuple(tape.temp(e, f"R{tag}_{i}{j}") for j, e in enumerate(row)) for i, row in enumerate(rows))
        # q' = 1/2 q (x) (0, omega) = (-v.omega, w omega + v x omega) / 2.
        vec = (x, y, z)
        qdot = (mul(-HALF, dot(vec, w_b)),) + tuple(mul(HALF, add(mul(w, o), c))
                                                   for o, c in zip(w_b, cross(vec, w_b)))
        return R, (E_X, E_Y, E_Z), ZERO3, qdot


class CardanRotation:
    """Angles (alpha, beta, gamma) of R = Rx(alpha) Ry(beta) Rz(gamma); velocities are their derivatives:
    omega_b = (cb cg, -cb sg, sb) alpha' + (sg, cg, 0) beta' + (0, 0, 1) gamma'."""

    nq = 3

    @staticmethod
    def evaluate(joint: JointKind, q, qd) -> tuple:
        tape, tag = joint.tape, joint.tag
        Rx = joint.axis_rotation(E_X, q[0], "a")
        Ry = joint.axis_rotation(E_Y, q[1], "b")
        Rz = joint.axis_rotation(E_Z, q[2], "c")
        R = matmul(tape, matmul(tape, Rx, Ry, f"R{tag}ab"), Rz, f"R{tag}")
        cb, sb = joint.cos_sin(q[1], "b")
        cg, sg = joint.cos_sin(q[2], "c")
        first = tape.vector([mul(cb, cg), -mul(cb, sg), sb], f"u{tag}")
        da, db, dg = qd
        d_first = (add(-mul(mul(sb, cg), db), -mul(mul(cb, sg), dg)),
                   add(mul(mul(sb, sg), db), -mul(mul(cb, cg), dg)),
                   mul(cb, db))
        d_second = (mul(cg, dg), -mul(sg, dg), ZERO)
        bias = tuple(add(mul(x, da), mul(y, db)) for x, y in zip(d_first, d_second))
        return R, (first, (sg, cg, ZERO), E_Z), bias, tuple(qd)


class _Rotational(JointKind):
    """Spherical and free joints: a translation in frame a (free only) followed by a parametrised rotation."""

    translation = False

    def motion(self, q, v):
        k = 3 if self.translation else 0
        rotation = QuaternionRotation if self.spec.rotation == "quaternion" else CardanRotation
        R, S_w, c_w, qdot_r = rotation.evaluate(self, q[k:], v[k:])
        S = tuple(angular(w) for w in S_w)
        c = tuple(c_w) + ZERO3
        if not self.translation:
            return JointMotion(R, ZERO3, S, c, qdot_r)
        # b's origin moves with pdot (a components), which is R^T pdot in b: the rows of R.
        S = tuple(linear(row) for row in R) + S
        c = tuple(add(x, y) for x, y in zip(c, translation_bias(S, v)))
        return JointMotion(R, tuple(q[:3]), S, c, tuple(v[:3]) + tuple(qdot_r))


class Spherical(_Rotational):
    pass


class Free(_Rotational):
    translation = True


KINDS = {"fixed": Fixed, "revolute": Revolute, "prismatic": Prismatic, "cylindrical": Cylindrical,
         "universal": Universal, "planar": Planar, "spherical": Spherical, "free": Free}


def joint_kind(spec: JointSpec, tape: Tape, tag: str) -> JointKind:
    """The hook object of `spec`'s kind; `tag` (e.g. the body number) distinguishes its temporaries."""
    return KINDS[spec.kind](spec, tape, tag)
