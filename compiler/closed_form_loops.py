"""Loops that close in closed form: the dependent coordinates as explicit functions of the independent ones.

A planar slider-crank or four-bar closes by a triangle: its loop-closure rows, solved one unknown at a time,
give each dependent coordinate either linearly (a slider's travel) or by a single trigonometric equation
a sin u + b cos u + c = 0 (a link's angle), whose solutions are u = atan2(a, b) +- acos(-c / sqrt(a^2 + b^2)).
This is what NEWEUL's users wrote by hand; here the compiler tries it with a bounded effort and refuses
conservatively, and the numeric loop solver (runtime/c/loops.c) stays the path for everything not proven:

* only loops whose rows read the free coordinates and the parameters (no time, no quaternions, qdot = v, no
  extra states or friction rows), whose non-vanishing rows number the rank of G, and that solve as a triangle:
  each step one row with one unknown, linear in it (with a coefficient free of the coordinates) or of the form
  above in an angle that enters only as sin/cos of (+-u + rest); or two rows with two angles u, w, linear in
  sin u and cos u, whose solution for them put into sin^2 u + cos^2 u = 1 is of that form in w (a four-bar);
* the branch (the sign of each acos) is the one nearest the model's initial state (defaults, no scene: the
  generated text does not depend on the scene), and must be clearly nearer than the other;
* the branch must stay away from its singular positions (|acos argument| reaching 1, a slider-crank with r = l,
  a four-bar passing flat) over every value of the independent angles (sampled over the full circle at the
  default parameters), and its guards may not depend on independent coordinates other than angles;
* at random states on the branch every constraint row (those left out as vanishing too) holds to round-off.

The steps are kept in order (each reads the independent coordinates and the unknowns solved before it), and
J = d q_D / d q_I = -G_D^-1 G_I and the bias Jdot v_I = -G_D^-1 (d(G v)/dq) v follow from the implicit function
theorem at the state they give (G_D^-1 by its adjugate, symbolically), and with them the reduced dynamics
(J^T M J) a = J^T (f - M Jdot v_I) in minimal coordinates (compiler/ccode_closed_form.py prints them). At run
time a state that leaves the branch (an acos argument within MBS_CF_BAND of 1, a dependent angle off the branch's
value: another assembly, a parameter that makes the map undefined) goes to the numeric solver. docs/numerics.md,
"Loops closed in closed form", has the figures.

Units: the model's (m, rad, s).
"""

from __future__ import annotations

import contextlib
import itertools
import math
import time
from dataclasses import dataclass

import numpy as np
import sympy as sp
import sympy.core.random as sympy_random

#: Compile-time budget of the attempt [s]; past it the attempt is refused (the numeric path stays).
BUDGET_S = 10.0
#: Largest expression (sympy count_ops) of a row the attempt works on.
MAX_OPS = 400
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
#: The seed of sympy's random generator during an attempt (restored after it). trigsimp factors by Wang's
#: algorithm, whose evaluation points sympy draws from a generator seeded by the operating system at import: the
#: four-bar of tests/compiler/models/four_bar.mbs took 2.8 s, 28 s or more than 2 minutes by the draw, to the
#: same result. Seeded, an attempt takes the same time in every process (`python bench/derive.py` measures it).
SYMPY_SEED = 0


@contextlib.contextmanager
def _seeded_sympy():
    """sympy's random generators seeded with SYMPY_SEED inside, their former states restored after."""
    states = sympy_random.rng.getstate(), sympy_random._assumptions_rng.getstate()
    sympy_random.seed(SYMPY_SEED)
    try:
        yield
    finally:
        sympy_random.rng.setstate(states[0])
        sympy_random._assumptions_rng.setstate(states[1])


class Refused(Exception):
    """The loops do not close in closed form as far as this module can prove (the reason says why)."""


