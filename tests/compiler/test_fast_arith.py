"""compiler/fast_arith.py builds products, sums, negatives and substitutions the way sympy does: checked against
sympy's own `a*b`, `Mul(*factors)`, `Add(*terms)`, `-a` and `xreplace` node for node (srepr: the classes, the
arguments and their order), on random expressions of the kinds the derivation makes (symbols and temporaries,
exact and float numbers, functions, powers, products and sums of them). The printed C follows the arguments'
order, so any difference would show."""

import random
from functools import cmp_to_key

import sympy as sp
from sympy.core.basic import Basic

from mbs.compiler import fast_arith
from mbs.compiler.tape import symbols_of

SYMBOLS = [sp.Dummy(f"d{i}") for i in range(5)] + list(sp.symbols("a b c"))
NUMBERS = [sp.Integer(2), sp.Integer(-1), sp.S.One, sp.Rational(1, 2), sp.Rational(-3, 4), sp.Float(0.5),
           sp.Float(-2.0)]


def random_expr(rng: random.Random, depth: int = 0):
    r = rng.random()
    if depth > 2 or r < 0.35:
        return rng.choice(SYMBOLS)
    if r < 0.45:
        return rng.choice(NUMBERS)
    if r < 0.5:
        return sp.sin(rng.choice(SYMBOLS))
    if r < 0.53:
        return sp.exp(rng.choice(SYMBOLS))  # E**x to sympy's products
    if r < 0.56:
        return sp.sqrt(2) * rng.choice(SYMBOLS)
    if r < 0.6:
        return rng.choice(SYMBOLS) ** rng.choice([2, -1, sp.Rational(1, 2)])
    if r < 0.65:
        return 1 / (random_expr(rng, depth + 1) + rng.choice(SYMBOLS))
    if r < 0.8:
        return random_expr(rng, depth + 1) * random_expr(rng, depth + 1)
    return random_expr(rng, depth + 1) + random_expr(rng, depth + 1)


def test_products_sums_and_negatives_are_sympys_node_for_node():
    rng = random.Random(12)
    for _ in range(600):
        a, b = random_expr(rng), random_expr(rng)
        assert sp.srepr(fast_arith.product(a, b)) == sp.srepr(a * b)
        assert sp.srepr(fast_arith.negative(a)) == sp.srepr(-a)
        terms = [e for e in (random_expr(rng) for _ in range(rng.randint(2, 4))) if e != 0]
        if len(terms) >= 2:
            assert sp.srepr(fast_arith.total(terms)) == sp.srepr(sp.Add(*terms))


def test_replaced_is_xreplace_node_for_node():
    rng = random.Random(7)
    for _ in range(300):
        expr = random_expr(rng) + random_expr(rng) * random_expr(rng)
        rule = {s: random_expr(rng) for s in rng.sample(SYMBOLS, 3)}
        assert sp.srepr(fast_arith.replaced(expr, rule)) == sp.srepr(expr.xreplace(rule))
        assert sp.srepr(fast_arith.replaced_symbols(expr, rule)) == sp.srepr(expr.xreplace(rule))
        n = rng.randint(3, 5)
        operands = [random_expr(rng) for _ in range(n)]
        assert sp.srepr(fast_arith.product_of(operands)) == sp.srepr(sp.Mul(*operands))


def test_sort_canonically_is_sympys_order():
    rng = random.Random(3)
    for _ in range(500):
        items = [random_expr(rng) for _ in range(rng.randint(2, 6))]
        expected = sorted(items, key=cmp_to_key(Basic.compare))
        fast_arith.sort_canonically(items)
        assert [sp.srepr(e) for e in items] == [sp.srepr(e) for e in expected]


def test_sort_canonically_is_sympys_order_for_any_node():
    """Deeper nodes and nodes of other kinds (piecewise, comparisons, min/max, undefined functions, floats),
    sorted by their keys where those stand for Basic.compare, else by Basic.compare: sympy's order either way,
    also when the same nodes are sorted again (their keys kept)."""
    rng = random.Random(5)
    f = sp.Function("f")
    def node(depth=0):
        e = random_expr(rng, depth)
        r = rng.random()
        if r < 0.15:
            return sp.Piecewise((e, rng.choice(SYMBOLS) > 0), (random_expr(rng), True))
        if r < 0.25:
            return sp.Max(e, rng.choice(SYMBOLS))
        if r < 0.35:
            return f(e, rng.choice(NUMBERS))
        if r < 0.45:
            return sp.atan2(e, rng.choice(SYMBOLS)) * node(depth + 2) if depth < 3 else e
        return e
    pool = [node() for _ in range(120)]
    for _ in range(400):
        items = rng.sample(pool, rng.randint(2, 7))
        expected = sorted(items, key=cmp_to_key(Basic.compare))
        fast_arith.sort_canonically(items)
        assert [sp.srepr(e) for e in items] == [sp.srepr(e) for e in expected]


def test_the_cases_sympy_evaluates_further_are_sympys():
    x, y = sp.symbols("x y")
    assert fast_arith.product(x, x) == x ** 2                               # a power
    assert fast_arith.product(2, x + y) == 2 * x + 2 * y                     # a number distributed over a sum
    assert fast_arith.product(sp.Rational(1, 2), 2 * x) == x                # the coefficients cancel
    assert fast_arith.total([x * y, -x * y]) == 0                           # the terms cancel
    assert fast_arith.total([x, sp.Integer(1), x + sp.Integer(2)]) == 2 * x + 3
    assert fast_arith.product(sp.oo, x) == sp.oo * x                         # not an exact finite number


def test_symbols_of_is_free_symbols():
    x, y, z = sp.symbols("x y z")
    d, f = sp.Dummy("d"), sp.Function("f")
    for e in (x, sp.Integer(3), x * y + sp.sin(z), sp.Piecewise((x, y > 0), (z, True)),
              sp.Derivative(f(x, y), x) + z, sp.Integral(x * y, (x, 0, 1)) * d, sp.And(x > 1, y < d),
              sp.Max(x, y) + sp.Abs(d) ** 2, sp.S.true, sp.pi * x):
        assert symbols_of(e) == e.free_symbols


def test_postprocessed_is_sympys_also_for_a_type_that_has_a_postprocessor():
    x, y = sp.symbols("x y")
    A, B = sp.MatrixSymbol("A", 2, 2), sp.MatrixSymbol("B", 2, 2)
    for node in (sp.Mul._from_args((x, y)), sp.Add._from_args((x, y)), sp.Mul._from_args((A, B), False),
                 sp.Add._from_args((A, B), True)):
        expected = type(node)._exec_constructor_postprocessors(node)
        assert sp.srepr(fast_arith._quiet_postprocessed(node)) == sp.srepr(expected)
