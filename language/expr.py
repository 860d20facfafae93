"""Expressions of the validated model: small immutable trees in SI units with every name resolved.

A model expression is data, never code: the only operations are the ones listed in FUNCTIONS and OPERATORS,
and the compiler turns them into sympy (compiler stage) while the validator evaluates them numerically with
parameter defaults (to check masses, inertias and axes). Names are resolved to flat, instance-prefixed names
and tagged with what they denote, so later stages need no scope rules.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Mapping, Union

# What a Sym denotes. 'local' is a variable bound by a force law (l, v) and replaced before lowering.
SYMBOL_KINDS = ("param", "input", "time", "coord", "speed", "sensor", "local", "state", "rate")  # rate: der(state)


@dataclass(frozen=True)
class Const:
    value: float


@dataclass(frozen=True)
class Sym:
    kind: str
    name: str


@dataclass(frozen=True)
class Op:
    """An operator or function application; ``op`` is a key of OPERATORS or FUNCTIONS."""

    op: str
    args: tuple["E", ...]


@dataclass(frozen=True)
class Table:
    """Lookup table y(x) with 'linear' or 'smooth' (monotone cubic, continuous slope) interpolation;
    constant extrapolation with the end values."""

    x: "E"
    xs: tuple[float, ...]
    ys: tuple[float, ...]
    method: str


@dataclass(frozen=True)
class Hook:
    """Result ``result`` (of ``results``) of the user hook ``name`` at ``args`` (language/hooks.py), arguments
    and result in the units the hook declares. Its value exists only while running, from the implementation
    supplied then."""

    name: str
    result: int
    results: int
    args: tuple["E", ...]


E = Union[Const, Sym, Op, Table, Hook]

ZERO, ONE = Const(0.0), Const(1.0)
TIME = Sym("time", "t")


def _smoothstep(x, x0, x1):
    """C1 cubic step from 0 at x0 to 1 at x1 (clamped)."""
    if x1 == x0:
        return 1.0 if x >= x1 else 0.0
    s = min(1.0, max(0.0, (x - x0) / (x1 - x0)))
    return s * s * (3.0 - 2.0 * s)


def _sign(x):
    return (x > 0) - (x < 0)


# Name -> (number of arguments, numeric implementation). The validator accepts exactly these calls.
FUNCTIONS: dict[str, tuple[int, Callable]] = {
    "sin": (1, math.sin), "cos": (1, math.cos), "tan": (1, math.tan),
    "asin": (1, math.asin), "acos": (1, math.acos), "atan": (1, math.atan), "atan2": (2, math.atan2),
    "sinh": (1, math.sinh), "cosh": (1, math.cosh), "tanh": (1, math.tanh),
    "sqrt": (1, math.sqrt), "exp": (1, math.exp), "log": (1, math.log), "abs": (1, abs),
    "sign": (1, _sign), "min": (2, min), "max": (2, max),
    "smoothstep": (3, _smoothstep), "if": (3, None),
}

OPERATORS: dict[str, Callable] = {
    "+": lambda a, b: a + b, "-": lambda a, b: a - b, "*": lambda a, b: a * b, "/": lambda a, b: a / b,
    "^": lambda a, b: a ** b, "neg": lambda a: -a,
    "<": lambda a, b: float(a < b), "<=": lambda a, b: float(a <= b), ">": lambda a, b: float(a > b),
    ">=": lambda a, b: float(a >= b), "==": lambda a, b: float(a == b), "!=": lambda a, b: float(a != b),
    "and": lambda a, b: float(bool(a) and bool(b)), "or": lambda a, b: float(bool(a) or bool(b)),
    "not": lambda a: float(not a),
}


class EvaluationError(Exception):
    """A numeric evaluation failed (domain error, division by zero, unknown name)."""


def evaluate(e: E, env: Mapping[str, float]) -> float:
    """Numeric value; ``env`` maps Sym names (and 't') to numbers."""
    if isinstance(e, Const):
        return e.value
    if isinstance(e, Sym):
        try:
            return env[e.name]
        except KeyError:
            raise EvaluationError(f"no value for '{e.name}'") from None
    if isinstance(e, Table):
        return interpolate(evaluate(e.x, env), e.xs, e.ys, e.method)
    if isinstance(e, Hook):
        raise EvaluationError(f"hook '{e.name}' has a value only while running")
    if e.op == "if":
        cond, a, b = e.args
        return evaluate(a, env) if evaluate(cond, env) else evaluate(b, env)
    values = [evaluate(a, env) for a in e.args]
    fn = OPERATORS.get(e.op) or FUNCTIONS[e.op][1]
    try:
        result = fn(*values)
    except ValueError:
        shown = ", ".join("%g" % v for v in values)
        raise EvaluationError(f"{e.op}({shown}) is undefined") from None
    except ZeroDivisionError:
        raise EvaluationError("division by zero") from None
    except OverflowError:
        raise EvaluationError(f"{e.op} overflows") from None
    if isinstance(result, complex):
        raise EvaluationError(f"{e.op} of a negative number")
    return float(result)


def interpolate(x: float, xs, ys, method: str) -> float:
    """Table lookup shared by the validator and the NumPy back end (the C back end emits the same logic)."""
    n = len(xs)
    if x <= xs[0]:
        return float(ys[0])
    if x >= xs[-1]:
        return float(ys[-1])
    lo, hi = 0, n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if xs[mid] <= x:
            lo = mid
        else:
            hi = mid
    h = xs[hi] - xs[lo]
    s = (x - xs[lo]) / h
    if method == "linear":
        return ys[lo] + s * (ys[hi] - ys[lo])
    m0, m1 = _pchip_slopes(xs, ys, lo), _pchip_slopes(xs, ys, hi)
    h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
    h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
    return h00 * ys[lo] + h10 * h * m0 + h01 * ys[hi] + h11 * h * m1


def _pchip_slopes(xs, ys, i):
    """Fritsch-Carlson monotone slope at knot i (no overshoot between table points)."""
    n = len(xs)
    if n < 2:
        return 0.0
    d = [(ys[k + 1] - ys[k]) / (xs[k + 1] - xs[k]) for k in range(max(0, i - 1), min(n - 1, i + 1))]
    if i == 0 or i == n - 1:
        return d[0] if d else 0.0
    a, b = d
    if a * b <= 0:
        return 0.0
    return 2.0 / (1.0 / a + 1.0 / b)


# ------------------------------------------------------------------------------------------ construction
def add(a: E, b: E) -> E:
    if a == ZERO:
        return b
    if b == ZERO:
        return a
    if isinstance(a, Const) and isinstance(b, Const):
        return Const(a.value + b.value)
    return Op("+", (a, b))


def mul(a: E, b: E) -> E:
    if a == ZERO or b == ZERO:
        return ZERO
    if a == ONE:
        return b
    if b == ONE:
        return a
    if isinstance(a, Const) and isinstance(b, Const):
        return Const(a.value * b.value)
    return Op("*", (a, b))


def neg(a: E) -> E:
    if isinstance(a, Const):
        return Const(-a.value)
    if isinstance(a, Op) and a.op == "neg":
        return a.args[0]
    return Op("neg", (a,))


def const(value: float) -> Const:
    return Const(float(value))


def substitute(e: E, mapping: Mapping[Sym, E]) -> E:
    """Replace symbols (function arguments, force-law locals) by expressions."""
    if isinstance(e, Sym):
        return mapping.get(e, e)
    if isinstance(e, Op):
        return Op(e.op, tuple(substitute(a, mapping) for a in e.args))
    if isinstance(e, Table):
        return Table(substitute(e.x, mapping), e.xs, e.ys, e.method)
    if isinstance(e, Hook):
        return Hook(e.name, e.result, e.results, tuple(substitute(a, mapping) for a in e.args))
    return e


def symbols(e: E) -> set[Sym]:
    out: set[Sym] = set()
    stack = [e]
    while stack:
        node = stack.pop()
        if isinstance(node, Sym):
            out.add(node)
        elif isinstance(node, (Op, Hook)):
            stack.extend(node.args)
        elif isinstance(node, Table):
            stack.append(node.x)
    return out


def to_text(e: E) -> str:
    """Readable infix text in SI (used in messages, JSON export and the formatter of flat models)."""
    if isinstance(e, Const):
        v = e.value
        return repr(int(v)) if v.is_integer() and abs(v) < 1e15 else repr(v)
    if isinstance(e, Sym):
        return f"der({e.name})" if e.kind == "speed" else e.name
    if isinstance(e, Table):
        pairs = ", ".join(f"[{x!r}, {y!r}]" for x, y in zip(e.xs, e.ys))
        return f"lookup({to_text(e.x)}, [{pairs}], \"{e.method}\")"
    if isinstance(e, Hook):
        chosen = "" if e.results == 1 else f"[result {e.result}]"
        return f"{e.name}{chosen}({', '.join(to_text(a) for a in e.args)})"
    if e.op == "neg":
        return f"(-{to_text(e.args[0])})"
    if e.op == "not":
        return f"(not {to_text(e.args[0])})"
    if e.op in OPERATORS:
        return f"({to_text(e.args[0])} {e.op} {to_text(e.args[1])})"
    return f"{e.op}({', '.join(to_text(a) for a in e.args)})"