@dataclass(frozen=True)
class ClosedForm:
    """q_D on one branch, with J = d q_D / d q_I (nd x ni, rows of `jacobian`), the bias Jdot v_I (nd) and the
    guards (each |guard| < 1 off the singular positions), as sympy expressions of the parameters and the state:
    positions[i] reads the independent coordinates and the dependent ones before it (`dependent` is in the order
    of solution); J, the bias and the guards read all coordinates and speeds (the dependent speed is J v_I).
    Indices are into q (and v: qdot = v here)."""

    independent: tuple[int, ...]
    dependent: tuple[int, ...]
    angle: tuple[bool, ...]           # per dependent coordinate: defined modulo 2 pi (unwrapped at run time)
    positions: tuple
    jacobian: tuple
    bias: tuple
    guards: tuple
    rows: tuple[int, ...]             # the constraint rows solved (the others vanish identically)
    sin_cos: tuple = ()               # per dependent coordinate: (sin, cos) of an angle as algebra, or None


@dataclass(frozen=True)
class _Step:
    unknown: sp.Symbol
    value: sp.Expr          # in the independent coordinates and the unknowns solved before
    angle: bool
    guard: sp.Expr | None
    radius: sp.Expr | None = None   # sqrt(a^2 + b^2) of a trigonometric step: 0 is singular too
    sin_cos: tuple | None = None    # (sin u, cos u) of an angle without trigonometric calls
    ab: tuple | None = None         # (a, b) of a trigonometric step (sin u, cos u follow with the branch)


def structural_refusal(constraints, equations) -> str | None:
    """Why closed_form refuses the loops whatever the parameters' values and the initial positions (None: it may
    not): the caller need not evaluate them (pipeline.closed_form_of)."""
    tree = constraints.tree
    q, v = tuple(tree.q_symbols), tuple(tree.v_symbols)
    if tree.nz or constraints.quaternion_slots or len(q) != len(v):
        return "extra states or quaternions"
    if tuple(equations.qdot) != v:
        return "qdot is not v"
    if len(q) > MAX_COORDINATES or constraints.nc > MAX_ROWS:
        return f"more than {MAX_COORDINATES} coordinates or {MAX_ROWS} rows"
    return None


def closed_form(constraints, equations, parameter_values: dict, q0, *, budget_s: float = BUDGET_S) -> ClosedForm:
    """The closed form of the loops of `constraints` (compiler/constraints.py) on the branch of the initial
    positions q0 (sequence, the tree's q order) at `parameter_values` ({symbol: float}); raises Refused."""
    with _seeded_sympy():
        return _closed_form(constraints, equations, parameter_values, q0, budget_s)


def _closed_form(constraints, equations, parameter_values: dict, q0, budget_s: float) -> ClosedForm:
    deadline = time.monotonic() + budget_s
    tree = constraints.tree
    q, v = tuple(tree.q_symbols), tuple(tree.v_symbols)
    reason = structural_refusal(constraints, equations)
    if reason is not None:
        raise Refused(reason)
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
    if not q:  # (loops between parts the tree holds fixed: nothing to solve for)
        raise Refused("no coordinates")
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
    first = _complete_pivoting(G, r)
    return [first] + [c for _, c in scored[:MAX_CANDIDATES] if c != first]


