"""Loops that close in closed form: the dependent coordinates as explicit functions of the independent ones.

A planar slider-crank or four-bar closes by a triangle: its loop-closure rows, solved one unknown at a time,
give each dependent coordinate either linearly (a slider's travel) or by a single trigonometric equation
a sin u + b cos u + c = 0 (a link's angle), whose solutions are u = atan2(a, b) +- acos(-c / sqrt(a^2 + b^2)).
This is what NEWEUL's users wrote by hand; here the compiler tries it with a bounded effort and refuses
conservatively, and the numeric loop solver (runtime/c/loops.c) stays the path for everything not proven:

* only loops whose rows read the free coordinates and the parameters (no time, no quaternions, qdot = v, no
  extra states or friction rows), whose non-vanishing rows number the rank of G, and that solve as a triangle:
  each step one row with one unknown, linear in it (with a coefficient free of the coordinates) or of the form
  above in an angle that enters only as sin/cos of (+-u + rest);
* the branch (the sign of each acos) is the one nearest the model's initial state (defaults, no scene: the
  generated text does not depend on the scene), and must be clearly nearer than the other;
* the branch must stay away from its singular positions (|acos argument| reaching 1, a slider-crank with r = l,
  a four-bar passing flat) over every value of the independent angles (sampled over the full circle at the
  default parameters), and its guards may not depend on independent coordinates other than angles;
* at random states on the branch every constraint row (those left out as vanishing too) holds to round-off.

From the explicit map q_D = phi(q_I) follow J = d phi / d q_I and the bias Jdot v_I (both symbolic), and with
them the reduced dynamics (J^T M J) a = J^T (f - M Jdot v_I) in minimal coordinates (compiler/ccode_closed_form.py
prints them). At run time a state that leaves the branch (an acos argument within MBS_CF_BAND of 1, a state
nearer the other branch, a parameter that makes the map undefined) falls back to the numeric solver.

Units: the model's (m, rad, s).
"""

from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass

import numpy as np
import sympy as sp

#: Compile-time budget of the attempt [s]; past it the attempt is refused (the numeric path stays).
BUDGET_S = 10.0
#: Largest expression (sympy count_ops) of a row the attempt works on.
MAX_OPS = 400
#: Largest explicit coordinate (count_ops) that sympy's simplify is asked to shorten.
SIMPLIFY_MAX_OPS = 150
#: ... and the smallest (below it simplify seldom finds anything and still takes a second).
SIMPLIFY_MIN_OPS = 20
#: Larger trees or more rows are not tried (their rows written out would be large).
MAX_COORDINATES, MAX_ROWS = 12, 12
#: Candidate partitions tried at most.
MAX_CANDIDATES = 40
#: |acos argument| allowed over the independent angles at compile time (1 is the singular position).
GUARD_MARGIN = 1e-2
#: Residual of the rows at random states on the branch, relative to the size of the terms: round-off.
RESIDUAL_TOL = 1e-10
#: Random states of the residual check, and angle samples of the singularity check.
CHECK_STATES = 20
ANGLE_SAMPLES = 720


class Refused(Exception):
    """The loops do not close in closed form as far as this module can prove (the reason says why)."""


@dataclass(frozen=True)
class ClosedForm:
    """q_D = positions(q_I) on one branch, with J = d q_D / d q_I (nd x ni, rows of `jacobian`), the bias
    Jdot v_I (nd) and the guards (each |guard| < 1 off the singular positions), as sympy expressions of the
    independent coordinates, their speeds and the parameters. Indices are into q (and v: qdot = v here)."""

    independent: tuple[int, ...]
    dependent: tuple[int, ...]
    angle: tuple[bool, ...]           # per dependent coordinate: defined modulo 2 pi (unwrapped at run time)
    positions: tuple
    jacobian: tuple
    bias: tuple
    guards: tuple
    rows: tuple[int, ...]             # the constraint rows solved (the others vanish identically)


@dataclass(frozen=True)
class _Step:
    unknown: sp.Symbol
    value: sp.Expr          # in the independent coordinates and the unknowns solved before
    angle: bool
    guard: sp.Expr | None
    radius: sp.Expr | None = None   # sqrt(a^2 + b^2) of a trigonometric step: 0 is singular too


