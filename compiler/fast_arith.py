"""Products, sums, negatives and substitutions of sympy expressions, built the way sympy builds them, without
its machinery for the common cases of the derivation.

Most of the arithmetic of the recursive algorithms (compiler/spatial.py) multiplies two temporaries, a coefficient
and a temporary, or adds a few such products. sympy's `a*b` runs `Mul.flatten` (powers gathered, numbers
collected, the factors sorted, assumptions asked) for every one of them: about a hundred Python calls, a fifth of
the derivation of a 40-link chain. For these cases the result is known without that work, and here it is built
directly: the same canonical arguments in the same order (`Basic.compare`, as sympy's `_mulsort`/`_addsort`),
so the expressions, and every text printed from them, are the ones sympy would give. Anything else (a square, a
sum times a number, which sympy distributes, an infinity, a float coefficient) goes to sympy as before. The
arguments are put in sympy's order by one key per argument where they are atoms or nodes of atoms
(`sort_canonically`), and `replaced` is xreplace with the changed sums and products rebuilt here.
tests/compiler/test_fast_arith.py compares every function with sympy's own, node for node.
"""

from __future__ import annotations

import math
from functools import cmp_to_key

import sympy as sp
from sympy.core.basic import Basic, ordering_of_classes

_PLAIN = (sp.Symbol, sp.Dummy)  # the exact types: a subclass may evaluate products its own way
_ONE, _ZERO, _MINUS_ONE = sp.S.One, sp.S.Zero, sp.S.NegativeOne
_ORDER = cmp_to_key(Basic.compare)  # sympy's canonical order of a product's and a sum's arguments
_CLASS_RANK = {name: k for k, name in enumerate(ordering_of_classes)}
_UNKNOWN_CLASS = len(ordering_of_classes) + 1  # (as in sympy's _cmp_name)
_Mul, _Add, _Pow = sp.Mul, sp.Add, sp.Pow
_AS_BASE_EXP = sp.Expr.as_base_exp  # (self, 1): the base of an expression that is no power


def _symbol(x) -> bool:
    return type(x) in _PLAIN and x.is_commutative


def _rational(x) -> bool:
    """An exact number other than 0 (a float coefficient is left to sympy)."""
    return isinstance(x, sp.Rational) and x.p != 0


def _class_key(kind: type) -> tuple:
    """The order of Basic.compare's first step (sympy's _cmp_name): a class listed in ordering_of_classes by its
    place there, before the others, which go by name."""
    name = kind.__name__
    rank = _CLASS_RANK.get(name)
    return (rank, "") if rank is not None else (_UNKNOWN_CLASS, name)


def _atom_key(x) -> tuple:
    content = x._hashable_content()
    for c in content:
        if isinstance(c, (Basic, frozenset)):
            raise TypeError  # (not an atom as far as the key goes)
    return _class_key(type(x)), len(content), content


def _shallow_key(x) -> tuple:
    """A key that orders as Basic.compare does (class, then the length of the hashable content, then its items
    in turn) for an atom or a node of atoms: for them, one key per item instead of a compare per pair of items
    (every sum and product the derivation builds sorts its arguments this way). TypeError for anything deeper or
    with items that compare otherwise, which then sorts with Basic.compare itself."""
    if not x.args:
        return _atom_key(x)
    content = x._hashable_content()
    if content is not x.args:  # (a class with more than its arguments to compare)
        raise TypeError
    return _class_key(type(x)), len(content), tuple(map(_atom_key, content))