def _complete_pivoting(G, r) -> tuple:
    """The pivot columns of Gaussian elimination with complete pivoting (runtime/c/loops.c's choice, whose exact
    Jacobian, runtime/c/loop_jacobian.c, the Rosenbrock methods use: the same partition keeps it the closed
    form's), in increasing order."""
    A = G.copy()
    rows, cols, chosen = list(range(A.shape[0])), list(range(A.shape[1])), []
    for _ in range(r):
        sub = np.abs(A[np.ix_(rows, cols)])
        i, j = np.unravel_index(np.argmax(sub), sub.shape)
        pi, pj = rows[i], cols[j]
        for k in rows:
            if k != pi:
                A[k] -= A[k, pj] / A[pi, pj] * A[pi]
        rows.remove(pi)
        cols.remove(pj)
        chosen.append(pj)
    return tuple(sorted(chosen))


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
            pair = _pair(pending, [u for u in unknowns if u not in {s.unknown for s in steps}], known, values, q,
                         q0)
            if pair is None:
                raise Refused("the rows do not solve one unknown at a time, nor two by a triangle")
            rows_used, pair_steps = pair
            for step in pair_steps:
                known[step.unknown] = _evaluate(step.value, known, values)
                steps.append(step)
            for row in rows_used:
                pending.remove(row)
    order = [s.unknown for s in steps]
    for k, s in enumerate(steps):  # an angle found by atan2 is defined modulo 2 pi: later steps may read it
        angles = [u for u in order[:k] if _angle_of(steps, u)]  # through sin and cos only
        if angles and not all(_is_angle(u, [s.value]) for u in angles):
            raise Refused(f"{s.unknown} reads a dependent angle other than through sin and cos")
    if any(s.guard is not None and s.guard.is_number and not abs(float(s.guard)) < 1 - GUARD_MARGIN
           for s in steps):
        raise Refused("the branch sits at a singular position")
    dep = tuple(q.index(u) for u in order)  # in the order of the steps
    G = sp.Matrix([g[i] for i in rows]).jacobian(q)
    G_D, G_I = G[:, list(dep)], G[:, list(independent)]
    det = sp.expand(G_D.det(method="berkowitz"))
    if det == 0:
        raise Refused("the dependent block of G is singular")
    evaluate = _sequence(steps, qi, values, det)
    _check_guards(evaluate, steps, q, independent, q0)
    _check_residuals(evaluate, g, q, independent, dep, values, q0, rng)
    # J = -G_D^-1 G_I and Jdot v_I = -G_D^-1 (d(G v)/dq v) with v_D = J v_I: by the implicit function theorem,
    # at the state the steps give (no derivative of the nested explicit expressions)
    inverse = G_D.adjugate() / det
    J = -inverse * G_I
    vs = sp.Matrix(v)
    rates = (G * vs).jacobian(q) * vs  # qdot = v
    bias = -inverse * rates
    return ClosedForm(independent, dep, tuple(_angle_of(steps, u) for u in order), tuple(s.value for s in steps),
                      tuple(tuple(sp.expand_trig(e) for e in J.row(i)) for i in range(J.rows)),
                      tuple(sp.expand_trig(e) for e in bias),
                      tuple(s.guard for s in steps if s.guard is not None and not s.guard.is_number), tuple(rows),
                      tuple(s.sin_cos for s in steps))


def _angle_of(steps, u) -> bool:
    return any(s.unknown == u and s.angle for s in steps)


def _sequence(steps, qi, values, det):
    """A NumPy function of the independent coordinates (arrays) that evaluates the steps in order: a dict of every
    unknown's value, and the lists of the guards, the radii (with |det G_D|) at those values."""
    args = list(qi) + [s.unknown for s in steps]
    compiled = [(s.unknown, sp.lambdify(args, s.value.xreplace(values), "numpy"),
                 None if s.guard is None else sp.lambdify(args, s.guard.xreplace(values), "numpy"),
                 None if s.radius is None else sp.lambdify(args, s.radius.xreplace(values), "numpy"))
                for s in steps]
    size = sp.lambdify(args, sp.Abs(det.xreplace(values)), "numpy")

    def evaluate(independent_values):
        with np.errstate(all="ignore"):  # (a singular sample gives NaN, which the checks refuse)
            return _evaluated(independent_values)

    def _evaluated(independent_values):
        n = np.size(independent_values[0])
        known = [np.broadcast_to(np.asarray(x, dtype=float), (n,)) for x in independent_values]
        known += [np.zeros(n) for _ in steps]
        guards, radii = [], []
        for k, (u, value, guard, radius) in enumerate(compiled):
            if guard is not None:
                guards.append(np.broadcast_to(np.asarray(guard(*known), dtype=float), (n,)))
            if radius is not None:
                radii.append(np.broadcast_to(np.abs(np.asarray(radius(*known), dtype=float)), (n,)))
            known[len(qi) + k] = np.broadcast_to(np.asarray(value(*known), dtype=float), (n,))
        radii.append(np.broadcast_to(np.asarray(size(*known), dtype=float), (n,)))
        return dict(zip(args, known)), guards, radii
    return evaluate


def _solve_linear(row, u, qi) -> _Step | None:
    """u from a row a u + b with a free of u and of the coordinates (a slider's travel)."""
    a = sp.diff(row, u)
    if u in a.free_symbols or a.free_symbols & set(qi) or a == 0:
        return None
    b = row.xreplace({u: 0})
    if sp.simplify(a * u + b - row) != 0:
        return None
    return _Step(u, -b / a, False, None)


def _sin_cos(row, u, S, C):
    """row with sin(u) and cos(u) written as S and C (u only inside sin/cos of +-u + rest), or None."""
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
    return None if u in expr.free_symbols else expr


