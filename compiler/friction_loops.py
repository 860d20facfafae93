"""Switched friction in a model with closed kinematic loops: a sticking element is one more constraint row.

In a tree the accelerations are a tape expression, so compiler/friction.py splits them into a0 + W F and solves for
the sticking force there. With loops the accelerations come from the run-time loop solver (runtime/c/loops.c:
M vdot = f + G^T lambda with G vdot = -gddot0), which already is the solve that gives a locking force exactly: a
sticking element is a constraint on the velocities like a loop closure, its force that row's multiplier.

So each element adds one row to the loop-closure constraints, switched by its mode (stick = 1 - mode^2):

    position      0                     (the lock is a velocity constraint; the projection keeps q_j where it is)
    velocity      stick * u             u = the joint speed v_j (a revolute joint: its angular speed), or the slip
                                        speed w of a point contact
    acceleration  stick * du/dt(vdot=0) the velocity-product part (zero for a joint)

Its multiplier lambda is then the generalized force on u's direction that holds it: the friction force (torque in a
revolute joint) while sticking, since G's row is du/dv and G^T lambda the force along the joint or the tangent.
While slipping the row is zero: the loop solver drops it as redundant (multiplier 0) and the element acts with
its kinetic force, an ordinary applied load. The loop solver's partition is re-chosen when a row appears or
vanishes (a zero pivot, a dropped row that no longer holds).

Events are those of the tree case with F_req = lambda, except that a grip cannot know the holding force before
the row is on (lambda is 0 while slipping): it sets the element to stick, and the event loop lets an element go
right after an event when its holding force is beyond the static limit (runtime/friction.py), in the direction
the system then accelerates in.

A plane contact (compiler/friction_plane.py) is two rows, one per tangent, its holding force the pair of
multipliers, checked against the cone.

Not here: bearing friction (normal = reaction) in a loop model, friction in a loop-closing joint.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import sympy as sp
from mbs.language.diagnostics import Diagnostic, MbsError

from mbs.language.friction import direction_names

from .constraints import ConstraintRow, Constraints
from .friction_plane import plane_events
from .reactions import MULTIPLIER_ARRAY
from .symbolic import parameter_symbol


@dataclass(frozen=True)
class FrictionRow:
    """One sticking element's constraint row (see the module docstring) and its multiplier symbol."""

    name: str
    position: sp.Expr
    velocity: sp.Expr
    acceleration: sp.Expr
    multiplier: sp.Symbol


def resolve_in_loops(low, elements, sticks, events_of) -> tuple[dict, tuple, tuple, tuple]:
    """(sensor values of the friction forces, events, constraint rows, run-time inputs of their multipliers) of
    `elements` (compiler/friction.py's _Element) in a model with cuts; the kinetic forces go on the kinematics."""
    for e in elements:
        if e.load is not None:
            raise MbsError([Diagnostic("error", "bearing friction (normal = reaction) in a model with a closed "
                                                "kinematic loop is not supported yet", e.force.span)])
    kin = low.kin
    tape = kin.tape
    tape.section("friction: kinetic forces and sticking rows (closed loops: the lock is a constraint row)")
    offset = len(low.acceleration_terms.multipliers)  # the rows of the cut joints come first
    zero = [sp.S.Zero] * kin.tree.nv
    loads, values, rows, events = {}, {}, [], []
    for k, e in enumerate(elements):
        stick = sticks(e)
        along = e.lever if e.direction is None else e.direction  # a plane contact's row: its direction component
        slipping = tape.temp((1 - stick) * (-e.mode * e.mu * e.normal * along), f"friction_kinetic{k}")
        label = f"{e.force.name}.stick" + (str(e.plane) if e.plane else "")
        multiplier = sp.Symbol(f"lambda.{label}")
        loads[e.placeholder] = slipping
        values[e.placeholder] = tape.temp(stick * multiplier + slipping, f"friction_force{k}")
        rows.append(FrictionRow(label, sp.S.Zero, tape.temp(stick * e.rate, f"gd_stick{k}"),
                                tape.temp(stick * e.locked(zero), f"gdd_stick{k}"), multiplier))
        limit = tape.temp(e.mu_s * e.normal * e.lever, f"friction_limit{k}")
        if e.plane == 1:  # both rows' multipliers make the holding force; the grip sticks while lambda is 0
            partner = elements[k + 1]
            events += plane_events(e.force.name, e.force.span, e.mode, [parameter_symbol(n) for n in
                                   direction_names(e.force.name)], (e.speed, partner.speed),
                                   (multiplier, sp.Symbol(f"lambda.{partner.force.name}.stick2")), limit)
        elif e.plane == 0:
            events += events_of(e, multiplier, limit, after_grip=sp.S.Zero)
    kin.substitute_loads(loads)
    low.acceleration_terms.used = True  # the events read the multipliers at run time
    inputs = tuple((r.multiplier, MULTIPLIER_ARRAY, offset + k) for k, r in enumerate(rows))
    return values, tuple(events), tuple(rows), inputs


def with_friction_rows(constraints: Constraints, rows: tuple[FrictionRow, ...]) -> Constraints:
    """The loop-closure constraints followed by the friction elements' rows (their multipliers' order)."""
    if not rows:
        return constraints
    return replace(constraints, rows=constraints.rows + tuple(ConstraintRow(-1, r.name) for r in rows),
                   position=constraints.position + tuple(r.position for r in rows),
                   velocity=constraints.velocity + tuple(r.velocity for r in rows),
                   acceleration=constraints.acceleration + tuple(r.acceleration for r in rows))


__all__ = ["FrictionRow", "resolve_in_loops", "with_friction_rows"]