def _kept_key(x) -> tuple | None:
    """_shallow_key, and one level deeper (a product of a sum and a symbol, a function of a product), kept for
    every node by its identity in _KEYS: a temporary is sorted into thousands of sums and products, and its key
    (sympy's hashable content of a Dummy, its assumptions sorted anew) was a tenth of the time of building them.
    None for deeper nodes (a key of all of a large expression costs more than the few comparisons that order it)
    and where the key cannot stand for Basic.compare (a node with more than its arguments to compare, an atom
    holding nodes)."""
    hit = _KEYS.get(id(x))
    if hit is not None and hit[0] is x:
        return hit[1]
    try:
        if not x.args:
            key = _atom_key(x)
        else:
            content = x._hashable_content()
            if content is not x.args:
                raise TypeError
            items = []
            for a in content:
                if a.args:
                    k = _KEYS.get(id(a))
                    k = k[1] if k is not None and k[0] is a else _shallow_key(a)
                    if k is None:
                        raise TypeError
                else:
                    k = _kept_key(a)
                items.append(k)
            key = (_class_key(type(x)), len(content), tuple(items))
    except TypeError:
        key = None
    if len(_KEYS) >= _KEYS_KEPT:
        _KEYS.clear()
    _KEYS[id(x)] = (x, key)  # (x kept alive with its key: its id is not reused while the entry stands)
    return key


_KEYS: dict = {}  # id(node) -> (node, _kept_key)
_KEYS_KEPT = 400_000  # entries before the cache starts anew (a derivation of the Iltis makes about 60,000)


def sort_canonically(items: list) -> None:
    """items.sort(key=cmp_to_key(Basic.compare)), sympy's order of the arguments of a sum or a product."""
    keys = list(map(sort_key, items))
    if None not in keys:
        try:
            order = sorted(range(len(items)), key=keys.__getitem__)
        except TypeError:  # (items of keys that Python cannot order: two classes of one name)
            pass
        else:
            items[:] = [items[k] for k in order]
            return
    items.sort(key=_ORDER)


def _shallow_or_none(x):
    try:
        return _shallow_key(x)
    except TypeError:
        return None


#: The key sort_canonically sorts by (None: sort with Basic.compare); _kept_key, or the key before the third
#: derivation pass (bench/derive.py measures the one against the other).
sort_key = _kept_key


def _mul_of(args: tuple):
    return postprocessed(_Mul._from_args(args, True))


def _quiet_postprocessed(node):
    """Basic._exec_constructor_postprocessors(node) for a sum or a product: node itself when none of its arguments'
    types (nor their bases) has a constructor postprocessor (sympy's matrix expressions have), which is every
    node the derivation builds; sympy's own asks its cache once per argument."""
    for a in node._args:
        kind = type(a)
        if kind not in _QUIET:
            if any(c in Basic._constructor_postprocessor_mapping for c in kind.__mro__):
                return type(node)._exec_constructor_postprocessors(node)
            _QUIET.add(kind)
    return node


_QUIET: set = set()  # argument types without a constructor postprocessor

#: The postprocessing of the sums and products built here: _quiet_postprocessed, or sympy's own before issue
#: 12's third derivation pass (bench/derive.py measures the one against the other).
postprocessed = _quiet_postprocessed


def _base(f):
    """The base of a factor to a power that sympy's Mul.flatten only collects (a symbol, a sum or a function, each
    to the power 1; a power of a non-number), or None for anything it treats otherwise (a number, exp(x) which is
    E**x, a non-commutative factor, ...)."""
    if _symbol(f):
        return f
    kind = type(f)
    if kind is _Pow:
        base = f.args[0]
        return None if base.is_Number or not f.is_commutative else base
    if (kind is _Add or f.is_Function) and f.is_commutative and kind.as_base_exp is _AS_BASE_EXP:
        return f
    return None


def _factors(x):
    """(coefficient, factors) of a product's operand whose factors all have a _base, or None."""
    if _rational(x):
        return x, ()
    if type(x) is _Mul and x.is_commutative:
        args = x.args
        coeff = _ONE
        if args[0].is_Number:
            if not _rational(args[0]):
                return None
            coeff, args = args[0], args[1:]
        for f in args:
            if _base(f) is None:
                return None
        return coeff, args
    return (_ONE, (x,)) if _base(x) is not None else None