def _linear_in(expr, S, C):
    """(a, b, c) with expr = a S + b C + c, or None."""
    try:
        poly = sp.Poly(expr, S, C)
    except sp.PolynomialError:
        return None
    if any(sum(m) > 1 for m in poly.monoms()):
        return None
    return poly.coeff_monomial(S), poly.coeff_monomial(C), poly.coeff_monomial(1)


def _solve_trig(row, u) -> _Step | None:
    """u from a row a sin u + b cos u + c (u only inside sin/cos of +-u + rest): one of
    u = atan2(a, b) +- acos(-c / sqrt(a^2 + b^2)); the sign is chosen later (_choose_branch), here +."""
    S, C = sp.Dummy("S"), sp.Dummy("C")
    expr = _sin_cos(row, u, S, C)
    abc = None if expr is None else _linear_in(expr, S, C)
    return None if abc is None else _trig_step(u, *abc)


def _trig_step(u, a, b, c) -> _Step:
    radius = sp.sqrt(sp.trigsimp(sp.expand(a ** 2 + b ** 2)))
    guard = sp.trigsimp(-c / radius)
    return _Step(u, sp.atan2(a, b) + sp.acos(guard), True, guard, radius, None, (a, b))


def _solve_pair(r1, r2, u, w) -> tuple[_Step, _Step] | None:
    """(w, u) from two rows linear in sin u and cos u whose solution for them, put into sin^2 u + cos^2 u = 1,
    leaves a sin w + b cos w + c = 0 (a four-bar: the coupler's angle u eliminated by the triangle of its
    length, the rocker's w solved as above, then u = atan2(sin u, cos u))."""
    S, C, Sw, Cw = sp.Dummy("S"), sp.Dummy("C"), sp.Dummy("Sw"), sp.Dummy("Cw")
    rows = [_sin_cos(r, u, S, C) for r in (r1, r2)]
    if None in rows:
        return None
    coefficients = [_linear_in(r, S, C) for r in rows]
    if None in coefficients:
        return None
    (a1, b1, c1), (a2, b2, c2) = coefficients
    if any(w in e.free_symbols for e in (a1, b1, a2, b2)):
        return None
    det = sp.expand(a1 * b2 - a2 * b1)
    if det == 0:
        return None
    sin_u, cos_u = (b1 * c2 - b2 * c1) / det, (a2 * c1 - a1 * c2) / det
    eliminated = _sin_cos(sp.expand((b1 * c2 - b2 * c1) ** 2 + (a2 * c1 - a1 * c2) ** 2 - det ** 2), w, Sw, Cw)
    if eliminated is None:
        return None
    eliminated = sp.expand(eliminated.xreplace({Cw: sp.sqrt(1 - Sw ** 2)}))  # cos^2 = 1 - sin^2 ...
    try:
        poly = sp.Poly(eliminated, Sw, sp.sqrt(1 - Sw ** 2))
    except sp.PolynomialError:
        return None
    terms = dict(zip(poly.monoms(), poly.coeffs()))
    if any(sum(m) > 1 and sp.simplify(c) != 0 for m, c in terms.items()):  # ... leaves it linear, or refused
        return None
    a, b, c = (sp.factor(sp.trigsimp(terms.get(m, sp.S.Zero))) for m in ((1, 0), (0, 1), (0, 0)))
    step_w = _trig_step(w, a, b, c)
    step_u = _Step(u, sp.atan2(sin_u, cos_u), True, None, sp.Abs(det), (sin_u, cos_u))
    return step_w, step_u


def _pair(pending, left, known, values, q, q0):
    """(the two rows, the two steps) of the first pair of rows in two unknowns that _solve_pair solves."""
    for r1, r2 in itertools.combinations(pending, 2):
        unknowns = (r1.free_symbols | r2.free_symbols) & set(left)
        if len(unknowns) != 2:
            continue
        for u, w in itertools.permutations(sorted(unknowns, key=str)):
            steps = _solve_pair(r1, r2, u, w)
            if steps is None:
                continue
            step_w = _choose_branch(steps[0], w, known, values, q0[q.index(w)])
            return (r1, r2), (step_w, steps[1])
    return None


