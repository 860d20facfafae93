"""Forward differentiation of results on a tape: d(result)/d(symbol) as new temporaries.

The equations of motion live on a tape of small expressions (compiler/tape.py), so their derivatives are best
taken the way forward-mode automatic differentiation does it: walk the tape once in order and, for every
temporary that depends on one of the symbols `wrt`, put its derivative on the tape as a temporary of its own,

    d(entry)/d(s) = sum over the symbols a the entry reads of  d(entry.expr)/d(a) * d(a)/d(s).

Only non-zero derivatives are kept (a body's velocity does not depend on the coordinates of the bodies below
it), so the cost is the tape's length times the number of symbols it actually depends on, and the result is
itself a tape the emitters print like any other function. `wrt` may be any symbols: the states and t for the
Jacobian of the right-hand side (compiler/jacobian.py), parameters for sensitivities.

The original tape is not touched: the derivatives go on a fork (`Tape.fork`), so differentiating is a pure
function of the equations. Functions without a usable derivative (lookup tables, undefined functions) raise
NotDifferentiable; callers then fall back to finite differences.
"""

from __future__ import annotations

from collections.abc import Sequence

import sympy as sp

from . import fast_arith
from .emit_common import CodegenError
from .tape import Tape, symbols_of


class NotDifferentiable(CodegenError):
    """An expression on the tape has no derivative the code generators can print."""


def forward_derivatives(tape: Tape, results: Sequence, wrt: Sequence[sp.Symbol], *,
                        labels: Sequence[str] | None = None) -> tuple[Tape, list[list[sp.Expr]]]:
    """(fork, D) with D[i][k] = d results[i] / d wrt[k], expressions on `fork` (a fork of `tape`).

    labels: readable names of the symbols, for the section comments of the derivative temporaries."""
    fork = tape.fork()
    seeds = {s: k for k, s in enumerate(wrt)}
    labels = list(labels) if labels is not None else [str(s) for s in wrt]
    derivative: dict = {}  # temporary -> {k: d temporary / d wrt[k]} (non-zero entries only)
    results = [sp.sympify(r) for r in results]
    for entry in tape.entries_for(results):
        found = _differentiate(entry.expr, seeds, derivative)
        if found:
            fork.section(f"derivatives of {entry.section}")
            # in the order of wrt, not of the set of symbols the entry reads (which changes from run to run, and
            # with it the text of the generated C and the build cache's key)
            derivative[entry.symbol] = {k: fork.temp(d, f"{entry.name}_d{k}") for k, d in sorted(found.items())}
    rows = []
    for r in results:
        found = _differentiate(r, seeds, derivative)
        rows.append([found.get(k, sp.S.Zero) for k in range(len(wrt))])
    return fork, rows


def _differentiate(expr: sp.Expr, seeds: dict, derivative: dict) -> dict:
    """{k: d expr / d wrt[k]} by the chain rule through the symbols expr reads."""
    total: dict = {}
    prepared = None  # (expr made differentiable, once for all the symbols it reads)
    for a in symbols_of(expr):
        if a in seeds:
            inner = {seeds[a]: sp.S.One}
        else:
            inner = derivative.get(a)
            if not inner:
                continue
        if prepared is None:
            prepared = _differentiable(expr)
        partial = _partial(prepared, a)
        if partial == 0:
            continue
        for k, d in inner.items():
            term = fast_arith.product(partial, d)
            known = total.get(k)
            total[k] = term if known is None else fast_arith.total((known, term))
    # in the order of wrt, not of the set of free symbols (whose order changes with the hash seed), so that the
    # generated text, and with it the build cache key, is the same in every process
    return {k: total[k] for k in sorted(total) if total[k] != 0}


def partial_derivative(expr: sp.Expr, a: sp.Symbol) -> sp.Expr:
    """d expr / d a, with the generalised functions sympy produces for kinks and jumps replaced by what a
    Jacobian of a piecewise smooth function needs: the derivative of the piece in force (sign' = 0, |u|' =
    sign(u) u', max/min follow their active argument)."""
    return _partial(_differentiable(expr), a)


