"""Dry friction as an exact stick/slip switch: the ``coulomb`` element lowered to a mode and two events.

It acts in a prismatic or revolute joint (a generalized force on its coordinate) or at a point contact (a force
along a tangent of frame a at frame b's origin, `_Contact`).

**Stick.** The relative motion is locked: the friction force is exactly what the rest of the system needs for zero
relative acceleration (of the joint coordinate, or of the contact point along the tangent). The right-hand side is
linear in the friction forces F (the articulated-body algorithm is linear in the joint forces), so the compiler
derives it once with F as placeholders and splits it on the tape into the accelerations without friction, a0, and
their response to F, W = d vdot / dF (the columns M^-1 e_j: exact, by forward differentiation of the affine chain,
no stiff spring and no finite difference). The sticking element's force solves a0_i + sum_l W_il F_l = 0: the
multiplier of the locking constraint. Several elements are solved together (rows of slipping elements hold their
kinetic force; the system's pivots are ratios of principal minors of the positive definite W, so no pivoting is
needed).

**Slip.** F = -mode * mu(w) * N (times the radius in a revolute joint), mode = +1 or -1 the sign of the slip speed
w, mu(w) = mu_k + (mu_s - mu_k) exp(-(w / stribeck_speed)^2) (Stribeck).

**Bearing friction** (``normal = reaction``: the paper's "reibungsbehaftete Lagerstellen"): N = k |R| with R the
force the joint carries across its axis (the radial load of a pin, the normal load of a slider), which depends on
the accelerations and so on F itself. R is affine in F as well (R = R0 + B F, from the Newton-Euler inward pass with
the accelerations a0 + W F), so the kinetic law F = -mode c |R0 + B F| (c = mu k r) is solved *exactly*: with rho =
|R|, (1 - c^2 B.B) rho^2 - 2 sigma c (R0.B) rho - R0.R0 = 0, sigma = -mode, whose positive root is unique while c
|B| < 1 (beyond that the law has no unique solution, Painleve's paradox: the right-hand side turns NaN and the run
stops there). That is the case of one element alone; several, or one with other switched elements, are solved
by compiler/friction_bearing.py (the loads by Newton's method from these quadratics).

**Events** (named ``<force>.slip`` and ``<force>.grip``, the mode ``<force>.mode``): slip when |F_req| rises through
the static limit mu_s N while sticking (the new mode is the direction the system then accelerates in); grip when the
slip speed falls through zero while slipping: the speed is set to exactly zero and the element sticks if |F_req| <=
mu_s N, else slips on in the other direction. F_req (the force that would hold the joint) is computed in every mode.
At the start of a run the runtime decides the mode from the state (runtime/friction.py).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import sympy as sp
from mbs.language import model as M
from mbs.language.diagnostics import Diagnostic, MbsError
from mbs.language.friction import direction_names, is_switched, mode_name

from . import dynamics
from .events import LoweredEvent
from .friction_bearing import solve_loaded
from .friction_loops import resolve_in_loops
from .friction_plane import kinetic_directions, plane_events, plane_tangents, slip_speed
from .reactions import point_acceleration
from .spatial import ZERO3, add, cross, dot, mul
from .symbolic import ToSympy, parameter_symbol

#: Stands for the local 'reaction' while the normal-force law is converted.
REACTION = sp.Symbol("friction.reaction")


def _error(message: str, span) -> MbsError:
    return MbsError([Diagnostic("error", message, span)])


@dataclass(frozen=True)
class _Element:
    force: M.Force
    body: int                # the tree body whose joint carries the load (bearing friction); -1 for a contact
    coordinate: str | None   # the joint coordinate whose speed a grip sets to zero, 'contact.s'
    locked: Callable         # vdot -> the relative acceleration a stick holds at zero
    rate: sp.Expr            # the speed a stick holds at zero: the joint speed, or the contact's slip speed
    placeholder: sp.Symbol   # the generalized force while the equations are split
    mode: sp.Symbol          # 0 sticks, +1/-1 slips
    speed: sp.Expr           # slip speed at the friction surface [m/s]
    lever: sp.Expr           # 1 in a prismatic joint or a contact, the radius in a revolute joint
    mu_k: sp.Expr
    mu_s: sp.Expr
    mu: sp.Expr              # kinetic coefficient at the slip speed (Stribeck)
    normal: sp.Expr | None   # normal force, None when it is load * |reaction|
    load: sp.Expr | None     # k of normal = k * reaction
    direction: sp.Expr | None = None  # a plane contact's row: the kinetic force's direction component (else: mode)
    plane: int = 0           # 0 one row per element; a plane contact's rows are 1 and 2 (compiler/friction_plane.py)
    cut: int = -1            # a joint that closes a loop: its index in the lowering's cuts ...
    axis: tuple = ()         # ... and its axis (world components), across which it carries its load


class FrictionLowering:
    """Collects the friction elements while forces are attached (`attach`), then derives their forces and events
    (`resolve`) once every other load is on the kinematics."""

    def __init__(self, lowering):
        self.low = lowering
        self.elements: list[_Element] = []
        self.rows: tuple = ()    # closed loops: the sticking elements' constraint rows (compiler/friction_loops.py)
        self.inputs: tuple = ()  # ... and their multipliers as run-time inputs
        self.bearing = None      # ... and bearing friction there (compiler/friction_loops.py LoadedFriction)

    def attach(self, inter: M.Interaction, force: M.Force) -> sp.Expr:
        """Put the element's generalized force on its joint; returns it (a placeholder for a switched one)."""
        low = self.low
        body = low.body_of_interaction.get(inter.name)
        conv = ToSympy(lambda s: REACTION if s.kind == "local" else low._state_symbol(s), low.tables, low.switches)
        arg = lambda name: None if force.arg(name) is None else conv(force.arg(name))
        mu_k = arg("mu_k")
        mu_s = arg("mu_s") if force.arg("mu_s") is not None else mu_k
        lever = arg("radius") if force.arg("radius") is not None else sp.Integer(1)
        if force.arg("surface_normal") is not None:
            return self._attach_plane(inter, force, arg, mu_k, mu_s, conv(force.arg("normal")))
        if force.arg("tangent") is not None or body is None:  # a point contact, or a joint that closes a loop
            if force.arg("tangent") is not None:
                contact = _Contact(low, inter, [low.geometry(c) for c in force.arg("tangent")])
            elif inter.joint.kind == "prismatic":  # frame b's origin slides along the axis of frame a
                contact = _Contact(low, inter, [low.geometry(c) for c in inter.joint.axes[0]])
            else:
                contact = _Pin(low, inter, [low.geometry(c) for c in inter.joint.axes[0]])
            rate, locked, coordinate, body, apply = contact.speed, contact.acceleration, None, -1, contact.apply
            speed = lever * rate
            cut, axis = -1, ()
            if inter.joint is not None:
                cut = next(k for k, c in enumerate(low.cuts) if c.name == inter.name)
                axis = contact.t if isinstance(contact, _Contact) else contact.n
        else:
            slot = low.kin.tree.v_slots[body][0]
            rate, coordinate = low.kin.joint_velocity(body, 0), inter.joint.coordinates[0].name
            speed = lever * rate
            locked = lambda vdot: vdot[slot]
            apply = lambda value: low.kin.add_generalized_force(body, 0, value)
            cut, axis = -1, ()
        mu = mu_k
        if force.arg("stribeck_speed") is not None:
            mu = mu_k + (mu_s - mu_k) * sp.exp(-(speed / arg("stribeck_speed")) ** 2)
        normal, load = conv(force.arg("normal")), None
        if normal.has(REACTION):
            load = sp.diff(normal, REACTION)
            states = set(low.kin.tree.q_symbols) | set(low.kin.tree.v_symbols)
            if load.has(REACTION) or sp.expand(normal - load * REACTION) != 0 or load.free_symbols & states:
                raise _error("a load-dependent normal force is 'normal = reaction' or a constant times it",
                             force.span)
            normal = None
        if not is_switched(force):
            if normal is None:
                raise _error("the smoothed (tanh) friction law takes a normal force that does not depend on the "
                             "joint's reaction; use the switched element for bearing friction", force.span)
            value = -mu * normal * lever * sp.tanh(speed / arg("smoothing"))
            apply(value)
            return value
        placeholder = sp.Symbol(f"friction.{force.name}")
        apply(placeholder)
        self.elements.append(_Element(force, body, coordinate, locked, rate, placeholder,
                                      parameter_symbol(mode_name(force.name)), speed, lever, mu_k, mu_s, mu, normal,
                                      load, cut=cut, axis=tuple(axis)))
        return placeholder

    def _attach_plane(self, inter, force, arg, mu_k, mu_s, normal) -> sp.Expr:
        """A point contact sliding in a plane: two rows with one mode (compiler/friction_plane.py); returns the
        magnitude of its friction force."""
        low = self.low
        if not is_switched(force):
            raise _error("the smoothed (tanh) law is for one tangent; a plane contact (surface_normal = ..) is the "
                         "switched element", force.span)
        try:
            tangents = plane_tangents([low.geometry(c) for c in force.arg("surface_normal")])
        except ValueError as exc:
            raise _error(str(exc), force.span) from None
        contacts = [_Contact(low, inter, t) for t in tangents]
        w = [c.speed for c in contacts]
        mu = mu_k
        if force.arg("stribeck_speed") is not None:
            mu = mu_k + (mu_s - mu_k) * sp.exp(-(slip_speed(w) ** 2) / arg("stribeck_speed") ** 2)
        mode = parameter_symbol(mode_name(force.name))
        e = [parameter_symbol(n) for n in direction_names(force.name)]
        placeholders = []
        for k, (contact, d) in enumerate(zip(contacts, kinetic_directions(w, e))):
            placeholder = sp.Symbol(f"friction.{force.name}.{k + 1}")
            contact.apply(placeholder)
            placeholders.append(placeholder)
            self.elements.append(_Element(force, -1, None, contact.acceleration, contact.speed, placeholder, mode,
                                          contact.speed, sp.Integer(1), mu_k, mu_s, mu, normal, None, d, k + 1))
        return sp.sqrt(placeholders[0] ** 2 + placeholders[1] ** 2)

    def resolve(self) -> tuple[dict, tuple[LoweredEvent, ...]]:
        """({placeholder: friction force}, events): the forces replace the placeholders on the kinematics."""
        if not self.elements:
            return {}, ()
        low, elements = self.low, self.elements
        if low.cuts:
            values, events, self.rows, self.inputs, self.bearing = resolve_in_loops(low, elements, _sticks, _events)
            return values, events
        loaded = [e for e in elements if e.load is not None]
        kin = low.kin
        tape = kin.tape
        tape.section("friction: accelerations with the friction forces as placeholders")
        vdot = dynamics.forward_dynamics(kin)
        targets = [e.locked(vdot) for e in elements]
        if loaded:
            transmitted = dynamics.transmitted_loads(kin, vdot)
            for e in loaded:
                targets += _across_axis(tape, kin, e.body, transmitted)
        tape.section("friction: accelerations without friction and their response to the friction forces")
        zero, slope = affine_split(tape, targets, [e.placeholder for e in elements])
        n = len(elements)
        if loaded and n == 1:
            forces, required, limits = _bearing(tape, elements[0], zero[0], slope[0][0], zero[1:],
                                                [row[0] for row in slope[1:]])
        elif loaded:
            forces, required, limits = _several_loaded(tape, elements, zero[:n], slope[:n], zero[n:], slope[n:])
        else:
            forces, required, limits = _locked(tape, elements, zero, slope)
        mapping = {e.placeholder: f for e, f in zip(elements, forces)}
        kin.substitute_loads(mapping)
        events = []
        for i, (e, req, lim) in enumerate(zip(elements, required, limits)):
            if e.plane == 1:
                events += plane_events(e.force.name, e.force.span, e.mode, _directions(e), (e.speed,
                                       elements[i + 1].speed), (req, required[i + 1]), lim)
            elif e.plane == 0:
                events += _events(e, req, lim)
        events = tuple(events)
        return mapping, events


