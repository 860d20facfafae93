"""Forward kinematics of a `Tree` on a `Tape`, and the applied loads attached to it.

`Kinematics(tree)` runs the outward recursion once (joint transforms, body placements, spatial velocities and the
velocity-product terms), each body in its own frame. World quantities (positions, rotations and velocities of
frames, for springs, dampers, tyres, sensors) are built on request from the same tape.

Loads are attached with `add_force`, `add_torque`, `add_generalized_force` and `add_line_force`; the derivation
(`mbs.compiler.equations.derive_equations`) reads them when it runs, so attach all loads before deriving.

Units: m, rad, s, N, N*m. Bodies are given by index (0-based, -1 = ground) or by name ("ground" = -1).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property

import sympy as sp

from .joints import combine, joint_kind
from .spatial import (IDENTITY, ZERO, ZERO3, ZERO6, RigidInertia, add, cross, dot, force_cross, is_identity, is_zero,
                      matmul, matTvec, matvec, motion_cross, motion_from_frame, motion_to_child, mul, transpose)
from .tape import Tape
from .tree import Tree, coordinate_names, t, velocity_of_coordinate


@dataclass(frozen=True)
class BodyKinematics:
    """Kinematic quantities of one body on the tape; 6-vectors (omega; v) in the body frame at its origin.

    X: (R, r) placement of the body frame in the parent body's frame (R: body -> parent components).
    q, v: the joint's coordinates and velocities (state symbols, or expressions of t when prescribed).
    qdot: time derivatives of the joint's coordinates (length nq of the joint).
    S: one motion vector per joint velocity; free: local indices of the velocities that are states.
    vJ: joint velocity S v; vel: the body's spatial velocity.
    bias: acceleration terms that do not depend on the state accelerations: c_J + S_p vdot_p + vel x vJ
        (velocity products and prescribed accelerations).
    joint_bias: the joint's own part of bias, c_J + S_p vdot_p (expressions, not on the tape): the bias relative
        to an ancestor body is joint_bias + vel_rel x vJ (compiler/relative_motion.py).
    """

    X: tuple
    q: tuple
    v: tuple
    qdot: tuple
    S: tuple
    free: tuple
    vJ: tuple
    vel: tuple
    bias: tuple
    joint_bias: tuple = ()


class Kinematics:
    """The kinematics of `tree` on `tape` (a new tape if None), with the loads attached so far."""

    def __init__(self, tree: Tree, tape: Tape | None = None):
        self.tree = tree
        self.tape = tape if tape is not None else Tape()
        self.bodies: list[BodyKinematics] = []
        for i in range(len(tree.bodies)):
            self.bodies.append(self._outward(i))
        self._world: dict[int, tuple] = {-1: (IDENTITY, ZERO3)}
        self._inertia: dict[int, RigidInertia] = {}
        self._gyroscopic: dict[int, tuple] = {}
        self._wrenches: dict[int, list] = {}
        self._generalized: dict[int, list] = {}
        self._bias_acc: dict[int, tuple] = {}
        self._relative: dict[int, object] = {}

    # ---- the outward recursion ----------------------------------------------------------------------------------

    def _outward(self, i: int) -> BodyKinematics:
        tree, tape = self.tree, self.tape
        body, n = tree.bodies[i], i + 1
        tape.section(f"body {n} ({body.name}): {body.joint.kind} joint")
        names = coordinate_names(body.joint)
        q, v, vdot = [], [None] * body.joint.nv, {}
        for k, e in enumerate(body.prescribed):
            if e is None:
                q.append(tree.q_symbols[tree.q_slots[i][k]])
                continue
            kv = velocity_of_coordinate(body.joint, k)
            q.append(tape.temp(e, f"{names[k]}{n}"))
            v[kv] = tape.temp(sp.diff(e, t), f"d{names[k]}{n}")
            vdot[kv] = tape.temp(sp.diff(e, t, 2), f"dd{names[k]}{n}")
        for k in body.free_velocities:
            v[k] = tree.v_symbols[tree.v_slots[i][k]]
        motion = joint_kind(body.joint, tape, str(n)).motion(tuple(q), tuple(v))

        # Placement of the body in its parent: R = Ra R_J Rb^T, r = ra + Ra p_J - R rb.
        (Ra, ra), (Rb, rb) = (_tuples(X) for X in (body.X_parent_joint, body.X_child_joint))
        R = matmul(tape, matmul(tape, Ra, motion.R, f"E{n}a"), transpose(Rb), f"E{n}")
        Rrb = [dot(row, rb) for row in R]
        r = tape.vector([add(x, y, -z) for x, y, z in zip(ra, [dot(row, motion.p) for row in Ra], Rrb)], f"r{n}")
        S = tuple(motion_from_frame(tape, (Rb, rb), s, f"S{n}{k}") for k, s in enumerate(motion.S))
        cJ = motion_from_frame(tape, (Rb, rb), motion.c, f"cJ{n}")

        tape.section(f"body {n} ({body.name}): velocity")
        vJ = tape.vector(combine(S, v), f"vJ{n}")
        if body.parent < 0:
            vel = vJ
        else:
            vel = motion_to_child(tape, (R, r), self.bodies[body.parent].vel, f"vp{n}")
            vel = tape.vector([add(x, y) for x, y in zip(vel, vJ)], f"v{n}")
        a_presc = combine([S[k] for k in vdot], list(vdot.values()))
        cross_term = motion_cross(tape, vel, vJ, f"vx{n}")
        bias = tape.vector([add(x, y, z) for x, y, z in zip(cJ, a_presc, cross_term)], f"cv{n}")
        return BodyKinematics((R, r), tuple(q), tuple(v), motion.qdot, S, tuple(body.free_velocities), vJ, vel,
                              bias, tuple(add(x, y) for x, y in zip(cJ, a_presc)))

    # ---- body-frame quantities used by the dynamics -------------------------------------------------------------

    def inertia(self, i: int) -> RigidInertia:
        """Spatial inertia of body i about its frame origin (computed once, on first use)."""
        if i not in self._inertia:
            b = self.tree.bodies[i]
            self.tape.section(f"body {i + 1} ({b.name}): spatial inertia")
            Ic = tuple(tuple(b.inertia[r, c] for c in range(3)) for r in range(3))
            self._inertia[i] = RigidInertia.of_body(self.tape, b.mass, tuple(b.com), Ic, f"I{i + 1}")
        return self._inertia[i]

    def gyroscopic(self, i: int) -> tuple:
        """v x* (I v): the centrifugal and gyroscopic force of body i (body frame), computed once."""
        if i not in self._gyroscopic:
            inertia = self.inertia(i)
            vel = self.bodies[i].vel
            self.tape.section(f"body {i + 1} ({self.tree.bodies[i].name}): momentum and gyroscopic force")
            self._gyroscopic[i] = force_cross(self.tape, vel, inertia.apply(self.tape, vel, f"h{i + 1}"),
                                              f"vxh{i + 1}")
        return self._gyroscopic[i]

    def external_wrench(self, i: int) -> tuple:
        """Sum of the applied loads on body i as a force vector (n; f) in the body frame at its origin."""
        parts = self._wrenches.get(i)
        if not parts:
            return ZERO6
        self.tape.section(f"body {i + 1} ({self.tree.bodies[i].name}): applied loads")
        return self.tape.vector([add(*(p[k] for p in parts)) for k in range(6)], f"fe{i + 1}")

    def generalized_forces(self) -> tuple:
        """Applied generalized forces, one per free velocity (state order)."""
        return tuple(add(*self._generalized.get(k, ())) for k in range(self.tree.nv))

    @cached_property
    def qdot(self) -> tuple:
        """Time derivatives of the free coordinates (state order), length nq."""
        out = []
        for i, body in enumerate(self.tree.bodies):
            out += [self.bodies[i].qdot[k] for k in body.free_coordinates]
        return tuple(out)

    # ---- world quantities (built on request) --------------------------------------------------------------------

    def world_pose(self, body: int | str) -> tuple:
        """(R, r): rotation body -> world components and the body origin in world components [m]."""
        i = self.tree.body_index(body)
        if i not in self._world:
            parent = self.tree.bodies[i].parent
            R_p, r_p = self.world_pose(parent)
            R, r = self.bodies[i].X
            self.tape.section(f"body {i + 1} ({self.tree.bodies[i].name}): world pose")
            self._world[i] = (matmul(self.tape, R_p, R, f"R0{i + 1}"),
                              self.tape.vector([add(x, dot(row, r)) for x, row in zip(r_p, R_p)], f"r0{i + 1}"))
        return self._world[i]

    def frame_position(self, body: int | str, r_local) -> tuple:
        """World position of the point with body coordinates r_local [m]."""
        R, r = self.world_pose(body)
        return self.tape.vector([add(x, dot(row, _sym(r_local))) for x, row in zip(r, R)], "pos")

    def frame_rotation(self, body: int | str, R_local=None) -> tuple:
        """Rotation (frame -> world components) of a frame with orientation R_local in the body (identity)."""
        R, _ = self.world_pose(body)
        return R if R_local is None else matmul(self.tape, R, _tuples((R_local, ZERO3))[0], "rot")

    def body_angular_velocity(self, body: int | str) -> tuple:
        """Angular velocity of the body in world components [rad/s]."""
        i = self.tree.body_index(body)
        if i < 0:
            return ZERO3
        return matvec(self.tape, self.world_pose(i)[0], self.bodies[i].vel[:3], f"w0{i + 1}")

    def frame_velocity(self, body: int | str, r_local) -> tuple:
        """World velocity of the point with body coordinates r_local, world components [m/s]."""
        i = self.tree.body_index(body)
        if i < 0:
            return ZERO3
        vel = self.bodies[i].vel
        local = [add(x, y) for x, y in zip(vel[3:], cross(vel[:3], _sym(r_local)))]
        return matvec(self.tape, self.world_pose(i)[0], local, "vel")

    # ---- accelerations with vdot = 0 (for the loop-closure constraints) ---------------------------------------

    def bias_acceleration(self, body: int | str) -> tuple:
        """Spatial acceleration (omega'; v') of the body, body frame at its origin, with every state acceleration
        vdot = 0: a_i = X_i a_parent + bias_i, the ground at rest (no gravity). Only the velocity-product and
        prescribed-motion terms remain; the full acceleration adds sum_k S_k vdot_k along the path to the
        ground. Computed once per body."""
        i = self.tree.body_index(body)
        if i < 0:
            return ZERO6
        if i not in self._bias_acc:
            parent = self.tree.bodies[i].parent
            a_p = self.bias_acceleration(parent)
            bk = self.bodies[i]
            self.tape.section(f"body {i + 1} ({self.tree.bodies[i].name}): acceleration with vdot = 0")
            a = ZERO6 if all(x is ZERO for x in a_p) else motion_to_child(self.tape, bk.X, a_p, f"a0p{i + 1}")
            self._bias_acc[i] = self.tape.vector([add(x, y) for x, y in zip(a, bk.bias)], f"a0{i + 1}")
        return self._bias_acc[i]

    def angular_bias_acceleration(self, body: int | str) -> tuple:
        """Angular acceleration of the body with vdot = 0, world components [rad/s^2]."""
        i = self.tree.body_index(body)
        if i < 0:
            return ZERO3
        return matvec(self.tape, self.world_pose(i)[0], self.bias_acceleration(i)[:3], f"al0{i + 1}")

    def frame_bias_acceleration(self, body: int | str, r_local) -> tuple:
        """Acceleration of the point with body coordinates r_local with vdot = 0, world components [m/s^2]:
        the classical acceleration a' + alpha x r + omega x (v + omega x r) of the spatial quantities."""
        i = self.tree.body_index(body)
        if i < 0:
            return ZERO3
        vel, acc, r = self.bodies[i].vel, self.bias_acceleration(i), _sym(r_local)
        w = vel[:3]
        v_point = [add(x, y) for x, y in zip(vel[3:], cross(w, r))]
        local = [add(x, y, z) for x, y, z in zip(acc[3:], cross(acc[:3], r), cross(w, v_point))]
        return matvec(self.tape, self.world_pose(i)[0], local, "acc")

    def joint_coordinate(self, body: int | str, k: int) -> sp.Expr:
        """Coordinate k of the body's joint: its state symbol, or its expression of t when prescribed."""
        return self.bodies[self.tree.body_index(body)].q[k]

    def joint_velocity(self, body: int | str, k: int) -> sp.Expr:
        """Velocity k of the body's joint (see `tree.velocity_names`)."""
        return self.bodies[self.tree.body_index(body)].v[k]

    # ---- applied loads ------------------------------------------------------------------------------------------

    def add_force(self, body: int | str, point, force, scale=1) -> None:
        """A force (world components) [N] acting at the point with body coordinates `point` [m], times `scale`
        (kept out of the tape, so that a placeholder there can be substituted later: `substitute_loads`)."""
        i = self.tree.body_index(body)
        if i < 0:
            return  # the ground takes any load
        f = matTvec(self.tape, self.world_pose(i)[0], _sym(force), f"fb{i + 1}")
        self._wrenches.setdefault(i, []).append(tuple(mul(scale, c) for c in tuple(cross(_sym(point), f)) + f))

    def add_torque(self, body: int | str, torque, scale=1) -> None:
        """A torque (world components) [N*m] acting on the body, times `scale` (kept out of the tape, as in
        `add_force`)."""
        i = self.tree.body_index(body)
        if i < 0:
            return
        n = matTvec(self.tape, self.world_pose(i)[0], _sym(torque), f"nb{i + 1}")
        self._wrenches.setdefault(i, []).append(tuple(mul(scale, c) for c in n) + ZERO3)

    def add_generalized_force(self, body: int | str, k: int, value) -> None:
        """A generalized force [N or N*m] on velocity k of the body's joint (doing work with that velocity).
        On a prescribed coordinate it only changes the (not computed) drive reaction, so it is dropped."""
        i = self.tree.body_index(body)
        slot = self.tree.v_slots[i][k]
        if slot is not None:
            self._generalized.setdefault(slot, []).append(sp.sympify(value))

    def substitute_loads(self, mapping) -> None:
        """Replace placeholder symbols in the applied loads: a friction force is known only once the equations
        with its placeholder are derived (compiler/friction.py)."""
        for slot, values in self._generalized.items():
            self._generalized[slot] = [sp.sympify(v).xreplace(mapping) for v in values]
        for body, wrenches in self._wrenches.items():
            self._wrenches[body] = [tuple(sp.sympify(c).xreplace(mapping) for c in w) for w in wrenches]

    def add_line_force(self, body_a: int | str, point_a, body_b: int | str, point_b,
                       tension: Callable[[sp.Expr, sp.Expr], sp.Expr]) -> tuple:
        """A force along the line between two points (spring, damper, rope, actuator).

        tension(length, rate) -> tension [N], positive pulling the points together; length [m] is the distance
        and rate [m/s] its time derivative. Returns (length, rate, tension) as tape expressions. The direction is
        undefined when the points coincide (the generated code then reports a non-finite result).

        Between two bodies below a common body (a car's strut between the car body and a control arm) the line
        is computed in that body's frame (`load_frame`), from the poses and velocities relative to it: the same
        length and rate, without the world poses of the bodies and the rotations of the force to and from world
        components (the load on the common body is in its own components already).
        """
        frame = self.load_frame(body_a, body_b)
        if frame >= 0:
            return self._relative_line_force(frame, body_a, point_a, body_b, point_b, tension)
        tape = self.tape
        pa, pb = self.frame_position(body_a, point_a), self.frame_position(body_b, point_b)
        d = tape.vector([add(y, -x) for x, y in zip(pa, pb)], "ld")
        length = tape.temp(sp.sqrt(dot(d, d)), "len")
        e = tape.vector([mul(x, tape.temp(1 / length, "ilen")) for x in d], "le")
        va, vb = self.frame_velocity(body_a, point_a), self.frame_velocity(body_b, point_b)
        rate = tape.temp(dot(e, [add(y, -x) for x, y in zip(va, vb)]), "rate")
        T = tape.temp(sp.sympify(tension(length, rate)), "tension")
        force_on_a = tape.vector([mul(T, x) for x in e], "lf")
        self.add_force(body_a, point_a, force_on_a)
        self.add_force(body_b, point_b, [-x for x in force_on_a])
        return length, rate, T

    def _relative_line_force(self, frame: int, body_a, point_a, body_b, point_b, tension) -> tuple:
        """add_line_force in the frame of the body `frame` above both bodies."""
        tape = self.tape
        (pa, va), (pb, vb) = self.point_in(frame, body_a, point_a), self.point_in(frame, body_b, point_b)
        d = tape.vector([add(y, -x) for x, y in zip(pa, pb)], "ld")
        length = tape.temp(sp.sqrt(dot(d, d)), "len")
        e = tape.vector([mul(x, tape.temp(1 / length, "ilen")) for x in d], "le")
        rate = tape.temp(dot(e, [add(y, -x) for x, y in zip(va, vb)]), "rate")
        T = tape.temp(sp.sympify(tension(length, rate)), "tension")
        self.add_force_along(frame, body_a, point_a, e, T)
        self.add_force_along(frame, body_b, point_b, e, -T)
        return length, rate, T

    # ---- loads computed in the frame of a body above both ends ----------------------------------------------

    def load_frame(self, body_a: int | str, body_b: int | str) -> int:
        """The nearest body above (or equal to) both bodies, in whose frame a load between them is computed; -1
        (world components) when there is none."""
        from .relative_motion import common_ancestor  # (it imports this module)
        return common_ancestor(self, self.tree.body_index(body_a), self.tree.body_index(body_b))

    def relative_motion(self, frame: int):
        """The motion of the bodies below body `frame` relative to it (compiler/relative_motion.py), on this
        kinematics' tape (a copy of the kinematics on a fork of the tape gets its own)."""
        from .relative_motion import RelativeMotion
        found = self._relative.get(frame)
        if found is None or found.kin is not self:
            found = RelativeMotion(self, frame)
            self._relative[frame] = found
        return found

    def point_in(self, frame: int, body: int | str, r_local) -> tuple:
        """(position, velocity) of the point with body coordinates r_local relative to body `frame` (at or above
        the body), in its components [m, m/s]."""
        rel, i, r = self.relative_motion(frame), self.tree.body_index(body), _sym(r_local)
        R, r0 = rel.pose(i)
        position = self.tape.vector([add(x, dot(row, r)) for x, row in zip(r0, R)], "posr")
        vel = rel.velocity(i)
        if is_zero(vel):
            return position, ZERO3
        local = [add(x, y) for x, y in zip(vel[3:], cross(vel[:3], r))]
        return position, matvec(self.tape, R, local, "velr")

    def direction_in(self, frame: int, body: int | str, e_local) -> tuple:
        """(e, omega): the direction with body components e_local and the body's angular velocity relative to body
        `frame` (at or above it), both in its components."""
        rel, i = self.relative_motion(frame), self.tree.body_index(body)
        R = rel.pose(i)[0]
        e = self.tape.vector([dot(row, _sym(e_local)) for row in R], "dirr")
        vel = rel.velocity(i)
        return e, (ZERO3 if is_zero(vel[:3]) else matvec(self.tape, R, vel[:3], f"wr{i + 1}"))

    def add_force_along(self, frame: int, body: int | str, point, e, tension) -> None:
        """The force tension * e (e in the components of body `frame`, at or above the body) [N] acting at the
        point with body coordinates `point`: its wrench is tension times the body's unit wrench (e and point x e
        in body components), which the loads along the same line at the same point (a spring and a damper)
        share."""
        i = self.tree.body_index(body)
        if i < 0:
            return
        R = self.relative_motion(frame).pose(i)[0]
        e_body = e if is_identity(R) else matTvec(self.tape, R, e, f"eb{i + 1}")
        torque = self.tape.vector(cross(_sym(point), e_body), f"eu{i + 1}")
        self._wrenches.setdefault(i, []).append(tuple(mul(tension, c) for c in tuple(torque) + tuple(e_body)))

def _sym(v) -> tuple:
    return tuple(sp.sympify(x) for x in v)


def _tuples(X) -> tuple:
    """(R, r) with sympy matrices -> tuples of rows and a tuple."""
    R, r = X
    R = tuple(tuple(sp.sympify(R[i][j] if isinstance(R, tuple) else R[i, j]) for j in range(3)) for i in range(3))
    return R, tuple(sp.sympify(x) for x in r)