def product(a, b):
    """a*b (sympy expressions or ints), as sympy gives it."""
    if isinstance(a, Basic) and isinstance(b, Basic):
        return product_of((a, b))
    return a * b


def product_of(operands):
    """Mul(*operands) of two or more sympy expressions, as sympy gives it."""
    coeff, factors = _ONE, []
    for x in operands:
        split = _factors(x)
        if split is None:
            return _Mul(*operands)
        if split[0] is not _ONE:
            coeff = coeff * split[0]
        factors.extend(split[1])
    if not factors or len(set(map(_base, factors))) < len(factors):  # numbers alone; a common base: powers
        return _Mul(*operands)
    if coeff is not _ONE:
        if len(factors) == 1 and factors[0].is_Add:  # sympy distributes a number over a sum
            return _Mul(*operands)
        sort_canonically(factors)
        return _mul_of((coeff, *factors))
    if len(factors) == 1:
        return factors[0]
    sort_canonically(factors)
    return _mul_of(tuple(factors))


def replaced(expr, rule: dict):
    """expr.xreplace(rule), its changed sums and products rebuilt by `total` and `product_of` (sympy rebuilds
    every changed node with its full evaluation: the inlining of the printed temporaries spent half its time
    there)."""
    return _replaced(expr, rule, False)[0] if rule else expr


def replaced_symbols(expr, rule: dict):
    """replaced for a rule of symbols only (the printer's temporaries written in place): only the symbols of expr
    are looked up in it (a look-up hashes its key, by a Python call for a sympy node)."""
    return _replaced(expr, rule, True)[0] if rule else expr


def _replaced(node, rule: dict, symbols_only: bool) -> tuple:
    args = node.args
    if not symbols_only or not args:
        hit = rule.get(node) if not symbols_only or node.is_Symbol else None
        if hit is not None:
            return hit, True
    if not args:
        return node, False
    new, changed = [], False
    for a in args:
        if isinstance(a, Basic):
            a, c = _replaced(a, rule, symbols_only)
            changed |= c
        new.append(a)
    if not changed:
        return node, False
    kind = type(node)
    if kind is _Add:
        return total(new), True
    if kind is _Mul:
        return product_of(new), True
    return node.func(*new), True


def negative(a):
    """-a, as sympy gives it."""
    if _symbol(a):
        return _mul_of((_MINUS_ONE, a))
    return -a


def total(terms):
    """sp.Add(*terms) of two or more terms, none of them 0, as sympy gives it: Add.flatten's steps for symbols,
    functions, powers of non-numbers, products with an exact coefficient, sums and exact or finite numbers."""
    seq = list(terms)
    collected: dict = {}
    coeff = _ZERO
    for term in seq:  # (grows with the terms of a sum, at its end, as in Add.flatten)
        if not isinstance(term, Basic):
            return _Add(*terms)
        if _symbol(term) or term.is_Function or (term.is_Pow and not term.args[0].is_Number):
            c, rest = _ONE, term
        elif type(term) is _Mul and term.is_commutative:
            args = term.args
            first = args[0]
            if not first.is_Number:
                c, rest = _ONE, term
            elif isinstance(first, sp.Rational):
                c, rest = first, (args[1] if len(args) == 2 else term._new_rawargs(*args[1:]))
            else:
                return _Add(*terms)
        elif type(term) is _Add:
            seq.extend(term.args)
            continue
        elif isinstance(term, sp.Rational) or (type(term) is sp.Float and math.isfinite(term)):
            coeff += term
            continue
        else:
            return _Add(*terms)
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
        elif rest.is_Add:
            args.append(_Mul(c, rest, evaluate=False))
        else:
            args.append(product_of((c, rest)))
    sort_canonically(args)
    if coeff is not _ZERO:
        args.insert(0, coeff)
    if not args:
        return _ZERO
    if len(args) == 1:
        return args[0]
    return postprocessed(_Add._from_args(args, True))