class _Contact:
    """A point contact: frame b's origin, a point of b's part, slides on a's part along `tangent` (an axis of
    frame a).  The slip speed is the tangential velocity of that point relative to the point of a's part at the
    same place; the friction force acts on both parts there."""

    def __init__(self, low, inter: M.Interaction, axis):
        kin, tape = low.kin, low.kin.tape
        self.kin = kin
        self.ba, _, _, Ra = low.frame_world(inter.a)
        self.bb, self.pb_local, pb, _ = low.frame_world(inter.b)
        self.t = [tape.temp(dot(Ra[k], axis), "fric_t") for k in range(3)]
        self.pa_local = ZERO3
        if self.ba >= 0:  # the point of a's part where b's origin is
            Rwa, rwa = kin.world_pose(self.ba)
            self.pa_local = [tape.temp(dot([Rwa[k][c] for k in range(3)], [p - r for p, r in zip(pb, rwa)]),
                                       "fric_pa") for c in range(3)]
        self.dv = [y - x for x, y in zip(kin.frame_velocity(self.ba, self.pa_local),
                                         kin.frame_velocity(self.bb, self.pb_local))]
        self.speed = tape.temp(dot(self.t, self.dv), "fric_w")

    def apply(self, value) -> None:
        self.kin.add_force(self.bb, self.pb_local, self.t, scale=value)
        self.kin.add_force(self.ba, self.pa_local, self.t, scale=-value)

    def acceleration(self, vdot) -> sp.Expr:
        """d(slip speed)/dt for the state accelerations vdot: t.(a_b - a_a) + (omega_a x t).(v_b - v_a)."""
        kin = self.kin
        acc = dynamics.body_accelerations(kin, vdot, gravity=False, tag="facc")
        da = [y - x for x, y in zip(point_acceleration(kin, acc, self.ba, self.pa_local),
                                    point_acceleration(kin, acc, self.bb, self.pb_local))]
        turning = cross(kin.body_angular_velocity(self.ba), self.t)
        return kin.tape.temp(add(dot(self.t, da), dot(turning, self.dv)), "fric_acc")


