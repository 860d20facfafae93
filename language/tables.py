"""Lookup tables whose points depend on parameters, written out as model expressions.

A table of numbers becomes `expr.Table` (static arrays in the generated code, binary search at run time). A
table with a parameter among its points cannot be frozen into numbers when the model is validated: parameters
are run-time inputs (`--param`, a scene's `param`, Python's `params=`), so the table must be re-evaluated with
the values of the run. Such a table is written here as a piecewise expression in the model's own expression
language (`if`, arithmetic), which every back end and the validator already evaluate with the run's
parameters. The interpolation is the same as `expr.interpolate`: piecewise linear, or monotone cubic Hermite
with Fritsch-Carlson slopes, constant beyond the ends. Tables of parameters are short (a few measured points
scaled by a parameter), so the linear search of the nested `if` costs nothing worth a run-time array.
"""

from __future__ import annotations

from . import expr as X


def _sub(a: X.E, b: X.E) -> X.E:
    return X.add(a, X.neg(b))


def _div(a: X.E, b: X.E) -> X.E:
    if isinstance(a, X.Const) and isinstance(b, X.Const) and b.value != 0:
        return X.const(a.value / b.value)
    return X.Op("/", (a, b))


def _if(cond: X.E, a: X.E, b: X.E) -> X.E:
    return a if a == b else X.Op("if", (cond, a, b))


def _slopes(xs: list[X.E], ys: list[X.E]) -> list[X.E]:
    """Fritsch-Carlson slopes at the knots: the secant at the ends; inside, the harmonic mean of the two
    neighbouring secants, or zero where they differ in sign (2ab/(a+b) equals 2/(1/a + 1/b) without dividing
    by a zero secant)."""
    d = [_div(_sub(ys[k + 1], ys[k]), _sub(xs[k + 1], xs[k])) for k in range(len(xs) - 1)]
    inner = []
    for a, b in zip(d, d[1:]):
        product = X.mul(a, b)
        inner.append(_if(X.Op("<=", (product, X.ZERO)), X.ZERO,
                         _div(X.mul(X.const(2.0), product), X.add(a, b))))
    return [d[0], *inner, d[-1]]


def _segment(x: X.E, k: int, xs: list[X.E], ys: list[X.E], slopes: list[X.E] | None) -> X.E:
    h = _sub(xs[k + 1], xs[k])
    s = _div(_sub(x, xs[k]), h)
    if slopes is None:
        return X.add(ys[k], X.mul(s, _sub(ys[k + 1], ys[k])))
    s2, s3 = X.mul(s, s), X.mul(X.mul(s, s), s)
    h00 = X.add(_sub(X.mul(X.const(2.0), s3), X.mul(X.const(3.0), s2)), X.ONE)
    h10 = X.add(_sub(s3, X.mul(X.const(2.0), s2)), s)
    h01 = _sub(X.mul(X.const(3.0), s2), X.mul(X.const(2.0), s3))
    h11 = _sub(s3, s2)
    terms = (X.mul(h00, ys[k]), X.mul(X.mul(h10, h), slopes[k]), X.mul(h01, ys[k + 1]),
             X.mul(X.mul(h11, h), slopes[k + 1]))
    total = terms[0]
    for term in terms[1:]:
        total = X.add(total, term)
    return total


def parametric_table(x: X.E, xs: list[X.E], ys: list[X.E], method: str) -> X.E:
    """y(x) through the points (xs[i], ys[i]) (at least two, x increasing for the parameters' values)."""
    slopes = _slopes(xs, ys) if method == "smooth" else None
    result = ys[-1]  # at and beyond the last point
    for k in reversed(range(len(xs) - 1)):
        result = _if(X.Op("<", (x, xs[k + 1])), _segment(x, k, xs, ys, slopes), result)
    return _if(X.Op("<=", (x, xs[0])), ys[0], result)


def depends_on_parameters(e: X.E) -> bool:
    return any(s.kind == "param" for s in X.symbols(e))
