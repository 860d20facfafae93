"""Products, sums and negatives of sympy expressions, built the way sympy builds them, without its machinery for
the common cases of the derivation.

Most of the arithmetic of the recursive algorithms (compiler/spatial.py) multiplies two temporaries, a coefficient
and a temporary, or adds a few such products. sympy's `a*b` runs `Mul.flatten` (powers gathered, numbers
collected, the factors sorted, assumptions asked) for every one of them: about a hundred Python calls, a fifth of
the derivation of a 40-link chain. For these cases the result is known without that work, and here it is built
directly: the same canonical arguments in the same order (`Basic.compare`, as sympy's `_mulsort`/`_addsort`),
so the expressions, and every text printed from them, are the ones sympy would give. Anything else (a square, a
sum times a number, which sympy distributes, an infinity, a float coefficient) goes to sympy as before.
"""

from __future__ import annotations

from functools import cmp_to_key

import sympy as sp
from sympy.core.basic import Basic

_PLAIN = (sp.Symbol, sp.Dummy)  # the exact types: a subclass may evaluate products its own way
_ONE, _ZERO, _MINUS_ONE = sp.S.One, sp.S.Zero, sp.S.NegativeOne
_ORDER = cmp_to_key(Basic.compare)  # sympy's canonical order of a product's and a sum's arguments
_Mul, _Add = sp.Mul, sp.Add


def _symbol(x) -> bool:
    return type(x) in _PLAIN and x.is_commutative


def _rational(x) -> bool:
    """An exact number other than 0 and 1 (a float coefficient is left to sympy)."""
    return isinstance(x, sp.Rational) and x.p != 0 and x is not _ONE


def _mul_of(args: tuple):
    return _Mul._exec_constructor_postprocessors(_Mul._from_args(args, True))


def product(a, b):
    """a*b (sympy expressions or ints), as sympy gives it."""
    if _symbol(a):
        if _symbol(b):
            order = a.compare(b)
            if order:  # (equal symbols make a power)
                return _mul_of((a, b) if order < 0 else (b, a))
        elif _rational(b):
            return _mul_of((b, a))
    elif _rational(a) and _symbol(b):
        return _mul_of((a, b))
    return a * b


def negative(a):
    """-a, as sympy gives it."""
    if _symbol(a):
        return _mul_of((_MINUS_ONE, a))
    return -a


def _split(term):
    """(coefficient, rest) of a term of a sum, as Add.flatten splits it (term.as_coeff_Mul()), or None when the
    term is not a symbol or a product with an exact, finite coefficient."""
    if _symbol(term):
        return _ONE, term
    if type(term) is _Mul and term.is_commutative:
        args = term.args
        first = args[0]
        if not first.is_Number:
            return _ONE, term
        if not isinstance(first, sp.Rational):
            return None
        return first, (args[1] if len(args) == 2 else term._new_rawargs(*args[1:]))
    return None


def total(terms):
    """sp.Add(*terms) of two or more terms, none of them 0, as sympy gives it."""
    collected: dict = {}
    for term in terms:
        split = _split(term)
        if split is None:
            return _Add(*terms)
        c, rest = split
        known = collected.get(rest)
        collected[rest] = c if known is None else known + c
    args = []
    for rest, c in collected.items():
        if c.p == 0:  # (the coefficients are exact: sums of rationals)
            continue
        if c is _ONE:
            args.append(rest)
        elif rest.is_Mul:
            args.append(rest._new_rawargs(c, *rest.args))
        else:
            args.append(product(c, rest))
    if not args:
        return _ZERO
    if len(args) == 1:
        return args[0]
    args.sort(key=_ORDER)
    return _Add._exec_constructor_postprocessors(_Add._from_args(args, True))