class _Pin:
    """A revolute joint that closes a loop (no coordinate of its own): b's part turns against a's about the joint
    axis n, fixed in frame a. The slip rate is n.(omega_b - omega_a) [rad/s]; the friction torque acts about n on
    both parts (on b's, and the opposite on a's), so its power is the torque times that rate and a lock's
    multiplier is the holding torque."""

    def __init__(self, low, inter: M.Interaction, axis):
        kin, tape = low.kin, low.kin.tape
        self.kin = kin
        self.ba, _, _, Ra = low.frame_world(inter.a)
        self.bb = low.body(inter.b.part)
        self.n = [tape.temp(dot(Ra[k], axis), "fric_n") for k in range(3)]
        self.dw = [y - x for x, y in zip(kin.body_angular_velocity(self.ba), kin.body_angular_velocity(self.bb))]
        self.speed = tape.temp(dot(self.n, self.dw), "fric_wrel")

    def apply(self, value) -> None:
        self.kin.add_torque(self.bb, self.n, scale=value)
        self.kin.add_torque(self.ba, self.n, scale=-value)

    def acceleration(self, vdot) -> sp.Expr:
        """d(slip rate)/dt for the state accelerations vdot: n.(alpha_b - alpha_a) + (omega_a x n).(omega_b -
        omega_a)."""
        kin = self.kin
        acc = dynamics.body_accelerations(kin, vdot, gravity=False, tag="facc")
        alpha = [ZERO3 if b < 0 else kin.tape.vector([dot(row, acc[b][:3]) for row in kin.world_pose(b)[0]],
                                                       "fric_alpha") for b in (self.ba, self.bb)]
        turning = cross(kin.body_angular_velocity(self.ba), self.n)
        return kin.tape.temp(add(dot(self.n, [y - x for x, y in zip(*alpha)]), dot(turning, self.dw)), "fric_acc")