def closed_form(constraints, equations, parameter_values: dict, q0, *, budget_s: float = BUDGET_S) -> ClosedForm:
    """The closed form of the loops of `constraints` (compiler/constraints.py) on the branch of the initial
    positions q0 (sequence, the tree's q order) at `parameter_values` ({symbol: float}); raises Refused."""
    deadline = time.monotonic() + budget_s
    tree = constraints.tree
    q, v = tuple(tree.q_symbols), tuple(tree.v_symbols)
    if tree.nz or constraints.quaternion_slots or len(q) != len(v):
        raise Refused("extra states or quaternions")
    if tuple(equations.qdot) != v:
        raise Refused("qdot is not v")
    if len(q) > MAX_COORDINATES or constraints.nc > MAX_ROWS:
        raise Refused(f"more than {MAX_COORDINATES} coordinates or {MAX_ROWS} rows")
    g = [sp.sympify(e) for e in constraints.tape.expand(list(constraints.position))]
    allowed = set(q) | set(parameter_values)
    for e in g:
        if not e.free_symbols <= allowed:
            raise Refused(f"a row reads {sorted(map(str, e.free_symbols - allowed))}")
        if sp.count_ops(e) > MAX_OPS:
            raise Refused("a row is too large")
    values = {s: float(x) for s, x in parameter_values.items()}
    q0 = np.asarray(q0, dtype=float)
    rng = np.random.default_rng(12)
    rows = [i for i, e in enumerate(g) if not _vanishes(e, q, values, rng)]
    if not rows:
        raise Refused("no rows")
    G = sp.Matrix([g[i] for i in rows]).jacobian(q)
    G_num = sp.lambdify(q, G.subs(values), "numpy")
    ranks = {np.linalg.matrix_rank(np.asarray(G_num(*_random_q(q0, rng)), dtype=float)) for _ in range(3)}
    if ranks != {len(rows)}:
        raise Refused("the rows that do not vanish are redundant or the rank varies")
    used = [k for k in range(len(q)) if any(q[k] in g[i].free_symbols for i in rows)]
    reasons = []
    for dependent in _candidates(G_num, q0, used, len(rows)):
        if time.monotonic() > deadline:
            reasons.append("out of time")
            break
        try:
            return _attempt(g, rows, q, v, dependent, values, q0, rng, deadline)
        except Refused as exc:
            reasons.append(f"dependent {', '.join(q[k].name for k in dependent)}: {exc}")
    raise Refused("no partition closes in closed form (" + "; ".join(reasons) + ")")


def _vanishes(e, q, values, rng) -> bool:
    """Is the row zero at every state (sympy says so, or at random states to round-off and simplify agrees)?"""
    if e == 0:
        return True
    f = sp.lambdify(q, e.subs(values), "numpy")
    if any(abs(float(f(*rng.uniform(-3, 3, len(q))))) > 1e-14 for _ in range(5)):
        return False
    return sp.simplify(e) == 0


def _random_q(q0, rng):
    return q0 + rng.uniform(-0.5, 0.5, q0.size)


def _candidates(G_num, q0, used, r):
    """Dependent coordinate sets of size r among `used`: first the pivot columns of complete pivoting of G at
    q0 (the runtime's choice), then the others by the conditioning of their block of G at q0."""
    G = np.asarray(G_num(*q0), dtype=float)
    scored = []
    for combo in itertools.combinations(used, r):
        s = np.linalg.svd(G[:, combo], compute_uv=False)
        scored.append((-(s[-1] / s[0]) if s[0] > 0 else 0.0, combo))
    scored.sort()
    return [c for _, c in scored[:MAX_CANDIDATES]]


