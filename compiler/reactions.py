"""Quantities that need the accelerations: joint reaction loads and acceleration sensors.

They are outputs, never inputs of the motion, so they are derived as expressions of the state *and* of two
vectors the run time computes first at the same (t, x): the state accelerations vdot (the right-hand side) and,
with closed loops, the Lagrange multipliers lambda of the loop-closure rows (M vdot = f + G^T lambda). The
generated output function obtains both by calling the model's own right-hand side and multiplier functions, so
a scene that asks for no reaction pays nothing, and one that does pays one extra evaluation per output sample.

Reaction of a tree joint: the inward pass of the recursive Newton-Euler algorithm with the true accelerations
gives the load each joint transmits onto its child body (Featherstone's f_i); the constraint loads of the cut
joints enter that pass as applied loads. Reaction of a cut joint: the multipliers of its rows times the row loads
(`constraints.cut_loads`). Both are reported as the load on the interaction's frame b, moment about b's origin.

Units: N, N*m, m/s^2.
"""

from __future__ import annotations

from functools import cached_property

import sympy as sp

from . import dynamics
from .constraints import ROWS, CutJoint, cut_loads
from .kinematics import Kinematics
from .spatial import ZERO3, add, cross, dot, matTvec, matvec, mul

#: Array names of the two run-time vectors in generated code (the generator's own prefix: no clash with names
#: made from the model).
ACCELERATION_ARRAY, MULTIPLIER_ARRAY = "mbs_acc", "mbs_lam"


def acceleration_symbol(v_symbol: sp.Symbol) -> sp.Symbol:
    """The symbol of the time derivative of the free velocity `v_symbol` (a run-time input of the outputs)."""
    return sp.Symbol(f"acc.{v_symbol.name}")