def affine_split(tape, targets, symbols) -> tuple[list, list]:
    """(values at symbols = 0, d value / d symbols) of `targets`, expressions on `tape` that are affine in `symbols`
    (the friction forces: the dynamics is linear in the joint forces).  One walk over the tape: every temporary
    that reads a symbol gets a copy at zero and its derivatives (partials taken at zero: exact for affine
    chains), so nothing is expanded and the cost is the length of the chain times the number of symbols."""
    seeds = {s: k for k, s in enumerate(symbols)}
    at_zero = {s: sp.S.Zero for s in symbols}
    slopes = {s: {seeds[s]: sp.S.One} for s in symbols}
    entries = tape.entries_for(targets)

    def split(expr, name):
        # in sympy's order of the symbols, and the slopes in the order of the forces, not in the order of the set
        # of free symbols (which changes with the hash seed, and with it the order of the temporaries in the
        # generated C and the build cache's key)
        read = sorted((a for a in expr.free_symbols if a in at_zero), key=sp.default_sort_key)
        if not read:
            return expr, {}
        value = tape.temp(expr.xreplace(at_zero), f"{name}_f0")
        d: dict = {}
        for a in read:
            partial = sp.diff(expr, a).xreplace(at_zero)
            for k, da in slopes[a].items():
                d[k] = d.get(k, sp.S.Zero) + partial * da
        return value, {k: tape.temp(v, f"{name}_dF{k}") for k, v in sorted(d.items()) if v != 0}

    for entry in entries:
        value, d = split(entry.expr, entry.name)
        if d or value is not entry.expr:
            at_zero[entry.symbol], slopes[entry.symbol] = value, d
    values, rows = [], []
    for k, target in enumerate(targets):
        value, d = split(sp.sympify(target), f"friction_target{k}")
        values.append(value)
        rows.append([d.get(i, sp.S.Zero) for i in range(len(symbols))])
    return values, rows


