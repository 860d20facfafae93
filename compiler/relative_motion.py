"""Motion of body points and directions relative to an ancestor body of the tree, on the tape.

A loop that closes below a body (the four corners of a car close below the car body) has closure conditions that
depend only on the coordinates between that body and the cut joint, once they are written in the body's frame:
its position, its velocity and the coordinates above it drop out exactly. Written in world components instead,
the rows read the body's coordinates too (the terms cancel only numerically), which couples every loop to every
other through the body's columns of the constraint Jacobian G and fills the loop solver's factors and null-space
basis. So the closure rows of such a cut are built here: the subtree below the ancestor is treated as a tree of
its own with the ancestor as its ground, by the outward recursion of `Kinematics` with the ancestor at rest
(positions, spatial velocities and accelerations with every state acceleration zero, each body in its own frame),
and points and directions of its bodies come out in the ancestor's frame with their first and second time
derivatives.

Units: m, rad, s.
"""

from __future__ import annotations

from .kinematics import Kinematics
from .spatial import IDENTITY, ZERO3, ZERO6, add, cross, dot, matmul, matvec, motion_cross, motion_to_child


def common_ancestor(kin: Kinematics, a: int, b: int) -> int:
    """The nearest body both a and b are (descendants of or) equal to; -1 (the ground) when there is none."""
    above = set()
    while a >= 0:
        above.add(a)
        a = kin.tree.bodies[a].parent
    while b >= 0 and b not in above:
        b = kin.tree.bodies[b].parent
    return b


class RelativeMotion:
    """Poses, velocities and accelerations (vdot = 0) of the bodies below `ancestor` relative to it: what they
    would be if the ancestor were the ground. Vectors in the ancestor's frame unless said otherwise."""

    def __init__(self, kin: Kinematics, ancestor: int):
        self.kin, self.ancestor, self.tape = kin, ancestor, kin.tape
        self._pose: dict[int, tuple] = {ancestor: (IDENTITY, ZERO3)}
        self._vel: dict[int, tuple] = {ancestor: ZERO6}
        self._acc: dict[int, tuple] = {ancestor: ZERO6}

    def _parent(self, i: int) -> int:
        parent = self.kin.tree.bodies[i].parent
        if parent < 0:
            raise ValueError(f"body {i} is not below body {self.ancestor}")
        return parent

    def pose(self, i: int) -> tuple:
        """(R, r): rotation body -> ancestor components and the body origin in the ancestor's frame [m]."""
        if i not in self._pose:
            R_p, r_p = self.pose(self._parent(i))
            R, r = self.kin.bodies[i].X
            self.tape.section(f"body {i + 1} ({self.kin.tree.bodies[i].name}): pose in body {self.ancestor + 1}")
            self._pose[i] = (matmul(self.tape, R_p, R, f"Rr{i + 1}"),
                             self.tape.vector([add(x, dot(row, r)) for x, row in zip(r_p, R_p)], f"rr{i + 1}"))
        return self._pose[i]

    def velocity(self, i: int) -> tuple:
        """Spatial velocity (omega; v) relative to the ancestor, body frame at its origin."""
        if i not in self._vel:
            parent = self._parent(i)
            bk = self.kin.bodies[i]
            v_p = self.velocity(parent)
            self.tape.section(f"body {i + 1} ({self.kin.tree.bodies[i].name}): velocity in body {self.ancestor + 1}")
            if all(x == 0 for x in v_p):
                self._vel[i] = bk.vJ
            else:
                moved = motion_to_child(self.tape, bk.X, v_p, f"vrp{i + 1}")
                self._vel[i] = self.tape.vector([add(x, y) for x, y in zip(moved, bk.vJ)], f"vr{i + 1}")
        return self._vel[i]

    def acceleration(self, i: int) -> tuple:
        """Spatial acceleration relative to the ancestor with vdot = 0, body frame at its origin: the tree's
        recursion with the relative velocity in the velocity product (joint_bias + vel_rel x vJ)."""
        if i not in self._acc:
            parent = self._parent(i)
            bk = self.kin.bodies[i]
            a_p, vel = self.acceleration(parent), self.velocity(i)
            self.tape.section(f"body {i + 1} ({self.kin.tree.bodies[i].name}): acceleration in body "
                              f"{self.ancestor + 1} with vdot = 0")
            moved = ZERO6 if all(x == 0 for x in a_p) else motion_to_child(self.tape, bk.X, a_p, f"arp{i + 1}")
            product = motion_cross(self.tape, vel, bk.vJ, f"vxr{i + 1}")
            self._acc[i] = self.tape.vector([add(m, b, x) for m, b, x in zip(moved, bk.joint_bias, product)],
                                            f"ar{i + 1}")
        return self._acc[i]

    def point(self, i: int, r_local) -> tuple:
        """(position, velocity, acceleration with vdot = 0) of the point with body coordinates r_local."""
        R, r0 = self.pose(i)
        vel, acc = self.velocity(i), self.acceleration(i)
        w, v, alpha, a = vel[:3], vel[3:], acc[:3], acc[3:]
        position = self.tape.vector([add(x, dot(row, r_local)) for x, row in zip(r0, R)], "posr")
        v_point = [add(x, y) for x, y in zip(v, cross(w, r_local))]
        a_point = [add(x, y, z) for x, y, z in zip(a, cross(alpha, r_local), cross(w, v_point))]
        return position, matvec(self.tape, R, v_point, "velr"), matvec(self.tape, R, a_point, "accr")

    def direction(self, i: int, e_local) -> tuple:
        """(e, e', e'') of the unit vector with body components e_local: e' = w x e, e'' = alpha x e + w x e'."""
        R = self.pose(i)[0]
        e = self.tape.vector([dot(row, e_local) for row in R], "dirr")
        if i == self.ancestor:
            return e, ZERO3, ZERO3
        vel, acc = self.velocity(i), self.acceleration(i)
        w = matvec(self.tape, R, vel[:3], f"wr{i + 1}")
        alpha = matvec(self.tape, R, acc[:3], f"alr{i + 1}")
        rate = self.tape.vector(cross(w, e), "ddirr")
        accel = [add(x, y) for x, y in zip(cross(alpha, e), cross(w, rate))]
        return e, rate, self.tape.vector(accel, "dddirr")
