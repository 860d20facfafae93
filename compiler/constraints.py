"""Loop-closure constraints of the cut joints, as tape expressions of the spanning tree's state.

A joint outside the spanning tree (`Topology.cuts`) closes a kinematic loop. Its frames a (on body A) and b (on
body B) coincide at zero joint motion; the joint lets b move relative to a only as its kind allows, which is
written as position residuals g(q, t) = 0, nc rows in all. For each row the derivation also gives its exact time
derivative gdot = G(q) v + g_t(q, t) (linear in the free velocities v) and its second derivative with every state
acceleration set to zero, gddot0(q, v, t), so that the accelerations satisfy G vdot + gddot0 = 0.

Rows per cut-joint kind (d = p_b - p_a in the frame of the nearest body above both of the joint's bodies, world
components when the loop closes through the ground; n the joint axis, u, w two unit vectors perpendicular to it;
subscripts say in which frame a direction is fixed):

    spherical    3: d                                     revolute     5: d, n_a.u_b, n_a.w_b
    universal    4: d, n1_a.n2_b                          prismatic    5: 3 rotation rows, u_a.d, w_a.d
    cylindrical  4: u_a.d, w_a.d, n_a.u_b, n_a.w_b        planar       3: n_a.d, n_a.u_b, n_a.w_b
    fixed        6: d and 3 rotation rows                 free         0

The 3 rotation rows are the small-angle rotation of b relative to a in frame-a components,
(R_a^T R_b - R_b^T R_a)^vee / 2; translation rows are in metres, the others dimensionless. The reaction of a row
is its Lagrange multiplier: M vdot = f + G^T lambda, so lambda of the rows d is the force on B (components in the
frame d is written in, on A the opposite) [N]; `RowLoad` gives every row's load in world components.

Rows of a loop that closes below a body (a car's suspension below the car body) are built relative to that body
(compiler/relative_motion.py): they read only the coordinates below it, so G has exact zeros in the columns of
the body and of every other loop, and the loop solver's factors and null-space basis stay block sparse.

Units: m, rad, s.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import sympy as sp

from .kinematics import Kinematics
from .relative_motion import RelativeMotion, common_ancestor
from .spatial import ZERO3, add, cross, dot, mul
from .tape import Tape
from .tree import JointSpec, Tree, TreeError, natural_key, t

#: Row labels per cut-joint kind, in row order.
ROWS = {
    "spherical": ("x", "y", "z"),
    "revolute": ("x", "y", "z", "tilt_u", "tilt_w"),
    "universal": ("x", "y", "z", "cross"),
    "prismatic": ("rx", "ry", "rz", "shift_u", "shift_w"),
    "cylindrical": ("shift_u", "shift_w", "tilt_u", "tilt_w"),
    "planar": ("normal", "tilt_u", "tilt_w"),
    "fixed": ("x", "y", "z", "rx", "ry", "rz"),
    "free": (),
}


@dataclass(frozen=True)
class CutJoint:
    """A joint that closes a loop (it is not part of the spanning tree).

    name: the interaction's name; constraint rows are called `<name>.<label>`.
    joint: its kind and axes (frame-a components; the rotation parametrisation does not matter here).
    body_a, body_b: tree body index (-1 = ground) of the parts carrying frame a and frame b.
    X_a, X_b: (R 3x3, r 3) pose of frame a in body_a's frame and of frame b in body_b's frame [-, m], as
        `TreeBody.X_parent_joint`: R rotates frame components into body components.
    """

    name: str
    joint: JointSpec
    body_a: int
    X_a: tuple
    body_b: int
    X_b: tuple

    @property
    def labels(self) -> tuple[str, ...]:
        return ROWS[self.joint.kind]


@dataclass(frozen=True)
class RowLoad:
    """The load of one constraint row per unit multiplier, world components: the force `force` [N] on body B at
    frame b's origin with the torque `torque` [N*m]; body A takes the opposite force and torque, the force at the
    same point in space when `a_at_b`, else at frame a's origin."""

    force: tuple
    torque: tuple
    a_at_b: bool


@dataclass(frozen=True)
class ConstraintRow:
    """Row k of the constraints: `cut` indexes `Constraints.cuts`; `name` is `<joint>.<label>`."""

    cut: int
    name: str