def _across_axis(tape, kin, body: int, transmitted) -> list:
    """The force the joint of `body` carries across its axis (body frame): the radial load of a pin, the normal
    load of a slider.  Along the axis it carries a revolute joint's thrust (a collar's business, not the pin's)
    and a prismatic joint's own friction force, so that part is left out."""
    S = kin.bodies[body].S[0]
    axis = S[:3] if any(c != 0 for c in S[:3]) else S[3:]
    force = transmitted[body][3:]
    along = tape.temp(dot(axis, force), "friction_axial")
    return [tape.temp(f - along * a, f"friction_radial{c}") for c, (f, a) in enumerate(zip(force, axis))]


def _sticks(e: _Element):
    """1 while the element sticks (mode 0), 0 while it slips (mode +-1): no branch in the generated code."""
    return 1 - e.mode ** 2


def _locked(tape, elements, a0, W) -> tuple[list, list, list]:
    """Forces, holding forces F_req and static limits of elements with given normal forces: rows of sticking
    elements lock their joint (a0_i + W_i. F = 0), rows of slipping ones hold the kinetic force."""
    n = len(elements)
    kinetic = [-e.mode * e.mu * e.normal * (e.lever if e.direction is None else e.direction) for e in elements]
    A = [[add(mul(_sticks(e), W[i][j]), (1 - _sticks(e)) if i == j else 0) for j in range(n)]
         for i, e in enumerate(elements)]
    b = [add(-_sticks(e) * a0[i], (1 - _sticks(e)) * kinetic[i]) for i, e in enumerate(elements)]
    forces = _solve(tape, A, b)
    required = _required(tape, elements, a0, W, forces)
    limits = [tape.temp(e.mu_s * e.normal * e.lever, f"friction_limit{i}") for i, e in enumerate(elements)]
    return forces, required, limits


