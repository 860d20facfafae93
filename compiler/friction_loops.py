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

**A joint that closes a loop** has no coordinate: its relative motion is a function of the tree state. A prismatic
one is a contact of frame b's origin along its axis (compiler/friction.py _Contact), a revolute one a torque about
its axis on both parts with the slip rate n.(omega_b - omega_a) (_Pin); the row and the events are the same.

**Bearing friction** (normal = reaction): the load R of the joint across its axis comes from the accelerations
and the multipliers (a tree joint's by the inverse dynamics with the cut joints' loads, a cut joint's from its
rows' multipliers), and those come from the loop solve, in which the kinetic force F acts: coupled. Everything is
affine in F, though: with the loaded element's force F_l put on its own row's multiplier (0 there while slipping,
the row being zero), R_l = R0_l + sum_j B_lj F_j where R0 comes from the solve without the bearings' kinetic
forces and B from the solve's response to each bearing's generalized force E_j. runtime/c/loops.c makes both
solves with the same factors; mbs_friction_loads (generated here, `bearing_routines`) solves F_l = k_l |R_l|
(k_l = -mode mu load lever) exactly, as the tree case does: the quadratic of one element, Newton's method for
several (compiler/friction_bearing.py loads_by_newton). mbs_forces leaves the bearings' kinetic forces out
(loops.c adds E F). While sticking the row holds the joint and F is 0; the static limit is mu_s load lever |R| at
the holding force. A model with bearing friction in its loops has no exact loop Jacobian (its residuals would not
know that f depends on the solve): the stiff integrators difference the right-hand side.

A loop model is assembled without the stick rows (runtime/friction.py stick_rows_released): the run then decides
each element's mode from the assembled state, slip if it moves, else by its holding force against the limit.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import sympy as sp
from mbs.language.diagnostics import Diagnostic, MbsError

from mbs.language.friction import direction_names

from .constraints import ConstraintRow, Constraints
from .friction_bearing import loads_by_newton
from .friction_plane import plane_events
from .reactions import MULTIPLIER_ARRAY
from .spatial import add, dot, mul
from .symbolic import parameter_symbol


@dataclass(frozen=True)
class FrictionRow:
    """One sticking element's constraint row (see the module docstring) and its multiplier symbol."""

    name: str
    position: sp.Expr
    velocity: sp.Expr
    acceleration: sp.Expr
    multiplier: sp.Symbol


@dataclass(frozen=True)
class LoadedFriction:
    """Bearing friction (normal = reaction) in a loop model, for the generated code (see the module docstring):
    the multipliers of the loaded elements' rows (their kinetic forces ride on them), the functions of the forces
    (mbs_friction_loads: the kinetic forces from the loop solver's affine response) and their inputs."""

    multipliers: tuple   # of the loaded elements' rows, in element order
    rows: tuple          # their index among all multipliers
    forces: tuple        # F_l as expressions of `inputs`, the state and the parameters
    inputs: tuple        # (symbol, "x", index): a0, lambda0, Wv (nv x m), Wl (nc x m) after the state


def resolve_in_loops(low, elements, sticks, events_of) -> tuple[dict, tuple, tuple, tuple, LoadedFriction | None]:
    """(sensor values of the friction forces, events, constraint rows, run-time inputs of their multipliers, the
    bearing friction's data or None) of `elements` (compiler/friction.py's _Element) in a model with cuts; the
    kinetic forces go on the kinematics."""
    kin = low.kin
    tape = kin.tape
    tape.section("friction: kinetic forces and sticking rows (closed loops: the lock is a constraint row)")
    offset = len(low.acceleration_terms.multipliers)  # the rows of the cut joints come first
    zero = [sp.S.Zero] * kin.tree.nv
    loads, values, rows, limits = {}, {}, [], []
    for k, e in enumerate(elements):
        stick = sticks(e)
        label = f"{e.force.name}.stick" + (str(e.plane) if e.plane else "")
        multiplier = sp.Symbol(f"lambda.{label}")
        if e.load is None:
            along = e.lever if e.direction is None else e.direction  # a plane contact's row: its direction component
            slipping = tape.temp((1 - stick) * (-e.mode * e.mu * e.normal * along), f"friction_kinetic{k}")
            loads[e.placeholder] = slipping
            values[e.placeholder] = tape.temp(stick * multiplier + slipping, f"friction_force{k}")
            limits.append(tape.temp(e.mu_s * e.normal * e.lever, f"friction_limit{k}"))
        else:  # the row's multiplier is the holding force, or the kinetic force loops.c puts there while slipping
            loads[e.placeholder] = (1 - stick) * multiplier
            values[e.placeholder] = multiplier
            limits.append(None)
        rows.append(FrictionRow(label, sp.S.Zero, tape.temp(stick * e.rate, f"gd_stick{k}"),
                                tape.temp(stick * e.locked(zero), f"gdd_stick{k}"), multiplier))
    loaded = [k for k, e in enumerate(elements) if e.load is not None]
    bearing = None
    if loaded:
        vectors = _load_vectors(low, [elements[k] for k in loaded], values)
        for l, k in enumerate(loaded):
            e = elements[k]
            limits[k] = tape.temp(e.mu_s * e.load * e.lever * sp.sqrt(dot(vectors[l], vectors[l])),
                                  f"friction_limit{k}")
        bearing = _kinetic_forces(low, [elements[k] for k in loaded], [offset + k for k in loaded], rows, vectors)
    events = []
    for k, e in enumerate(elements):
        multiplier, limit = rows[k].multiplier, limits[k]
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
    return values, tuple(events), tuple(rows), inputs, bearing


def _load_vectors(low, loaded, values) -> list:
    """The load R across each loaded element's axis (3 components) in the accelerations and all multipliers:
    a tree joint's from the inverse dynamics, a cut joint's from its rows' multipliers; friction forces that act
    as loads (at a contact, in a cut joint) are the placeholders still, replaced by their values (affine)."""
    from .friction import _across_axis as across_axis, affine_split  # (friction.py imports this module)
    kin, terms = low.kin, low.acceleration_terms
    tape = kin.tape
    transmitted = terms.transmitted_loads() if any(e.body >= 0 for e in loaded) else None
    tape.section("friction: the loads of the bearings with friction (closed loops)")
    vectors = []
    for e in loaded:
        if e.body >= 0:
            vectors.append(across_axis(tape, kin, e.body, transmitted))
            continue
        force = terms.cut_load(e.cut)[0]
        along = tape.temp(dot(force, e.axis), "friction_axial")
        vectors.append([tape.temp(f - along * a, f"friction_radial{c}") for c, (f, a) in enumerate(zip(force,
                                                                                                        e.axis))])
    placeholders = list(values)
    flat, slopes = affine_split(tape, [c for v in vectors for c in v], placeholders)
    return [[tape.temp(add(flat[3 * l + c], *(mul(slopes[3 * l + c][j], values[s]) for j, s in
                                             enumerate(placeholders))), f"friction_R{l}") for c in range(3)]
            for l in range(len(vectors))]


def _kinetic_forces(low, loaded, rows, friction_rows, vectors) -> LoadedFriction:
    """mbs_friction_loads: the loop solver gives the accelerations and multipliers affine in the loaded
    elements' kinetic forces F (a0 + Wv F, lambda0 + Wl F; F itself rides on its row's multiplier), so each
    load is R_l = R0_l + sum_j B_lj F_j, and F_l = k_l |R_l| with k_l = -mode mu load lever (0 while sticking):
    the quadratic of one element, Newton's method for several (compiler/friction_bearing.py), exact as in a tree."""
    from .friction import _solve as solve_linear, affine_split
    kin, terms = low.kin, low.acceleration_terms
    tape, tree = kin.tape, kin.tree
    acc = list(terms.vdot)
    lam = list(terms.multipliers) + [r.multiplier for r in friction_rows]
    nv, nc, m, nx = len(acc), len(lam), len(loaded), tree.nx
    tape.section("friction: the bearings' kinetic forces from the loop solver's response (closed loops)")
    flat, slopes = affine_split(tape, [c for v in vectors for c in v], acc + lam)
    a0 = [sp.Symbol(f"friction.a0.{i}") for i in range(nv)]
    l0 = [sp.Symbol(f"friction.l0.{i}") for i in range(nc)]
    Wv = [[sp.Symbol(f"friction.Wv.{i}.{j}") for j in range(m)] for i in range(nv)]
    Wl = [[sp.Symbol(f"friction.Wl.{i}.{j}") for j in range(m)] for i in range(nc)]
    R0, B = [], []
    for l in range(m):
        rv = [slopes[3 * l + c][:nv] for c in range(3)]
        rl = [slopes[3 * l + c][nv:] for c in range(3)]
        R0.append([tape.temp(add(flat[3 * l + c], *(mul(rv[c][i], a0[i]) for i in range(nv)),
                                 *(mul(rl[c][i], l0[i]) for i in range(nc))), f"friction_R0{l}") for c in range(3)])
        B.append([[tape.temp(add(rl[c][rows[j]], *(mul(rv[c][i], Wv[i][j]) for i in range(nv)),
                                 *(mul(rl[c][i], Wl[i][j]) for i in range(nc))), f"friction_B{l}{j}")
                   for j in range(m)] for c in range(3)])
    k = [tape.temp(-e.mode * e.mu * e.load * e.lever, f"friction_k{l}") for l, e in enumerate(loaded)]
    Q = [[[mul(B[l][c][j], k[j]) for j in range(m)] for c in range(3)] for l in range(m)]
    rho = loads_by_newton(tape, R0, Q, solve_linear)
    forces = tuple(tape.temp(mul(k[l], rho[l]), f"friction_kinetic{l}") for l in range(m))
    symbols = a0 + l0 + [s for row in Wv for s in row] + [s for row in Wl for s in row]
    inputs = tuple((s, "x", nx + i) for i, s in enumerate(symbols))
    return LoadedFriction(tuple(friction_rows[i - len(terms.multipliers)].multiplier for i in rows), tuple(rows),
                          forces, inputs)


def bearing_routines(equations, bearing: LoadedFriction, nc: int):
    """(equations whose forces f leave out the bearings' kinetic forces, (routines, inputs, definitions, work)
    for the C emitter): mbs_friction_directions E = d f / d F (nv x m, row-major) and mbs_friction_loads
    F(x; a0, lambda0, Wv, Wl), which runtime/c/loops.c combines (f + E F, with its response to F) in every solve."""
    from .friction import affine_split
    tape = equations.tape
    tape.section("friction: the forces without the bearings' kinetic forces, and their directions")
    f0, E = affine_split(tape, list(equations.forces), list(bearing.multipliers))
    nv, m, nx = len(f0), len(bearing.multipliers), equations.tree.nx
    routines = [
        ("mbs_friction_directions", "out", "E = d f / d F: the generalized forces of unit kinetic forces of the "
         "bearings with friction (nv x m, row-major; runtime/c/loops.c)", (nv, m),
         [(i * m + j, E[i][j]) for i in range(nv) for j in range(m)], False),
        ("mbs_friction_loads", "out", "the bearings' kinetic forces F at x = [x; a0; lambda0; Wv; Wl], the loop "
         "solver's accelerations and multipliers without them and their response to them (compiler/"
         "friction_loops.py)", (m,), list(enumerate(bearing.forces)), False)]
    work = nx + 5 * nv + 2 * nc + 2 * nv * m + nc * m + m
    definitions = "\n".join([
        f"#define MBS_NLOADED {m}   /* bearings with friction in the loops (runtime/c/loops.c) */",
        f"#define MBS_FRICTION_NWORK {work}   /* doubles of the loop solver's work they use, at its end */",
        "/* The row (multiplier) of each: its kinetic force is put there while it slips. */",
        f"static const int mbs_loaded_row[{m}] = {{{', '.join(map(str, bearing.rows))}}};",
        "int mbs_friction_directions(double t, const double *x, const double *p, double *out, double *work);",
        "int mbs_friction_loads(double t, const double *x, const double *p, double *out, double *work);"])
    return replace(equations, forces=tuple(f0)), (routines, bearing.inputs, definitions, work)


def with_friction_rows(constraints: Constraints, rows: tuple[FrictionRow, ...]) -> Constraints:
    """The loop-closure constraints followed by the friction elements' rows (their multipliers' order)."""
    if not rows:
        return constraints
    return replace(constraints, rows=constraints.rows + tuple(ConstraintRow(-1, r.name) for r in rows),
                   position=constraints.position + tuple(r.position for r in rows),
                   velocity=constraints.velocity + tuple(r.velocity for r in rows),
                   acceleration=constraints.acceleration + tuple(r.acceleration for r in rows))


__all__ = ["FrictionRow", "LoadedFriction", "bearing_routines", "resolve_in_loops", "with_friction_rows"]