@dataclass(frozen=True)
class Constraints:
    """The loop-closure constraints of `cuts` on `kinematics.tape` (nc rows each tuple).

    position: g(q, t) [m or -]; velocity: gdot = G(q) v + g_t [m/s or 1/s];
    acceleration: gddot with vdot = 0 [m/s^2 or 1/s^2].
    """

    kinematics: Kinematics
    cuts: tuple[CutJoint, ...]
    rows: tuple[ConstraintRow, ...]
    position: tuple
    velocity: tuple
    acceleration: tuple

    @property
    def tree(self) -> Tree:
        return self.kinematics.tree

    @property
    def tape(self) -> Tape:
        return self.kinematics.tape

    @property
    def nc(self) -> int:
        return len(self.rows)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(r.name for r in self.rows)

    @property
    def quaternion_slots(self) -> tuple[int, ...]:
        """Index in q of the first component (qw) of every quaternion; its four components are consecutive."""
        tree = self.tree
        return tuple(tree.q_slots[i][-4] for i, b in enumerate(tree.bodies) if b.joint.uses_quaternion)

    def outputs(self) -> list:
        """Every result expression (for slicing the tape)."""
        return list(self.position) + list(self.velocity) + list(self.acceleration)

    def parameters(self) -> tuple:
        """Symbols the rows use other than the state and t, in `natural_key` order (geometry that only a cut
        joint uses appears here and not in `Equations.parameters`)."""
        return self._parameters

    @cached_property
    def _parameters(self) -> tuple:
        """(found once, as Equations._parameters)"""
        tree = self.tree
        found = self.tape.free_symbols(self.outputs()) - set(tree.q_symbols) - set(tree.v_symbols) - {t}
        return tuple(sorted(found, key=natural_key))


# ---- jets: a quantity with its first and second time derivative (the second with vdot = 0) -------------------

@dataclass(frozen=True)
class _Jet:
    value: tuple
    rate: tuple
    accel: tuple


def _point(kin: Kinematics, body: int, r_local) -> _Jet:
    return _Jet(kin.frame_position(body, r_local), kin.frame_velocity(body, r_local),
                kin.frame_bias_acceleration(body, r_local))


def _direction(kin: Kinematics, body: int, e_local) -> _Jet:
    """A unit vector fixed in the body: e' = w x e, e'' = alpha x e + w x (w x e) (world components)."""
    R = kin.world_pose(body)[0]
    e = kin.tape.vector([dot(row, e_local) for row in R], "dir")
    if body < 0:
        return _Jet(e, ZERO3, ZERO3)
    w, alpha = kin.body_angular_velocity(body), kin.angular_bias_acceleration(body)
    rate = kin.tape.vector(cross(w, e), "ddir")
    accel = [add(x, y) for x, y in zip(cross(alpha, e), cross(w, rate))]
    return _Jet(e, rate, kin.tape.vector(accel, "dddir"))


def _difference(a: _Jet, b: _Jet) -> _Jet:
    """a - b, component-wise."""
    return _Jet(*(tuple(add(x, -y) for x, y in zip(p, q)) for p, q in ((a.value, b.value), (a.rate, b.rate),
                                                                        (a.accel, b.accel))))


def _component(a: _Jet, k: int) -> tuple:
    return a.value[k], a.rate[k], a.accel[k]


def _dot(a: _Jet, b: _Jet) -> tuple:
    """(a.b, (a.b)', (a.b)''): the product rule."""
    return (dot(a.value, b.value), add(dot(a.rate, b.value), dot(a.value, b.rate)),
            add(dot(a.accel, b.value), mul(2, dot(a.rate, b.rate)), dot(a.value, b.accel)))


def _half_difference(p: tuple, q: tuple) -> tuple:
    return tuple(mul(sp.Rational(1, 2), add(x, -y)) for x, y in zip(p, q))


# ---- rows of one cut joint --------------------------------------------------------------------------------------

def perpendiculars(n) -> tuple:
    """Two unit vectors u, w = n x u completing the numeric unit vector n to a right-handed basis (n, u, w):
    u = n x e / |n x e| with e the coordinate axis least aligned with n."""
    if not all(sp.sympify(c).is_number for c in n):
        raise TreeError(f"the axis {tuple(n)} of a loop-closing joint must be a numeric vector")
    n = sp.Matrix(n)
    e = sp.eye(3)[:, min(range(3), key=lambda k: abs(float(n[k])))]
    u = n.cross(e)
    u = u / sp.sqrt(u.dot(u))
    w = n.cross(u)
    return tuple(sp.simplify(c) for c in u), tuple(sp.simplify(c) for c in w)


