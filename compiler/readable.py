"""The equations of motion as a person reads them: M(y, t) v' + k(y, v, t) = q(y, v, t) in named terms.

NEWEUL printed the kinematics of each body (rotation, position, velocities) and then M, k and q written in
those names. Here the same comes from the tape of the O(n) algorithms: the temporaries M, k and q need are
kept as named intermediates, section by section (one section per body and algorithm step), except those that
are cheaper to read inline (used once, or a single operation), which are substituted into their users.

Simplification scales because it works on the small named expressions, never on the expanded whole: each
intermediate is expanded and its trigonometric terms combined (a few operations each), and exact constants
(compiler/exact.py) let exact zeros cancel on the way. Writing M, k, q out in full (`written_out`) remains
available for small models and for checks.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

import sympy as sp

from . import dynamics
from .hooks import HookCall
from .kinematics import Kinematics

INLINE_OPS = 2         # an intermediate of at most this many operations is shown inline
PROGRESS_AFTER = 1.0   # s: stages that take longer than this report on the progress callback


@dataclass(frozen=True)
class Intermediate:
    section: str      # "body 2 (upper): velocity"
    symbol: sp.Symbol  # named as on the tape: v2_3, E2_01, ...
    expr: sp.Expr


@dataclass(frozen=True)
class ReadableEquations:
    """M v' + k = q with M (nv x nv), k and q (nv x 1) in terms of the intermediates, which are in terms of the
    coordinates y, the speeds v, the parameters, t and earlier intermediates (in order)."""

    y: tuple
    v: tuple
    intermediates: tuple[Intermediate, ...]
    M: sp.Matrix
    k: sp.Matrix
    q: sp.Matrix

    def written_out(self) -> tuple[sp.Matrix, sp.Matrix, sp.Matrix]:
        """M, k, q with every intermediate substituted (grows quickly with the number of bodies)."""
        values: dict = {}
        for item in self.intermediates:
            values[item.symbol] = item.expr.xreplace(values)
        return tuple(m.xreplace(values) for m in (self.M, self.k, self.q))  # type: ignore[return-value]

    def evaluate(self, values: dict, hook_value: Callable | None = None) -> tuple[sp.Matrix, sp.Matrix, sp.Matrix]:
        """Numeric M, k, q for numeric values of every coordinate, speed, parameter (and t), keyed by symbol.
        hook_value(name, result, args) -> float: the value of a user hook's call (compiler/hooks.py)."""
        env = {s: sp.Float(x, 17) for s, x in values.items()}

        def numeric(expr):
            expr = expr.xreplace(env).evalf(17)
            if hook_value is not None:  # innermost calls first: a hook's argument may be another hook's result
                while True:
                    calls = [c for c in expr.atoms(HookCall) if all(a.is_Number for a in c.args)]
                    if not calls:
                        break
                    expr = expr.xreplace({c: sp.Float(hook_value(c.hook[0], c.hook[1], [float(a) for a in c.args[1:]]),
                                                      17) for c in calls}).evalf(17)
            return expr
        for item in self.intermediates:
            env[item.symbol] = numeric(item.expr)
        return tuple(numeric(m) for m in (self.M, self.k, self.q))  # type: ignore[return-value]


def readable_equations(kin: Kinematics, *, simplify: bool = True,
                       progress: Callable[[str], None] | None = None) -> ReadableEquations:
    """M, k, q of the tree of `kin` (with its loads attached) in named intermediates, as `ReadableEquations`."""
    clock = _Clock(progress)
    nv = kin.tree.nv
    M = dynamics.mass_matrix(kin)
    k = dynamics.inverse_dynamics(kin, gravity=False, loads=False, name="k")
    mq = dynamics.inverse_dynamics(kin, inertial=False, name="mq")
    outputs = [x for row in M for x in row] + list(k) + [-x for x in mq]
    tape = kin.tape
    entries = tape.entries_for(outputs)
    clock.report(f"derived {len(entries)} intermediates")
    uses: dict = {}
    for entry in entries:
        for s in tape.dependencies(entry):
            uses[s] = uses.get(s, 0) + 1
    for e in outputs:
        for s in sp.sympify(e).free_symbols:
            uses[s] = uses.get(s, 0) + 1
    named = {entry.symbol: sp.Symbol(entry.name) for entry in entries}
    inline: dict = {}
    kept = []
    for n, entry in enumerate(entries):
        expr = entry.expr.xreplace(inline)
        if simplify:
            expr = tidy(expr)
        if expr.is_number or uses.get(entry.symbol, 0) <= 1 or sp.count_ops(expr) <= INLINE_OPS:
            inline[entry.symbol] = expr
        else:
            inline[entry.symbol] = named[entry.symbol]
            kept.append(Intermediate(entry.section, named[entry.symbol], expr))
        clock.tick(f"simplified {n + 1}/{len(entries)} intermediates")
    finals = [sp.sympify(e).xreplace(inline) for e in outputs]
    if simplify:
        finals = [tidy(e) for e in finals]
    clock.report(f"M, k, q in {len(kept)} named intermediates")
    return ReadableEquations(tuple(kin.tree.q_symbols), tuple(kin.tree.v_symbols), tuple(kept),
                             sp.Matrix(nv, nv, finals[:nv * nv]), sp.Matrix(finals[nv * nv:nv * nv + nv]),
                             sp.Matrix(finals[nv * nv + nv:]))


def tidy(e: sp.Expr) -> sp.Expr:
    """A cheap simplification of one small expression: expanded, trigonometric products combined when the
    expression is small, common factors pulled out; the shorter of that and the input is kept."""
    if e.is_Atom:
        return e
    out = _pythagoras(sp.expand(e))
    out = sp.factor_terms(out)
    return out if sp.count_ops(out) <= sp.count_ops(e) else e


def _pythagoras(e: sp.Expr) -> sp.Expr:
    """sin(x)^2 + cos(x)^2 = 1 where it shortens an expanded sum (sympy's trigsimp does more, at a cost that
    grows too fast to run on every intermediate)."""
    if not e.is_Add:
        return e
    squares = {p.base.args[0] for p in e.atoms(sp.Pow) if p.exp == 2 and isinstance(p.base, sp.sin)}
    for x in squares:
        if e.has(sp.cos(x) ** 2):
            shorter = sp.expand(e.xreplace({sp.sin(x) ** 2: 1 - sp.cos(x) ** 2}))
            if sp.count_ops(shorter) < sp.count_ops(e):
                e = shorter
    return e


class _Clock:
    """Progress for slow stages only: nothing is reported before PROGRESS_AFTER seconds."""

    def __init__(self, progress):
        self.progress = progress
        self.start = self.last = time.perf_counter()

    def report(self, message: str) -> None:
        now = time.perf_counter()
        if self.progress is not None and now - self.start > PROGRESS_AFTER:
            self.progress(f"{message} ({now - self.start:.1f} s)")
            self.last = now

    def tick(self, message: str) -> None:
        if time.perf_counter() - self.last > PROGRESS_AFTER:
            self.report(message)


__all__ = ["ReadableEquations", "Intermediate", "readable_equations", "tidy"]