def _attempt(g, rows, q, v, dependent, values, q0, rng, deadline) -> ClosedForm:
    unknowns = [q[k] for k in dependent]
    independent = tuple(k for k in range(len(q)) if k not in dependent)
    qi = [q[k] for k in independent]
    known = {q[k]: q0[k] for k in independent}
    pending = [g[i] for i in rows]
    steps: list[_Step] = []
    while pending:
        if time.monotonic() > deadline:
            raise Refused("out of time")
        for row in pending:
            left = row.free_symbols & set(unknowns) - {s.unknown for s in steps}
            if len(left) == 1:
                u = left.pop()
                step = _solve_linear(row, u, qi) or _solve_trig(row, u)
                if step is None:
                    continue
                step = _choose_branch(step, u, known, values, q0[q.index(u)])
                known[u] = _evaluate(step.value, known, values)
                steps.append(step)
                pending.remove(row)
                break
        else:
            raise Refused("the rows do not solve one unknown at a time")
    explicit: dict = {}
    for s in steps:
        explicit[s.unknown] = s.value.xreplace(explicit)
    guards = tuple(gd for gd in (s.guard.xreplace(explicit) for s in steps if s.guard is not None)
                   if not gd.is_number)  # (a constant argument is checked below like the others, not at run time)
    constant = [abs(float(s.guard)) for s in steps if s.guard is not None and s.guard.is_number]
    if any(not c < 1 - GUARD_MARGIN for c in constant):
        raise Refused("the branch sits at a singular position")
    radii = tuple(s.radius.xreplace(explicit) for s in steps if s.radius is not None)
    _check_guards(guards, radii, q, independent, values, q0)
    order = [q[k] for k in dependent]
    positions = tuple(_simpler(explicit[u], deadline) for u in order)
    _check_residuals(g, q, independent, dependent, positions, values, q0, rng)
    J = sp.Matrix(positions).jacobian(qi).applyfunc(lambda e: _simpler(e, deadline))
    vi = sp.Matrix([v[k] for k in independent])
    velocity = J * vi
    bias = velocity.jacobian(qi) * vi  # (of the simplified J: short enough, and simplify is the slow part)
    angle = {s.unknown: s.angle for s in steps}
    return ClosedForm(independent, tuple(dependent), tuple(angle[u] for u in order), positions,
                      tuple(tuple(J.row(i)) for i in range(J.rows)), tuple(bias), guards, tuple(rows))


def _solve_linear(row, u, qi) -> _Step | None:
    """u from a row a u + b with a free of u and of the coordinates (a slider's travel)."""
    a = sp.diff(row, u)
    if u in a.free_symbols or a.free_symbols & set(qi) or a == 0:
        return None
    b = row.xreplace({u: 0})
    if sp.simplify(a * u + b - row) != 0:
        return None
    return _Step(u, -b / a, False, None)


def _solve_trig(row, u) -> _Step | None:
    """u from a row a sin u + b cos u + c (u only inside sin/cos of +-u + rest): one of
    u = atan2(a, b) +- acos(-c / sqrt(a^2 + b^2)); the sign is chosen later (_choose_branch), here +."""
    S, C = sp.Dummy("S"), sp.Dummy("C")
    replaced = {}
    for f in row.atoms(sp.sin, sp.cos):
        if u not in f.free_symbols:
            continue
        arg = sp.expand(f.args[0])
        k = arg.coeff(u)
        rest = sp.expand(arg - k * u)
        if k not in (1, -1) or u in rest.free_symbols:
            return None
        s, c = k * S, C  # sin(k u), cos(k u)
        if isinstance(f, sp.sin):
            replaced[f] = s * sp.cos(rest) + c * sp.sin(rest)
        else:
            replaced[f] = c * sp.cos(rest) - s * sp.sin(rest)
    expr = sp.expand(row.xreplace(replaced))
    if u in expr.free_symbols:
        return None
    try:
        poly = sp.Poly(expr, S, C)
    except sp.PolynomialError:
        return None
    if any(sum(m) > 1 for m in poly.monoms()):
        return None
    a, b, c = poly.coeff_monomial(S), poly.coeff_monomial(C), poly.coeff_monomial(1)
    radius = sp.sqrt(sp.trigsimp(sp.expand(a ** 2 + b ** 2)))
    guard = sp.trigsimp(-c / radius)
    return _Step(u, sp.atan2(a, b) + sp.acos(guard), True, guard, radius)


def _simpler(expr, deadline):
    """expr simplified when that is cheap enough and makes it smaller (the derivatives, and so the C, follow its
    size); the residual check runs on the result."""
    ops = sp.count_ops(expr)
    if not SIMPLIFY_MIN_OPS <= ops <= SIMPLIFY_MAX_OPS or time.monotonic() > deadline:
        return expr
    simpler = sp.simplify(expr)
    return simpler if sp.count_ops(simpler) < ops else expr