class _CutRows:
    """Builds the rows of one cut joint from jets of its frames: relative to the nearest body above both of its
    bodies when there is one (`relative`; compiler/relative_motion.py: the rows then read only the coordinates
    below that body), else in world components. Scalar rows are the same either way; the translation rows d are
    the components in that body's frame. `loads` are in world components in both cases."""

    def __init__(self, kin: Kinematics, cut: CutJoint, relative: bool = True):
        self.kin, self.cut = kin, cut
        (self.Ra, self.ra), (self.Rb, self.rb) = (_local(X) for X in (cut.X_a, cut.X_b))
        self.ancestor = common_ancestor(kin, cut.body_a, cut.body_b)
        self.relative = RelativeMotion(kin, self.ancestor) if relative and self.ancestor >= 0 else None

    @cached_property
    def pa(self) -> _Jet:
        return self._point(self.cut.body_a, self.ra)

    @cached_property
    def pb(self) -> _Jet:
        return self._point(self.cut.body_b, self.rb)

    def _point(self, body: int, r_local) -> _Jet:
        if self.relative is None:
            return _point(self.kin, body, r_local)
        return _Jet(*self.relative.point(body, r_local))

    def _direction(self, body: int, e_local) -> _Jet:
        if self.relative is None:
            return _direction(self.kin, body, e_local)
        return _Jet(*self.relative.direction(body, e_local))

    def axis_a(self, e) -> _Jet:
        """A direction given in frame-a components, fixed in body A."""
        return self._direction(self.cut.body_a, [dot(row, e) for row in self.Ra])

    def axis_b(self, e) -> _Jet:
        return self._direction(self.cut.body_b, [dot(row, e) for row in self.Rb])

    def rows(self) -> list[tuple]:
        kind, axes = self.cut.joint.kind, self.cut.joint.axes
        d = _difference(self.pb, self.pa)
        translation = [_component(d, k) for k in range(3)]
        if kind == "free":
            return []
        if kind == "spherical":
            return translation
        if kind == "fixed":
            return translation + self.rotation()
        if kind == "universal":
            return translation + [_dot(self.axis_a(axes[0]), self.axis_b(axes[1]))]
        if kind == "planar":
            n = self.axis_a(axes[0])
            u = axes[1]
            return [_dot(n, d)] + self.tilt(n, u, cross(axes[0], u))
        u, w = perpendiculars(axes[0])
        n = self.axis_a(axes[0])
        if kind == "revolute":
            return translation + self.tilt(n, u, w)
        shift = [_dot(self.axis_a(u), d), _dot(self.axis_a(w), d)]
        if kind == "prismatic":
            return self.rotation() + shift
        return shift + self.tilt(n, u, w)  # cylindrical

    def loads(self) -> list["RowLoad"]:
        """Per row (in the order of `rows`), the load a unit multiplier exerts: the virtual power of lambda times
        the row's rate, lambda gdot, split over the bodies. For n_a.e_b the rate is (e_b x n_a).(w_b - w_a): a
        torque e_b x n_a on B; for u_a.d it is u_a.(v_b - v_a) + w_a.(u_a x d): the force u_a on B at p_b and its
        opposite on A at the same point in space; for d itself the force on B at p_b, on A at p_a."""
        kind, axes = self.cut.joint.kind, self.cut.joint.axes
        if kind == "free":
            return []
        # the translation rows are the components of d in the frame of the body above both (world without one)
        R = self.kin.world_pose(self.ancestor)[0]
        translation = [RowLoad(tuple(R[i][k] for i in range(3)), ZERO3, False) for k in range(3)]
        if kind == "spherical":
            return translation
        if kind == "fixed":
            return translation + self.rotation_loads()
        if kind == "universal":
            return translation + [self.tilt_load(self.axis_a(axes[0]), axes[1])]
        if kind == "planar":
            n = self.axis_a(axes[0])
            u = axes[1]
            return [RowLoad(n.value, ZERO3, True)] + [self.tilt_load(n, e) for e in (u, cross(axes[0], u))]
        u, w = perpendiculars(axes[0])
        n = self.axis_a(axes[0])
        tilt = [self.tilt_load(n, u), self.tilt_load(n, w)]
        if kind == "revolute":
            return translation + tilt
        shift = [RowLoad(self.axis_a(e).value, ZERO3, True) for e in (u, w)]
        if kind == "prismatic":
            return self.rotation_loads() + shift
        return shift + tilt  # cylindrical

    def tilt_load(self, n_a: _Jet, e) -> "RowLoad":
        return RowLoad(ZERO3, cross(self.axis_b(e).value, n_a.value), False)

    def rotation_loads(self) -> list["RowLoad"]:
        eye = sp.eye(3)
        a = [self.axis_a(tuple(eye[:, k])).value for k in range(3)]
        b = [self.axis_b(tuple(eye[:, k])).value for k in range(3)]
        half = sp.Rational(1, 2)
        return [RowLoad(ZERO3, tuple(mul(half, add(x, -y)) for x, y in zip(cross(b[j], a[k]), cross(b[k], a[j]))),
                        False) for j, k in ((1, 2), (2, 0), (0, 1))]

    def tilt(self, n_a: _Jet, u, w) -> list:
        """The axis n (fixed in A) stays perpendicular to u and w fixed in B."""
        return [_dot(n_a, self.axis_b(u)), _dot(n_a, self.axis_b(w))]

    def rotation(self) -> list:
        """Small-angle rotation of b relative to a, frame-a components: (e_a,k . e_b,j - e_a,j . e_b,k) / 2."""
        eye = sp.eye(3)
        a = [self.axis_a(tuple(eye[:, k])) for k in range(3)]
        b = [self.axis_b(tuple(eye[:, k])) for k in range(3)]
        return [_half_difference(_dot(a[k], b[j]), _dot(a[j], b[k])) for j, k in ((1, 2), (2, 0), (0, 1))]