class AccelerationTerms:
    """Builds reaction loads and accelerations on the tape of `kinematics` for the tree's state plus the
    symbols `vdot` (one per free velocity) and `multipliers` (one per loop-closure row of `cuts`, in order).
    Everything is computed on first use, so a model that asks for none of it gets nothing on its tape."""

    def __init__(self, kinematics: Kinematics, cuts: tuple[CutJoint, ...] = ()):
        self.kin, self.cuts = kinematics, tuple(cuts)
        tree = kinematics.tree
        self.vdot = tuple(acceleration_symbol(v) for v in tree.v_symbols)
        self.multipliers = tuple(sp.Symbol(f"lambda.{cut.name}.{label}") for cut in self.cuts
                                 for label in ROWS[cut.joint.kind])
        self.used = False

    def inputs(self) -> tuple:
        """(symbol, array, index) of the run-time vectors, for the emitters; empty unless something was used."""
        if not self.used:
            return ()
        return tuple((s, ACCELERATION_ARRAY, k) for k, s in enumerate(self.vdot)) + \
            tuple((s, MULTIPLIER_ARRAY, k) for k, s in enumerate(self.multipliers))

    # ---- loads of the loop-closing joints ---------------------------------------------------------------------

    @cached_property
    def _cut_rows(self) -> tuple:
        """Per cut: (first multiplier index, row loads, p_a, p_b)."""
        out, first = [], 0
        for cut in self.cuts:
            loads, pa, pb = cut_loads(self.kin, cut)
            out.append((first, loads, pa, pb))
            first += len(loads)
        return tuple(out)

    def cut_load(self, j: int) -> tuple:
        """(force, torque about frame b's origin) the cut joint j exerts on its body B, world components."""
        self.used = True
        first, loads, _, _ = self._cut_rows[j]
        lam = self.multipliers[first:first + len(loads)]
        force = tuple(add(*(mul(m, row.force[c]) for m, row in zip(lam, loads))) for c in range(3))
        torque = tuple(add(*(mul(m, row.torque[c]) for m, row in zip(lam, loads))) for c in range(3))
        tape = self.kin.tape
        return tape.vector(force, "rcf"), tape.vector(torque, "rct")

    def _constraint_wrenches(self) -> dict:
        """Per tree body, the loads of the cut joints on it as a body-frame 6-vector (n; f) at the body origin."""
        parts: dict[int, list] = {}
        for j, cut in enumerate(self.cuts):
            first, loads, pa, pb = self._cut_rows[j]
            for m, row in zip(self.multipliers[first:first + len(loads)], loads):
                force = tuple(mul(m, c) for c in row.force)
                torque = tuple(mul(m, c) for c in row.torque)
                self._add(parts, cut.body_b, pb, force, torque)
                self._add(parts, cut.body_a, pb if row.a_at_b else pa, tuple(-c for c in force),
                          tuple(-c for c in torque))
        tape = self.kin.tape
        return {i: tape.vector([add(*(p[k] for p in ps)) for k in range(6)], f"fc{i + 1}")
                for i, ps in parts.items()}

    def _add(self, parts: dict, body: int, point, force, torque) -> None:
        if body < 0:
            return  # the ground takes any load
        R, r = self.kin.world_pose(body)
        moment = [add(x, y) for x, y in zip(torque, cross([add(p, -o) for p, o in zip(point, r)], force))]
        tape = self.kin.tape
        parts.setdefault(body, []).append(matTvec(tape, R, moment, f"nc{body + 1}")
                                          + matTvec(tape, R, force, f"fcb{body + 1}"))

    # ---- loads of the tree joints -----------------------------------------------------------------------------

    @cached_property
    def _transmitted(self) -> tuple:
        return self.transmitted_loads()

    def transmitted_loads(self) -> tuple:
        """Per tree body the load its joint transmits (Featherstone's f_i, body frame) with the accelerations
        `vdot`, the multipliers' loads and the loads on the kinematics as they are now (friction's placeholders
        before they are resolved: compiler/friction_loops.py); not kept."""
        self.used = True
        extra = self._constraint_wrenches() if self.cuts else None
        self.kin.tape.section("reaction loads: inverse dynamics with the actual accelerations")
        return dynamics.transmitted_loads(self.kin, self.vdot, extra)

    def tree_joint_load(self, body: int, on_child: bool, point) -> tuple:
        """(force, torque about `point`) in world components that the joint of tree body `body` exerts on the
        child body (`on_child`) or on the parent (the opposite load)."""
        self.used = True
        n, f = self._transmitted[body][:3], self._transmitted[body][3:]
        tape = self.kin.tape
        R, r = self.kin.world_pose(body)
        force = matvec(tape, R, f, "rjf")
        moment = [add(x, y) for x, y in zip(matvec(tape, R, n, "rjn"),
                                            cross([add(o, -p) for o, p in zip(r, point)], force))]
        sign = 1 if on_child else -1
        return (tape.vector([mul(sign, c) for c in force], "rf"),
                tape.vector([mul(sign, c) for c in moment], "rm"))

    # ---- accelerations ----------------------------------------------------------------------------------------

    @cached_property
    def _accelerations(self) -> tuple:
        return dynamics.body_accelerations(self.kin, self.vdot, gravity=False, tag="acc")

    def point_acceleration(self, body: int, r_local) -> tuple:
        """World acceleration of the point with body coordinates `r_local` [m/s^2] (zero on the ground)."""
        if body < 0:
            return ZERO3
        self.used = True
        return point_acceleration(self.kin, self._accelerations, body, r_local)


def point_acceleration(kin: Kinematics, accelerations, body: int, r_local) -> tuple:
    """World acceleration of the point with body coordinates `r_local` [m/s^2], from the bodies' spatial
    accelerations (`dynamics.body_accelerations` without gravity); zero on the ground."""
    if body < 0:
        return ZERO3
    vel, acc = kin.bodies[body].vel, accelerations[body]
    r = tuple(sp.sympify(c) for c in r_local)
    w = vel[:3]
    v_point = [add(x, y) for x, y in zip(vel[3:], cross(w, r))]
    local = [add(x, y, z) for x, y, z in zip(acc[3:], cross(acc[:3], r), cross(w, v_point))]
    return matvec(kin.tape, kin.world_pose(body)[0], local, "pacc")


def in_frame(tape, R_in, vector, name: str) -> tuple:
    """World components -> components in the frame with rotation R_in (frame -> world)."""
    return tuple(tape.temp(dot([R_in[k][c] for k in range(3)], vector), name) for c in range(3))


__all__ = ["AccelerationTerms", "acceleration_symbol", "in_frame", "point_acceleration", "ACCELERATION_ARRAY",
           "MULTIPLIER_ARRAY"]