def _evaluate(expr, known, values) -> float:
    return float(expr.xreplace(values).xreplace({s: sp.Float(x) for s, x in known.items()}).evalf())


def _choose_branch(step: _Step, u, known, values, initial: float) -> _Step:
    """The sign of the acos whose value lies nearest the initial value of u (modulo 2 pi), when clearly so."""
    if not step.angle:
        return step
    base = step.value - sp.acos(step.guard)
    branches = [base + sp.acos(step.guard), base - sp.acos(step.guard)]
    distance = [abs(_wrap(_evaluate(b, known, values) - initial)) for b in branches]
    best = int(np.argmin(distance))
    if not (distance[best] < 0.2 and distance[1 - best] > 2 * distance[best] + 1e-3):
        raise Refused(f"the initial state does not tell the branch of {u}")
    return _Step(u, branches[best], True, step.guard, step.radius)


def _wrap(x: float) -> float:
    return (x + math.pi) % (2 * math.pi) - math.pi


def _is_angle(s, exprs) -> bool:
    """Does s enter the expressions only through sin and cos (a periodic coordinate)?"""
    D = sp.Dummy()
    for e in exprs:
        stripped = e.replace(lambda f: isinstance(f, (sp.sin, sp.cos)), lambda f: D)
        if s in stripped.free_symbols:
            return False
    return True


def _check_guards(guards, radii, q, independent, values, q0) -> None:
    """Every acos argument stays below 1 - GUARD_MARGIN, and every radius sqrt(a^2 + b^2) above GUARD_MARGIN
    times its largest value, over the full circle of each independent angle they read (the other independent
    coordinates at their initial values); one that reads a coordinate that is not an angle cannot be bounded
    this way: refused."""
    exprs = tuple(guards) + tuple(radii)
    if not exprs:
        return
    reads = sorted(set().union(*(gd.free_symbols for gd in exprs)) & {q[k] for k in independent}, key=str)
    if not all(_is_angle(s, exprs) for s in reads):
        raise Refused("a guard reads a coordinate that is not an angle")
    rng = np.random.default_rng(3)
    n = ANGLE_SAMPLES if len(reads) <= 1 else ANGLE_SAMPLES * len(reads)
    grid = {s: (np.linspace(-math.pi, math.pi, n) if len(reads) == 1 else rng.uniform(-math.pi, math.pi, n))
            for s in reads}
    fixed = {q[k]: q0[k] for k in independent if q[k] not in grid}
    def sampled(e):
        f = sp.lambdify(reads, e.xreplace(values).xreplace(fixed), "numpy")
        return np.abs(np.broadcast_to(np.asarray(f(*[grid[s] for s in reads]), dtype=float), (n,)))

    for gd in guards:
        if not np.max(sampled(gd)) < 1 - GUARD_MARGIN:
            raise Refused("the branch can reach a singular position")
    for radius in radii:
        size = sampled(radius)
        if not np.min(size) > GUARD_MARGIN * np.max(size):
            raise Refused("the branch can reach a singular position (a vanishing radius)")


def _check_residuals(g, q, independent, dependent, positions, values, q0, rng) -> None:
    """All rows vanish to round-off at random states of the branch (near the initial state)."""
    qi = [q[k] for k in independent]
    pos = sp.lambdify(qi, [p.xreplace(values) for p in positions], "numpy")
    rows = sp.lambdify(q, [e.xreplace(values) for e in g], "numpy")
    terms = sp.lambdify(q, [sum(abs(t) for t in sp.Add.make_args(sp.expand(e.xreplace(values)))) for e in g],
                        "numpy")
    for _ in range(CHECK_STATES):
        x = q0.copy()
        x[list(independent)] += rng.uniform(-1.0, 1.0, len(independent))
        x[list(dependent)] = np.asarray(pos(*x[list(independent)]), dtype=float)
        r = np.abs(np.asarray(rows(*x), dtype=float))
        scale = 1.0 + np.abs(np.asarray(terms(*x), dtype=float))
        if not np.all(np.isfinite(r)) or np.any(r > RESIDUAL_TOL * scale):
            raise Refused("the closed form does not satisfy the rows")


__all__ = ["ClosedForm", "Refused", "closed_form"]