def _local(X) -> tuple:
    R, r = X
    R = tuple(tuple(sp.sympify(R[i, j] if hasattr(R, "shape") else R[i][j]) for j in range(3)) for i in range(3))
    return R, tuple(sp.sympify(c) for c in r)


def cut_loads(kinematics: Kinematics, cut: CutJoint) -> tuple:
    """(loads, p_a, p_b): the `RowLoad` of each row of `cut` and the world positions of its frames a and b, on
    the tape of `kinematics` (for reaction forces: the multipliers times these are the loads of the joint)."""
    rows = _CutRows(kinematics, cut, relative=False)
    return tuple(rows.loads()), rows.pa.value, rows.pb.value


def derive_constraints(kinematics: Kinematics, cuts) -> Constraints:
    """The rows of every cut joint, in the order of `cuts`, on the tape of `kinematics`. Raises TreeError for a
    cut joint whose bodies are not in the tree or whose axis is symbolic where perpendiculars are needed."""
    tape, tree = kinematics.tape, kinematics.tree
    rows, position, velocity, acceleration = [], [], [], []
    for j, cut in enumerate(cuts):
        for body in (cut.body_a, cut.body_b):
            if not -1 <= body < len(tree.bodies):
                raise TreeError(f"cut joint {cut.name!r}: body index {body} is not in the tree")
        if cut.body_a == cut.body_b:
            raise TreeError(f"cut joint {cut.name!r} connects a body to itself")
        tape.section(f"cut joint {cut.name} ({cut.joint.kind}): frames")
        values = _CutRows(kinematics, cut).rows()
        tape.section(f"cut joint {cut.name} ({cut.joint.kind}): loop-closure constraints")
        for label, (g, gd, gdd) in zip(cut.labels, values):
            name = f"{cut.name}.{label}"
            rows.append(ConstraintRow(j, name))
            position.append(tape.temp(g, f"g_{label}"))
            velocity.append(tape.temp(gd, f"gd_{label}"))
            acceleration.append(tape.temp(gdd, f"gdd_{label}"))
    return Constraints(kinematics, tuple(cuts), tuple(rows), tuple(position), tuple(velocity), tuple(acceleration))


__all__ = ["ROWS", "CutJoint", "ConstraintRow", "Constraints", "RowLoad", "cut_loads", "derive_constraints",
           "perpendiculars"]