def _evaluate(expr, known, values) -> float:
    """expr at the parameters' values and the known coordinates; Refused where it is not real there (an acos of
    more than 1 in size: the initial state lies off the branch this closed form describes)."""
    value = complex(expr.xreplace(values).xreplace({s: sp.Float(x) for s, x in known.items()}).evalf())
    if value.imag != 0.0:
        raise Refused("the initial state lies outside the closed form's range")
    return value.real


def _choose_branch(step: _Step, u, known, values, initial: float) -> _Step:
    """The sign of the acos whose value lies nearest the initial value of u (modulo 2 pi), when clearly so."""
    if step.guard is None:
        return step
    base = step.value - sp.acos(step.guard)
    branches = [base + sp.acos(step.guard), base - sp.acos(step.guard)]
    distance = [abs(_wrap(_evaluate(b, known, values) - initial)) for b in branches]
    best = int(np.argmin(distance))
    if not (distance[best] < 0.2 and distance[1 - best] > 2 * distance[best] + 1e-3):
        raise Refused(f"the initial state does not tell the branch of {u}")
    # u = delta + sigma acos(gamma), delta = atan2(a, b): sin and cos by the sum formulas, no trigonometric call
    a, b = step.ab
    sigma = 1 if best == 0 else -1
    gamma, other = step.guard, sigma * sp.sqrt(1 - step.guard ** 2)
    sin_u = (a * gamma + b * other) / step.radius
    cos_u = (b * gamma - a * other) / step.radius
    return _Step(u, branches[best], True, step.guard, step.radius, (sin_u, cos_u), step.ab)


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


def _check_guards(evaluate, steps, q, independent, q0) -> None:
    """Every acos argument stays below 1 - GUARD_MARGIN, and every radius sqrt(a^2 + b^2) (and |det G_D|) above
    GUARD_MARGIN times its largest value, over the full circle of each independent angle (the others at their
    initial values); with an independent coordinate that is not an angle this cannot be bounded: refused (unless
    the steps have no guards and the radii are constants)."""
    qi = [q[k] for k in independent]
    values = [s.value for s in steps] + [s.guard for s in steps if s.guard is not None] + [
        s.radius for s in steps if s.radius is not None]
    reads = [k for k, s in enumerate(qi) if any(s in e.free_symbols for e in values)]
    if not all(_is_angle(qi[k], values) for k in reads):
        raise Refused("the solution reads an independent coordinate that is not an angle")
    rng = np.random.default_rng(3)
    n = ANGLE_SAMPLES * max(1, len(reads))
    grid = [np.full(n, q0[k]) for k in independent]
    for k in reads:
        grid[k] = (np.linspace(-math.pi, math.pi, n) if len(reads) == 1 else rng.uniform(-math.pi, math.pi, n))
    _, guards, radii = evaluate(grid)
    for gd in guards:
        if not np.max(np.abs(gd)) < 1 - GUARD_MARGIN:
            raise Refused("the branch can reach a singular position")
    for radius in radii:
        if not np.min(radius) > GUARD_MARGIN * np.max(radius):
            raise Refused("the branch can reach a singular position (a vanishing radius or pivot)")


def _check_residuals(evaluate, g, q, independent, dependent, values, q0, rng) -> None:
    """All rows vanish to round-off at random states of the branch (the independent coordinates near their
    initial values)."""
    rows = sp.lambdify(q, [e.xreplace(values) for e in g], "numpy")
    terms = sp.lambdify(q, [sum(abs(t) for t in sp.Add.make_args(sp.expand(e.xreplace(values)))) for e in g],
                        "numpy")
    x = np.tile(q0[:, None], (1, CHECK_STATES))
    for k in independent:
        x[k] += rng.uniform(-1.0, 1.0, CHECK_STATES)
    known, _, _ = evaluate([x[k] for k in independent])
    for k in dependent:
        x[k] = known[q[k]]
    r = np.abs(np.array([np.broadcast_to(np.asarray(e, dtype=float), (CHECK_STATES,)) for e in rows(*x)]))
    scale = 1.0 + np.abs(np.array([np.broadcast_to(np.asarray(e, dtype=float), (CHECK_STATES,)) for e in terms(*x)]))
    if not np.all(np.isfinite(r)) or np.any(r > RESIDUAL_TOL * scale):
        raise Refused("the closed form does not satisfy the rows")


__all__ = ["ClosedForm", "Refused", "closed_form"]