def _differentiable(expr: sp.Expr) -> tuple:
    """(expr with |u| as u sign(u), max/min as conditionals and the piecewise constant functions as constants,
    {constant: the function it stands for}): what partial_derivative differentiates, the same for every symbol."""
    expr = expr.replace(lambda e: isinstance(e, sp.Abs), lambda e: e.args[0] * sp.sign(e.args[0]))
    expr = expr.replace(lambda e: isinstance(e, (sp.Max, sp.Min)), _as_piecewise)
    # piecewise constant functions: constants for the differentiation, put back afterwards
    steps = {e: sp.Dummy("step") for e in expr.atoms(*_PIECEWISE_CONSTANT)}
    return expr.xreplace(steps), {v: k for k, v in steps.items()}


def _partial(differentiable: tuple, a: sp.Symbol) -> sp.Expr:
    expr, steps = differentiable
    d = sympy_diff(expr, a, {}).xreplace(steps)
    bad = d.atoms(sp.Derivative, sp.Subs)
    if bad:
        raise NotDifferentiable(f"no derivative of {sorted(map(str, bad))[0]} for the generated Jacobian")
    return d


_PIECEWISE_CONSTANT = (sp.sign, sp.Heaviside, sp.floor, sp.ceiling)
_NOT_FINITE = frozenset({sp.oo, -sp.oo, sp.zoo, sp.nan})


def sympy_diff(expr: sp.Expr, a: sp.Symbol, memo: dict) -> sp.Expr:
    """sp.diff(expr, a), the same expression, for less: sums, products, powers and symbols are differentiated
    here by the rules sympy applies to them (Add._eval_derivative, Mul._eval_derivative_n_times with n = 1,
    Pow._eval_derivative, AtomicExpr), every other node by sympy itself. What this saves is sympy's Derivative
    around every node (argument checks, a walk of the node's free symbols, and a walk of its result for unevaluated
    derivatives): most of the constraint Jacobian's time (compiler/ccode_loops.py). `memo`: node -> its derivative
    by `a` (a node met twice is differentiated once). tests/compiler/test_differentiate.py compares the results
    with sympy's own, expression for expression."""
    hit = memo.get(expr)
    if hit is not None:
        return hit
    if expr.is_Symbol:
        d = sp.S.One if expr == a else sp.S.Zero
    elif expr.is_Number:
        d = sp.S.Zero
    elif expr.is_Add:
        terms = [sympy_diff(term, a, memo) for term in expr.args]
        d = sp.S.Zero if all(term is sp.S.Zero for term in terms) else fast_arith.total(terms)
    elif expr.is_Mul and expr.is_commutative:
        d = _product_rule(expr, a, memo)
    elif expr.is_Pow:
        base, exp = expr.args
        dbase, dexp = sympy_diff(base, a, memo), sympy_diff(exp, a, memo)
        d = sp.S.Zero if dbase is sp.S.Zero and dexp is sp.S.Zero \
            else expr * (dexp * sp.log(base) + dbase * exp / base)
    else:
        d = expr.diff(a)
    memo[expr] = d
    return d


def _product_rule(expr: sp.Mul, a: sp.Symbol, memo: dict) -> sp.Expr:
    """Mul._eval_derivative_n_times(a, 1): the sum over the factors of the product with that factor differentiated,
    in the order sympy's multinomial iterator gives them; a term whose differentiated factor is zero is zero (unless
    another factor is not finite, which only sympy's own product gives right)."""
    from sympy.ntheory.multinomial import multinomial_coefficients_iterator
    args = expr.args
    derivatives = [sympy_diff(arg, a, memo) for arg in args]
    if all(d is sp.S.Zero for d in derivatives) and not any(arg in _NOT_FINITE for arg in args):
        return sp.S.Zero
    terms = []
    for kvals, c in multinomial_coefficients_iterator(len(args), 1):
        k = kvals.index(1)
        if derivatives[k] is sp.S.Zero and not any(arg in _NOT_FINITE for arg in args):
            continue
        terms.append(c * fast_arith.product_of([derivatives[i] if i == k else arg for i, arg in enumerate(args)]))
    return fast_arith.total(terms)


def _as_piecewise(e):
    """max(a, b, ...) or min(...) as nested conditionals, whose derivative sympy takes branch by branch."""
    first, *rest = e.args
    better = (lambda x, y: x > y) if isinstance(e, sp.Max) else (lambda x, y: x < y)
    result = first
    for arg in rest:
        result = sp.Piecewise((arg, better(arg, result)), (result, True))
    return result