def _several_loaded(tape, elements, a0, W, R0, B) -> tuple[list, list, list]:
    """Forces, holding forces and static limits with several load-dependent elements (compiler/friction_bearing.py);
    R0, B: the load vectors' components (three per loaded element, in order) and their slopes in the forces."""
    forces, loaded = solve_loaded(tape, elements, a0, W, [R0[3 * l:3 * l + 3] for l in range(len(R0) // 3)],
                                  [B[3 * l:3 * l + 3] for l in range(len(B) // 3)], _solve, _sticks, affine_split)
    required = _required(tape, elements, a0, W, forces)
    limits = []
    for i, e in enumerate(elements):
        if e.load is None:
            limits.append(tape.temp(e.mu_s * e.normal * e.lever, f"friction_limit{i}"))
            continue
        l = loaded.index(i)  # its load with its own force at the holding force
        held = [add(R0[3 * l + c], *(mul(B[3 * l + c][j], required[i] if j == i else forces[j])
                                     for j in range(len(elements)))) for c in range(3)]
        limits.append(tape.temp(e.mu_s * e.load * e.lever * sp.sqrt(dot(held, held)), f"friction_limit{i}"))
    return forces, required, limits


def _required(tape, elements, a0, W, forces) -> list:
    """Per element (a plane contact: per row) the force that would hold it, the others' forces as they are."""
    n = len(elements)
    required = []
    for i in range(n):
        if elements[i].plane == 2:
            continue
        if elements[i].plane == 1:  # the plane contact's two rows together: a 2 x 2 block
            required += _required_pair(tape, a0, W, forces, i)
            continue
        others = add(a0[i], *(mul(W[i][j], forces[j]) for j in range(n) if j != i))
        required.append(tape.temp(-others * tape.inverse(W[i][i], f"friction_iW{i}"), f"friction_required{i}"))
    return required


def _required_pair(tape, a0, W, forces, i) -> list:
    """The forces of rows i, i + 1 (a plane contact) that hold both, the other elements' forces as they are."""
    n, j = len(a0), i + 1
    r = [add(a0[k], *(mul(W[k][l], forces[l]) for l in range(n) if l not in (i, j))) for k in (i, j)]
    inv = tape.inverse(tape.temp(W[i][i] * W[j][j] - W[i][j] * W[j][i], f"friction_det{i}"), f"friction_idet{i}")
    return [tape.temp((-W[j][j] * r[0] + W[i][j] * r[1]) * inv, f"friction_required{i}"),
            tape.temp((W[j][i] * r[0] - W[i][i] * r[1]) * inv, f"friction_required{j}")]


def _directions(e: _Element) -> list:
    return [parameter_symbol(n) for n in direction_names(e.force.name)]


def _solve(tape, A, b) -> list:
    """A x = b by Gaussian elimination on the tape (pivots positive: see the module docstring)."""
    n = len(b)
    A = [list(row) for row in A]
    b = list(b)
    for k in range(n):
        inv = tape.inverse(A[k][k], f"friction_pivot{k}")
        for i in range(k + 1, n):
            factor = tape.temp(mul(A[i][k], inv), f"friction_l{i}{k}")
            A[i] = [tape.temp(add(A[i][j], -mul(factor, A[k][j])), f"friction_a{i}{j}") if j > k else 0
                    for j in range(n)]
            b[i] = tape.temp(add(b[i], -mul(factor, b[k])), f"friction_b{i}")
    x = [None] * n
    for k in reversed(range(n)):
        inv = tape.inverse(A[k][k], f"friction_pivot{k}")
        x[k] = tape.temp(mul(add(b[k], *(-mul(A[k][j], x[j]) for j in range(k + 1, n))), inv), f"friction_force{k}")
    return x


def _bearing(tape, e: _Element, a0, W, R0, B) -> tuple[list, list, list]:
    """Force, holding force and static limit of one element with normal = load * |R|, R = R0 + B F (exact)."""
    required = tape.temp(-a0 * tape.inverse(W, "friction_iW"), "friction_required")
    held = [add(r, mul(bk, required)) for r, bk in zip(R0, B)]
    limit = tape.temp(e.mu_s * e.load * sp.sqrt(dot(held, held)) * e.lever, "friction_limit")
    c = tape.temp(e.mu * e.load * e.lever, "friction_c")
    p, q, bb = (tape.temp(dot(x, y), name) for x, y, name in ((R0, B, "friction_RB"), (R0, R0, "friction_RR"),
                                                                  (B, B, "friction_BB")))
    # alpha > 0 unless the law has no unique solution (Painleve): then sqrt makes the right-hand side NaN, which
    # the runtime reports with the time and the state (a guard would call it a singular mass matrix)
    root_alpha = tape.temp(sp.sqrt(1 - (1 - _sticks(e)) * c ** 2 * bb), "friction_root_alpha")  # 1 in stick
    alpha = tape.temp(root_alpha * root_alpha, "friction_alpha")
    inv_alpha = tape.temp(1 / alpha, "friction_ialpha")
    sigma = -e.mode
    rho = tape.temp((sigma * c * p + sp.sqrt(c ** 2 * p ** 2 + alpha * q)) * inv_alpha, "friction_load")
    slip = sigma * c * rho
    force = tape.temp(_sticks(e) * required + (1 - _sticks(e)) * slip, "friction_force")
    return [force], [required], [limit]


def _events(e: _Element, required, limit, after_grip=None) -> tuple[LoweredEvent, LoweredEvent]:
    """slip: |F_req| rises through the limit while sticking; grip: the slip speed falls through zero while
    slipping, and the element takes the mode `after_grip` (default: sticks when |F_req| is within the limit)."""
    stick = _sticks(e)
    direction_held = sp.Piecewise((-1, required > 0), (1, True))  # where the system accelerates when let go
    start = sp.Piecewise((1, e.speed > 0), (-1, e.speed < 0), (direction_held, True))
    slip = LoweredEvent(f"{e.force.name}.slip", stick * (sp.Abs(required) - limit) - e.mode ** 2, 1, False,
                        (("set", mode_name(e.force.name), start),), e.force.span)
    after = sp.Piecewise((0, sp.Abs(required) <= limit), (direction_held, True)) if after_grip is None else after_grip
    reinit = (("speed", e.coordinate, sp.S.Zero),) if e.coordinate is not None else ()
    grip = LoweredEvent(f"{e.force.name}.grip", e.mode * e.speed + stick, -1, False,
                        reinit + (("set", mode_name(e.force.name), after),), e.force.span)
    return slip, grip


__all__ = ["REACTION", "FrictionLowering", "affine_split"]
