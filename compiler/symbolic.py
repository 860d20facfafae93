"""Model expressions (language/expr.py) -> sympy, the bridge from the data model to the equations.

Parameters become sympy Symbols named as in the model (run-time inputs, never folded into constants);
joint coordinates, speeds and sensor values are resolved by the caller, since only the kinematics knows
them. Lookup tables become calls of numbered undefined functions (``mbs_table_3(x)``) whose data the code
generator emits as static arrays: sympy has no node for interpolation, and inlining a 50-point table as a
Piecewise would swell every expression that uses it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import sympy as sp

from mbs.language import expr as X

from .exact import exact_number
from .hooks import hook_function
from .tree import t as T  # the one time symbol of the equations

def safe_atan2(y, x):
    """sympy folds atan2(0, 0) to nan; C's atan2(0, 0) is 0, and so is ours (a sensor angle that is zero by
    construction must not poison the generated code)."""
    if y == 0 and x == 0:
        return sp.Integer(0)
    return sp.atan2(y, x)


_FUNCTIONS: dict[str, Callable] = {
    "sin": sp.sin, "cos": sp.cos, "tan": sp.tan, "asin": sp.asin, "acos": sp.acos, "atan": sp.atan,
    "atan2": safe_atan2, "sinh": sp.sinh, "cosh": sp.cosh, "tanh": sp.tanh, "sqrt": sp.sqrt, "exp": sp.exp,
    "log": sp.log, "abs": sp.Abs, "sign": sp.sign, "min": sp.Min, "max": sp.Max,
}
_RELATIONS = {"<": sp.Lt, "<=": sp.Le, ">": sp.Gt, ">=": sp.Ge, "==": sp.Eq, "!=": sp.Ne}


@dataclass
class TableRegistry:
    """Tables met while converting, in order; the C emitter prints one static array pair per entry."""

    tables: list[X.Table] = field(default_factory=list)

    def function(self, table: X.Table) -> sp.Function:
        key = (table.xs, table.ys, table.method)
        for i, t in enumerate(self.tables):
            if (t.xs, t.ys, t.method) == key:
                return sp.Function(f"mbs_table_{i}")
        self.tables.append(table)
        return sp.Function(f"mbs_table_{len(self.tables) - 1}")


def parameter_symbol(name: str) -> sp.Symbol:
    return sp.Symbol(name)


class ToSympy:
    """Convert with a resolver for the names only the caller can give meaning to.

    ``resolve(sym)`` is called for coordinates, speeds, sensors, locals and inputs and returns a sympy
    expression; parameters and time are handled here.
    """

    def __init__(self, resolve: Callable[[X.Sym], sp.Expr], tables: TableRegistry | None = None, switches=None):
        self.resolve = resolve
        self.tables = tables if tables is not None else TableRegistry()
        self.switches = switches  # compiler.events.SwitchRegistry: comparisons and kinks become switches
        self._memo: dict[X.E, sp.Expr] = {}

    def __call__(self, e: X.E) -> sp.Expr:
        hit = self._memo.get(e)
        if hit is None:
            hit = self._convert(e)
            self._memo[e] = hit
        return hit

    def _convert(self, e: X.E) -> sp.Expr:
        if isinstance(e, X.Const):
            return exact_number(e.value)  # exact where the model wrote it exactly: exact zeros cancel
        if isinstance(e, X.Sym):
            if e.kind == "param":
                return parameter_symbol(e.name)
            if e.kind == "time":
                return T
            return self.resolve(e)
        if isinstance(e, X.Table):
            x = self(e.x)
            switched = self.switches.table(e, x) if self.switches is not None else None
            return switched if switched is not None else self.tables.function(e)(x)
        if isinstance(e, X.Hook):
            return hook_function(e.name, e.result, e.results)(T, *(self(a) for a in e.args))
        args = [self(a) for a in e.args]
        op = e.op
        if op == "+":
            return args[0] + args[1]
        if op == "-":
            return args[0] - args[1]
        if op == "*":
            return args[0] * args[1]
        if op == "/":
            return args[0] / args[1]
        if op == "^":
            return args[0] ** args[1]
        if op == "neg":
            return -args[0]
        if op in _RELATIONS:
            if self.switches is not None and op not in ("==", "!="):
                return self.switches.relation(op, args[0], args[1])
            return _RELATIONS[op](args[0], args[1])
        if op == "and":
            return sp.And(_as_bool(args[0]), _as_bool(args[1]))
        if op == "or":
            return sp.Or(_as_bool(args[0]), _as_bool(args[1]))
        if op == "not":
            return sp.Not(_as_bool(args[0]))
        if op == "if":
            if self.switches is not None:  # notes whether the branches agree where a switch of the condition flips
                return self.switches.branch(_as_bool(args[0]), args[1], args[2])
            return sp.Piecewise((args[1], _as_bool(args[0])), (args[2], True))
        if op == "smoothstep":
            x, x0, x1 = args
            s = (x - x0) / (x1 - x0)
            return sp.Piecewise((0, x <= x0), (1, x >= x1), (s * s * (3 - 2 * s), True))
        if self.switches is not None and op in ("min", "max", "abs", "sign"):
            switched = self.switches.function(op, args)
            if switched is not None:
                return switched
        return _FUNCTIONS[op](*args)


def _as_bool(e):
    """A number used as a condition is true when non-zero (as in the validator's evaluator)."""
    if isinstance(e, (sp.logic.boolalg.Boolean, sp.core.relational.Relational)):
        return e
    return sp.Ne(e, 0)
