"""A force law shared by the instances of one component, converted to sympy once and renamed for the others.

The four tyres of a car are four instances of one component: their laws are the same model expression but for
the names of what they read (`tyre_fl.A0` against `tyre_fr.A0`, the temporaries of each tyre's slip quantities).
Converting a law runs sympy's evaluation at every node, and the Calspan lateral force, |a| of a piecewise slip,
is slow there (sympy's Abs asks the assumptions of the whole expression and builds its conjugate): a quarter of
the lowering of the Iltis went to converting the same law four times.

sympy's evaluation depends on the names of the symbols only through their order (the canonical order of a sum's
terms, which term gives up its sign, ...). So where the names of the next instance stand in the same order as
those of the first, its converted law is the first one's with the names exchanged node for node, the nodes
rebuilt as they are (`renamed`): the same expression that converting it would give. Where they do not (or a
law reads a value that is not a plain symbol, a table or a hook), the law is converted as before.
tests/compiler/test_instances.py compares both ways on the Iltis's tyres.
"""

from __future__ import annotations

from functools import cmp_to_key

import sympy as sp
from sympy.core.basic import Basic
from sympy.core.function import Application, DefinedFunction
from sympy.functions.elementary.piecewise import ExprCondPair
from sympy.logic.boolalg import ITE

from mbs.language import expr as X

from . import fast_arith

_PLAIN = (sp.Symbol, sp.Dummy)  # exact types: a renamed leaf must be of the same one


class SharedLaws:
    """Converted laws by their form (the model expression with its names numbered in the order of reading)."""

    def __init__(self):
        self._converted: dict = {}

    def convert(self, expr: X.E, to_sympy) -> sp.Expr:
        """to_sympy(expr) for a ToSympy without switches (compiler/symbolic.py), from an instance converted
        before where that gives the same expression."""
        leaves: dict = {}
        form = _form(expr, leaves, {})
        if form is None:
            return to_sympy(expr)
        # every name resolved in the order converting reads them (the same side effects in the same order)
        values = tuple(to_sympy(leaf) for leaf in leaves)
        if not all(type(v) in _PLAIN for v in values) or len(set(values)) != len(values):
            return to_sympy(expr)
        first = self._converted.get(form)
        if first is None:
            result = to_sympy(expr)
            self._converted[form] = (values, result)
            return result
        first_values, first_result = first
        if not _same_order(first_values, values):
            return to_sympy(expr)
        try:
            return renamed(first_result, dict(zip(first_values, values)))
        except _Unknown:
            return to_sympy(expr)


def _form(e: X.E, leaves: dict, seen: dict):
    """The expression with each name replaced by its number in the order of first reading (depth first, left to
    right, as ToSympy converts), or None for a table or a hook."""
    hit = seen.get(id(e))
    if hit is not None:
        return hit
    if isinstance(e, X.Sym):
        form = ("name", e.kind, leaves.setdefault(e, len(leaves)))
    elif isinstance(e, X.Const):
        form = e
    elif isinstance(e, X.Op):
        args = []
        for a in e.args:
            f = _form(a, leaves, seen)
            if f is None:
                return None
            args.append(f)
        form = (e.op, tuple(args))
    else:  # a table registers itself, a hook's function is named: converted as written
        return None
    seen[id(e)] = form
    return form


def _same_order(first: tuple, then: tuple) -> bool:
    """Whether `then` stands in the order of `first`, name for name, in both of sympy's orders (Basic.compare,
    which sorts sums and products, and sort_key, which sorts min, max and logic), each of the same type and
    assumptions."""
    for a, b in zip(first, then):
        if type(a) is not type(b) or a.assumptions0 != b.assumptions0:
            return False
    by_key = sorted(range(len(first)), key=lambda k: first[k].sort_key())
    if any(then[i].sort_key() >= then[j].sort_key() for i, j in zip(by_key, by_key[1:])):
        return False
    by_compare = sorted(range(len(first)), key=cmp_to_key(lambda i, j: first[i].compare(first[j])))
    return all(first[i].compare(first[j]) < 0 and then[i].compare(then[j]) < 0
               for i, j in zip(by_compare, by_compare[1:]))


def renamed(expr: sp.Expr, names: dict) -> sp.Expr:
    """expr with its symbols exchanged by `names`, every node rebuilt with its arguments in the order they have
    (no evaluation): what sympy builds from the renamed operands when the names keep their order."""
    return _renamed(expr, names, {})


def _renamed(node, names: dict, done: dict):
    hit = names.get(node)
    if hit is not None:
        return hit
    args = node.args
    if not args:
        return node
    key = id(node)
    hit = done.get(key)
    if hit is not None:
        return hit[1]
    new = tuple(_renamed(a, names, done) for a in args)
    if all(a is b for a, b in zip(new, args)):
        result = node
    else:
        result = _rebuilt(node, new)
    done[key] = (node, result)  # (node kept alive: its id stays its own)
    return result


def _rebuilt(node, args: tuple):
    """`node` of the renamed `args` as they stand; _Unknown for a kind of node not known to be built so."""
    kind = type(node)
    if kind is sp.Add or kind is sp.Mul:
        return fast_arith.postprocessed(kind._from_args(args, node.is_commutative))
    if kind is sp.Piecewise or kind is ExprCondPair:  # (their constructors would look at the conditions again)
        return Basic.__new__(kind, *args)
    if kind in _AS_WRITTEN:
        return kind(*args, evaluate=False)
    if kind is ITE:  # (its constructor looks at the condition's symbols again)
        return Application.__new__(kind, *args, evaluate=False)
    if _elementary(kind):
        return kind(*args, evaluate=False)
    raise _Unknown(kind.__name__)


def _elementary(kind: type) -> bool:
    """A function (sin, |x|, atan2, ...) whose constructor is sympy's generic one for defined functions, which
    with evaluate=False builds the node of its arguments."""
    for c in kind.__mro__:
        if "__new__" in vars(c) or "_new_" in vars(c):
            return c is DefinedFunction
    return False


class _Unknown(Exception):
    """A node `renamed` does not know how to rebuild as it stands (the law is then converted as written)."""


#: Nodes whose constructor with evaluate=False builds the node of its arguments as they stand (min and max sort
#: them by sort_key, in which the renamed names keep their order).
_AS_WRITTEN = frozenset({sp.Pow, sp.Min, sp.Max, sp.StrictLessThan, sp.LessThan, sp.StrictGreaterThan,
                         sp.GreaterThan, sp.Equality, sp.Unequality})
